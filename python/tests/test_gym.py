"""minos.gym: NavEnv passes Gymnasium's checker; VectorNavEnv equals N NavEnvs; the oracle
through the environments reproduces `minos.run`'s episodes; Python task hooks."""

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")
from gymnasium.utils.env_checker import check_env  # noqa: E402

import minos  # noqa: E402
from minos.gym import NavEnv, VectorNavEnv  # noqa: E402


def test_nav_env_passes_the_checker(world):
    env = NavEnv(data=world.data, episodes=world.point, size=24)
    check_env(env, skip_render_check=True)
    assert env.action_names == ["forward", "turn_left", "turn_right", "stop"]
    assert isinstance(env.action_space, gym.spaces.Discrete) and env.action_space.n == 4
    obs, info = env.reset(seed=3)
    assert env.observation_space.contains(obs)
    assert set(obs) == {
        "color", "depth", "semantic", "goal", "goal_room", "goal_object", "at_goal",
        "contact", "collision", "previous_action", "steps_left",
    }
    assert obs["color"].shape == (24, 24, 3)
    assert info["steps"] == 0 and info["geodesic"] > 0
    # An episode's first observation: nothing before it, the whole step budget left, a
    # PointGoal (no room class, no object category), the goal at its stored distance.
    assert obs["previous_action"].tolist() == [0.0] * 9 and obs["collision"][0] == 0.0
    assert obs["steps_left"][0] == env.episode.max_steps
    assert obs["goal_room"].sum() == 0 and obs["goal_object"][0] == -1
    assert abs(obs["goal"][0] - info["euclidean"]) < 1e-6
    assert abs(float(np.hypot(obs["goal"][1], obs["goal"][2])) - 1.0) < 1e-5
    forward = env.action_names.index("forward")
    obs, *_ = env.step(forward)
    assert obs["previous_action"][0] == 1.0 and obs["previous_action"][1:].sum() == 0
    assert obs["steps_left"][0] == env.episode.max_steps - 1


def test_reset_seed_fixes_the_episode_order(world):
    env = NavEnv(data=world.data, episodes=world.point, size=8)
    ids = []
    for _ in range(2):
        env.reset(seed=9)
        seq = [env.episode.episode_id]
        for _ in range(3):
            env.reset()
            seq.append(env.episode.episode_id)
        ids.append(seq)
    assert ids[0] == ids[1] and len(set(ids[0])) == 4
    env.reset()  # no seed: episode-id order continues
    env2 = NavEnv(data=world.data, episodes=world.point, size=8)
    env2.reset()
    assert env2.episode.episode_id == sorted(e.episode_id for e in world.episodes)[0]


def rollout(step, first_obs, actions):
    frames = [first_obs]
    for a in actions:
        frames.append(step(a))
    return frames


def test_vector_env_equals_single_envs(world):
    eps = sorted(world.episodes, key=lambda e: e.episode_id)
    n = 3
    venv = VectorNavEnv(data=world.data, episodes=world.point, num_envs=n, size=16, threads=2)
    assert venv.observation_space["color"].shape == (n, 16, 16, 3)
    obs, info = venv.reset()
    singles = [NavEnv(data=world.data, episodes=[eps[k]], size=16) for k in range(n)]
    sobs = [s.reset()[0] for s in singles]
    rng = np.random.default_rng(0)
    for t in range(25):
        for k in range(n):
            for key in sobs[k]:
                assert np.array_equal(obs[key][k], sobs[k][key]), (t, k, key)
        actions = rng.integers(0, 3, size=n)  # moves only: no episode ends early
        obs, rew, term, trunc, info = venv.step(actions)
        for k in range(n):
            o, r, te, tr, _ = singles[k].step(actions[k])
            sobs[k] = o
            assert np.float32(r) == np.float32(rew[k])
            assert (te, tr) == (bool(term[k]), bool(trunc[k]))
            if te or tr:
                return  # compared up to the first episode's end


def test_the_oracle_reproduces_minos_run(world, tmp_path):
    report = minos.run(world.data, world.point, "oracle", tmp_path / "run", size=16,
                       reward="geodesic")
    by_id = {m["episode_id"]: m for m in report["metrics"]}
    assert report["episodes"] == len(world.episodes) and not report["failures"]
    n = 2
    # The oracle declares arrival with `stop`, as in `minos run`.
    venv = VectorNavEnv(data=world.data, episodes=world.point, num_envs=n, size=16,
                        reward="geodesic", require_stop=True)
    venv.reset()
    stop = venv.action_names.index("stop")
    done_eps = {}
    steps = np.zeros(n, dtype=int)
    returns = np.zeros(n)
    for _ in range(3000):
        a = venv.oracle_actions()
        cur = [e.episode_id for e in venv.current_episodes()]
        obs, rew, term, trunc, info = venv.step(a)
        for k in range(n):
            if info["reset"][k]:
                steps[k], returns[k] = 0, 0.0
                continue
            steps[k] += 1
            returns[k] += rew[k]
            if term[k] or trunc[k]:
                assert a[k] == stop and term[k] and info["success"][k]
                done_eps.setdefault(cur[k], (int(steps[k]), returns[k]))
        if len(done_eps) == len(world.episodes):
            break
    assert set(done_eps) == set(by_id)
    for eid, (s, ret) in done_eps.items():
        assert by_id[eid]["success"]
        assert s == by_id[eid]["steps"], eid  # actions including the stop
        assert ret > 2.5 - 0.01 * s  # the success bonus was paid once


