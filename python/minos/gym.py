"""Gymnasium environments over a minos episode file.

``NavEnv`` is a ``gymnasium.Env``; ``VectorNavEnv`` a ``gymnasium.vector.VectorEnv`` that
steps its N environments in Rust threads in one call (the GIL released), resets ended
environments on their next step (Gymnasium's next-step auto-reset) and returns batched NumPy
observations. Both run the episodes as ``minos run`` does: the agent presets, sensor files,
variants and reward functions of the CLI (``dist_time``, ``path_delta``, ``geodesic``); an
episode ends on arrival (the success test after a step, unless ``require_stop``), on the
``stop`` action, or at the step limit (truncation).

Observations (a ``Dict`` space): one array per camera sensor, named as in the sensor file
(``color`` (H, W, 3) uint8, ``depth`` (H, W, 1) float32 metres, ``semantic`` (H, W) uint16
with the default sensors), and the per-step features the run tables and the LeRobot export
also hold (``observation.<key>`` there; docs/FORMATS.md): ``goal`` = (Euclidean distance,
direction right, direction forward) of the goal in the agent's frame (object and room goals:
to the target the shortest path ends at), ``goal_room`` (the room goal's MINOS class,
one-hot, 9), ``goal_object`` (the object goal's category as an index into ``goal_objects``,
-1 otherwise), ``at_goal`` (1 when the success test holds), ``contact`` (one 0/1 per contact
sensor), ``collision`` (1 when the step into this observation collided),
``previous_action`` (the previous action's eight strengths and ``stop``, zeros at an
episode's start) and ``steps_left``.

Task hooks (MINOS's task specification by a Python function): ``success_fn(obs, info) ->
bool`` replaces the success test (the episode ends when it holds, or on ``stop`` with
``require_stop``) and ``reward_fn(obs, info) -> float`` replaces the reward; ``info`` holds
the built-in ``reward`` and ``success``, ``geodesic`` and ``euclidean`` distances to the goal,
``collision``, ``steps``, ``position``, ``yaw``, ``action`` and ``episode`` (a
``minos.Episode``).
"""

from __future__ import annotations

from typing import Any, Callable, Optional

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector.utils import batch_space

from ._minos import _VecCore

try:  # gymnasium >= 1.1
    from gymnasium.vector import AutoresetMode

    _NEXT_STEP: Any = AutoresetMode.NEXT_STEP
except ImportError:  # pragma: no cover - older gymnasium
    _NEXT_STEP = "NextStep"

_INT_RANGES = {"uint8": (0, 255), "uint16": (0, 65535), "uint32": (0, 2**32 - 1)}


def _observation_space(core: _VecCore) -> spaces.Dict:
    d: dict[str, spaces.Space] = {}
    for s in core.sensor_specs:
        dtype = np.dtype(s["dtype"])
        shape = tuple(s["shape"])
        if dtype.kind == "f":
            low = 0.0 if s["modality"] == "depth" else -np.inf
            d[s["name"]] = spaces.Box(low, np.inf, shape, dtype)
        else:
            lo, hi = _INT_RANGES[s["dtype"]]
            d[s["name"]] = spaces.Box(lo, hi, shape, dtype)
    # The per-step features (minos::run::step_features), as the LeRobot export's
    # observation.* features hold them.
    d["goal"] = spaces.Box(-np.inf, np.inf, (3,), np.float32)
    d["goal_room"] = spaces.Box(0.0, 1.0, (9,), np.float32)
    d["goal_object"] = spaces.Box(-1, max(len(core.goal_objects) - 1, -1), (1,), np.int64)
    d["at_goal"] = spaces.Box(0.0, 1.0, (1,), np.float32)
    if core.contact_count:
        d["contact"] = spaces.MultiBinary(core.contact_count)
    d["collision"] = spaces.Box(0.0, 1.0, (1,), np.float32)
    d["previous_action"] = spaces.Box(0.0, np.inf, (9,), np.float32)
    d["steps_left"] = spaces.Box(0.0, np.inf, (1,), np.float32)
    return spaces.Dict(d)


def _core(data, episodes, num_envs, agent, sensors, size, renderer, reward, seed, max_steps,
          require_stop, allow_body_mismatch, threads, variant) -> _VecCore:
    return _VecCore(
        data, episodes, num_envs=num_envs, agent=agent, sensors=sensors, size=size,
        renderer=renderer, reward=reward, seed=seed, max_steps=max_steps,
        require_stop=require_stop, allow_body_mismatch=allow_body_mismatch, threads=threads,
        variant=variant,
    )


