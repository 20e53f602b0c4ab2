"""Evaluation on held-out episodes: a trained policy, and the random agent, in
:class:`minos.gym.VectorNavEnv`, summarised with minos's metrics (success, SPL, SoftSPL,
MINOS speed)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Optional

import torch

from .metrics import aggregate
from .rollout import policy_chooser, random_chooser, run_episodes
from .util import Progress, ProgressArg, pick_device, torch_threads


def make_env(data: str | Path, episodes: str | Path, agent: str = "minos-paper",
             num_envs: int = 8, size: int = 84, seed: int = 0, max_steps: Optional[int] = None,
             require_stop: bool = False, threads: Optional[int] = None, sensors=None,
             renderer: str = "cpu", variant: Optional[str] = None):
    """The evaluation environment (one of ``num_envs`` per episode at most)."""
    import minos
    from minos.gym import VectorNavEnv

    n_eps = len(minos.read_episodes(episodes)) if not isinstance(episodes, list) else len(episodes)
    return VectorNavEnv(data=data, episodes=episodes, num_envs=max(1, min(num_envs, n_eps)),
                        agent=agent, size=size, seed=seed, max_steps=max_steps,
                        require_stop=require_stop, threads=threads, sensors=sensors,
                        renderer=renderer, variant=variant)


def evaluate_policy(policy, venv, seed: int = 0, sample: bool = True,
                    max_steps: Optional[int] = None, device: Optional[str] = None,
                    progress: ProgressArg = None) -> dict:
    """Every episode of ``venv`` once with ``policy``; returns ``{"aggregate": …,
    "episodes": {id: metrics}, "steps": env steps, "seconds": wall time}``."""
    if list(venv.action_names) != list(policy.spec.env_actions):
        raise ValueError(f"the policy acts in {policy.spec.env_actions} but the environment's "
                         f"actions are {venv.action_names} (another --agent preset?)")
    dev = pick_device(device)
    policy.to(dev).eval()
    choose, clear = policy_chooser(policy, policy.spec.keys, dev, sample=sample, seed=seed)
    bar = Progress(progress, 0, desc="evaluate")
    t0 = time.perf_counter()
    threads = 1 if dev.type == "cpu" else torch.get_num_threads()
    with torch.inference_mode(), torch_threads(threads):
        res = run_episodes(venv, choose, policy.spec.keys, clear=clear, seed=seed,
                           max_steps=max_steps, progress=bar,
                           goal_objects=policy.spec.extra.get("goal_objects"))
    bar.close()
    return _summary(res, time.perf_counter() - t0)


def evaluate_random(venv, seed: int = 0, max_steps: Optional[int] = None,
                    progress: ProgressArg = None) -> dict:
    """The random agent (uniform over the moves, never ``stop``: minos's ``random`` agent)
    on every episode of ``venv`` once."""
    names = list(venv.action_names)
    choose = random_chooser(len(names), names.index("stop") if "stop" in names else -1, seed)
    bar = Progress(progress, 0, desc="random")
    t0 = time.perf_counter()
    res = run_episodes(venv, choose, [], seed=seed, max_steps=max_steps,
                       progress=bar)
    bar.close()
    return _summary(res, time.perf_counter() - t0)


def _summary(res, seconds: float) -> dict:
    return {"aggregate": aggregate(res.metrics.values()),
            "episodes": {k: m.to_dict() for k, m in sorted(res.metrics.items())},
            "steps": res.steps, "seconds": seconds}


__all__ = ["evaluate_policy", "evaluate_random", "make_env"]
