"""DAgger (Ross et al. 2011) with minos's oracle as the expert: roll the current policy out
on the training episodes (with probability β per step the oracle acts instead), label every
visited frame with the oracle's action (``VectorNavEnv.oracle_actions()``), add those
episodes to the demonstrations, and retrain; β halves every iteration (β_i = β₀ / 2^(i−1)).

Each round retrains the policy it rolled out on every frame so far, so a round costs its
epochs times all the frames: most of a DAgger row's time (docs/RESULTS.md, "Cost"). Fewer
epochs per round than the cloning had (``epochs``) fine-tune instead of retraining.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, Callable, Optional

import torch

from .data import Demonstrations
from .rollout import policy_chooser, run_episodes
from .train import TrainConfig, train_bc
from .util import Progress, ProgressArg, pick_device, save_atomic, torch_threads


def dagger(policy, demos: Demonstrations, venv, config: TrainConfig, iterations: int = 3,
           beta: float = 0.5, checkpoint: Optional[str | Path] = None,
           progress: ProgressArg = None,
           callback: Optional[Callable[[dict], Any]] = None,
           epochs: Optional[int] = None) -> list[dict]:
    """Runs ``iterations`` DAgger rounds on ``venv`` (a :class:`minos.gym.VectorNavEnv` over
    the *training* episodes), each followed by ``epochs`` (default ``config.epochs``) epochs
    of behaviour cloning on all the frames so far; ``policy`` should already be trained on
    ``demos``. Returns one record per round (``iteration``, ``beta``, ``frames_added``,
    ``unlabelled`` — the frames added where the oracle found no plan, which train nothing —,
    ``frames``, the rollout's success, and the last epoch's ``loss``). ``checkpoint`` is
    rewritten after every round.
    """
    if list(venv.action_names) != list(policy.spec.env_actions):
        raise ValueError(f"the policy acts in {policy.spec.env_actions}, the environment in "
                         f"{venv.action_names}")
    if epochs is not None:
        if epochs < 1:
            raise ValueError(f"epochs: {epochs} DAgger epochs a round; at least 1")
        config = replace(config, epochs=epochs)
    keys = policy.spec.keys
    demos.frames = {k: demos.frames[k] for k in keys}
    device = pick_device(config.device)
    records: list[dict] = []
    history: list[dict] = []
    for i in range(1, iterations + 1):
        b = beta / 2 ** (i - 1)
        policy.to(device).eval()
        choose, clear = policy_chooser(policy, keys, device, sample=True, seed=config.seed + i)
        bar = Progress(progress, 0, desc=f"dagger {i}/{iterations} rollout")
        with torch.inference_mode(), torch_threads(1 if device.type == "cpu" else
                                                   torch.get_num_threads()):
            res = run_episodes(venv, choose, keys, clear=clear, seed=config.seed + i,
                               record=True, beta=b, progress=bar,
                               goal_objects=policy.spec.extra.get("goal_objects"))
        bar.close()
        frames, labels, lengths = res.recorded(keys)
        demos.extend(frames, labels, lengths)
        history = train_bc(policy, demos, config, progress=progress,
                           start_epoch=len(history), history=history)
        success = sum(m.success for m in res.metrics.values()) / max(len(res.metrics), 1)
        rec = {"iteration": i, "beta": b, "frames_added": int(labels.numel()),
               "unlabelled": int((labels < 0).sum()), "frames": demos.num_frames, "rollout_success": success,
               "loss": history[-1]["loss"]}
        records.append(rec)
        if checkpoint is not None:
            from .train import checkpoint_state

            save_atomic(checkpoint_state(policy, None, len(history) - 1, history, config,
                                         {"dagger": records}), Path(checkpoint))
        if callback is not None:
            callback(rec)
    return records


__all__ = ["dagger"]
