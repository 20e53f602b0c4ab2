"""Episode metrics, as minos defines them (``EpisodeMetrics::finish`` and ``Aggregate`` in
src/run/metrics.rs, the numbers ``minos run`` writes into metrics.json):

- ``success``: reached the goal (and stopped, for agents that must stop);
- ``speed`` (MINOS's): the fraction of the step budget left on success, ``1 − steps /
  max_steps``, else 0;
- ``spl``: success × shortest path / max(shortest path, path taken); ``soft_spl``: the same
  weight × (1 − final geodesic / start geodesic) on failure;
- ``steps`` counts every decision, a final ``stop`` included; ``path_length`` sums the
  distances moved; the shortest path is the episode's ``geodesic_distance``.

Group means count episodes that failed with an error as failures (0) in every rate.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Iterable, Optional


@dataclass
class EpisodeMetrics:
    """One episode's metrics (the fields of minos's ``EpisodeMetrics``)."""

    success: bool
    speed: float
    spl: float
    soft_spl: float
    path_length: float
    steps: int
    collisions: int
    final_geodesic: float

    @classmethod
    def finish(cls, success: bool, steps: int, max_steps: int, path_length: float,
               collisions: int, start_geodesic: float, final_geodesic: float) -> "EpisodeMetrics":
        """The derived fields from the raw ones (``EpisodeMetrics::finish``)."""
        longest = max(path_length, start_geodesic)
        weight = start_geodesic / longest if longest > 0.0 else 1.0
        if start_geodesic > 0.0 and math.isfinite(final_geodesic):
            progress = min(max(1.0 - final_geodesic / start_geodesic, 0.0), 1.0)
        else:
            progress = 0.0
        return cls(
            success=bool(success),
            speed=1.0 - steps / max(max_steps, 1) if success else 0.0,
            spl=weight if success else 0.0,
            soft_spl=weight if success else progress * weight,
            path_length=float(path_length), steps=int(steps), collisions=int(collisions),
            final_geodesic=float(final_geodesic),
        )

    def to_dict(self) -> dict:
        return asdict(self)


def aggregate(metrics: Iterable[Optional[EpisodeMetrics]]) -> dict:
    """Means over episodes (``None``: an episode that failed with an error, counted as a
    failure): ``episodes``, ``failed``, ``success``, ``spl``, ``soft_spl``, ``speed`` (over
    every episode), ``path_length``, ``steps`` and ``collisions`` (means over the episodes
    that ran) — ``Aggregate::of``."""
    ms = list(metrics)
    ran = [m for m in ms if m is not None]
    n = max(len(ms), 1)
    out = {
        "episodes": len(ms),
        "failed": len(ms) - len(ran),
        "success": sum(m.success for m in ran) / n,
        "spl": sum(m.spl for m in ran) / n,
        "soft_spl": sum(m.soft_spl for m in ran) / n,
        "speed": sum(m.speed for m in ran) / n,
        "path_length": sum(m.path_length for m in ran) / max(len(ran), 1),
        "steps": sum(m.steps for m in ran) / max(len(ran), 1),
        "collisions": sum(m.collisions for m in ran) / max(len(ran), 1),
    }
    return out


__all__ = ["EpisodeMetrics", "aggregate"]
