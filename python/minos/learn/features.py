"""What a policy sees: modalities, feature names, and the action mapping.

A frame is a dict of tensors named as the LeRobot features without their prefix
(``observation.goal`` → ``goal``, ``observation.images.gray`` → ``gray``), which are also the
names of the Gym observations of :class:`minos.gym.VectorNavEnv`. Frames from a dataset
(:mod:`minos.learn.data`) and from an environment (:func:`env_frames`) have the same keys,
dtypes and layouts, so one policy reads both:

=================  ==============================  ==========================================
key                layout (one frame)              meaning
=================  ==============================  ==========================================
camera image       (C, H, W) uint8                 ``color`` (C = 3) or ``gray`` (C = 1)
``depth``          (1, H, W) float16, metres       0 = no return
``semantic``       (1, H, W) int32                 label ids
``goal``           (3,) float32                    distance (m), direction [right, forward]
``goal_room``      (9,) float32                    RoomGoal class one-hot (zeros otherwise)
``goal_object``    (1,) int64                      ObjectGoal category index (−1 otherwise)
``at_goal``        (1,) float32                    the success test holds now
``steps_left``     (1,) float32                    steps left before truncation
``contact``        (4,) float32                    front, left, back, right contact bits
``collision``      (1,) float32                    the step into this frame collided
``previous_action``(9,) float32                    the previous frame's action strengths
=================  ==============================  ==========================================

Modalities (the MINOS paper's letters, plus S and A): ``M`` measurements (``goal`` and, where
the dataset has them, ``goal_room``, ``goal_object``, ``at_goal``, ``steps_left``), ``V``
vision (the colour or grey camera), ``D`` depth, ``F`` forces (``contact`` and ``collision``),
``S`` semantic labels, ``A`` the previous action.
"""

from __future__ import annotations

from typing import Iterable, Mapping, Sequence

import numpy as np
import torch

#: The eight MINOS action strengths then ``stop``: the ``action`` feature of a minos LeRobot
#: export (``meta/info.json`` names them; this is the order minos writes).
ACTION_STRENGTHS = (
    "forward", "backward", "strafe_left", "strafe_right",
    "turn_left", "turn_right", "look_up", "look_down", "stop",
)

MODALITIES = ("M", "V", "D", "F", "S", "A")

#: Optional measurement keys that join ``goal`` in M when the dataset has them.
MEASUREMENT_EXTRAS = ("goal_room", "goal_object", "at_goal", "steps_left")

#: Keys of the image-shaped features (everything else is a vector).
IMAGE_KEYS_NON_CAMERA = ("depth", "semantic")

VECTOR_DIMS = {
    "goal": 3, "goal_room": 9, "at_goal": 1, "steps_left": 1,
    "contact": 4, "collision": 1, "previous_action": len(ACTION_STRENGTHS),
}

#: ObjectGoal categories are one-hot over this many slots (larger indices share the last).
GOAL_OBJECT_SLOTS = 32


def parse_modalities(text: str | Sequence[str]) -> tuple[str, ...]:
    """``"M,D"`` or ``"MD"`` or ``["M", "D"]`` → ``("M", "D")`` (sorted as in MODALITIES)."""
    if isinstance(text, str):
        letters = [c for c in text.replace(",", "").replace("+", "").upper() if not c.isspace()]
    else:
        letters = [str(c).upper() for c in text]
    unknown = sorted(set(letters) - set(MODALITIES))
    if unknown:
        raise ValueError(f"unknown modalities {unknown}: use any of {','.join(MODALITIES)}")
    if not letters:
        raise ValueError("no modality given: use any of " + ",".join(MODALITIES))
    return tuple(m for m in MODALITIES if m in letters)


def modality_name(mods: Iterable[str]) -> str:
    """``("M", "D")`` → ``"M+D"`` (the paper's row names)."""
    return "+".join(mods)


def keys_for(mods: Sequence[str], available: Iterable[str], camera: str | None) -> list[str]:
    """The frame keys a policy over ``mods`` reads, given the keys a source offers.

    ``camera`` is the name of the colour or grey camera (``V``). Raises ``KeyError`` naming the
    missing feature when a modality cannot be served.
    """
    have = set(available)
    keys: list[str] = []

    def need(key: str, mod: str) -> None:
        if key not in have:
            raise KeyError(f"modality {mod} needs the feature `{key}`, which the source lacks "
                           f"(it has {sorted(have)})")
        keys.append(key)

    for m in mods:
        if m == "M":
            need("goal", m)
            keys.extend(k for k in MEASUREMENT_EXTRAS if k in have)
        elif m == "V":
            if camera is None:
                raise KeyError("modality V needs a colour or grey camera (observation.images.*)")
            need(camera, m)
        elif m == "D":
            need("depth", m)
        elif m == "S":
            need("semantic", m)
        elif m == "F":
            if "contact" not in have and "collision" not in have:
                raise KeyError("modality F needs `contact` or `collision`, which the source lacks")
            keys.extend(k for k in ("contact", "collision") if k in have)
        elif m == "A":
            need("previous_action", m)
    return keys


def action_labels(strengths: torch.Tensor, strength_names: Sequence[str],
                  env_actions: Sequence[str]) -> torch.Tensor:
    """Maps ``action`` rows (N, 9 strengths) to indices into the environment's discrete
    actions (``VectorNavEnv.action_names``).

    A frame's discrete action is the strength with the largest value (ties: the first); its
    name picks the environment action of the same name. Frames with no positive strength, or
    whose action the environment does not have (e.g. ``backward`` of ``--preset minos`` for the
    paper's forward / turn agent), get −100, which ``cross_entropy`` ignores.
    """
    lookup = torch.full((len(strength_names),), -100, dtype=torch.long)
    for i, name in enumerate(strength_names):
        if name in env_actions:
            lookup[i] = list(env_actions).index(name)
    top, idx = strengths.max(dim=1)
    labels = lookup[idx]
    labels[top <= 0] = -100
    return labels


