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

Modalities (the MINOS paper's letters, plus S and A): ``M`` measurements, per task as MINOS
fed them (:func:`measurement_keys`), ``V`` vision (the colour or grey camera), ``D`` depth,
``F`` forces (``contact`` and ``collision``), ``S`` semantic labels, ``A`` the previous action.

Frames from a dataset and from the environment index ``goal_object`` differently (the
dataset's ``minos.vocabulary``, the environment's ``goal_objects``); the policy keeps the
dataset's vocabulary and :func:`env_frames` maps the environment's indices onto it.
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

#: M per task, as MINOS's measurement functions fed its agents (minos/lib/util/measures.py):
#: PointGoal and ObjectGoal ``MeasureDistDirTime`` (distance, direction, time → ``goal`` and
#: ``steps_left``; ObjectGoal's target category beside it, as the UNREAL objective),
#: RoomGoal ``MeasureGoalRoomType`` (the goal room class one-hot) with ``MeasureMatchRoomType``
#: (in a goal room → ``at_goal``).
TASK_MEASUREMENTS = {
    "pointgoal": ("goal", "steps_left"),
    "objectgoal": ("goal", "goal_object", "steps_left"),
    "roomgoal": ("goal_room", "at_goal"),
}

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


#: The paper's order of the senses in a row's name (its table has ``M+D+V+F``, not ``M+V+D+F``).
PAPER_NAME_ORDER = ("M", "D", "V", "F", "S", "A")


def modality_name(mods: Iterable[str]) -> str:
    """``("M", "V", "D")`` → ``"M+D+V"``: the paper's row names, in its order of the senses
    (file names keep ``MODALITIES``' order: :func:`modality_tag`)."""
    mods = set(mods)
    return "+".join(m for m in PAPER_NAME_ORDER if m in mods)


def modality_tag(mods: Iterable[str]) -> str:
    """``("M", "V", "D")`` → ``"MVD"``: a row's name in file names (``MODALITIES``' order,
    which names every result and checkpoint written so far)."""
    mods = set(mods)
    return "".join(m for m in MODALITIES if m in mods)


def measurement_keys(tasks: Iterable[str]) -> list[str]:
    """The keys of M for a dataset of ``tasks`` (the union over them, in a fixed order)."""
    tasks = set(tasks) or {"pointgoal"}
    unknown = tasks - set(TASK_MEASUREMENTS)
    if unknown:
        raise ValueError(f"unknown tasks {sorted(unknown)}")
    order = ("goal", "goal_room", "goal_object", "at_goal", "steps_left")
    return [k for k in order if any(k in TASK_MEASUREMENTS[t] for t in tasks)]


def keys_for(mods: Sequence[str], available: Iterable[str], camera: str | None,
             tasks: Iterable[str] = ("pointgoal",)) -> list[str]:
    """The frame keys a policy over ``mods`` reads, given the keys a source offers and the
    tasks of its episodes (for M).

    ``camera`` is the name of the colour or grey camera (``V``). Raises ``KeyError`` naming the
    missing feature when a modality cannot be served.
    """
    have = set(available)
    keys: list[str] = []

    def need(key: str, mod: str) -> None:
        if key not in have:
            raise KeyError(f"modality {mod} needs the feature `observation.{key}`, which the "
                           f"source lacks (it has {sorted(have)})")
        keys.append(key)

    for m in mods:
        if m == "M":
            for k in measurement_keys(tasks):
                need(k, m)
        elif m == "V":
            if camera is None:
                raise KeyError("modality V needs a colour or grey camera (observation.images.*)")
            need(camera, m)
        elif m == "D":
            need("depth", m)
        elif m == "S":
            need("semantic", m)
        elif m == "F":
            need("contact", m)
            need("collision", m)
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


def env_frames(obs: Mapping[str, np.ndarray], keys: Iterable[str],
               goal_object_map: np.ndarray | None = None) -> dict[str, torch.Tensor]:
    """A batch of Gym observations (N environments, :class:`minos.gym.VectorNavEnv`) → frames
    in the dataset's layout, for the given keys. ``goal_object_map[i]`` is the dataset's index
    of the environment's category ``i`` (−1: unknown to the dataset); None keeps the indices."""
    out: dict[str, torch.Tensor] = {}
    for k in keys:
        v = np.asarray(obs[k])
        if k == "semantic":  # (N, H, W) → (N, 1, H, W)
            v = v.astype(np.int32)
            v = v[:, None] if v.ndim == 3 else np.moveaxis(v, -1, 1)
        elif k == "depth":  # (N, H, W, 1) → (N, 1, H, W)
            v = np.moveaxis(v, -1, 1) if v.shape[-1] == 1 and v.ndim == 4 else v
            v = v.astype(np.float16)
        elif v.ndim == 4:  # camera (N, H, W, C) → (N, C, H, W)
            v = np.moveaxis(v, -1, 1) if v.shape[-1] in (1, 3) else v
        elif k == "goal_object":
            v = v.reshape(len(v), 1).astype(np.int64)
            if goal_object_map is not None and len(goal_object_map):
                v = np.where(v >= 0, goal_object_map[np.clip(v, 0, None)], -1)
        else:
            v = v.reshape(len(v), -1).astype(np.float32)
        out[k] = torch.from_numpy(np.ascontiguousarray(v))
    return out


def goal_object_map(env_categories: Sequence[str], vocabulary: Sequence[str]) -> np.ndarray:
    """Environment category index → dataset vocabulary index (−1 where the dataset lacks it)."""
    vocab = list(vocabulary)
    return np.array([vocab.index(c) if c in vocab else -1 for c in env_categories], np.int64)


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
    "ACTION_STRENGTHS", "MODALITIES", "TASK_MEASUREMENTS", "action_labels", "env_frames",
    "goal_object_map", "is_image_key", "keys_for", "measurement_keys", "modality_name",
    "modality_tag",
    "normalised_vector", "parse_modalities", "strengths_of", "vector_width",
]
