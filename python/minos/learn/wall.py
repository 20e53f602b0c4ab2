"""A blind teacher: wall following from what a blind agent senses.

minos's oracle plans on the map, so it goes straight for the doorway it knows; a policy that
sees no walls (measurements M, contact bits F) cannot tell from its inputs which way the
oracle will turn at a wall, and cloned from the oracle it pushes into the wall or dithers
there (docs/RESULTS.md, "The blind rows"). :class:`WallFollower` decides from the goal vector,
the contact bits and the collision flag alone — the inputs of an M+F policy — so every one
of its decisions is a function of what the student observes (with memory), and a recurrent
policy can learn it.

It is Bug-style navigation (Lumelsky & Stepanov 1987) for MINOS's forward / turn agent:
head for the goal; when blocked with the goal ahead, follow the wall on a side drawn at
random, pressing into it so that the simulator's slide carries the body along; leave the wall
once the goal is nearer than where the wall was met by ``leave_margin`` and no longer behind
it; after ``budget`` steps along a wall without leaving it, turn round and follow it the
other way, for twice as long each time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Optional, Sequence

import numpy as np
import torch

from .data import Demonstrations
from .rollout import run_episodes
from .util import Progress, ProgressArg

#: The frame keys the wall follower reads (the Gym observation / LeRobot feature names).
KEYS = ("goal", "contact", "collision")


@dataclass
class _State:
    following: bool = False
    side: int = 1  # +1: the wall on the right, −1: on the left
    met_at: float = 0.0  # goal distance where the wall was met
    steps: int = 0  # steps along this wall
    limit: int = 0  # steps before turning round
    lost: int = 0  # steps since the wall was last felt


class WallFollower:
    """A chooser (``choose(frames, n) -> actions``, as :func:`minos.learn.rollout.run_episodes`
    takes) over ``num_envs`` environments with actions ``action_names`` (which must hold
    ``forward``, ``turn_left`` and ``turn_right``), and :meth:`clear` for environments that
    start an episode. ``frames`` holds :data:`KEYS`: ``goal`` (distance, right, forward),
    ``contact`` (front, left, back, right) and ``collision``. ``seed`` draws the side of each
    wall followed; ``budget`` is the first stretch along a wall before turning round (on the
    door-small-empty test episodes 40 steps give 91.4–94.5 % success over three seeds; a
    first version of this follower did worse with longer stretches: 89.0 % at 80 steps,
    87.1 % at 120, 79.1 % at 200)."""

    def __init__(self, num_envs: int, action_names: Sequence[str], budget: int = 40,
                 seed: int = 0, aim_deg: float = 12.0, blocked_deg: float = 30.0,
                 leave_margin: float = 0.25):
        names = list(action_names)
        missing = [a for a in ("forward", "turn_left", "turn_right") if a not in names]
        if missing:
            raise ValueError(f"the wall follower needs the actions {missing}; the environment "
                             f"has {names}")
        if budget < 1:
            raise ValueError(f"budget must be at least 1 step, got {budget}")
        self.forward = names.index("forward")
        self.left = names.index("turn_left")
        self.right = names.index("turn_right")
        self.budget = budget
        self.aim = math.radians(aim_deg)
        self.blocked = math.radians(blocked_deg)
        self.leave_margin = leave_margin
        self.rng = np.random.default_rng(seed)
        self.states = [_State() for _ in range(num_envs)]
        #: The frame keys it reads (run_episodes' ``teacher`` protocol).
        self.keys = KEYS

    def clear(self, mask: np.ndarray) -> None:
        """Forgets the walls of the environments where ``mask`` is set (a new episode)."""
        for k in np.nonzero(np.asarray(mask, bool))[0]:
            self.states[k] = _State()

    def __call__(self, frames: Mapping[str, torch.Tensor | np.ndarray], n: int) -> np.ndarray:
        goal = np.asarray(frames["goal"], np.float64).reshape(n, -1)
        contact = np.asarray(frames["contact"]).reshape(n, -1) > 0.5
        collided = np.asarray(frames["collision"]).reshape(n) > 0.5
        return np.array([self._decide(self.states[k], goal[k], contact[k], bool(collided[k]))
                         for k in range(n)], np.int64)

    def _head(self, angle: float) -> int:
        """Forward when the goal is within the aim, else the turn towards it."""
        if abs(angle) < self.aim:
            return self.forward
        return self.right if angle > 0 else self.left

    def _decide(self, s: _State, goal: np.ndarray, contact: np.ndarray, collided: bool) -> int:
        distance, right, forward = float(goal[0]), float(goal[1]), float(goal[2])
        angle = math.atan2(right, forward)  # > 0: the goal is to the right
        front, left_bit, right_bit = bool(contact[0]), bool(contact[1]), bool(contact[3])
        if not s.following:
            if (collided or front) and abs(angle) < self.blocked:
                s.following, s.met_at, s.steps, s.limit, s.lost = True, distance, 0, \
                    self.budget, 0
                s.side = 1 if self.rng.random() < 0.5 else -1
            else:
                return self._head(angle)
        s.steps += 1
        felt = right_bit if s.side == 1 else left_bit
        away, toward = (self.left, self.right) if s.side == 1 else (self.right, self.left)
        goal_clear = angle * s.side <= math.radians(10)  # not through the wall's side
        if s.steps > 3 and distance < s.met_at - self.leave_margin and goal_clear and not front:
            s.following = False
            return self._head(angle)
        if s.steps > s.limit:
            s.side, s.steps, s.limit, s.met_at = -s.side, 0, s.limit * 2, distance
            away, toward = toward, away
            felt = right_bit if s.side == 1 else left_bit
        if front or (collided and not felt):
            s.lost = 0
            return away
        if felt:
            s.lost = 0
            return self.forward
        # The wall is gone (a corner or a doorway): turn into it and step, alternately.
        s.lost += 1
        return toward if s.lost % 2 == 1 else self.forward


def wall_demonstrations(like: Demonstrations, venv, passes: int = 2, budget: int = 40,
                        seed: int = 0, successes_only: bool = False,
                        progress: ProgressArg = None,
                        callback: Optional[Callable[[dict], Any]] = None
                        ) -> tuple[Demonstrations, list[dict]]:
    """The wall follower's demonstrations: ``passes`` runs of :class:`WallFollower` over
    every episode of ``venv`` (a :class:`minos.gym.VectorNavEnv` over the *training*
    episodes), pass ``p`` drawing its walls' sides from ``seed + p``, every frame labelled
    with the follower's action. ``successes_only``: keep only the episodes the follower
    finished at the goal (filtered behaviour cloning: its failed searches, run to the step
    limit, are most of its frames in 3–5-room houses). The frames have ``like``'s keys, and
    the demonstrations its actions, camera and info (the goal categories' vocabulary among
    them); ``like``'s own frames are not among them. Returns them and one record per pass
    (``pass``, ``frames_added``, ``frames``, ``episodes_kept``, the pass's
    ``teacher_success`` and ``collisions`` over all its episodes)."""
    if passes < 1:
        raise ValueError(f"passes must be at least 1, got {passes}")
    if list(venv.action_names) != list(like.env_actions):
        raise ValueError(f"the demonstrations act in {like.env_actions}, the environment in "
                         f"{venv.action_names}")
    keys = list(like.frames)
    empty = torch.zeros(0, dtype=torch.long)
    out = Demonstrations({k: v[:0].clone() for k, v in like.frames.items()}, empty.clone(),
                         empty.clone(), empty.clone(), list(like.env_actions), like.camera,
                         dict(like.info))
    records: list[dict] = []
    for p in range(1, passes + 1):
        teacher = WallFollower(venv.num_envs, venv.action_names, budget=budget, seed=seed + p)
        bar = Progress(progress, 0, desc=f"wall follower {p}/{passes}")
        with torch.inference_mode():
            res = run_episodes(venv, None, keys, seed=seed + p, record=True, progress=bar,
                               goal_objects=like.info.get("goal_objects"), teacher=teacher)
        bar.close()
        if successes_only:
            res = res.successful()
        added = res.record_into(out)
        rec = {"pass": p, "budget": budget, "frames_added": added["frames_added"],
               "frames": added["frames"], "episodes_kept": len(res.episodes),
               "teacher_success": added["success"],
               "collisions": added["collisions"]}
        records.append(rec)
        if callback is not None:
            callback(rec)
    return out, records


__all__ = ["KEYS", "WallFollower", "wall_demonstrations"]
