"""minos.learn: the reference learner — behaviour cloning (with DAgger or DART) from minos's
LeRobot datasets and evaluation in :class:`minos.gym.VectorNavEnv` on unseen houses with
minos's metrics (docs/PYTHON.md, "Learning"). Needs torch and lerobot.

    from minos.learn import load_lerobot, make_policy, train_bc, TrainConfig
    from minos.learn import make_env, evaluate_policy
    demos = load_lerobot("runs/oracle/lerobot", ["forward", "turn_left", "turn_right", "stop"])
    policy = make_policy(demos, ("M", "D"))
    train_bc(policy, demos, TrainConfig(epochs=10), checkpoint="md.pt", progress=True)
    print(evaluate_policy(policy, make_env("DATA", "eps/test.parquet"))["aggregate"])

Command line: ``python -m minos.learn {train,eval,cell} --help``.

Importing it selects torch's CPU kernels (:mod:`minos.learn.kernels`): by default the
portable ones, which give the same bits on AVX2 and AVX-512 processors.
"""

import warnings

from . import kernels

try:  # before any of torch's convolutions (oneDNN reads its settings once)
    kernels.select()
except ValueError as e:
    warnings.warn(f"{e}; the portable kernels are used", stacklevel=2)
    kernels.select("portable")

from .cell import CellConfig, run_cell
from .dagger import dagger
from .dart import noisy_demonstrations
from .data import Demonstrations, load_lerobot
from .evaluate import evaluate_policy, evaluate_random, make_env
from .metrics import EpisodeMetrics, aggregate
from .policy import NavPolicy, PolicySpec
from .train import TrainConfig, load_policy, make_policy, train_bc

__all__ = [
    "CellConfig", "Demonstrations", "EpisodeMetrics", "NavPolicy", "PolicySpec", "TrainConfig",
    "aggregate", "dagger", "evaluate_policy", "evaluate_random", "kernels", "load_lerobot",
    "load_policy", "make_env", "make_policy", "noisy_demonstrations", "run_cell", "train_bc",
]
