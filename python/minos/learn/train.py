"""Behaviour cloning: cross-entropy between the policy's action distribution and the
demonstrated discrete action, over whole episodes (the GRU starts each from zeros, as in the
environment), batched by frame count, with Adam, checkpoints and resume.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

import numpy as np
import torch
import torch.nn.functional as F

from . import kernels
from .data import Demonstrations
from .features import keys_for
from .policy import NavPolicy, PolicySpec
from .util import Progress, ProgressArg, pick_device, save_atomic, seed_everything


@dataclass
class TrainConfig:
    """Behaviour-cloning settings (stored in checkpoints)."""

    epochs: int = 10
    batch_frames: int = 512  # frames per optimiser step (whole episodes up to this many)
    lr: float = 1e-3
    weight_decay: float = 0.0
    grad_clip: float = 1.0
    seed: int = 0
    device: str = "auto"


def make_policy(demos: Demonstrations, modalities: Sequence[str], memory: str = "gru",
                hidden: int = 128, image_size: int = 84, use_stop: bool = False,
                seed: int = 0) -> NavPolicy:
    """A policy over ``modalities`` for the frames ``demos`` holds (``use_stop``: see
    :class:`minos.learn.policy.PolicySpec`), its weights drawn from ``seed`` alone. (torch
    seeds its global generator at random in every process, so weights drawn from it would
    make the same training command give another policy each run; the global generator is
    left as it was.)"""
    tasks = demos.info.get("tasks") or ["pointgoal"]
    keys = keys_for(modalities, demos.frames.keys(), demos.camera, tasks)
    channels = {k: int(demos.frames[k].shape[1]) for k in keys if demos.frames[k].ndim == 4}
    extra = {"tasks": list(tasks), "goal_objects": list(demos.info.get("goal_objects") or [])}
    spec = PolicySpec(keys=keys, channels=channels, num_actions=len(demos.env_actions),
                      env_actions=list(demos.env_actions), modalities=list(modalities),
                      image_size=image_size, hidden=hidden, memory=memory, use_stop=use_stop,
                      extra=extra)
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        return NavPolicy(spec)


def _batches(demos: Demonstrations, budget: int, rng: np.random.Generator) -> list[np.ndarray]:
    """Shuffled episode indices grouped so that each group holds about ``budget`` frames."""
    order = rng.permutation(demos.num_episodes)
    lengths = demos.lengths.numpy()
    out, cur, frames = [], [], 0
    for e in order:
        cur.append(e)
        frames += int(lengths[e])
        if frames >= budget:
            out.append(np.array(cur))
            cur, frames = [], 0
    if cur:
        out.append(np.array(cur))
    return out


def _batch(demos: Demonstrations, episodes: np.ndarray, keys: Sequence[str],
           device: torch.device, labels: Optional[torch.Tensor] = None
           ) -> tuple[dict, torch.Tensor, torch.Tensor]:
    """Frames (in (episode, time) order), the (B, T) mask and the labels of ``episodes``."""
    starts = demos.starts[episodes]
    lengths = demos.lengths[episodes]
    t = int(lengths.max())
    mask = torch.arange(t)[None, :] < lengths[:, None]
    rows = torch.cat([torch.arange(int(s), int(s) + int(n)) for s, n in zip(starts, lengths)])
    frames = {k: demos.frames[k][rows].to(device, non_blocking=True) for k in keys}
    labels = demos.labels if labels is None else labels
    return frames, mask.to(device), labels[rows].to(device)


def training_labels(demos: Demonstrations, policy: NavPolicy) -> torch.Tensor:
    """The labels trained on: ``demos.labels`` with ``stop`` ignored (−100) unless the
    policy uses ``stop``."""
    labels = demos.labels.clone()
    if not policy.spec.use_stop and "stop" in demos.env_actions:
        labels[labels == demos.env_actions.index("stop")] = -100
    return labels


def checkpoint_state(policy: NavPolicy, optimiser, epoch: int, history: list,
                     config: TrainConfig, extra: Optional[dict] = None) -> dict:
    """What a checkpoint holds: enough to rebuild the policy and to resume training."""
    return {
        "spec": policy.spec.to_dict(), "model": policy.state_dict(),
        "optimiser": optimiser.state_dict() if optimiser is not None else None,
        "epoch": epoch, "history": history, "config": asdict(config),
        "rng": {"torch": torch.get_rng_state(), "numpy": np.random.get_state()},
        "extra": extra or {}, "cpu_kernels": kernels.settings(),
    }


def load_policy(path: str | Path, device: Optional[str] = None) -> tuple[NavPolicy, dict]:
    """A policy from a checkpoint (and the checkpoint's dict)."""
    ckpt = torch.load(path, map_location="cpu", weights_only=False)
    policy = NavPolicy(PolicySpec.from_dict(ckpt["spec"]))
    policy.load_state_dict(ckpt["model"])
    policy.to(pick_device(device)).eval()
    return policy, ckpt


def train_bc(policy: NavPolicy, demos: Demonstrations, config: TrainConfig,
             checkpoint: Optional[str | Path] = None, resume: bool = False,
             progress: ProgressArg = None,
             callback: Optional[Callable[[dict], Any]] = None,
             start_epoch: int = 0, history: Optional[list] = None) -> list[dict]:
    """Trains ``policy`` on ``demos`` for ``config.epochs`` epochs (counted from
    ``start_epoch``); returns the history, one dict per epoch (``epoch``, ``loss``,
    ``accuracy``, ``frames``, ``seconds``).

    ``checkpoint``: written after every epoch (atomically); with ``resume`` and an existing
    checkpoint, training continues after its last epoch with its optimiser and generator
    states. ``progress``: a tqdm bar, True, or ``f(done, total)`` over optimiser steps;
    ``callback(record)`` after every epoch.
    """
    device = pick_device(config.device)
    seed_everything(config.seed)
    policy.to(device).train()
    optimiser = torch.optim.Adam(policy.parameters(), lr=config.lr,
                                 weight_decay=config.weight_decay)
    history = list(history or [])
    first = start_epoch
    path = Path(checkpoint) if checkpoint else None
    if path is not None and resume and path.is_file():
        ckpt = torch.load(path, map_location="cpu", weights_only=False)
        policy.load_state_dict(ckpt["model"])
        if ckpt.get("optimiser"):
            optimiser.load_state_dict(ckpt["optimiser"])
        torch.set_rng_state(ckpt["rng"]["torch"])
        np.random.set_state(ckpt["rng"]["numpy"])
        history = ckpt["history"]
        first = ckpt["epoch"] + 1
    keys = policy.spec.keys
    labels_all = training_labels(demos, policy)
    if not bool((labels_all >= 0).any()):
        raise ValueError("no frame of the dataset has an action of the environment's set "
                         f"{demos.env_actions}")
    last = start_epoch + config.epochs
    for epoch in range(first, last):
        rng = np.random.default_rng([config.seed, epoch])
        batches = _batches(demos, config.batch_frames, rng)
        bar = Progress(progress, len(batches), desc=f"epoch {epoch + 1}/{last}")
        t0 = time.perf_counter()
        total_loss, total_right, total_n = 0.0, 0, 0
        for i, eps in enumerate(batches):
            frames, mask, labels = _batch(demos, eps, keys, device, labels_all)
            logits = policy(frames, mask)
            loss = F.cross_entropy(logits, labels, ignore_index=-100)
            optimiser.zero_grad(set_to_none=True)
            loss.backward()
            if config.grad_clip:
                torch.nn.utils.clip_grad_norm_(policy.parameters(), config.grad_clip)
            optimiser.step()
            ok = labels >= 0
            n = int(ok.sum())
            total_loss += float(loss.detach()) * n
            total_right += int((logits.argmax(1)[ok] == labels[ok]).sum())
            total_n += n
            bar.to(i + 1, {"loss": f"{total_loss / max(total_n, 1):.3f}"})
        bar.close()
        record = {"epoch": epoch, "loss": total_loss / max(total_n, 1),
                  "accuracy": total_right / max(total_n, 1), "frames": total_n,
                  "seconds": time.perf_counter() - t0}
        history.append(record)
        if path is not None:
            save_atomic(checkpoint_state(policy, optimiser, epoch, history, config), path)
        if callback is not None:
            callback(record)
    policy.eval()
    return history


__all__ = ["TrainConfig", "load_policy", "make_policy", "train_bc"]
