"""Rolling a policy out in :class:`minos.gym.VectorNavEnv`: every episode of the environment's
episode file once, with minos's episode metrics, and optionally the visited frames labelled
by the oracle (DAgger).

The environment resets an ended environment on its next step (Gymnasium's next-step
auto-reset): the action given to an environment whose episode just ended is ignored, and
the observation that comes back starts its next episode (``info["reset"]``). The recurrent
state is cleared there. Every input comes from the Gym observation, which holds the same
per-step features as the dataset (:func:`minos.learn.features.env_frames`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence

import numpy as np
import torch

from .features import env_frames, goal_object_map
from .metrics import EpisodeMetrics

#: choose(frames, n) -> actions (N,) int64 for the N environments.
Chooser = Callable[[dict, int], np.ndarray]


@dataclass
class RolloutResult:
    """Per-episode metrics (by episode id) and, when recorded, the frames of each episode
    with the oracle's action at every frame."""

    metrics: dict[str, EpisodeMetrics]
    episodes: list[tuple[dict[str, torch.Tensor], torch.Tensor]] = field(default_factory=list)
    episode_ids: list[str] = field(default_factory=list)  # of ``episodes``
    steps: int = 0

    def recorded(self, keys) -> tuple[dict[str, torch.Tensor], torch.Tensor, list[int]]:
        """The recorded episodes as :meth:`Demonstrations.extend` takes them: the frames of
        ``keys`` and the labels, concatenated in episode order, and each episode's length."""
        frames = {k: torch.cat([f[k] for f, _ in self.episodes]) for k in keys}
        labels = torch.cat([lab for _, lab in self.episodes])
        return frames, labels, [len(lab) for _, lab in self.episodes]

    def successful(self) -> "RolloutResult":
        """The same rollout with only its successful episodes' recordings (every episode's
        metrics kept): filtered behaviour cloning's demonstrations."""
        kept = [k for k, e in enumerate(self.episode_ids) if self.metrics[e].success]
        return RolloutResult(self.metrics, [self.episodes[k] for k in kept],
                             [self.episode_ids[k] for k in kept], self.steps)

    def record_into(self, demos) -> dict:
        """Appends the recorded episodes (the keys ``demos`` holds) to ``demos``; returns the
        pass's record: ``frames_added``, ``frames`` (now in ``demos``), the rollout's
        ``success`` rate and ``collisions`` (over every episode, recorded or not)."""
        added = 0
        if self.episodes:  # none when filtering kept none
            frames, labels, lengths = self.recorded(list(demos.frames))
            demos.extend(frames, labels, lengths)
            added = int(labels.numel())
        metrics = self.metrics.values()
        return {"frames_added": added, "frames": demos.num_frames,
                "success": sum(m.success for m in metrics) / max(len(metrics), 1),
                "collisions": int(sum(m.collisions for m in metrics))}


class _Track:
    """One environment's running episode."""

    def __init__(self) -> None:
        self.episode = None
        self.path = 0.0
        self.decisions = 0
        self.collisions = 0
        self.pos = np.zeros(3)
        self.ended = False
        self.repeat = False  # another environment started this episode first
        self.frames: list[dict[str, torch.Tensor]] = []
        self.labels: list[int] = []

    def start(self, episode, pos) -> None:
        self.__init__()
        self.episode = episode
        self.pos = np.asarray(pos, np.float64)


def policy_chooser(policy, keys: Sequence[str], device: torch.device | str = "cpu",
                   sample: bool = True, seed: int = 0) -> tuple[Chooser, Callable]:
    """A chooser driving ``policy`` (:class:`minos.learn.policy.NavPolicy`) and a reset hook
    ``clear(mask)`` for its recurrent state. ``sample``: draw from the action distribution
    (default) rather than take its argmax."""
    gen = torch.Generator().manual_seed(seed)
    holder: dict = {"h": None}

    def choose(frames: dict, n: int) -> np.ndarray:
        if holder["h"] is None:
            holder["h"] = policy.initial_state(n, device)
        f = {k: v.to(device) for k, v in frames.items() if k in keys}
        logits, holder["h"] = policy.act(f, holder["h"])
        logits = logits.float().cpu()
        if sample:
            a = torch.multinomial(torch.softmax(logits, 1), 1, generator=gen)[:, 0]
        else:
            a = logits.argmax(1)
        return a.numpy().astype(np.int64)

    def clear(mask: np.ndarray) -> None:
        if holder["h"] is not None and mask.any():
            holder["h"][:, torch.from_numpy(mask)] = 0.0

    return choose, clear


