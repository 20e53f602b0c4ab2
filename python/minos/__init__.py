"""minos in Python: the simulator, path queries, Gymnasium environments and the dataset
pipeline of minos, in-process (bindings of the Rust library, built with PyO3 + maturin).

    import minos
    minos.generate("gen", houses=2, seed=1)
    minos.ingest("gen", "DATA")
    minos.split("DATA", "all", ratios=(0.6, 0.2, 0.2))
    minos.bake("DATA")
    minos.sample_episodes("DATA", "pointgoal", "eps.parquet", per_scene=5)
    sim = minos.Simulator("DATA", minos.read_episodes("eps.parquet")[0].scene_id)

Errors raise :class:`MinosError` with the one-line message the command line prints. See
docs/PYTHON.md.
"""

from ._minos import (
    BadInputError,
    BodyMismatchError,
    Episode,
    LockedError,
    MinosError,
    NotFoundError,
    NotReadyError,
    PathFinder,
    Simulator,
    __version__,
    bake,
    diff,
    generate,
    import_episodes,
    ingest,
    read_episodes,
    run,
    sample_episodes,
    split,
    variants,
    verify,
)


class GreedyFollower:
    """Habitat's ``GreedyFollower``: the next action towards the simulator's goal, from the
    oracle (it plans over the agent's reachable states with the simulator's own motion, so
    it never gets stuck on a reachable goal). ``next_action()`` returns an action name, or
    ``"stop"`` once the success test holds."""

    def __init__(self, sim: Simulator):
        self.sim = sim

    def next_action(self) -> str:
        return self.sim.oracle_action()


__all__ = [
    "BadInputError",
    "BodyMismatchError",
    "Episode",
    "GreedyFollower",
    "LockedError",
    "MinosError",
    "NotFoundError",
    "NotReadyError",
    "PathFinder",
    "Simulator",
    "__version__",
    "bake",
    "diff",
    "generate",
    "import_episodes",
    "ingest",
    "read_episodes",
    "run",
    "sample_episodes",
    "split",
    "variants",
    "verify",
]
