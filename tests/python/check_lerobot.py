"""Loads a minos LeRobot dataset with the real lerobot package and checks it.

Usage: check_lerobot.py DATASET_ROOT RUN_DIR

Checks, with lerobot's own classes and functions:
- LeRobotDataset(repo_id, root=DATASET_ROOT) loads offline; its length, episode count and fps
  are those of info.json;
- every frame is read; episode boundaries from meta/episodes match each frame's
  episode_index/frame_index; the last frame of each episode is done;
- the task string of each frame is its episode's instruction in the run's episodes.parquet;
- every camera comes back channel-first, read independently from the run's
  observations.parquet: colour equals the raw pixels scaled to [0, 1] (float32 (3, h, w));
  depth is float32 (1, h, w) in metres, exactly; semantic, instance, room and room-class ids
  are int32 (1, h, w), exactly; normals are float32 (3, h, w), exactly;
- each camera's statistics in meta/stats.json are per channel, shaped (c, 1, 1), so they
  broadcast against its tensor (as LeRobot's normalisation uses them);
- meta/stats.json equals lerobot's aggregate_stats over the per-episode statistics of
  meta/episodes;
- a DataLoader with delta_timestamps (the way policies read) pads at episode edges.
Prints "lerobot loaded" when everything holds; raises otherwise.
"""

import json
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import torch
from lerobot.datasets.compute_stats import aggregate_stats
from lerobot.datasets.lerobot_dataset import LeRobotDataset
from lerobot.datasets.utils import cast_stats_to_numpy, load_stats


def raw(row, schema, name, dtype):
    """A camera's cell as an (h, w, c) array, decoded from the run's own raw bytes."""
    h, w, c = json.loads(schema.field(name).metadata[b"shape"])
    return np.frombuffer(row[name], dtype=dtype).reshape(h, w, c)


def cameras(row, schema):
    """The tensors LeRobot should return for the run's observation row's cameras (those of
    SENSORS that the run has): channel-first, in the dtype LeRobot documents."""
    out = {}
    for name, (key, dtype, tensor_dtype) in SENSORS.items():
        if name not in schema.names:
            continue
        a = raw(row, schema, name, dtype).transpose(2, 0, 1).astype(tensor_dtype)
        t = torch.from_numpy(np.ascontiguousarray(a))
        out[key] = t / 255.0 if key.startswith("observation.images.") else t
    return out


# Sensor → (LeRobot key, raw dtype, tensor dtype).
SENSORS = {
    "color": ("observation.images.color", np.uint8, np.float32),
    "depth": ("observation.depth", "<f4", np.float32),
    "normal": ("observation.normal", "<f4", np.float32),
    "semantic": ("observation.semantic", "<u2", np.int32),
    "instance": ("observation.instance", "<u4", np.int32),
    "room": ("observation.room", "<u4", np.int32),
    "room_class": ("observation.room_class", np.uint8, np.int32),
}