class _Hooks:
    """Applies Python success and reward functions to one environment's step."""

    def __init__(self, core: _VecCore, require_stop: bool, success_fn, reward_fn):
        self.core = core
        self.require_stop = require_stop
        self.success_fn = success_fn
        self.reward_fn = reward_fn
        self.episodes = None

    def active(self) -> bool:
        return self.success_fn is not None or self.reward_fn is not None

    def apply(self, obs, info, action_name, reward, terminated, truncated):
        info["reward"] = reward
        info["action"] = action_name
        if self.success_fn is not None:
            success = bool(self.success_fn(obs, info))
            info["success"] = success
            terminated = action_name == "stop" or (success and not self.require_stop)
            truncated = truncated and not terminated
        if self.reward_fn is not None:
            reward = float(self.reward_fn(obs, info))
        return reward, terminated, truncated


class NavEnv(gym.Env):
    """A Gymnasium environment over the episodes of a minos episode file.

    ``NavEnv(data=..., episodes=..., agent="habitat", sensors=None, size=84, renderer="cpu",
    reward="dist_time", seed=0, max_steps=None, require_stop=False,
    allow_body_mismatch=False, variant=None, reward_fn=None, success_fn=None)``

    ``episodes`` is an episode file (``minos episodes --out``) or a list of ``minos.Episode``.
    The action space is ``Discrete``: the agent's actions (``action_names``), then ``stop``.
    ``reset(seed=s)`` shuffles the episode order by ``s`` and starts over; ``reset()`` goes
    on to the next episode. ``oracle_action()`` is the oracle's next action.
    """

    metadata = {"render_modes": []}

    def __init__(self, data, episodes, agent: str = "habitat", sensors=None, size: int = 84,
                 renderer: str = "cpu", reward: str = "dist_time", seed: int = 0,
                 max_steps: Optional[int] = None, require_stop: bool = False,
                 allow_body_mismatch: bool = False, variant: Optional[str] = None,
                 reward_fn: Optional[Callable[[dict, dict], float]] = None,
                 success_fn: Optional[Callable[[dict, dict], bool]] = None):
        # With a Python success test, arrival is decided here, not by the built-in test.
        self._core = _core(data, episodes, 1, agent, sensors, size, renderer, reward, seed,
                           max_steps, require_stop or success_fn is not None,
                           allow_body_mismatch, 1, variant)
        self._hooks = _Hooks(self._core, require_stop, success_fn, reward_fn)
        self.action_names = list(self._core.action_names)
        #: The object goals' categories: what ``goal_object`` indexes.
        self.goal_objects = list(self._core.goal_objects)
        self.observation_space = _observation_space(self._core)
        self.action_space = spaces.Discrete(len(self.action_names))

    @staticmethod
    def _one(obs: dict) -> dict:
        return {k: v[0] for k, v in obs.items()}

    def _info(self, info: dict) -> dict:
        g = float(info["geodesic"][0])
        return {
            "success": bool(info["success"][0]),
            "collision": bool(info["collision"][0]),
            "geodesic": None if np.isnan(g) else g,
            "euclidean": float(info["euclidean"][0]),
            "steps": int(info["steps"][0]),
            "episode_id": info["episode_id"][0],
            "position": tuple(float(x) for x in info["position"][0]),
            "yaw": float(info["yaw"][0]),
        }

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        super().reset(seed=seed)
        obs, info = self._core.reset(seed)
        return self._one(obs), self._info(info)

    def step(self, action):
        a = int(action)
        obs, r, term, trunc, info = self._core.step(np.asarray([a], dtype=np.int64))
        o, i = self._one(obs), self._info(info)
        reward, terminated, truncated = float(r[0]), bool(term[0]), bool(trunc[0])
        if self._hooks.active():
            i["episode"] = self._core.current_episodes()[0]
            reward, terminated, truncated = self._hooks.apply(
                o, i, self.action_names[a], reward, terminated, truncated)
            if terminated or truncated:
                self._core.set_done(np.asarray([True]))
        return o, reward, terminated, truncated, i

    def oracle_action(self) -> int:
        """The oracle's next action (an index into ``action_names``; ``stop`` at the goal; -1
        where it finds no plan from the current state, e.g. one a learner drove it to)."""
        return int(self._core.oracle_actions()[0])

    @property
    def episode(self):
        """The current ``minos.Episode``."""
        return self._core.current_episodes()[0]