def test_auto_reset_starts_the_next_episode(world):
    venv = VectorNavEnv(data=world.data, episodes=world.point, num_envs=2, size=8)
    obs, info = venv.reset(seed=1)
    first = list(info["episode_id"])
    stop = venv.action_names.index("stop")
    obs, rew, term, trunc, info = venv.step(np.array([stop, 0]))
    assert term[0] and not term[1] and not info["reset"][0]
    obs, rew, term, trunc, info = venv.step(np.array([0, 0]))
    assert info["reset"][0] and not info["reset"][1] and rew[0] == 0.0
    assert info["episode_id"][0] != first[0] and info["episode_id"][1] == first[1]
    assert info["steps"][0] == 0 and info["steps"][1] == 2
    # gymnasium's vector-info convention: a boolean mask per key, every environment set.
    keys = [k for k in info if not k.startswith("_")]
    assert {"success", "reset", "episode_id", "geodesic"} <= set(keys)
    for k in keys:
        mask = info["_" + k]
        assert mask.dtype == np.bool_ and mask.shape == (2,) and mask.all(), k
    assert set(info) == set(keys) | {"_" + k for k in keys}


def test_python_success_and_reward_hooks(world):
    calls = []

    def success(obs, info):
        calls.append(info["action"])
        return info["steps"] >= 2

    env = NavEnv(data=world.data, episodes=world.point, size=8, success_fn=success,
                 reward_fn=lambda obs, info: 10.0 * info["steps"])
    env.reset(seed=0)
    _, r1, t1, _, i1 = env.step(1)
    _, r2, t2, _, i2 = env.step(1)
    assert (r1, t1, r2, t2) == (10.0, False, 20.0, True) and i2["success"]
    assert calls == ["turn_left", "turn_left"]
    venv = VectorNavEnv(data=world.data, episodes=world.point, num_envs=2, size=8,
                        success_fn=lambda o, i: i["collision"] or i["steps"] >= 1)
    venv.reset()
    _, _, term, _, _ = venv.step(np.array([1, 2]))
    assert term.all()
    _, _, _, _, info = venv.step(np.array([1, 2]))
    assert info["reset"].all()


def test_same_seed_same_vector_observations(world):
    def run():
        venv = VectorNavEnv(data=world.data, episodes=world.point, num_envs=2, size=16, seed=3)
        obs, _ = venv.reset(seed=5)
        out = [obs["depth"].copy()]
        for a in [[0, 1], [0, 0], [2, 0], [0, 0]]:
            out.append(venv.step(np.array(a))[0]["depth"].copy())
        return out
    a, b = run(), run()
    assert all(np.array_equal(x, y) for x, y in zip(a, b))


def test_gymnasium_vector_wrappers_read_the_infos(world):
    # Real consumers of the vector infos: DictInfoToList reads every `_<key>` mask (a
    # missing one is a KeyError) and RecordEpisodeStatistics adds its episode statistics.
    from gymnasium.wrappers.vector import DictInfoToList, RecordEpisodeStatistics
    venv = DictInfoToList(RecordEpisodeStatistics(
        VectorNavEnv(data=world.data, episodes=world.point, num_envs=2, size=8)))
    obs, infos = venv.reset(seed=1)
    assert len(infos) == 2 and [i["steps"] for i in infos] == [0, 0]
    stop = venv.unwrapped.action_names.index("stop")
    obs, rew, term, trunc, infos = venv.step(np.array([stop, 0]))
    assert term[0] and not term[1]
    assert infos[1]["steps"] == 1
    assert isinstance(infos[1]["episode_id"], str) and infos[0]["success"] in (True, False)
    assert infos[0]["episode"]["l"] == 1 and "episode" not in infos[1]


def test_as_many_threads_as_environments_reset_and_step(world):
    # VectorNavEnv(num_envs=N, threads=N) never returned from reset() for N >= 8 (simulators
    # made on the pool's threads waited on each other's lazy scene set-up). Each pair runs
    # in a child process with a deadline, so a hang fails instead of stalling the suite.
    import subprocess
    import sys

    pairs = [(8, 8), (9, 9), (12, 12), (16, 16), (3, 8), (16, 8), (32, 32), (1, 32)]
    code = (
        "import sys\n"
        "from minos.gym import VectorNavEnv\n"
        "for n, t in " + repr(pairs) + ":\n"
        "    v = VectorNavEnv(data=sys.argv[1], episodes=sys.argv[2], num_envs=n, size=8,\n"
        "                     threads=t)\n"
        "    obs, info = v.reset()\n"
        "    assert obs['color'].shape[0] == n and info['reset'].all()\n"
        "    for _ in range(3):\n"
        "        obs, rew, term, trunc, info = v.step(v.oracle_actions())\n"
        "        assert rew.shape == (n,)\n"
        "    print(n, t, 'ok', flush=True)\n"
    )
    p = subprocess.run([sys.executable, "-c", code, str(world.data), str(world.point)],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert p.stdout.count(" ok") == len(pairs), p.stdout
