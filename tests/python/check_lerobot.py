"""Loads a minos LeRobot dataset with the real lerobot package and checks it.

Usage: check_lerobot.py DATASET_ROOT RUN_DIR

Checks, with lerobot's own classes and functions:
- LeRobotDataset(repo_id, root=DATASET_ROOT) loads offline; its length, episode count and fps
  are those of info.json;
- every frame is read; episode boundaries from meta/episodes match each frame's
  episode_index/frame_index; the last frame of each episode is done;
- the task string of each frame is its episode's instruction in the run's episodes.parquet;
- colour frames equal the run's raw observations scaled to [0, 1]; depth and semantic arrays
  equal them exactly;
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
    raw = {}
    for row in obs.to_pylist():
        raw[(row["episode_id"], row["step"])] = row

    meta = ds.meta.episodes
    for e in range(ds.num_episodes):
        start, end = meta[e]["dataset_from_index"], meta[e]["dataset_to_index"]
        minos_id = meta[e]["minos/episode_id"]
        for i in range(start, end):
            item = ds[i]
            assert item["episode_index"].item() == e
            assert item["frame_index"].item() == i - start
            assert item["task"] == instructions[minos_id], (item["task"], minos_id)
            row = raw[(minos_id, i - start)]
            h, w, c = json.loads(schema.field("color").metadata[b"shape"])
            color = np.frombuffer(row["color"], dtype=np.uint8).reshape(h, w, c)
            expected = torch.from_numpy(color.transpose(2, 0, 1).astype(np.float32) / 255.0)
            assert torch.allclose(item["observation.images.color"], expected)
            depth = np.frombuffer(row["depth"], dtype="<f4").reshape(h, w, 1)
            assert np.array_equal(item["observation.depth"].numpy(), depth)
            semantic = np.frombuffer(row["semantic"], dtype="<u2").reshape(h, w, 1)
            assert np.array_equal(item["observation.semantic"].numpy(), semantic.astype(np.int64))
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
    assert batch["observation.images.color"].shape[1:] == (3, h, w)
    print(f"lerobot loaded {len(ds)} frames of {ds.num_episodes} episodes at {fps} fps")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))
