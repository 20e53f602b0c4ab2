"""Loads minos's Habitat exports with habitat-lab's own dataset classes (tests/habitat.rs).

Usage: habitat_check.py DIR SPLIT SUFFIX
  DIR/pointgoal, DIR/objectgoal, DIR/roomgoal each hold one export (DIR/<task>/<SPLIT>/...);
  DIR/vln, when present, a VLN-CE export (DIR/vln/<SPLIT>/<SPLIT>.json.gz) loaded with
  habitat-lab's VLNDatasetV1 (R2RVLN-v1).

Every content file is loaded twice: through the split file (the dataset constructor, as a
Habitat config does it) and on its own (`from_json` of a fresh dataset). Failed checks raise;
the last line printed is a JSON summary per task. Exit status 3 means habitat-lab cannot be
imported here (the caller skips).

habitat-lab imports habitat-sim, magnum and corrade at import time; they are not on PyPI and
the dataset classes never call them, so when they are missing they are replaced by inert
stand-ins (reported in the summary as `stubbed`).
"""

import gzip
import importlib.abc
import importlib.machinery
import json
import os
import sys
import types

SIMULATOR_MODULES = {"habitat_sim", "magnum", "corrade"}
stubbed = set()


class _Any:
    """Any attribute of a stubbed simulator module; the dataset loaders never use it."""

    def __init__(self, *args, **kwargs):
        pass

    def __call__(self, *args, **kwargs):
        return _Any()

    def __getattr__(self, name):
        return _Any()

    def __getitem__(self, key):
        return _Any()

    def __or__(self, other):
        return _Any()

    def __ror__(self, other):
        return _Any()

    def __mro_entries__(self, bases):
        return ()


