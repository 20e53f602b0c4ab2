"""Demonstrations: frames read from a LeRobot dataset (the real consumer: ``LeRobotDataset`` and
a torch ``DataLoader``), held in memory as one tensor per feature, grouped into episodes.

One pass through ``LeRobotDataset`` decodes every frame once (only the columns the policy
needs); training epochs then draw whole episodes from memory. DAgger appends the frames it
collects (:meth:`Demonstrations.extend`).

Every feature the learner reads is one minos writes per step (docs/FORMATS.md); a dataset from
a minos that predates one is refused with the missing feature's name (re-export the run with
``minos export-dataset``).

What M (the measurements) holds depends on the task, as MINOS fed its agents
(:func:`minos.learn.features.measurement_keys`); :func:`dataset_tasks` tells the tasks of a
dataset from its ``goal_room`` and ``goal_object`` columns.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

import numpy as np
import torch

from .features import ACTION_STRENGTHS, action_labels

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


def video_backend() -> str:
    """LeRobot's default video decoder, torchcodec, when it loads (it needs the FFmpeg
    libraries of the system), else PyAV (whose wheels carry their own FFmpeg)."""
    try:
        import torchcodec.decoders  # noqa: F401
        return "torchcodec"
    except Exception:  # ImportError, or OSError/RuntimeError when FFmpeg is missing
        return "pyav"


def load_lerobot(root: str | Path, env_actions: Sequence[str], keys: Optional[Sequence[str]] = None,
                 repo_id: str = "minos/run", batch_size: int = 64, num_workers: int = 2,
                 decode: str = "arrow",
                 progress: Optional[Callable[[int, int], None]] = None) -> Demonstrations:
    """Reads a LeRobot dataset (``LeRobotDataset(repo_id, root=root)``) through a torch
    ``DataLoader`` into :class:`Demonstrations`.

    ``env_actions`` are the environment's discrete actions (``VectorNavEnv.action_names``) the
    9-strength ``action`` is mapped to (:func:`features.action_labels`). ``keys`` limits the
    decoded features (default: all); a key the dataset lacks raises ``KeyError`` naming the
    feature. ``progress(done, total)`` is called per batch.

    ``decode`` picks how the dataset's Hugging Face table turns rows into tensors:
    ``"lerobot"`` keeps LeRobot's own transform (``hf_transform_to_torch``, through Python
    lists); ``"arrow"`` (default) sets the table's ``torch`` format (Arrow → NumPy → torch).
    Both go through ``LeRobotDataset.__getitem__`` and give the same frames (tested).
    """
    from lerobot.datasets.lerobot_dataset import LeRobotDataset
    from lerobot.datasets.utils import hf_transform_to_torch

    # The features come from meta/info.json, checked before LeRobot opens the data.
    feats = json.loads((Path(root) / "meta" / "info.json").read_text())["features"]
    names = {_internal_name(f): f for f in feats if _internal_name(f)}
    cameras = [n for n, f in names.items() if f.startswith("observation.images.")]
    camera = cameras[0] if cameras else None
    strength_names = list(feats["action"].get("names") or ACTION_STRENGTHS)
    wanted = list(keys) if keys is not None else sorted(set(names) - {"state"})
    _require(root, wanted, names)
    videos = {k for k, f in feats.items() if f.get("dtype") == "video"}
    ds = LeRobotDataset(repo_id, root=str(root),
                        video_backend=video_backend() if videos else None)

    columns = list(_BOOKKEEPING) + [names[k] for k in wanted]
    # Decode only what is needed: depth and labels are the slow columns. Video features are
    # not columns: LeRobot decodes them from videos/ at each frame's timestamp.
    table = (set(columns) - videos) | {"timestamp", "task_index"}
    ds.hf_dataset = ds.hf_dataset.select_columns(sorted(table))
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
    frames = {k: _to_frame_layout(k, cols[names[k]]) for k in wanted}
    labels = action_labels(cols["action"].float(), strength_names, env_actions)
    # Episodes: consecutive runs of episode_index (rows are sorted by index).
    change = torch.ones(len(ep), dtype=torch.bool)
    change[1:] = ep[1:] != ep[:-1]
    starts = torch.nonzero(change).reshape(-1)
    lengths = torch.diff(torch.cat([starts, torch.tensor([len(ep)])]))
    info = {"root": str(root), "repo_id": repo_id, "features": sorted(names),
            "strength_names": strength_names, "goal_objects": goal_objects(root),
            "tasks": sorted(dataset_tasks(root))}
    return Demonstrations(frames, labels, starts, lengths, list(env_actions), camera, info)


def load_many(roots: Sequence[str | Path], env_actions: Sequence[str],
              keys: Optional[Sequence[str]] = None, **kwargs) -> Demonstrations:
    """:func:`load_lerobot` of several datasets, their episodes concatenated in the order
    given — oracle runs, ``minos serve`` recordings of people and runs of imported (e.g.
    Habitat) episodes mixed, since every minos export has the same features. ObjectGoal
    category indices are renumbered onto the sorted union of the datasets' vocabularies."""
    if not roots:
        raise ValueError("no dataset given")
    parts = [load_lerobot(r, env_actions, keys=keys, **kwargs) for r in roots]
    first = parts[0]
    keys_of = sorted(first.frames)
    vocabulary = sorted({c for p in parts for c in p.info.get("goal_objects", [])})
    for p in parts:
        if sorted(p.frames) != keys_of:
            raise KeyError(f"{p.info['root']}: features {sorted(p.frames)} differ from "
                           f"{first.info['root']}'s {keys_of}")
        if "goal_object" in p.frames:
            mine = p.info.get("goal_objects", [])
            remap = torch.tensor([vocabulary.index(c) for c in mine] + [-1], dtype=torch.long)
            g = p.frames["goal_object"]
            # −1 (no object goal) maps to the table's last entry, −1.
            p.frames["goal_object"] = remap[torch.where(g < 0, len(mine), g)]
    out = Demonstrations({k: v.clone() for k, v in first.frames.items()}, first.labels.clone(),
                         first.starts.clone(), first.lengths.clone(), list(env_actions),
                         first.camera, dict(first.info))
    for p in parts[1:]:
        out.extend(p.frames, p.labels, p.lengths.tolist())
    out.info["root"] = [str(r) for r in roots]
    out.info["goal_objects"] = vocabulary
    out.info["tasks"] = sorted({t for p in parts for t in p.info.get("tasks", [])})
    return out


