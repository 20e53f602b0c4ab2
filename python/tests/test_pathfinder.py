"""minos.PathFinder answers as `minos nav query` does."""

import json
import math

import numpy as np
import pytest

import minos
from conftest import cli, cli_error


def pairs(world, n=6):
    pf = minos.PathFinder(world.data, world.scenes[0])
    pts = pf.sample_navigable_points(2 * n, seed=5)
    pts = [tuple(float(x) for x in p) for p in pts]
    return pf, [(pts[2 * i], pts[2 * i + 1]) for i in range(n)]


def test_paths_equal_the_cli(world, minos_bin):
    pf, ps = pairs(world)
    ps += [(e.start_position, tuple(e.goal["position"])) for e in world.episodes
           if e.scene_id == world.scenes[0]]
    rooms_seen = 0
    for a, b in ps:
        got = pf.find_path(a, b)
        p = cli(minos_bin, "nav", "query", "--data", world.data, "--scene", world.scenes[0],
                "--from", ",".join(map(repr, a)), "--to", ",".join(map(repr, b)), "--json")
        want = json.loads(p.stdout)
        assert got["reachable"] == want["reachable"]
        if want["geodesic"] is None:
            assert got["geodesic"] is None
        else:
            assert np.float32(got["geodesic"]) == np.float32(want["geodesic"])
        assert np.float32(got["euclidean"]) == np.float32(want["euclidean"])
        assert got["rooms"] == want["rooms"]
        assert got["doors"] == want["doors"]
        rooms_seen += len(want["rooms"])
        assert got["path"].shape == (len(want["path"]), 3)
        assert np.array_equal(got["path"], np.asarray(want["path"], dtype=np.float32).reshape(-1, 3))
        # Independent check: the geodesic is the length of the path's polyline.
        if got["reachable"]:
            seg = np.linalg.norm(np.diff(got["path"].astype(np.float64), axis=0), axis=1).sum()
            assert abs(seg - got["geodesic"]) < 1e-3
            assert got["geodesic"] >= got["euclidean"] - 1e-4
    assert rooms_seen > 0, "no compared path passes a room"


def test_batched_distances_equal_single_queries(world):
    pf, ps = pairs(world, 8)
    a = np.array([p[0] for p in ps], dtype=np.float32)
    b = np.array([p[1] for p in ps], dtype=np.float32)
    batch = pf.geodesic_distance(a, b)
    assert batch.shape == (8,) and batch.dtype == np.float32
    single = [pf.geodesic_distance(x, y) for x, y in ps]
    assert np.array_equal(batch, np.asarray(single, dtype=np.float32))
    assert np.array_equal(pf.geodesic_distances(a.tolist(), b.tolist()), batch)
    # A point far from any floor: inf in the batch, an error alone (as the CLI says).
    far = np.array([[500.0, 0.0, 500.0]], dtype=np.float32)
    assert math.isinf(pf.geodesic_distance(far, a[:1])[0])


def test_points_off_the_floor_raise_the_cli_message(world, minos_bin):
    pf = minos.PathFinder(world.data, world.scenes[0])
    a = pf.sample_navigable_point(seed=1)
    with pytest.raises(minos.MinosError) as e:
        pf.geodesic_distance((500.0, 0.0, 500.0), a)
    p = cli(minos_bin, "nav", "query", "--data", world.data, "--scene", world.scenes[0],
            "--from", "500,0,500", "--to", ",".join(map(repr, a)), ok=False)
    assert str(e.value) == cli_error(p)


def test_unknown_scene_raises_with_the_file(world):
    with pytest.raises(minos.MinosError) as e:
        minos.PathFinder(world.data, "no-such-scene")
    assert "no-such-scene" in str(e.value) and "\n" not in str(e.value)


def test_sampling_snapping_and_islands(world):
    pf = minos.PathFinder(world.data, world.scenes[0])
    p1 = pf.sample_navigable_point(seed=7)
    assert p1 == pf.sample_navigable_point(seed=7)
    assert p1 != pf.sample_navigable_point(seed=8)
    assert len(p1) == 3 and pf.is_navigable(p1)
    pts = pf.sample_navigable_points(50, seed=2)
    assert pts.shape == (50, 3)
    assert all(pf.is_navigable(tuple(p)) for p in pts)
    # Snapping a point lifted 0.5 m lands on floor near it.
    s = pf.snap_point((p1[0], p1[1] + 0.5, p1[2]))
    assert s is not None and pf.is_navigable(s)
    assert math.dist((s[0], s[2]), (p1[0], p1[2])) < 0.1
    assert pf.snap_point((500.0, 0.0, 500.0)) is None
    assert not pf.is_navigable((500.0, 0.0, 500.0))
    isl = pf.island_id(p1)
    assert isl is not None and 0 <= isl < pf.num_islands
    r = pf.island_radius(isl)
    assert r > 0 and r == pf.island_radius(p1)
    # Every point sampled on that island is within its radius of... the island itself: the
    # same island id, and reachable from p1.
    q = pf.sample_navigable_point(seed=3, island=isl)
    assert pf.island_id(q) == isl
    assert math.isfinite(pf.geodesic_distance(p1, q))
    assert pf.navigable_area > 1.0


def test_rooms_and_doors_on_paths(world):
    pf = minos.PathFinder(world.data, world.scenes[0])
    found_multi = False
    # Most walkable floor of a generated house is the yard around it: many pairs are needed.
    pts = pf.sample_navigable_points(200, seed=11)
    for i in range(0, 200, 2):
        a, b = tuple(pts[i]), tuple(pts[i + 1])
        path = pf.find_path(a, b)
        if not path["reachable"]:
            continue
        assert pf.rooms_on_path(a, b) == [r["id"] for r in path["rooms"]]
        assert pf.doors_on_path(a, b) == path["doors"]
        found_multi |= len(path["rooms"]) > 1
    assert found_multi, "no sampled path crosses two rooms"