class _StubFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Last on the import path: only modules that are really missing get a stand-in."""

    def find_spec(self, name, path, target=None):
        if name.split(".")[0] in SIMULATOR_MODULES:
            stubbed.add(name.split(".")[0])
            return importlib.machinery.ModuleSpec(name, self, is_package=True)
        return None

    def create_module(self, spec):
        module = types.ModuleType(spec.name)
        module.__path__ = []
        module.__getattr__ = lambda attr: _Any()
        return module

    def exec_module(self, module):
        pass


sys.meta_path.append(_StubFinder())
try:
    import habitat
    from habitat.core.simulator import AgentState
    from habitat.datasets.object_nav.object_nav_dataset import ObjectNavDatasetV1
    from habitat.datasets.pointnav.pointnav_dataset import PointNavDatasetV1
    from habitat.datasets.vln.r2r_vln_dataset import VLNDatasetV1
    from habitat.tasks.vln.vln import InstructionData, VLNEpisode
    from habitat.tasks.nav.nav import NavigationGoal
    from habitat.tasks.nav.object_nav_task import ObjectGoal
    from omegaconf import OmegaConf
except Exception as e:  # noqa: BLE001 - any failure to import means "cannot check here"
    print(f"habitat-lab cannot be imported: {type(e).__name__}: {e}")
    sys.exit(3)


def check(cond, what):
    if not cond:
        raise AssertionError(what)


def load_split(cls, root, split):
    cfg = OmegaConf.create(
        {
            "data_path": os.path.join(root, "{split}", "{split}.json.gz"),
            "split": split,
            "scenes_dir": "data/scene_datasets",
            "content_scenes": ["*"],
        }
    )
    return cls(cfg)


def load_alone(cls, path):
    ds = cls()
    with gzip.open(path, "rt") as f:
        ds.from_json(f.read(), scenes_dir=None)
    return ds


def check_point(root, split, suffix):
    ds = load_split(PointNavDatasetV1, root, split)
    for e in ds.episodes:
        check(e.episode_id == e.info["minos_episode_id"], f"{e.episode_id}: id changed")
        check(e.scene_id.endswith(suffix), f"{e.episode_id}: scene_id {e.scene_id}")
        check(len(e.goals) == 1 and isinstance(e.goals[0], NavigationGoal), "goals")
        check(len(e.goals[0].position) == 3, "goal position")
    alone = 0
    for name in sorted(os.listdir(os.path.join(root, split, "content"))):
        alone += len(load_alone(PointNavDatasetV1, os.path.join(root, split, "content", name)).episodes)
    return {
        "episodes_via_split": len(ds.episodes),
        "episodes_alone": alone,
        "minos_ids": [e.info["minos_episode_id"] for e in ds.episodes],
    }


def check_object(root, split, suffix, rooms):
    ds = load_split(ObjectNavDatasetV1, root, split)
    view_points = 0
    keys = set()
    for e in ds.episodes:
        tag = e.info["minos_episode_id"]
        check(e.scene_id.endswith(suffix), f"{tag}: scene_id {e.scene_id}")
        check(e.goals_key in ds.goals_by_category, f"{tag}: no goals under {e.goals_key}")
        keys.add(e.goals_key)
        check(e.object_category in ds.category_to_task_category_id, f"{tag}: category map")
        check(len(e.goals) > 0, f"{tag}: no goals")
        for g in e.goals:
            check(isinstance(g, ObjectGoal), f"{tag}: goal type")
            check(isinstance(g.object_name_id, int), f"{tag}: object_name_id {g.object_name_id!r}")
            check(g.object_category == e.object_category, f"{tag}: goal category")
            if rooms:
                check(g.room_id == g.object_id, f"{tag}: room_id {g.room_id!r}")
                check(g.room_name == e.object_category, f"{tag}: room_name {g.room_name!r}")
            check(len(g.view_points) > 0, f"{tag}: goal {g.object_id} has no view points")
            for v in g.view_points:
                check(isinstance(v.agent_state, AgentState), f"{tag}: agent_state")
                check(len(v.agent_state.position) == 3, f"{tag}: view point position")
                check(len(v.agent_state.rotation) == 4, f"{tag}: view point rotation")
                view_points += 1
    alone = 0
    for name in sorted(os.listdir(os.path.join(root, split, "content"))):
        one = load_alone(ObjectNavDatasetV1, os.path.join(root, split, "content", name))
        check(one.category_to_task_category_id == ds.category_to_task_category_id, "maps")
        for i, e in enumerate(one.episodes):
            check(e.episode_id == str(i), "habitat-lab numbers episodes by index")
            check(":" in e.info["minos_episode_id"], "minos id kept in info")
            check(len(e.goals) > 0, "goals found alone")
        alone += len(one.episodes)
    return {
        "episodes_via_split": len(ds.episodes),
        "episodes_alone": alone,
        "minos_ids": [e.info["minos_episode_id"] for e in ds.episodes],
        "view_points": view_points,
        "goal_keys": sorted(keys),
    }


def r2r_tokens(text):
    """R2R's tokeniser (Matterport3D simulator's Tokenizer.split_sentence), written here."""
    import re

    toks = []
    for word in [s.strip().lower() for s in re.split(r"(\W+)", text.strip()) if len(s.strip()) > 0]:
        if all(c in ".,;:!?'\"()" for c in word) and not all(c in "." for c in word):
            toks += list(word)
        else:
            toks.append(word)
    return toks


def check_vln(root, split, suffix):
    ds = load_split(VLNDatasetV1, root, split)
    vocab = ds.instruction_vocab
    check(vocab.PAD_INDEX == 0 and vocab.UNK_INDEX == 1, "pad and unk indices")
    trajectories = set()
    for e in ds.episodes:
        tag = e.info["minos_episode_id"]
        check(isinstance(e, VLNEpisode), f"{tag}: episode type")
        check(isinstance(e.instruction, InstructionData), f"{tag}: instruction type")
        check(e.scene_id.endswith(suffix), f"{tag}: scene_id {e.scene_id}")
        check(len(e.goals) == 1 and isinstance(e.goals[0], NavigationGoal), f"{tag}: goals")
        check(e.reference_path[0] == list(e.start_position), f"{tag}: path starts at the start")
        check(e.reference_path[-1] == list(e.goals[0].position), f"{tag}: path ends at the goal")
        ids = [vocab.word2idx(w) for w in r2r_tokens(e.instruction.instruction_text)]
        want = ids + [vocab.PAD_INDEX] * (len(e.instruction.instruction_tokens) - len(ids))
        check(e.instruction.instruction_tokens == want, f"{tag}: tokens")
        check(vocab.UNK_INDEX not in ids, f"{tag}: a word outside the vocabulary")
        trajectories.add(e.trajectory_id)
    return {
        "episodes_via_split": len(ds.episodes),
        "trajectories": len(trajectories),
        "instructions": [e.instruction.instruction_text for e in ds.episodes],
        "vocabulary": vocab.get_size(),
    }


def main():
    out, split, suffix = sys.argv[1], sys.argv[2], sys.argv[3]
    summary = {"habitat_lab": habitat.__version__}
    summary["pointgoal"] = check_point(os.path.join(out, "pointgoal"), split, suffix)
    summary["objectgoal"] = check_object(os.path.join(out, "objectgoal"), split, suffix, False)
    summary["roomgoal"] = check_object(os.path.join(out, "roomgoal"), split, suffix, True)
    if os.path.isdir(os.path.join(out, "vln")):
        summary["vln"] = check_vln(os.path.join(out, "vln"), split, suffix)
    summary["stubbed"] = sorted(stubbed)
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