def _require(root, wanted: Sequence[str], names: dict) -> None:
    missing = [k for k in wanted if k not in names]
    if missing:
        raise KeyError(
            f"{root}: the dataset has no {', '.join('observation.' + k for k in missing)} "
            "(written by a minos older than the per-step features of docs/FORMATS.md? "
            "re-export the run with `minos export-dataset --run RUN --out OUT`)")


def goal_objects(root: str | Path) -> list[str]:
    """The ObjectGoal categories ``observation.goal_object`` indexes (``info.json``'s
    ``minos.vocabulary``; empty without object goals)."""
    info = json.loads((Path(root) / "meta" / "info.json").read_text())
    f = info["features"].get("observation.goal_object") or {}
    return list((f.get("info") or {}).get("minos.vocabulary") or [])


def dataset_tasks(root: str | Path) -> set[str]:
    """The tasks among a dataset's frames: ``roomgoal`` where ``goal_room`` is set,
    ``objectgoal`` where ``goal_object`` ≥ 0, ``pointgoal`` for the other frames."""
    import pyarrow.parquet as pq

    tasks: set[str] = set()
    for f in sorted((Path(root) / "data").rglob("*.parquet")):
        t = pq.read_table(f, columns=["observation.goal_room", "observation.goal_object"])
        rooms = np.array([max(r, default=0.0) > 0 for r in t["observation.goal_room"].to_pylist()],
                         bool)
        objects = np.array([(o[0] if isinstance(o, list) else o) >= 0
                            for o in t["observation.goal_object"].to_pylist()], bool)
        if rooms.any():
            tasks.add("roomgoal")
        if objects.any():
            tasks.add("objectgoal")
        if (~rooms & ~objects).any():
            tasks.add("pointgoal")
    return tasks


def available_keys(root: str | Path, repo_id: str = "minos/run") -> tuple[set[str], Optional[str]]:
    """The frame keys of a dataset and its camera name, from ``meta/info.json`` alone (no
    decoding)."""
    info = json.loads((Path(root) / "meta" / "info.json").read_text())
    names = {_internal_name(f) for f in info["features"]} - {None}
    cameras = sorted(n for n in info["features"] if n.startswith("observation.images."))
    camera = _internal_name(cameras[0]) if cameras else None
    return {str(n) for n in names}, camera


__all__ = [
    "Demonstrations", "available_keys", "dataset_tasks", "goal_objects", "load_lerobot",
    "load_many", "video_backend",
]
