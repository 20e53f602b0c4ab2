"""DART (Laskey et al. 2017, "DART: Noise Injection for Robust Imitation Learning") with
minos's oracle as the supervisor: the oracle drives the training episodes, a uniformly random
move replaces its action with probability ``eps`` per step, and every visited frame is
labelled with the oracle's action (``VectorNavEnv.oracle_actions()``). The frames join the
demonstrations before cloning.

An oracle that is never wrong never shows how to recover: it turns away from a wall before
touching it, so its demonstrations hold no contact and almost no off-path state. A blind
policy (measurements, contact bits, no image) cloned from them pushes into the first wall
between it and the goal for the rest of the episode. DAgger's rollouts of such a policy
wander far from the oracle's paths and made the blind rows worse; DART's perturbed oracle
stays near them and shows the corrections (docs/RESULTS.md).
"""

from __future__ import annotations

from typing import Any, Callable, Optional

import torch

from .data import Demonstrations
from .rollout import random_chooser, run_episodes
from .util import Progress, ProgressArg


def noisy_demonstrations(demos: Demonstrations, venv, rounds: int = 2, eps: float = 0.3,
                         seed: int = 0, progress: ProgressArg = None,
                         goal_objects: Optional[list[str]] = None,
                         callback: Optional[Callable[[dict], Any]] = None) -> list[dict]:
    """Adds ``rounds`` passes over every episode of ``venv`` (a
    :class:`minos.gym.VectorNavEnv` over the *training* episodes) to ``demos``: the oracle's
    actions with a random move (never ``stop``) instead with probability ``eps``, every frame
    labelled with the oracle's action. Only the keys ``demos`` holds are recorded. Returns one
    record per round (``round``, ``eps``, ``frames_added``, ``frames``, the rollout's
    ``rollout_success`` and ``collisions``)."""
    if not 0.0 <= eps < 1.0:
        raise ValueError(f"eps: {eps} is not a probability below 1")
    if list(venv.action_names) != list(demos.env_actions):
        raise ValueError(f"the demonstrations act in {demos.env_actions}, the environment in "
                         f"{venv.action_names}")
    keys = list(demos.frames)
    if goal_objects is None:
        goal_objects = demos.info.get("goal_objects")
    names = list(venv.action_names)
    stop = names.index("stop") if "stop" in names else -1
    records: list[dict] = []
    for r in range(1, rounds + 1):
        choose = random_chooser(len(names), stop, seed=seed + r)
        bar = Progress(progress, 0, desc=f"noise {r}/{rounds} rollout")
        with torch.inference_mode():
            res = run_episodes(venv, choose, keys, seed=seed + r, record=True,
                               beta=1.0 - eps, progress=bar, goal_objects=goal_objects)
        bar.close()
        added = res.record_into(demos)
        rec = {"round": r, "eps": eps, "frames_added": added["frames_added"],
               "frames": added["frames"], "rollout_success": added["success"],
               "collisions": added["collisions"]}
        records.append(rec)
        if callback is not None:
            callback(rec)
    return records


__all__ = ["noisy_demonstrations"]
