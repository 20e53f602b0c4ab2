"""minos.Simulator: observations as NumPy arrays, motion, determinism, the oracle."""

import math

import numpy as np
import pytest

import minos


def test_observations_are_arrays_of_the_sensors(world):
    ep = world.episodes[0]
    sim = minos.Simulator(world.data, ep.scene_id, size=32)
    obs = sim.reset(ep)
    assert obs["color"].shape == (32, 32, 3) and obs["color"].dtype == np.uint8
    assert obs["depth"].shape == (32, 32, 1) and obs["depth"].dtype == np.float32
    assert obs["semantic"].shape == (32, 32) and obs["semantic"].dtype == np.uint16
    assert obs["contact"].shape == (4,) and obs["contact"].dtype == np.bool_
    m = obs["measurements"]
    assert m["step"] == 0
    assert np.allclose(m["position"], ep.start_position)
    # The goal distance is the episode's: Euclidean exactly, geodesic to the cell.
    goal = np.asarray(ep.goal["position"])
    assert abs(m["goal_euclidean"] - np.linalg.norm(goal - np.asarray(ep.start_position))) < 1e-4
    assert abs(m["goal_geodesic"] - ep.geodesic_distance) < 0.1
    # Depth is metres: something is in view, nothing beyond the far plane.
    d = obs["depth"]
    assert (d > 0).any() and d.max() <= 50.0
    specs = {s["name"]: s for s in sim.sensor_specs}
    assert specs["color"]["shape"] == [32, 32, 3] and specs["semantic"]["dtype"] == "uint16"


def test_every_modality_and_sensor_files(world, tmp_path):
    ep = world.episodes[0]
    sim = minos.Simulator(world.data, ep.scene_id, sensors="all", size=16)
    obs = sim.reset(ep)
    assert obs["normal"].shape == (16, 16, 3) and obs["normal"].dtype == np.float32
    assert obs["instance"].dtype == np.uint32 and obs["room"].dtype == np.uint32
    assert obs["room_class"].shape == (16, 16, 1)
    n = obs["normal"].reshape(-1, 3)
    lengths = np.linalg.norm(n[np.abs(n).sum(axis=1) > 0], axis=1)
    assert np.allclose(lengths, 1.0, atol=1e-3)
    assert (obs["room"] > 0).any()
    f = tmp_path / "s.toml"
    f.write_text('[[camera]]\nname = "rgb"\nmodality = "color"\nresolution = [40, 30]\n\n'
                 '[[camera]]\nname = "d8"\nmodality = "depth"\nresolution = [20, 10]\n'
                 'depth_encoding = "u8"\n')
    sim = minos.Simulator(world.data, ep.scene_id, sensors=f)
    obs = sim.reset(ep)
    assert obs["rgb"].shape == (30, 40, 3)
    assert obs["d8"].shape == (10, 20, 1) and obs["d8"].dtype == np.uint8
    assert obs["contact"].shape == (0,)
    bad = tmp_path / "bad.toml"
    bad.write_text('[[camera]]\nname = "a"\nmodality = "smell"\nresolution = [8, 8]\n')
    with pytest.raises(minos.MinosError) as e:
        minos.Simulator(world.data, ep.scene_id, sensors=bad)
    assert str(e.value).startswith(str(bad))


def test_discrete_motion_follows_the_preset(world):
    ep = world.episodes[0]
    sim = minos.Simulator(world.data, ep.scene_id, size=8)
    assert sim.action_names == ["forward", "turn_left", "turn_right"]
    sim.reset(ep)
    yaw0 = sim.state["yaw"]
    obs = sim.step("turn_left")
    assert math.isclose((sim.state["yaw"] - yaw0) % math.tau, math.radians(10), abs_tol=1e-4)
    assert obs["measurements"]["step"] == 1
    # Forward moves 0.25 m unless something is hit.
    for _ in range(36):
        p0 = np.asarray(sim.state["position"])
        obs = sim.step(0)
        moved = np.linalg.norm(np.asarray(sim.state["position"])[[0, 2]] - p0[[0, 2]])
        if not obs["measurements"]["collision"]:
            assert abs(moved - 0.25) < 1e-4
            break
        sim.step("turn_left")
    else:
        pytest.fail("every direction collides")
    with pytest.raises(ValueError):
        sim.step("jump")
    with pytest.raises(ValueError):
        sim.step(7)