def run_episodes(venv, choose: Optional[Chooser], keys: Sequence[str],
                 clear: Optional[Callable] = None,
                 seed: int = 0, record: bool = False, beta: float = 0.0,
                 max_steps: Optional[int] = None,
                 progress: Optional[Callable[[int, int], None]] = None,
                 goal_objects: Optional[Sequence[str]] = None,
                 teacher=None) -> RolloutResult:
    """Runs every episode of ``venv`` (a :class:`minos.gym.VectorNavEnv`) once, choosing
    actions with ``choose`` (None: the oracle's).

    ``record``: keep every frame of every episode with the oracle's action as its label
    (``venv.oracle_actions()``); ``beta``: with this probability per step an environment
    takes the oracle's action instead of the chooser's (DAgger's mixture). ``max_steps`` is
    the environment's step limit override (None: each episode's own). ``progress(done,
    total)`` is called as episodes finish. ``goal_objects``: the vocabulary ``goal_object``
    frames index (a dataset's, the policy's; None: the environment's ``goal_objects``).
    ``teacher``: the expert in the oracle's place — driving when ``choose`` is None, labelling
    the recorded frames, taking β's share — a chooser with ``keys`` (the frame keys it reads)
    and ``clear(mask)`` (:class:`minos.learn.wall.WallFollower`).

    Each episode counts once, by the run that started it first: an environment that has
    finished its share of the episodes goes on to others' while the last ones run (the batch
    steps together), and those repeats are neither measured nor recorded — the first of two
    runs to *finish* would favour the shorter, successful one.
    """
    n = venv.num_envs
    names = list(venv.action_names)
    stop = names.index("stop") if "stop" in names else -1
    total = len({e.episode_id for e in venv._core.episodes})
    rng = np.random.default_rng(seed)
    obs, info = venv.reset(seed=seed)
    tracks = [_Track() for _ in range(n)]
    result = RolloutResult(metrics={})
    need_oracle = record or beta > 0.0
    started: set[str] = set()
    gmap = (goal_object_map(venv.goal_objects, goal_objects)
            if goal_objects is not None else None)
    while len(result.metrics) < total:
        fresh = np.asarray(info["reset"], bool)
        if fresh.any():
            current = venv.current_episodes()
            for k in np.nonzero(fresh)[0]:
                tracks[k].start(current[k], info["position"][k])
                tracks[k].repeat = current[k].episode_id in started
                started.add(current[k].episode_id)
            if clear is not None:
                clear(fresh)
            if teacher is not None:
                teacher.clear(fresh)
        limits = np.array([max_steps or (t.episode.max_steps if t.episode else 500)
                           for t in tracks], np.float32)
        frames = env_frames(obs, keys, gmap)
        # The oracle is asked once per step: a second question in the same state makes it
        # re-plan, which may break a tie the other way.
        if teacher is not None:
            oracle = teacher(env_frames(obs, teacher.keys), n)
        else:
            oracle = venv.oracle_actions() if need_oracle or choose is None else None
        # -1: the oracle found no plan from where the learner led the agent; such a frame
        # gets no label, and the oracle's turn falls to the learner (or, alone, forward).
        if choose is None:
            actions = np.where(oracle >= 0, oracle, 0)
        else:
            actions = choose(frames, n)
        if beta > 0.0:
            mix = (rng.random(n) < beta) & (oracle >= 0)
            actions = np.where(mix, oracle, actions)
        if record:
            for k, t in enumerate(tracks):
                if not t.ended and not t.repeat:
                    t.frames.append({key: v[k:k + 1] for key, v in frames.items()})
                    t.labels.append(int(oracle[k]) if oracle[k] >= 0 else -100)
        obs, _, term, trunc, info = venv.step(actions)
        result.steps += int(n)
        for k, t in enumerate(tracks):
            if t.ended or t.episode is None:
                continue
            pos = np.asarray(info["position"][k], np.float64)
            t.decisions += 1
            t.path += float(np.linalg.norm(pos - t.pos))
            t.pos = pos
            if actions[k] != stop:
                t.collisions += int(bool(info["collision"][k]))
            if term[k] or trunc[k]:
                t.ended = True
                ep = t.episode
                if t.repeat:
                    continue
                g = float(info["geodesic"][k])
                result.metrics[ep.episode_id] = EpisodeMetrics.finish(
                    bool(info["success"][k]), t.decisions, int(limits[k]), t.path,
                    t.collisions, float(ep.geodesic_distance), g)
                if record:
                    keys_ = t.frames[0].keys()
                    ep_frames = {key: torch.cat([f[key] for f in t.frames]) for key in keys_}
                    result.episodes.append((ep_frames, torch.tensor(t.labels)))
                    result.episode_ids.append(ep.episode_id)
                if progress is not None:
                    progress(len(result.metrics), total)
    return result


def random_chooser(num_actions: int, stop_index: int, seed: int = 0) -> Chooser:
    """Uniform random moves (never ``stop``), as minos's ``random`` agent."""
    rng = np.random.default_rng(seed)
    moves = np.array([i for i in range(num_actions) if i != stop_index])

    def choose(frames: dict, n: int) -> np.ndarray:
        return rng.choice(moves, size=n)

    return choose


__all__ = ["RolloutResult", "policy_chooser", "random_chooser", "run_episodes"]