def _vector_info(info: dict, n: int) -> dict:
    """``info`` in gymnasium's vector-info form: every value an ``(n, …)`` array (lists, e.g.
    of episode ids, become object arrays) with its mask ``info["_k"]`` saying which of the
    ``n`` environments report ``info["k"]`` (all of them: every minos key is set every
    step)."""
    for key in [k for k in info if not k.startswith("_")]:
        if isinstance(info[key], list):
            column = np.empty(len(info[key]), dtype=object)
            column[:] = info[key]
            info[key] = column
        info["_" + key] = np.ones(n, dtype=bool)
    return info


class VectorNavEnv(gym.vector.VectorEnv):
    """N ``NavEnv`` stepped together in Rust threads: ``VectorNavEnv(data=..., episodes=...,
    num_envs=N, threads=None, **NavEnv options)``.

    Environment i runs episodes i, i + N, … of the order; ended environments reset on their
    next step (``metadata["autoreset_mode"]`` is next-step). Observations are a dict of
    ``(N, …)`` arrays; infos a dict of ``(N,)`` arrays (``success``, ``collision``,
    ``geodesic`` (NaN when unknown), ``euclidean``, ``steps``, ``reset`` (this step was a
    reset), ``episode_index``, ``episode_id``, ``position``, ``yaw``), each with gymnasium's
    mask ``_<key>`` (a boolean ``(N,)`` array: which environments report the key; every one
    does), as gymnasium's vector wrappers expect (``episode_id`` is an object array).
    ``threads`` sets the Rust worker threads (default: all cores).
    """

    metadata = {"autoreset_mode": _NEXT_STEP, "render_modes": []}

    def __init__(self, data, episodes, num_envs: int = 1, agent: str = "habitat", sensors=None,
                 size: int = 84, renderer: str = "cpu", reward: str = "dist_time",
                 seed: int = 0, max_steps: Optional[int] = None, require_stop: bool = False,
                 allow_body_mismatch: bool = False, variant: Optional[str] = None,
                 threads: Optional[int] = None,
                 reward_fn: Optional[Callable[[dict, dict], float]] = None,
                 success_fn: Optional[Callable[[dict, dict], bool]] = None):
        self._core = _core(data, episodes, num_envs, agent, sensors, size, renderer, reward,
                           seed, max_steps, require_stop or success_fn is not None,
                           allow_body_mismatch, threads, variant)
        self._hooks = _Hooks(self._core, require_stop, success_fn, reward_fn)
        self.num_envs = num_envs
        self.action_names = list(self._core.action_names)
        #: The object goals' categories: what ``goal_object`` indexes.
        self.goal_objects = list(self._core.goal_objects)
        self.single_observation_space = _observation_space(self._core)
        self.single_action_space = spaces.Discrete(len(self.action_names))
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)

    def reset(self, *, seed=None, options: Optional[dict] = None):
        if isinstance(seed, (list, tuple)):
            seed = seed[0] if seed else None
        super().reset(seed=seed)
        obs, info = self._core.reset(seed)
        return obs, _vector_info(info, self.num_envs)

    def step(self, actions):
        a = np.asarray(actions, dtype=np.int64).reshape(self.num_envs)
        obs, r, term, trunc, info = self._core.step(a)
        rewards = r.astype(np.float64)
        if self._hooks.active():
            term, trunc = term.copy(), trunc.copy()
            episodes = self._core.current_episodes()
            for k in range(self.num_envs):
                if info["reset"][k]:
                    continue
                o = {name: v[k] for name, v in obs.items()}
                i = {name: (v[k] if not isinstance(v, list) else v[k]) for name, v in info.items()}
                i["episode"] = episodes[k]
                rewards[k], term[k], trunc[k] = self._hooks.apply(
                    o, i, self.action_names[a[k]], float(rewards[k]), bool(term[k]), bool(trunc[k]))
            self._core.set_done(term | trunc)
        return obs, rewards, term, trunc, _vector_info(info, self.num_envs)

    def oracle_actions(self) -> np.ndarray:
        """The oracle's next action of every environment, as an (N,) int64 array (-1 where it
        finds no plan from that environment's state)."""
        return self._core.oracle_actions()

    def current_episodes(self):
        """The current ``minos.Episode`` of every environment."""
        return self._core.current_episodes()


__all__ = ["NavEnv", "VectorNavEnv"]