def test_same_seed_same_observations(world, tmp_path):
    f = tmp_path / "noisy.toml"
    f.write_text('[[camera]]\nname = "depth"\nmodality = "depth"\nresolution = [24, 24]\n'
                 'noise = { kind = "gaussian", sigma = 0.05 }\n')
    ep = world.episodes[1]
    runs = []
    for seed in (4, 4, 5):
        sim = minos.Simulator(world.data, ep.scene_id, sensors=f, seed=seed)
        frames = [sim.reset(ep)["depth"]]
        for a in ["forward", "turn_left", "forward", "turn_right", "forward"]:
            frames.append(sim.step(a)["depth"])
        runs.append(frames)
    assert all(np.array_equal(a, b) for a, b in zip(runs[0], runs[1]))
    assert not all(np.array_equal(a, b) for a, b in zip(runs[0], runs[2]))


def test_the_oracle_reaches_every_goal(world):
    for ep in world.episodes[:3]:
        sim = minos.Simulator(world.data, ep.scene_id, size=8)
        sim.reset(ep)
        follower = minos.GreedyFollower(sim)
        for _ in range(ep.max_steps):
            a = follower.next_action()
            if a == "stop":
                break
            sim.step(a)
        assert a == "stop" and sim.reached(), ep.episode_id
    # A pose and a point goal instead of an episode.
    ep = world.episodes[0]
    sim = minos.Simulator(world.data, ep.scene_id, size=8)
    sim.reset(start=ep.start_position, yaw=ep.start_yaw, goal=ep.goal["position"])
    steps = 0
    while (a := sim.oracle_action()) != "stop":
        sim.step(a)
        steps += 1
        assert steps < 500
    assert sim.reached()
    # Without a goal there is nothing to follow.
    sim.reset(start=ep.start_position)
    assert not sim.reached()
    with pytest.raises(minos.MinosError):
        sim.oracle_action()


def test_unknown_presets_and_scenes_are_errors(world):
    ep = world.episodes[0]
    with pytest.raises(minos.MinosError) as e:
        minos.Simulator(world.data, ep.scene_id, agent="robot")
    assert "unknown agent preset `robot`" in str(e.value)
    with pytest.raises(minos.MinosError) as e:
        minos.Simulator(world.data, "nope")
    assert "nope" in str(e.value)
    # Grids are baked for Habitat's body: MINOS's is refused, as `minos run` refuses it.
    with pytest.raises(minos.MinosError) as e:
        minos.Simulator(world.data, ep.scene_id, agent="minos")
    assert "rebake" in str(e.value) or "bake" in str(e.value)
    minos.Simulator(world.data, ep.scene_id, agent="minos", allow_body_mismatch=True)


def test_variants_like_the_cli(world, minos_bin):
    from conftest import cli

    cli(minos_bin, "variants", "--data", world.data, "--name", "empty", "--empty")
    baked = minos.bake(world.data, variant="empty", previews=False)
    assert baked["failed"] == {} and baked["baked"] == 2
    ep = world.episodes[0]
    full = minos.Simulator(world.data, ep.scene_id, sensors="all", size=48)
    empty = minos.Simulator(world.data, f"{ep.scene_id}@empty", sensors="all", size=48)
    assert empty.scene_id == f"{ep.scene_id}@empty"
    seen_full, seen_empty = set(), set()
    for yaw in np.linspace(0, 2 * np.pi, 8, endpoint=False):
        seen_full |= set(np.unique(full.reset(start=ep.start_position, yaw=yaw)["instance"]))
        seen_empty |= set(np.unique(empty.reset(start=ep.start_position, yaw=yaw)["instance"]))
    # The empty house keeps walls and floors (no instance) but shows fewer objects.
    assert len(seen_empty) < len(seen_full)
    env_eps = [e.on_variant("empty") for e in world.episodes[:2]]
    assert all(e.scene_id.endswith("@empty") for e in env_eps)
    from minos.gym import NavEnv

    env = NavEnv(data=world.data, episodes=world.point, variant="empty", size=8)
    env.reset()
    assert env.episode.scene_id.endswith("@empty")


def test_an_empty_sensor_file_is_refused_as_the_cli_refuses_it(world, tmp_path):
    empty = tmp_path / "s.toml"
    empty.write_text("  \n")
    with pytest.raises(minos.BadInputError, match=f"^{empty}: the sensor file is empty"):
        minos.Simulator(world.data, world.scenes[0], sensors=empty)
    with pytest.raises(minos.NotFoundError, match=f"^{tmp_path / 'none.toml'}: "):
        minos.Simulator(world.data, world.scenes[0], sensors=tmp_path / "none.toml")
    # A bare word that is neither a suite nor a file: the suites are listed.
    with pytest.raises(minos.BadInputError, match="^`depth` is neither a sensor suite \\(minos, minos-paper, all\\) nor a file$"):
        minos.Simulator(world.data, world.scenes[0], sensors="depth")