def strengths_of(actions: np.ndarray, env_actions: Sequence[str]) -> np.ndarray:
    """Discrete environment actions (N,) → (N, 9) strength rows, as the dataset writes them."""
    out = np.zeros((len(actions), len(ACTION_STRENGTHS)), dtype=np.float32)
    col = np.array([ACTION_STRENGTHS.index(n) for n in env_actions])
    out[np.arange(len(actions)), col[np.asarray(actions)]] = 1.0
    return out


def goal_vector(position: np.ndarray, yaw: np.ndarray, goal: np.ndarray) -> np.ndarray:
    """MINOS's PointGoal measurement from world poses: (N, 3) = Euclidean distance (m) and the
    unit horizontal direction to the goal in the agent's frame, [right, forward].

    minos's agent looks along −z at yaw 0 and yaw turns it left (counter-clockwise seen from
    above): forward = (−sin yaw, 0, −cos yaw), right = (cos yaw, 0, −sin yaw). This is the
    fallback for datasets written before ``observation.goal`` existed; the test suite checks it
    against the environment's ``goal`` observation.
    """
    d = np.asarray(goal, np.float64) - np.asarray(position, np.float64)
    s, c = np.sin(yaw), np.cos(yaw)
    fwd = -s * d[:, 0] - c * d[:, 2]
    right = c * d[:, 0] - s * d[:, 2]
    norm = np.hypot(fwd, right)
    safe = np.where(norm > 1e-9, norm, 1.0)
    out = np.stack([np.linalg.norm(d, axis=1), right / safe, fwd / safe], axis=1)
    out[norm <= 1e-9, 1:] = 0.0
    return out.astype(np.float32)


def env_frames(obs: Mapping[str, np.ndarray], extra: Mapping[str, np.ndarray],
               keys: Iterable[str]) -> dict[str, torch.Tensor]:
    """A batch of Gym observations (N environments, :class:`minos.gym.VectorNavEnv`) → frames
    in the dataset's layout, for the given keys.

    ``extra`` supplies what the observation dict does not (yet) hold, computed by the caller
    from the infos (``collision``, ``previous_action``, ``steps_left``, ``at_goal``); keys
    present in ``obs`` win.
    """
    out: dict[str, torch.Tensor] = {}
    for k in keys:
        v = obs[k] if k in obs else extra[k]
        v = np.asarray(v)
        if k == "semantic":
            v = v.astype(np.int32)
            v = v[:, None] if v.ndim == 3 else np.moveaxis(v, -1, 1)
        elif k == "depth":
            v = np.moveaxis(v, -1, 1) if v.shape[-1] == 1 and v.ndim == 4 else v
            v = v.astype(np.float16)
        elif v.ndim == 4:  # camera (N, H, W, C) → (N, C, H, W)
            v = np.moveaxis(v, -1, 1) if v.shape[-1] in (1, 3) else v
        elif k == "goal_object":
            v = v.reshape(len(v), 1).astype(np.int64)
        else:
            v = v.reshape(len(v), -1).astype(np.float32)
        out[k] = torch.from_numpy(np.ascontiguousarray(v))
    return out


def normalised_vector(frames: Mapping[str, torch.Tensor],
                      keys: Sequence[str]) -> torch.Tensor | None:
    """The vector inputs of ``keys`` concatenated and scaled to about [−1, 1]: distances in
    units of 5 m (log-compressed beyond), steps left in units of 500 steps, ObjectGoal index
    one-hot over :data:`GOAL_OBJECT_SLOTS`; (N, D) float32, or None without vector keys."""
    parts = []
    for k in keys:
        if k not in VECTOR_DIMS and k != "goal_object":
            continue
        v = frames[k]
        if k == "goal":
            v = v.float()
            d = v[:, :1]
            v = torch.cat([torch.log1p(d / 5.0) * 2.0, v[:, 1:3]], dim=1)
        elif k == "steps_left":
            v = v.float() / 500.0
        elif k == "goal_object":
            idx = v.reshape(-1).long()
            oh = torch.zeros(len(idx), GOAL_OBJECT_SLOTS + 1, device=v.device)
            oh[torch.arange(len(idx)), (idx.clamp(-1, GOAL_OBJECT_SLOTS - 1) + 1)] = 1.0
            v = oh
        else:
            v = v.float()
        parts.append(v.reshape(len(v), -1))
    return torch.cat(parts, dim=1) if parts else None


def vector_width(keys: Sequence[str]) -> int:
    """The width of :func:`normalised_vector` for ``keys``."""
    return sum(GOAL_OBJECT_SLOTS + 1 if k == "goal_object" else VECTOR_DIMS.get(k, 0)
               for k in keys)


def is_image_key(key: str) -> bool:
    """True for image-shaped frame keys (cameras, depth, semantic)."""
    return key in IMAGE_KEYS_NON_CAMERA or not (key in VECTOR_DIMS or key == "goal_object")


__all__ = [
    "ACTION_STRENGTHS", "MODALITIES", "action_labels", "env_frames", "goal_vector",
    "is_image_key", "keys_for", "modality_name", "normalised_vector", "parse_modalities",
    "strengths_of", "vector_width",
]