def main(root: Path, run: Path) -> None:
    info = json.loads((root / "meta/info.json").read_text())
    ds = LeRobotDataset("minos/check", root=root)
    assert len(ds) == info["total_frames"], (len(ds), info["total_frames"])
    assert ds.num_episodes == info["total_episodes"]
    assert ds.fps == info["fps"]

    episodes = pq.read_table(run / "episodes.parquet").to_pylist()
    instructions = {e["episode_id"]: e["instruction"] for e in episodes}
    obs = pq.read_table(run / "observations.parquet")
    schema = obs.schema
    rows = {}
    for row in obs.to_pylist():
        rows[(row["episode_id"], row["step"])] = row
    raw_row = next(iter(rows.values()))

    meta = ds.meta.episodes
    for e in range(ds.num_episodes):
        start, end = meta[e]["dataset_from_index"], meta[e]["dataset_to_index"]
        minos_id = meta[e]["minos/episode_id"]
        for i in range(start, end):
            item = ds[i]
            assert item["episode_index"].item() == e
            assert item["frame_index"].item() == i - start
            assert item["task"] == instructions[minos_id], (item["task"], minos_id)
            row = rows[(minos_id, i - start)]
            for name, expected in cameras(row, schema).items():
                got = item[name]
                assert got.dtype == expected.dtype, (name, got.dtype, expected.dtype)
                assert tuple(got.shape) == tuple(expected.shape), (name, got.shape)
                assert torch.equal(got, expected), (name, minos_id, i - start)
        assert ds[end - 1]["next.done"].item(), f"episode {e} ends done"

    # The per-step features come back as tensors of their declared shapes; the goal
    # vector's direction is a unit vector away from the goal.
    # (LeRobot reads features of shape [1] as plain values, as it does next.reward.)
    shapes = {
        "observation.goal": (3,),
        "observation.goal_room": (9,),
        "observation.at_goal": (),
        "observation.collision": (),
        "observation.previous_action": (9,),
        "observation.steps_left": (),
    }
    item = ds[0]
    for key, shape in shapes.items():
        assert tuple(item[key].shape) == shape, (key, tuple(item[key].shape))
        assert item[key].dtype == torch.float32, (key, item[key].dtype)
    assert item["observation.goal_object"].dtype == torch.int64
    goal = item["observation.goal"]
    if goal[0] > 0.05:
        assert abs(float(goal[1:].norm()) - 1.0) < 1e-4, goal
    assert item["observation.previous_action"].abs().sum() == 0, "no action before the first"

    # stats.json is lerobot's aggregation of the episodes' statistics.
    table = pq.read_table(root / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    per_episode = []
    for row in table:
        stats = {}
        for key, value in row.items():
            if key.startswith("stats/"):
                _, feature, stat = key.split("/")
                stats.setdefault(feature, {})[stat] = value
        per_episode.append(cast_stats_to_numpy(stats))
    expected = aggregate_stats(per_episode)
    written = load_stats(root)
    for feature, stats in expected.items():
        for stat, value in stats.items():
            got = written[feature][stat]
            assert got.shape == np.asarray(value).shape, (feature, stat, got.shape)
            assert np.allclose(got, value, rtol=1e-9, atol=1e-12), (feature, stat)

    # Camera statistics broadcast against the camera's tensors: (c, 1, 1).
    item = ds[0]
    for name in cameras(raw_row, schema):
        c = item[name].shape[0]
        for stat in ["min", "max", "mean", "std", "q01", "q50", "q99"]:
            assert written[name][stat].shape == (c, 1, 1), (name, stat, written[name][stat].shape)
    depth_stats = written["observation.depth"]
    depths = torch.stack([ds[i]["observation.depth"] for i in range(len(ds))])
    assert np.isclose(depth_stats["max"].item(), depths.max().item())
    assert np.isclose(depth_stats["mean"].item(), depths.double().mean().item())

    # The way a policy reads: two past frames, padded at the episode's start.
    fps = ds.fps
    with_history = LeRobotDataset(
        "minos/check",
        root=root,
        delta_timestamps={"observation.state": [-2 / fps, -1 / fps, 0.0]},
    )
    first = with_history[0]
    assert first["observation.state"].shape == (3, 5)
    assert first["observation.state_is_pad"].tolist() == [True, True, False]
    loader = torch.utils.data.DataLoader(with_history, batch_size=8, shuffle=False)
    batch = next(iter(loader))
    h, w = first["observation.depth"].shape[1:]
    assert batch["observation.images.color"].shape[1:] == (3, h, w)

    # An action chunk read by DataLoader workers: the cameras of the current frame, exact,
    # and four actions padded past the episode's end.
    chunked = LeRobotDataset(
        "minos/check",
        root=root,
        delta_timestamps={"action": [k / fps for k in range(4)]},
    )
    loader = torch.utils.data.DataLoader(chunked, batch_size=8, shuffle=False, num_workers=2)
    seen = 0
    for batch in loader:
        assert batch["action"].shape[1:] == (4, 9)
        assert batch["observation.depth"].shape[1:] == (1, h, w)
        assert batch["observation.depth"].dtype == torch.float32
        assert batch["observation.semantic"].dtype == torch.int32
        for k in range(len(batch["index"])):
            i = batch["index"][k].item()
            e = batch["episode_index"][k].item()
            minos_id = meta[e]["minos/episode_id"]
            row = rows[(minos_id, batch["frame_index"][k].item())]
            for name, expected in cameras(row, schema).items():
                assert torch.equal(batch[name][k], expected), (name, i)
            left = meta[e]["dataset_to_index"] - i
            assert batch["action_is_pad"][k].tolist() == [j >= left for j in range(4)]
        seen += len(batch["index"])
    assert seen == len(ds)
    print(f"lerobot loaded {len(ds)} frames of {ds.num_episodes} episodes at {fps} fps")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))
