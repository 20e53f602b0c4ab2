"""Demonstrations: frames read from a LeRobot dataset (the real consumer: ``LeRobotDataset`` and
a torch ``DataLoader``), held in memory as one tensor per feature, grouped into episodes.

One pass through ``LeRobotDataset`` decodes every frame once (only the columns the policy
needs); training epochs then draw whole episodes from memory. DAgger appends the frames it
collects (:meth:`Demonstrations.extend`).

Datasets written by minos builds that predate a feature of the contract (docs/FORMATS.md) are
completed from what they do have (the fallbacks, logged once each):

- ``goal`` ← ``observation.state`` (x, y, z, yaw) and the episode's goal position from the
  episode file (``episodes=``, else the run's ``manifest.json`` beside the dataset);
- ``previous_action`` ← the previous frame's ``action`` (zeros at an episode's first frame);
- ``steps_left`` ← the episode's step limit − ``frame_index``;
- ``contact`` / ``collision`` ← the run's ``trajectories.parquet`` beside the dataset;
- depth and semantic stored (H, W, 1) are made (1, H, W).
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

import numpy as np
import torch

from .features import ACTION_STRENGTHS, action_labels, goal_vector

log = logging.getLogger("minos.learn")

_BOOKKEEPING = ("episode_index", "frame_index", "index", "action")


@dataclass
class Demonstrations:
    """Frames in memory: ``frames[key]`` is an (N, …) tensor in the layout of
    :mod:`minos.learn.features`; ``labels`` (N,) indices into ``env_actions`` (−100: ignored);
    episode ``e`` is rows ``starts[e] : starts[e] + lengths[e]``."""

    frames: dict[str, torch.Tensor]
    labels: torch.Tensor
    starts: torch.Tensor
    lengths: torch.Tensor
    env_actions: list[str]
    camera: Optional[str] = None
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def num_frames(self) -> int:
        return int(self.labels.shape[0])

    @property
    def num_episodes(self) -> int:
        return int(self.starts.shape[0])

    def episode(self, e: int) -> tuple[dict[str, torch.Tensor], torch.Tensor]:
        """Frames and labels of episode ``e``."""
        s, n = int(self.starts[e]), int(self.lengths[e])
        return {k: v[s:s + n] for k, v in self.frames.items()}, self.labels[s:s + n]

    def extend(self, frames: dict[str, torch.Tensor], labels: torch.Tensor,
               lengths: Sequence[int]) -> None:
        """Appends episodes (frames with the same keys, concatenated in episode order)."""
        base = self.num_frames
        for k in self.frames:
            self.frames[k] = torch.cat([self.frames[k], frames[k].to(self.frames[k].dtype)])
        self.labels = torch.cat([self.labels, labels.long()])
        lens = torch.as_tensor(list(lengths), dtype=torch.long)
        starts = base + torch.cumsum(lens, 0) - lens
        self.starts = torch.cat([self.starts, starts])
        self.lengths = torch.cat([self.lengths, lens])

    def label_counts(self) -> dict[str, int]:
        """Frames per action name (``ignored``: frames without a usable action)."""
        out = {n: int((self.labels == i).sum()) for i, n in enumerate(self.env_actions)}
        out["ignored"] = int((self.labels < 0).sum())
        return out


def _internal_name(feature: str) -> Optional[str]:
    for prefix in ("observation.images.", "observation."):
        if feature.startswith(prefix):
            return feature[len(prefix):]
    return None


def _goal_positions(ds, episodes_file: Optional[Path]) -> tuple[dict, dict]:
    """episode_index → goal position and → step limit, from the episode file the run used."""
    import minos

    root = Path(ds.root)
    path = episodes_file
    if path is None:
        manifest = root.parent / "manifest.json"
        if manifest.is_file():
            given = Path(json.loads(manifest.read_text())["episodes_file"])
            for cand in (given, root.parent.parent / given, root.parent / given):
                if cand.is_file():
                    path = cand
                    break
    if path is None:
        raise FileNotFoundError(
            "the dataset has no observation.goal and no episode file to derive it from: pass "
            "episodes=FILE (the file `minos run` rolled out)")
    by_id = {e.episode_id: e for e in minos.read_episodes(path)}
    goals, limits = {}, {}
    meta = ds.meta.episodes
    for idx, eid in zip(meta["episode_index"], meta["minos/episode_id"]):
        ep = by_id[eid]
        goal = ep.goal
        if goal.get("kind") != "point":
            raise ValueError(f"episode {eid}: the goal vector fallback needs PointGoal episodes "
                             "(a newer minos export has observation.goal for every task)")
        goals[int(idx)] = np.asarray(goal["position"], np.float64)
        limits[int(idx)] = int(ep.max_steps)
    return goals, limits


def _trajectory_columns(ds, ep: torch.Tensor, fr: torch.Tensor) -> dict[str, np.ndarray]:
    """``contact`` and ``collision`` of the frames (episode_index, frame_index) from the run's
    trajectories.parquet."""
    import pyarrow.parquet as pq

    path = Path(ds.root).parent / "trajectories.parquet"
    if not path.is_file():
        raise FileNotFoundError(f"the dataset has no observation.contact/collision and {path} "
                                "is missing (modality F needs a newer minos export)")
    t = pq.read_table(path, columns=["episode_id", "step", "collision", "contacts"]).to_pandas()
    rows = {(e, int(s)): i for i, (e, s) in enumerate(zip(t["episode_id"], t["step"]))}
    meta = ds.meta.episodes
    ids = dict(zip(meta["episode_index"], meta["minos/episode_id"]))
    # Row `step` holds the action taken at frame `step` and what it led to (its collision,
    # the contacts after it): frame k's values are row k − 1's (zeros at an episode's start).
    order = np.array([rows.get((ids[int(e)], int(f) - 1), -1)
                      for e, f in zip(ep.tolist(), fr.tolist())])
    contacts = np.stack(t["contacts"].to_numpy()).astype(np.float32)
    collisions = t["collision"].to_numpy().astype(np.float32)
    first = order < 0
    contact = contacts[order]
    collision = collisions[order][:, None]
    contact[first] = 0.0
    collision[first] = 0.0
    return {"contact": contact, "collision": collision}


def _to_frame_layout(key: str, v: torch.Tensor) -> torch.Tensor:
    """A decoded LeRobot column (N, …) → the layout of minos.learn.features."""
    if v.ndim == 4 and v.shape[-1] in (1, 3) and v.shape[1] not in (1, 3):
        v = v.permute(0, 3, 1, 2)  # (N, H, W, C) → (N, C, H, W)
    if key == "depth":
        return v.to(torch.float16).contiguous()
    if key == "semantic":
        return v.to(torch.int32).contiguous()
    if v.ndim == 4:  # images: float [0, 1] (LeRobot's transform) or uint8 (arrow decoding)
        if v.dtype == torch.uint8:
            return v.contiguous()
        return (v * 255.0).round().clamp(0, 255).to(torch.uint8).contiguous()
    if key == "goal_object":
        return v.reshape(len(v), 1).long()
    return v.reshape(len(v), -1).float()


def load_lerobot(root: str | Path, env_actions: Sequence[str], keys: Optional[Sequence[str]] = None,
                 repo_id: str = "minos/run", episodes: Optional[str | Path] = None,
                 batch_size: int = 64, num_workers: int = 2, decode: str = "arrow",
                 progress: Optional[Callable[[int, int], None]] = None) -> Demonstrations:
    """Reads a LeRobot dataset (``LeRobotDataset(repo_id, root=root)``) through a torch
    ``DataLoader`` into :class:`Demonstrations`.

    ``env_actions`` are the environment's discrete actions (``VectorNavEnv.action_names``) the
    9-strength ``action`` is mapped to (:func:`features.action_labels`). ``keys`` limits the
    decoded features (default: all); ``episodes`` is the episode file of the run (only for
    the ``goal`` fallback of older exports). ``progress(done, total)`` is called per batch.

    ``decode`` picks how the dataset's Hugging Face table turns rows into tensors:
    ``"lerobot"`` keeps LeRobot's own transform (``hf_transform_to_torch``: through Python
    lists, ≈ 30–70 frames/s with depth on two cores for minos ≤ 0.1 exports); ``"arrow"``
    (default) sets the table's ``torch`` format (Arrow → NumPy → torch, ≈ 1,000+ frames/s).
    Both go through ``LeRobotDataset.__getitem__`` and give the same frames (tested).
    """
    from lerobot.datasets.lerobot_dataset import LeRobotDataset
    from lerobot.datasets.utils import hf_transform_to_torch

    ds = LeRobotDataset(repo_id, root=str(root))
    feats = ds.meta.features
    names = {_internal_name(f): f for f in feats if _internal_name(f)}
    cameras = [n for n, f in names.items() if f.startswith("observation.images.")]
    camera = cameras[0] if cameras else None
    strength_names = list(feats["action"].get("names") or ACTION_STRENGTHS)
    available = set(names) | {"goal", "previous_action", "steps_left"}
    if "contact" in names or (Path(ds.root).parent / "trajectories.parquet").is_file():
        available |= {"contact", "collision"}
    wanted = list(keys) if keys is not None else sorted(available - {"state"})
    missing = [k for k in wanted if k not in available]
    if missing:
        raise KeyError(f"{root}: no feature for {missing} (has {sorted(names)})")

    direct = [k for k in wanted if k in names]
    columns = list(_BOOKKEEPING) + [names[k] for k in direct]
    need_state = "goal" in wanted and "goal" not in names
    if need_state:
        columns.append("observation.state")
    # Decode only what is needed: depth and labels are the slow columns.
    ds.hf_dataset = ds.hf_dataset.select_columns(sorted(set(columns) | {"timestamp", "task_index"}))
    if decode == "lerobot":
        ds.hf_dataset.set_transform(hf_transform_to_torch)
    elif decode == "arrow":
        ds.hf_dataset.set_format("torch")
    else:
        raise ValueError(f"decode: `{decode}` is neither `arrow` nor `lerobot`")

    loader = torch.utils.data.DataLoader(ds, batch_size=batch_size, shuffle=False,
                                         num_workers=num_workers)
    chunks: dict[str, list[torch.Tensor]] = {c: [] for c in columns}
    total = len(loader)
    for i, batch in enumerate(loader):
        for c in columns:
            chunks[c].append(batch[c])
        if progress is not None:
            progress(i + 1, total)
    cols = {c: torch.cat(v) for c, v in chunks.items()}
    order = torch.argsort(cols["index"].reshape(-1))
    cols = {c: v[order] for c, v in cols.items()}

    ep = cols["episode_index"].reshape(-1).long()
    fr = cols["frame_index"].reshape(-1).long()
    action = cols["action"].float()
    frames: dict[str, torch.Tensor] = {k: _to_frame_layout(k, cols[names[k]]) for k in direct}
    fallbacks: list[str] = []
    if need_state or ("steps_left" in wanted and "steps_left" not in names):
        goals, limits = _goal_positions(ds, Path(episodes) if episodes else None)
    if need_state:
        state = cols["observation.state"].double().numpy()
        g = np.stack([goals[int(e)] for e in ep])
        frames["goal"] = torch.from_numpy(goal_vector(state[:, :3], state[:, 3], g))
        fallbacks.append("goal from observation.state and the episode file")
    if "steps_left" in wanted and "steps_left" not in names:
        lim = torch.tensor([limits[int(e)] for e in ep], dtype=torch.float32)
        frames["steps_left"] = (lim - fr.float())[:, None]
        fallbacks.append("steps_left from frame_index and the episode's step limit")
    if "previous_action" in wanted and "previous_action" not in names:
        prev = torch.zeros_like(action)
        prev[1:] = action[:-1]
        prev[fr == 0] = 0.0
        frames["previous_action"] = prev
        fallbacks.append("previous_action from the previous frame's action")
    if any(k in wanted and k not in names for k in ("contact", "collision")):
        tc = _trajectory_columns(ds, ep, fr)
        for k in ("contact", "collision"):
            if k in wanted and k not in names:
                frames[k] = torch.from_numpy(tc[k])
        fallbacks.append("contact/collision from the run's trajectories.parquet")
    for f in fallbacks:
        log.warning("%s: fallback: %s", root, f)

    labels = action_labels(action, strength_names, env_actions)
    # Episodes: consecutive runs of episode_index (rows are sorted by index).
    change = torch.ones(len(ep), dtype=torch.bool)
    change[1:] = ep[1:] != ep[:-1]
    starts = torch.nonzero(change).reshape(-1)
    lengths = torch.diff(torch.cat([starts, torch.tensor([len(ep)])]))
    info = {"root": str(root), "repo_id": repo_id, "features": sorted(names),
            "fallbacks": fallbacks, "strength_names": strength_names}
    return Demonstrations(frames, labels, starts, lengths, list(env_actions), camera, info)


def available_keys(root: str | Path, repo_id: str = "minos/run") -> tuple[set[str], Optional[str]]:
    """The frame keys :func:`load_lerobot` can serve for a dataset, and its camera name,
    from ``meta/info.json`` alone (no decoding)."""
    info = json.loads((Path(root) / "meta" / "info.json").read_text())
    names = {_internal_name(f) for f in info["features"]} - {None}
    cameras = sorted(n for n in info["features"] if n.startswith("observation.images."))
    # steps_left is derivable too, but M takes it only where the dataset has it.
    have = set(names) | {"goal", "previous_action"}
    if "contact" in names or (Path(root).parent / "trajectories.parquet").is_file():
        have |= {"contact", "collision"}
    camera = _internal_name(cameras[0]) if cameras else None
    return {str(n) for n in have}, camera


__all__ = ["Demonstrations", "available_keys", "load_lerobot"]
