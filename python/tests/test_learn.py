"""minos.learn, the reference learner: the action mapping, minos's metrics against the Rust
rollout's, dataset frames against environment frames, and a smoke run of the whole loop
(oracle run → LeRobot export → LeRobotDataset → one epoch of behaviour cloning whose loss
falls → DAgger round → evaluation in VectorNavEnv). Skipped without torch or lerobot."""

import json
import math
import os
import shutil

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="minos.learn needs torch (pip install torch)")
pytest.importorskip("lerobot", reason="minos.learn reads datasets with lerobot (pip install lerobot)")
pytest.importorskip("gymnasium")

import minos  # noqa: E402
from minos.gym import VectorNavEnv  # noqa: E402
from minos.learn.cell import PRESET_ACTIONS  # noqa: E402
from minos.learn.dagger import dagger  # noqa: E402
from minos.learn.data import dataset_tasks, goal_objects, load_lerobot  # noqa: E402
from minos.learn.evaluate import evaluate_policy, evaluate_random, make_env  # noqa: E402
from minos.learn.features import (  # noqa: E402
    ACTION_STRENGTHS, action_labels, keys_for, modality_name, modality_tag, parse_modalities,
    strengths_of)
from minos.learn.metrics import EpisodeMetrics, aggregate  # noqa: E402
from minos.learn.rollout import run_episodes  # noqa: E402
from minos.learn.train import TrainConfig, load_policy, make_policy, train_bc, _batch  # noqa: E402

ENV_ACTIONS = ["forward", "turn_left", "turn_right", "stop"]


def test_action_strengths_map_to_the_environment_actions():
    names = list(ACTION_STRENGTHS)
    rows = torch.zeros(6, 9)
    rows[0, names.index("forward")] = 1.0
    rows[1, names.index("turn_right")] = 1.0
    rows[2, names.index("stop")] = 1.0
    rows[3, names.index("backward")] = 1.0  # not an action of the paper's agent
    # row 4: no action at all
    rows[5, names.index("turn_left")] = 0.3  # a weaker strength still names the action
    rows[5, names.index("forward")] = 0.2
    assert action_labels(rows, names, ENV_ACTIONS).tolist() == [0, 2, 3, -100, -100, 1]
    # Round trip through the strengths a dataset writes.
    a = np.array([0, 1, 2, 3, 2])
    back = action_labels(torch.from_numpy(strengths_of(a, ENV_ACTIONS)), names, ENV_ACTIONS)
    assert back.tolist() == a.tolist()
    assert parse_modalities("M,D") == ("M", "D") == parse_modalities("D+M")
    with pytest.raises(ValueError):
        parse_modalities("M,X")
    # Rows are named in the paper's order of the senses; files keep the order results and
    # checkpoints have always been written in.
    every = parse_modalities("M+D+V+F")
    assert every == ("M", "V", "D", "F")
    assert modality_name(every) == "M+D+V+F" and modality_tag(every) == "MVDF"
    assert modality_name(parse_modalities("MFV")) == "M+V+F"


def test_preset_actions_are_the_environments(world):
    for preset in ("habitat", "minos-paper"):
        env = VectorNavEnv(data=world.data, episodes=world.point, agent=preset, size=8,
                           allow_body_mismatch=True)
        assert env.action_names == PRESET_ACTIONS[preset]


def test_metrics_follow_minos_definitions():
    # The numbers of src/run/metrics.rs's own tests, then an independent formula.
    m = EpisodeMetrics.finish(True, 50, 500, 10.0, 2, 8.0, 0.1)
    assert math.isclose(m.spl, 0.8, abs_tol=1e-6) and math.isclose(m.speed, 0.9, abs_tol=1e-6)
    f = EpisodeMetrics.finish(False, 500, 500, 4.0, 0, 8.0, 6.0)
    assert f.spl == 0.0 and f.speed == 0.0 and math.isclose(f.soft_spl, 0.25, abs_tol=1e-6)
    agg = aggregate([m, f, None])
    assert agg["episodes"] == 3 and agg["failed"] == 1
    assert math.isclose(agg["success"], 1 / 3) and math.isclose(agg["spl"], 0.8 / 3)
    assert math.isclose(agg["speed"], 0.9 / 3) and agg["steps"] == 275


def test_rollout_metrics_equal_minos_run(world, tmp_path):
    # The oracle through VectorNavEnv, measured by minos.learn, against the metrics the Rust
    # rollout (`minos run`) computes for the same episodes.
    rep = minos.run(world.data, world.point, "oracle", tmp_path / "run", size=16)
    ref = {e["episode_id"]: e["metrics"] for e in
           json.loads((tmp_path / "run" / "metrics.json").read_text())["episodes"]}
    venv = VectorNavEnv(data=world.data, episodes=world.point, num_envs=2, size=16,
                        require_stop=True)
    res = run_episodes(venv, None, keys=["goal"])
    assert set(res.metrics) == set(ref) and rep["episodes"] == len(ref)
    for eid, m in res.metrics.items():
        r = ref[eid]
        assert m.success == r["success"] and m.steps == r["steps"], eid
        assert m.collisions == r["collisions"], eid
        for k in ("spl", "soft_spl", "speed", "path_length", "final_geodesic"):
            assert math.isclose(getattr(m, k), r[k], abs_tol=1e-4), (eid, k)


class _ScriptedVectorEnv:
    """VectorNavEnv's scheduling (environment i's k-th episode is the order's (i + k·n)-th,
    wrapping round) with scripted runs: ``runs[(episode, instance)] = (steps, success)``."""

    def __init__(self, ids, num_envs, runs):
        from types import SimpleNamespace

        self.num_envs, self.runs = num_envs, runs
        self.action_names = ["forward", "turn_left", "turn_right", "stop"]
        self.goal_objects = []
        self._core = SimpleNamespace(episodes=[
            SimpleNamespace(episode_id=e, max_steps=500, geodesic_distance=1.0) for e in ids])
        self.instances = {e: 0 for e in ids}

    def _obs(self):
        return {"goal": np.zeros((self.num_envs, 3), np.float32)}

    def _info(self, reset):
        n = self.num_envs
        return {"reset": np.array(reset), "position": np.zeros((n, 3)),
                "collision": np.zeros(n, bool), "geodesic": np.zeros(n),
                "success": np.array([s.get("won", False) for s in self.slots])}

    def _next(self, i):
        eps = self._core.episodes
        slot = self.slots[i]
        ep = eps[(i + slot["started"] * self.num_envs) % len(eps)]
        self.instances[ep.episode_id] += 1
        steps, won = self.runs[(ep.episode_id, self.instances[ep.episode_id])]
        slot.update(started=slot["started"] + 1, ep=ep, left=steps, end=won, won=False,
                    done=False)

    def reset(self, seed=None):
        self.slots = [{"started": 0} for _ in range(self.num_envs)]
        for i in range(self.num_envs):
            self._next(i)
        return self._obs(), self._info([True] * self.num_envs)

    def current_episodes(self):
        return [s["ep"] for s in self.slots]

    def step(self, actions):
        n = self.num_envs
        reset, term, trunc = [False] * n, np.zeros(n, bool), np.zeros(n, bool)
        for i, slot in enumerate(self.slots):
            if slot["done"]:
                self._next(i)
                reset[i] = True
                continue
            slot["left"] -= 1
            if slot["left"] == 0:
                slot.update(done=True, won=slot["end"])
                term[i], trunc[i] = slot["end"], not slot["end"]
        return self._obs(), np.zeros(n), term, trunc, self._info(reset)

    def oracle_actions(self):
        return np.zeros(self.num_envs, np.int64)


def test_each_episode_counts_once_by_the_run_that_started_it():
    # Two environments, three episodes: environment 1 finishes `b` at once and goes on to
    # `a` (its (1 + 2)-th in the order), which environment 0 is still running and will fail;
    # the repeat succeeds in one step, long before. `a` counts as the first run's failure.
    runs = {("a", 1): (6, False), ("a", 2): (1, True), ("b", 1): (1, True),
            ("c", 1): (1, True), ("c", 2): (1, True), ("b", 2): (1, True)}
    venv = _ScriptedVectorEnv(["a", "b", "c"], 2, runs)
    res = run_episodes(venv, None, keys=["goal"], record=True)
    assert venv.instances["a"] == 2, "the scripted schedule did not repeat `a`"
    assert set(res.metrics) == {"a", "b", "c"}
    assert not res.metrics["a"].success and res.metrics["a"].steps == 6
    assert res.metrics["b"].success and res.metrics["c"].success
    # Recorded frames: one run of each episode, the first started.
    lengths = dict(zip(res.episode_ids, (len(lab) for _, lab in res.episodes)))
    assert lengths == {"a": 6, "b": 1, "c": 1}


@pytest.fixture(scope="module")
def oracle_dataset(world, tmp_path_factory):
    """The oracle's run of the point episodes as a LeRobot dataset (24² images)."""
    out = tmp_path_factory.mktemp("learn") / "run"
    minos.run(world.data, world.point, "oracle", out, size=24, format="lerobot")
    return out / "lerobot"


def test_dataset_frames_equal_environment_frames(world, oracle_dataset):
    # What the learner trains on (LeRobotDataset → DataLoader) is what it sees in the
    # environment: same keys, layouts and values, frame by frame.
    keys = ["color", "depth", "semantic", "goal", "goal_room", "goal_object", "at_goal",
            "steps_left", "previous_action", "contact", "collision"]
    demos = load_lerobot(oracle_dataset, ENV_ACTIONS, keys=keys)
    slow = load_lerobot(oracle_dataset, ENV_ACTIONS, keys=keys, decode="lerobot", num_workers=0)
    for k in keys:
        assert torch.equal(demos.frames[k], slow.frames[k]), k
    venv = VectorNavEnv(data=world.data, episodes=world.point, size=24, require_stop=True)
    res = run_episodes(venv, None, keys=keys, record=True)
    meta = {eid: i for i, eid in enumerate(_episode_ids(oracle_dataset))}
    assert len(res.episodes) == demos.num_episodes
    for eid, (frames, labels) in zip(res.episode_ids, res.episodes):
        d_frames, d_labels = demos.episode(meta[eid])
        assert torch.equal(labels, d_labels), eid
        for k in keys:
            a, b = frames[k], d_frames[k]
            assert a.shape == b.shape and a.dtype == b.dtype, (k, a.shape, b.shape)
            if k == "goal":
                assert torch.allclose(a, b, atol=2e-3), (eid, k)
            else:
                assert torch.equal(a, b), (eid, k)


def _episode_ids(root):
    import pyarrow.parquet as pq

    t = pq.read_table(root / "meta" / "episodes" / "chunk-000" / "file-000.parquet",
                      columns=["episode_index", "minos/episode_id"]).to_pydict()
    order = np.argsort(t["episode_index"])
    return [t["minos/episode_id"][i] for i in order]


def test_measurements_per_task_and_a_clear_error_for_old_datasets(world, oracle_dataset,
                                                                   tmp_path):
    # M is what MINOS fed each task: the goal vector and time for points and objects (with the
    # category), the goal room class and "in a goal room" for rooms.
    have = {"goal", "goal_room", "goal_object", "at_goal", "steps_left", "depth"}
    assert keys_for(("M",), have, None, ["pointgoal"]) == ["goal", "steps_left"]
    assert keys_for(("M",), have, None, ["objectgoal"]) == ["goal", "goal_object", "steps_left"]
    assert keys_for(("M", "D"), have, None, ["roomgoal"]) == ["goal_room", "at_goal", "depth"]
    assert dataset_tasks(oracle_dataset) == {"pointgoal"} and goal_objects(oracle_dataset) == []
    # A dataset without a feature (as older minos wrote them) is refused, naming it.
    with pytest.raises(KeyError, match="observation.contact"):
        keys_for(("F",), {"goal"}, None)
    import shutil

    old = tmp_path / "old"
    shutil.copytree(oracle_dataset, old)
    info = json.loads((old / "meta" / "info.json").read_text())
    del info["features"]["observation.goal"]
    (old / "meta" / "info.json").write_text(json.dumps(info))
    with pytest.raises(KeyError, match="observation.goal"):
        load_lerobot(old, ENV_ACTIONS, keys=["goal"])


def test_object_goal_categories_map_onto_the_dataset_vocabulary(world, tmp_path):
    # ObjectGoal: the dataset indexes `info.minos.vocabulary`, the environment its own
    # `goal_objects`; the frames the policy sees use the dataset's.
    minos.run(world.data, world.objects, "oracle", tmp_path / "obj", size=16, format="lerobot")
    root = tmp_path / "obj" / "lerobot"
    vocab = goal_objects(root)
    assert vocab and "objectgoal" in dataset_tasks(root)
    demos = load_lerobot(root, ENV_ACTIONS, keys=["goal_object"])
    venv = VectorNavEnv(data=world.data, episodes=world.objects, size=16, require_stop=True)
    res = run_episodes(venv, None, keys=["goal_object"], record=True, goal_objects=vocab)
    meta = {eid: i for i, eid in enumerate(_episode_ids(root))}
    for eid, (frames, _) in zip(res.episode_ids, res.episodes):
        assert torch.equal(frames["goal_object"], demos.episode(meta[eid])[0]["goal_object"])


def test_smoke_the_loss_falls_and_the_loop_runs(world, oracle_dataset, tmp_path):
    demos = load_lerobot(oracle_dataset, ENV_ACTIONS, keys=["goal", "steps_left", "depth"])
    assert 100 <= demos.num_frames <= 2000 and demos.label_counts()["ignored"] == 0
    policy = make_policy(demos, ("M", "D"), image_size=40)

    def dataset_loss() -> float:
        labels = demos.labels.clone()
        labels[labels == 3] = -100  # stop is not trained on (no stop, as MINOS's agents)
        f, m, lab = _batch(demos, np.arange(demos.num_episodes), policy.spec.keys, "cpu", labels)
        with torch.no_grad():
            return float(torch.nn.functional.cross_entropy(policy(f, m), lab, ignore_index=-100))

    before = dataset_loss()
    ckpt = tmp_path / "m.pt"
    hist = train_bc(policy, demos, TrainConfig(epochs=1, batch_frames=32, lr=3e-3, seed=1),
                    checkpoint=ckpt, progress=lambda d, t: None)
    after = dataset_loss()
    assert len(hist) == 1 and after < before, (before, after)
    # Resume: a second run with the same checkpoint and 1 epoch trains nothing more.
    again = train_bc(policy, demos, TrainConfig(epochs=1, batch_frames=32, seed=1),
                     checkpoint=ckpt, resume=True)
    assert again == hist
    loaded, ckpt_dict = load_policy(ckpt)
    assert loaded.spec.keys == ["goal", "steps_left", "depth"] and ckpt_dict["epoch"] == 0

    venv = make_env(world.data, world.point, agent="habitat", num_envs=2, size=24, max_steps=40)
    # A round of one epoch where the cloning had three (`epochs`): the round's checkpoint
    # holds one epoch.
    with pytest.raises(ValueError, match="at least 1"):
        dagger(policy, demos, venv, TrainConfig(epochs=3), iterations=1, epochs=0)
    # The oracle finds no plan (-1) in the first environment: its frames are added
    # unlabelled (-100, trained on by nothing), and the round counts them.
    real = venv.oracle_actions

    def no_plan_in_the_first():
        o = np.array(real(), copy=True)
        o[0] = -1
        return o

    venv.oracle_actions = no_plan_in_the_first
    rounds = dagger(policy, demos, venv, TrainConfig(epochs=3, batch_frames=64), iterations=1,
                    epochs=1, checkpoint=tmp_path / "d.pt")
    del venv.oracle_actions
    assert rounds[0]["frames_added"] > 0 and demos.num_frames == rounds[0]["frames"]
    added = demos.labels[-rounds[0]["frames_added"]:]
    assert 0 < rounds[0]["unlabelled"] == int((added == -100).sum()) < rounds[0]["frames_added"]
    assert len(torch.load(tmp_path / "d.pt", weights_only=False)["history"]) == 1
    res = evaluate_policy(policy, venv, max_steps=40)
    agg = res["aggregate"]
    assert agg["episodes"] == len(world.episodes) and 0.0 <= agg["success"] <= 1.0
    assert all(m["steps"] <= 40 for m in res["episodes"].values())
    rand = evaluate_random(venv, max_steps=40)
    assert rand["aggregate"]["episodes"] == len(world.episodes)


def test_a_policys_initial_weights_are_a_function_of_its_seed(world, oracle_dataset):
    demos = load_lerobot(oracle_dataset, ENV_ACTIONS, keys=["goal", "steps_left", "depth"])
    weights = lambda p: torch.cat([v.flatten() for v in p.state_dict().values()])  # noqa: E731
    before = torch.get_rng_state()
    a = make_policy(demos, ("M", "D"), image_size=40, seed=3)
    assert torch.equal(torch.get_rng_state(), before)  # the global generator is left alone
    torch.seed()
    b = make_policy(demos, ("M", "D"), image_size=40, seed=3)
    c = make_policy(demos, ("M", "D"), image_size=40, seed=4)
    assert torch.equal(weights(a), weights(b)) and not torch.equal(weights(a), weights(c))


# A depth policy's forward and backward pass over fixed frames, in a fresh process (oneDNN
# reads its settings once per process); prints the hash of the logits and the gradients.
_POLICY_BITS = """
import hashlib, sys
import numpy as np
if sys.argv[1] == "minos":
    import minos.learn  # noqa: F401  (selects the kernels)
import torch
from minos.learn.policy import NavPolicy, PolicySpec
torch.set_num_threads(1)
spec = PolicySpec(keys=["depth"], channels={"depth": 1}, num_actions=4,
                  env_actions=["forward", "turn_left", "turn_right", "stop"],
                  modalities=["D"], memory="none")
torch.manual_seed(0)
policy = NavPolicy(spec)
rng = np.random.default_rng(0)
depth = torch.from_numpy(rng.uniform(0, 10, (32, 1, 84, 84)).astype(np.float32))
logits = policy({"depth": depth}, torch.ones(32, 1, dtype=torch.bool))
logits.square().sum().backward()
h = hashlib.sha256(logits.detach().numpy().tobytes())
for p in policy.parameters():
    h.update(p.grad.numpy().tobytes())
print(h.hexdigest())
"""


def _kernel_free_env(**env: str) -> dict:
    """This process's environment without the kernel settings, plus ``env``."""
    from minos.learn import kernels

    settings = {*kernels.PORTABLE, kernels.ENV}
    return {**{k: v for k, v in os.environ.items() if k not in settings}, **env}


def _policy_bits(tmp_path, how: str, **env: str) -> str:
    import subprocess
    import sys

    script = tmp_path / "bits.py"
    script.write_text(_POLICY_BITS)
    out = subprocess.run([sys.executable, str(script), how], env=_kernel_free_env(**env),
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def _kernel_env(**env: str) -> dict:
    import subprocess
    import sys

    code = ("import json, os, warnings\nwarnings.simplefilter('always')\nimport minos.learn\n"
            "print(json.dumps({**minos.learn.kernels.settings(), "
            "'env': os.environ.get('MINOS_LEARN_KERNELS')}))")
    out = subprocess.run([sys.executable, "-c", code], env=_kernel_free_env(**env),
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return {**json.loads(out.stdout), **({"warning": out.stderr.strip()} if out.stderr else {})}


def test_importing_the_learner_caps_the_cpu_kernels_unless_told_otherwise():
    assert _kernel_env() == {"mode": "portable", "ONEDNN_MAX_CPU_ISA": "AVX2",
                             "MKL_CBWR": "AVX2", "env": "portable"}
    # a value the user set is kept, and says which kernels run
    assert _kernel_env(ONEDNN_MAX_CPU_ISA="AVX512_CORE", MKL_CBWR="AUTO") == {
        "mode": "native", "ONEDNN_MAX_CPU_ISA": "AVX512_CORE", "MKL_CBWR": "AUTO",
        "env": "portable"}
    assert _kernel_env(MINOS_LEARN_KERNELS="native") == {
        "mode": "native", "ONEDNN_MAX_CPU_ISA": None, "MKL_CBWR": None, "env": "native"}
    # an unknown mode is named in a warning and the portable kernels run
    unknown = _kernel_env(MINOS_LEARN_KERNELS="fast")
    assert "MINOS_LEARN_KERNELS: 'fast' is not one of portable, native; the portable " \
        "kernels are used" in unknown.pop("warning")
    assert unknown == {"mode": "portable", "ONEDNN_MAX_CPU_ISA": "AVX2", "MKL_CBWR": "AVX2",
                       "env": "portable"}


def test_native_kernels_undo_only_what_the_portable_ones_set(monkeypatch):
    from minos.learn import kernels

    # every variable select() writes is restored afterwards (the mode too: `python -m
    # minos.learn` in a later test reads it)
    monkeypatch.delenv("ONEDNN_MAX_CPU_ISA", raising=False)
    monkeypatch.delenv(kernels.ENV, raising=False)
    monkeypatch.setenv("MKL_CBWR", "COMPATIBLE")
    monkeypatch.setattr(kernels, "_set_here", set())
    assert kernels.select("portable") == "portable"
    assert os.environ["ONEDNN_MAX_CPU_ISA"] == "AVX2" and os.environ["MKL_CBWR"] == "COMPATIBLE"
    assert kernels.select("native") == "native" and kernels.mode() == "native"
    assert "ONEDNN_MAX_CPU_ISA" not in os.environ and os.environ["MKL_CBWR"] == "COMPATIBLE"


def test_a_row_with_an_image_trained_with_native_kernels_is_another_row(monkeypatch, tmp_path):
    from minos.learn.cell import CellConfig, row_file

    cfg = CellConfig(work="w", dagger=2)
    monkeypatch.setenv("ONEDNN_MAX_CPU_ISA", "AVX2")
    assert row_file(tmp_path, cfg, ("M", "D")).name == "MD-gru-s0-dagger2.json"
    monkeypatch.delenv("ONEDNN_MAX_CPU_ISA")
    assert row_file(tmp_path, cfg, ("M", "D")).name == "MD-gru-s0-dagger2-native.json"
    # a blind row has no convolution: the same bits with either kernels
    assert row_file(tmp_path, cfg, ("M", "F")).name == "MF-gru-s0-dagger2.json"


def test_a_policy_with_an_image_computes_with_the_learners_kernels_what_an_avx2_cpu_does(
        tmp_path):
    # With minos.learn's default kernels a convolutional policy's outputs and gradients are
    # the bits oneDNN computes capped at AVX2 — what an AVX2-only processor computes — on
    # this processor whatever it has.
    portable = _policy_bits(tmp_path, "minos")
    assert portable == _policy_bits(tmp_path, "torch", ONEDNN_MAX_CPU_ISA="AVX2")
    assert portable == _policy_bits(tmp_path, "minos", MKL_CBWR="AVX2")


def test_native_kernels_on_an_avx512_cpu_compute_other_bits(tmp_path):
    # Why the cap is the default: on a processor with AVX-512 the native kernels sum in
    # another order (docs/RESULTS.md, "Seeds").
    flags = open("/proc/cpuinfo").read() if os.path.exists("/proc/cpuinfo") else ""
    if " avx512f" not in flags:
        pytest.skip("this processor has no AVX-512: oneDNN's native kernels are its AVX2 ones")
    assert _policy_bits(tmp_path, "minos", MINOS_LEARN_KERNELS="native") != \
        _policy_bits(tmp_path, "minos")


def test_dart_adds_the_perturbed_oracles_frames_labelled_by_the_oracle(world, oracle_dataset):
    from minos.learn.dart import noisy_demonstrations

    demos = load_lerobot(oracle_dataset, ENV_ACTIONS, keys=["goal", "steps_left", "contact"])
    before = demos.num_frames
    venv = make_env(world.data, world.point, agent="habitat", num_envs=2, size=16)
    recs = noisy_demonstrations(demos, venv, rounds=2, eps=0.5, seed=3)
    assert [r["round"] for r in recs] == [1, 2] and recs[-1]["frames"] == demos.num_frames
    added = demos.num_frames - before
    assert added == sum(r["frames_added"] for r in recs) > 0
    assert demos.num_episodes == len(world.episodes) * 3  # the oracle's, then two rounds
    # Every added frame is labelled with what the oracle would do there (or has no label
    # where it found no plan), never with the random move taken.
    new = demos.labels[before:]
    assert ((new >= 0) & (new < len(ENV_ACTIONS)) | (new == -100)).all()
    # Half the steps random: the perturbed oracle takes longer than the oracle on average.
    assert added / 2 > before
    with pytest.raises(ValueError, match="eps"):
        noisy_demonstrations(demos, venv, rounds=1, eps=1.0)


def _blind_frame(distance, angle_deg, contact=(0, 0, 0, 0), collided=0.0):
    """One environment's goal (distance, right, forward), contact bits and collision."""
    a = math.radians(angle_deg)
    return {"goal": np.array([[distance, math.sin(a), math.cos(a)]], np.float32),
            "contact": np.array([contact], np.float32),
            "collision": np.array([[collided]], np.float32)}


def test_the_wall_follower_decides_from_what_a_blind_agent_senses():
    from minos.learn.wall import WallFollower

    fwd, left, right = 0, 1, 2
    wf = WallFollower(1, ENV_ACTIONS, budget=5, seed=0)
    act = lambda *a, **k: int(wf(_blind_frame(*a, **k), 1)[0])  # noqa: E731
    # Free: forward within the aim (12°), else the turn towards the goal.
    assert [act(3.0, 5), act(3.0, 40), act(3.0, -40)] == [fwd, right, left]
    # A collision with the goal ahead: it follows the wall on a side drawn from its seed
    # (+1: the wall on the right), first turning away from it.
    side = 1 if np.random.default_rng(0).random() < 0.5 else -1
    away, toward = (left, right) if side == 1 else (right, left)
    felt = (0, 0, 0, 1) if side == 1 else (0, 1, 0, 0)
    assert act(3.0, 0, collided=1.0) == away and wf.states[0].following
    assert act(3.0, 0, contact=(1, 0, 0, 0)) == away  # the front bit: away again
    assert act(3.0, 0, contact=felt) == fwd  # the wall at its side: along it
    # The wall gone (a corner, a doorway): into it and a step, in turn.
    assert [act(3.0, 0), act(3.0, 0)] == [toward, fwd]
    # The budget (5 steps along this wall) spent: it turns round, the wall now on the
    # other side, whose bit is not set, so it turns towards the new side.
    assert act(3.0, 0, contact=felt) == (right if side == -1 else left)
    assert wf.states[0].side == -side and wf.states[0].limit == 10
    # It leaves the wall once nearer the goal than where it met it by the margin (0.25 m)
    # and the goal is not through the wall's side.
    for _ in range(4):
        act(3.0, 0)
    assert wf.states[0].following
    assert act(2.5, 0) == fwd and not wf.states[0].following
    # A new episode forgets the wall.
    act(2.5, 0, collided=1.0)
    assert wf.states[0].following
    wf.clear(np.array([True]))
    assert not wf.states[0].following
    with pytest.raises(ValueError, match="turn_left"):
        WallFollower(1, ["forward", "backward", "stop"])


def test_wall_demonstrations_are_labelled_by_the_wall_follower(world, oracle_dataset):
    from minos.learn.wall import wall_demonstrations

    keys = ["goal", "steps_left", "contact", "collision"]
    oracle = load_lerobot(oracle_dataset, ENV_ACTIONS, keys=keys)
    venv = make_env(world.data, world.point, agent="habitat", num_envs=2, size=16)
    demos, recs = wall_demonstrations(oracle, venv, passes=2, budget=30, seed=1)
    assert [r["pass"] for r in recs] == [1, 2] and recs[-1]["frames"] == demos.num_frames
    assert demos.num_frames == sum(r["frames_added"] for r in recs) > 0
    assert demos.num_episodes == 2 * len(world.episodes)  # the oracle's frames are not kept
    assert set(demos.frames) == set(keys) and demos.env_actions == oracle.env_actions
    # Labels are the follower's moves: never stop, and at each episode's first frame (no
    # wall met yet) forward when the goal is within 12°, else the turn towards it.
    assert ((demos.labels >= 0) & (demos.labels < 3)).all()
    for e in range(demos.num_episodes):
        frames, labels = demos.episode(e)
        _, right, forward = frames["goal"][0].tolist()
        angle = math.degrees(math.atan2(right, forward))
        assert int(labels[0]) == (0 if abs(angle) < 12 else 2 if angle > 0 else 1), e
    with pytest.raises(ValueError, match="passes"):
        wall_demonstrations(oracle, venv, passes=0)
    # Filtered cloning keeps the follower's successful episodes of the same passes, frame
    # for frame, and drops the others; the records still give the passes' own success.
    kept, krecs = wall_demonstrations(oracle, venv, passes=2, budget=30, seed=1,
                                      successes_only=True)
    for r, k in zip(recs, krecs):
        assert k["teacher_success"] == r["teacher_success"]
        assert k["episodes_kept"] == round(r["teacher_success"] * len(world.episodes))
    assert 0 < kept.num_episodes < demos.num_episodes  # the follower fails some here
    assert kept.num_episodes == sum(k["episodes_kept"] for k in krecs)
    assert kept.num_frames == sum(k["frames_added"] for k in krecs) <= demos.num_frames
    every = [demos.episode(e) for e in range(demos.num_episodes)]
    for e in range(kept.num_episodes):  # each kept episode is one of the unfiltered ones
        frames, labels = kept.episode(e)
        assert any(torch.equal(labels, lab) and torch.equal(frames["goal"], f["goal"])
                   for f, lab in every), e


def test_command_line_train_and_eval(world, oracle_dataset, tmp_path):
    from minos.learn.__main__ import main

    ckpt = tmp_path / "cli.pt"
    train = ["-q", "train", "--dataset", str(oracle_dataset), "--modalities", "M,F",
             "--agent", "habitat", "--epochs", "1", "--noise", "1", "--noise-eps", "0.5",
             "--data", str(world.data), "--train-episodes", str(world.point), "--size", "24"]
    assert main(train + ["--out", str(ckpt)]) == 0
    # The same command gives the same policy, whatever torch's global generator holds (torch
    # seeds it at random in every process).
    torch.seed()
    again = tmp_path / "again.pt"
    assert main(train + ["--out", str(again)]) == 0
    first, second = (torch.load(p, weights_only=False)["model"] for p in (ckpt, again))
    assert first.keys() == second.keys()
    assert all(torch.equal(first[k], second[k]) for k in first)
    with pytest.raises(SystemExit, match="--train-episodes"):
        main(["-q", "train", "--dataset", str(oracle_dataset), "--noise", "1",
              "--out", str(tmp_path / "no.pt")])
    out = tmp_path / "eval.json"
    assert main(["-q", "eval", "--checkpoint", str(ckpt), "--data", str(world.data),
                 "--episodes", str(world.point), "--agent", "habitat", "--max-steps", "30",
                 "--size", "24", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["aggregate"]["episodes"] == len(world.episodes)
    # --variant reaches the environment: a variant the DATA folder lacks is named.
    with pytest.raises(Exception, match="nosuch"):
        main(["-q", "eval", "--checkpoint", str(ckpt), "--data", str(world.data),
              "--episodes", str(world.point), "--agent", "habitat", "--size", "24",
              "--variant", "nosuch"])


def test_tables_name_every_paper_cell_and_report_what_is_not_run(tmp_path):
    from minos.learn import tables

    names = tables.cells()
    assert set(tables.PAPER_COMPLEXITY) <= set(names)
    for col in tables.MOD_COLUMNS:
        for row in tables.MOD_ROWS:
            assert f"door-{col}/{row}" in names
    assert all(c.preset == "minos-paper" and c.max_steps == 500 and c.size == 84
               for c in names.values())
    # As MINOS's env configs: one random goal instance, doorways on the path by house size,
    # no Habitat ratio rule, the empty cells on the furnished houses' episodes.
    for name, c in names.items():
        assert not c.ratio_rule and c.random_agent == "minos-random", name
        assert (c.dagger, c.dagger_epochs) == (3, tables.DAGGER_EPOCHS), name
        assert c.select == ("any" if c.task == "pointgoal" else "random"), name
        if c.format == "suncg":
            assert c.min_doors == (1 if c.rooms == (2, 2) else 2), name
        assert c.episodes_on_base == (c.variant == "empty"), name
        # The door cells' goals are drawn from the starts of MINOS's episode states.
        assert c.states == (c.task == "objectgoal"), name
        # Three DAgger rounds for every row that sees an image; blind rows are cloned only.
        assert not c.dagger_blind, name
        # The modality table's blind rows would get two DART rounds; the complexity table's M
        # rows (an ablation: the paper's agents all saw images) are cloned only.
        assert c.noise == (2 if c.task == "objectgoal" else 0) and c.noise_eps == 0.3, name
        # ... and are cloned from the wall follower instead (which takes DART's place).
        assert c.blind_teacher == ("wall-follower" if c.task == "objectgoal" else "oracle")
        assert c.teacher_passes == 2, name
        # ... of whose episodes only those that reached the goal are kept.
        assert c.teacher_successes == (c.task == "objectgoal"), name
    rep = tables.report(tmp_path)
    assert "point-suncg-furnished-small" in rep and "| — |" in rep


def test_tables_take_another_number_of_dagger_rounds(tmp_path):
    # `tables --dagger 2`: the rows with an image get two rounds (the tables' three by
    # default) and are other rows (their files are kept apart from the three-round
    # ones); the blind rows are the same rows.
    from minos.learn import tables
    from minos.learn.__main__ import main
    from minos.learn.cell import row_file

    two, three = tables.cells(2), tables.cells()
    assert all(c.dagger == 2 for c in two.values())
    assert all(c.dagger == 3 for c in three.values())
    assert all(c.dagger == 4 for c in tables.cells(4).values())
    name = "door-small-empty/M+V+F"
    files = [row_file(tmp_path / c[name].work, c[name], ("M", "V", "F")) for c in (two, three)]
    assert [f.name for f in files] == ["MVF-gru-s0-dagger2e3.json", "MVF-gru-s0-dagger3e3.json"]
    blind = {row_file(tmp_path, c["door-small-empty/M"], ("M",)).name for c in (two, three)}
    assert blind == {"M-gru-s0-wall2s.json"}
    files[0].parent.mkdir(parents=True)
    for f, (success, speed) in zip(files, [(0.853, 0.772), (0.969, 0.827)]):
        f.write_text(json.dumps({"success": success, "speed": speed}))

    def cell(report):
        line = next(ln for ln in report.splitlines() if ln.startswith("| M+V+F |"))
        return line.split("|")[2].strip()

    assert cell(tables.report(tmp_path, 2)).startswith("85.3 / 77.2")
    assert cell(tables.report(tmp_path)).startswith("96.9 / 82.7")
    assert "3 DAgger rounds of 3 epochs" in tables.report(tmp_path)
    assert "2 DAgger rounds of 3 epochs" in tables.report(tmp_path, 2)
    assert main(["-q", "tables", "--root", str(tmp_path), "--report", "--dagger", "2"]) == 0
    assert cell((tmp_path / "tables.md").read_text()).startswith("85.3 / 77.2")
    assert main(["-q", "tables", "--root", str(tmp_path), "--report"]) == 0
    assert cell((tmp_path / "tables.md").read_text()).startswith("96.9 / 82.7")
    with pytest.raises(ValueError, match="at least 1"):
        tables.cells(0)
    # At the command line, a one-line error rather than a traceback.
    with pytest.raises(SystemExit, match="^dagger: 0 rounds; at least 1$"):
        main(["-q", "tables", "--root", str(tmp_path), "--report", "--dagger", "0"])
    for bad in ("0", "33"):
        with pytest.raises(SystemExit, match=f"^draws: {bad}; must be 1..32$"):
            main(["-q", "tables", "--root", str(tmp_path), "--draws", bad])
    with pytest.raises(ValueError, match="^draws: 0; must be 1..32$"):
        tables.run(tmp_path, draws=0)


def test_dagger_rows_are_other_rows_than_their_cloned_ones(tmp_path):
    from dataclasses import replace

    from minos.learn.cell import CellConfig, dagger_rounds, row_file

    seeing, blind = ("M", "D"), ("M",)
    cfg = CellConfig(work=str(tmp_path), dagger=2, dagger_blind=False)
    assert (dagger_rounds(cfg, seeing), dagger_rounds(cfg, blind)) == (2, 0)
    # Contact bits and the previous action are not images: still blind.
    assert dagger_rounds(cfg, ("M", "F")) == dagger_rounds(cfg, ("M", "F", "A")) == 0
    assert dagger_rounds(cfg, ("M", "V", "F")) == dagger_rounds(cfg, ("M", "S")) == 2
    assert row_file(tmp_path, cfg, seeing).name == "MD-gru-s0-dagger2.json"
    assert row_file(tmp_path, cfg, blind).name == "M-gru-s0.json"
    # As asked on the command line (`cell --dagger 1`): every row, measurements alone too.
    asked = CellConfig(work=str(tmp_path), dagger=1)
    assert dagger_rounds(asked, blind) == 1
    assert row_file(tmp_path, asked, blind).name == "M-gru-s0-dagger1.json"
    none = CellConfig(work=str(tmp_path))
    assert row_file(tmp_path, none, seeing).name == "MD-gru-s0.json"
    # DART rounds go to the rows without DAgger that sense contact, and name their row.
    from minos.learn.cell import noise_rounds

    touch = ("M", "F")
    dart = CellConfig(work=str(tmp_path), dagger=2, dagger_blind=False, noise=2)
    assert [noise_rounds(dart, m) for m in (seeing, blind, touch)] == [0, 0, 2]
    assert noise_rounds(dart, ("M", "V", "F")) == 0  # DAgger's
    assert row_file(tmp_path, dart, seeing).name == "MD-gru-s0-dagger2.json"
    assert row_file(tmp_path, dart, blind).name == "M-gru-s0.json"
    assert row_file(tmp_path, dart, touch).name == "MF-gru-s0-noise2.json"
    other = CellConfig(work=str(tmp_path), noise=1, noise_eps=0.5)
    assert row_file(tmp_path, other, touch).name == "MF-gru-s0-noise1e0.5.json"
    # DAgger rounds shorter than the cloning are another row; as long as it, the same one.
    short = CellConfig(work=str(tmp_path), dagger=2, epochs=8, dagger_epochs=3)
    assert row_file(tmp_path, short, seeing).name == "MD-gru-s0-dagger2e3.json"
    same = CellConfig(work=str(tmp_path), dagger=2, epochs=8, dagger_epochs=8)
    assert row_file(tmp_path, same, seeing).name == "MD-gru-s0-dagger2.json"
    # The wall follower teaches the blind rows without DAgger, in DART's place.
    from minos.learn.cell import wall_passes

    taught = replace(dart, blind_teacher="wall-follower", teacher_passes=3)
    assert [wall_passes(taught, m) for m in (seeing, blind, touch)] == [0, 3, 3]
    assert [noise_rounds(taught, m) for m in (seeing, blind, touch)] == [0, 0, 0]
    assert row_file(tmp_path, taught, blind).name == "M-gru-s0-wall3.json"
    assert row_file(tmp_path, taught, touch).name == "MF-gru-s0-wall3.json"
    filtered = replace(taught, teacher_successes=True)
    assert row_file(tmp_path, filtered, blind).name == "M-gru-s0-wall3s.json"
    assert row_file(tmp_path, filtered, seeing).name == "MD-gru-s0-dagger2.json"
    assert row_file(tmp_path, taught, seeing).name == "MD-gru-s0-dagger2.json"
    assert wall_passes(replace(taught, dagger_blind=True), touch) == 0  # DAgger's
    with pytest.raises(ValueError, match="blind_teacher"):
        wall_passes(replace(taught, blind_teacher="bug"), touch)


def test_a_rows_draws_are_other_rows_and_the_report_gives_their_mean_and_spread(tmp_path):
    from dataclasses import replace

    from minos.learn import tables
    from minos.learn.cell import CellConfig, check_same_data, policy_seed, row_file

    seeing = ("M", "D")
    cfg = CellConfig(work=str(tmp_path), dagger=2, epochs=8, dagger_epochs=3)
    # The cell's own seed keeps the row's name; another training seed is another file.
    assert row_file(tmp_path, replace(cfg, train_seed=0), seeing).name == \
        "MD-gru-s0-dagger2e3.json"
    assert row_file(tmp_path, replace(cfg, train_seed=2), seeing).name == \
        "MD-gru-s0-train2-dagger2e3.json"
    assert (policy_seed(cfg), policy_seed(replace(cfg, seed=4)),
            policy_seed(replace(cfg, train_seed=1))) == (0, 4, 1)
    # A training seed is not a data setting: a cell folder takes its other draws.
    work = tmp_path / "cell"
    work.mkdir()
    (work / "cell.json").write_text(json.dumps({"seed": 0, "train_seed": None}))
    check_same_data(replace(cfg, work=str(work), train_seed=3), work)

    # Three draws of door-small-empty M+D and one of M+V: the mean and the sample sd of
    # the draws' success (percentage points), their number, and speed's mean.
    root = tmp_path / "tables"
    col = tables.cells()["door-small-empty/M+D"]
    draws = [(0.90, 0.70), (0.95, 0.80), (1.00, 0.75)]
    for k, (success, speed) in enumerate(draws):
        f = row_file(root / col.work, replace(col, train_seed=col.seed + k), seeing)
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_text(json.dumps({"success": success, "speed": speed}))
    one = row_file(root / col.work, col, ("M", "V"))
    one.write_text(json.dumps({"success": 0.5, "speed": 0.25}))
    rows = {ln.split("|")[1].strip(): ln.split("|")[2].strip()
            for ln in tables.report(root).splitlines() if ln.startswith("| M")}
    succ = [s for s, _ in draws]
    mean = sum(succ) / 3
    sd = (sum((s - mean) ** 2 for s in succ) / 2) ** 0.5
    assert rows["M+D"] == (f"{100 * mean:.1f} / {100 * sum(v for _, v in draws) / 3:.1f} "
                           f"±{100 * sd:.1f} ×3 (92.7 / 77.6)")
    assert rows["M+D"].startswith("95.0 / 75.0 ±5.0 ×3")
    assert rows["M+V"] == "50.0 / 25.0 (86.8 / 71.2)"  # one draw: no spread
    assert rows["M"] == "— (90.6 / 68.1)"
    assert tables.summary([], "success") is None
    assert tables.summary([{"success": 0.4}], "success") == (0.4, 0.0, 1)
    assert tables.is_done(root, "door-small-empty/M+D", col, draws=3)
    assert not tables.is_done(root, "door-small-empty/M+D", col, draws=4)
    with pytest.raises(ValueError, match="^draws: 0; must be 1..32$"):
        tables.run(root, ["door-small-empty/M+D"], draws=0)


def test_a_rows_table_line_counts_the_frames_its_rounds_added():
    from minos.learn.cell import markdown

    base = {"task": "objectgoal", "preset": "minos-paper", "name": "M+F", "memory": "gru",
            "train_frames": 1000, "epochs": 8, "dagger": [], "noise": [], "success": 0.5,
            "spl": 0.25, "speed": 0.125, "random": {"success": 0.1, "spl": 0.05, "speed": 0.0},
            "seconds": {"train": 12.0, "eval": 3.0}}
    dart = {**base, "noise": [{"frames_added": 300}, {"frames_added": 200}]}
    dag = {**base, "name": "M+D", "dagger": [{"frames_added": 70}]}
    wall = {**base, "wall": [{"frames_added": 900}, {"frames_added": 800}]}
    head, rule, *lines = markdown([base, dart, dag, wall]).splitlines()
    cols = [c.strip() for c in head.strip("|").split("|")]
    assert len(cols) == rule.count("---")
    cells_of = [dict(zip(cols, (c.strip() for c in ln.strip("|").split("|")))) for ln in lines]
    # The wall follower's frames replace the oracle's: none of the oracle's in that row.
    assert [c["oracle frames"] for c in cells_of] == ["1000"] * 3 + ["0"]
    assert [c["frames added"] for c in cells_of] == ["0", "500", "70", "1700"]
    assert [(c["DAgger"], c["DART"], c["wall follower"]) for c in cells_of] == [
        ("0", "0", "0"), ("0", "2", "0"), ("1", "0", "0"), ("0", "0", "2")]
    assert cells_of[1]["success %"] == "50.0" and cells_of[1]["speed %"] == "12.5"


def test_a_cell_folder_made_with_other_data_settings_is_not_resumed(tmp_path):
    # Its stages are skipped when their outputs exist, so a folder made with other houses or
    # episodes would give the new settings' rows the old data: refused, naming what changed.
    from dataclasses import asdict

    from minos.learn.cell import CellConfig, check_same_data

    work = tmp_path / "cell"
    work.mkdir()
    made = CellConfig(work=str(work), rooms=(2, 2), houses=40)
    (work / "cell.json").write_text(json.dumps(asdict(made)))
    # Rows and devices may differ; a folder without cell.json is new.
    check_same_data(CellConfig(work=str(work), rooms=(2, 2), houses=40, modalities=["M", "D"],
                               epochs=3, dagger=2, device="cpu"), work)
    check_same_data(made, tmp_path / "new")
    with pytest.raises(ValueError, match=r"houses 40 -> 30; furnishing 'standard' -> 'dense'"):
        check_same_data(CellConfig(work=str(work), rooms=(2, 2), houses=30, furnishing="dense"),
                        work)
    # A cell.json from before a setting existed counts as that setting's default.
    old = asdict(made)
    del old["furnishing"]
    (work / "cell.json").write_text(json.dumps(old))
    check_same_data(made, work)
    with pytest.raises(ValueError, match="furnishing 'standard' -> 'dense'"):
        check_same_data(CellConfig(work=str(work), rooms=(2, 2), houses=40, furnishing="dense"),
                        work)


def _split(data, name, scenes):
    """Writes split ``name`` into ``data``: the first scene to train on, every scene to test."""
    lists = data / "splits" / name
    lists.mkdir(parents=True, exist_ok=True)
    (lists / "train.txt").write_text(scenes[0] + "\n")
    (lists / "val.txt").write_text("")
    (lists / "test.txt").write_text("".join(s + "\n" for s in scenes))


def test_a_cells_random_row_is_minos_random_averaged_over_seeds(world, tmp_path):
    # `random_only`: houses, episodes and MINOS's random agent (`minos run --agent
    # minos-random`) once per seed; no oracle dataset, no training. The row is the mean of
    # the seeds' metrics.json, recomputed here from the runs.
    from minos.learn.cell import CellConfig, random_file, run_cell

    _split(world.data, "learn-random-row", world.scenes)
    cfg = CellConfig(work=str(tmp_path / "cell"), data=str(world.data), split="learn-random-row",
                     preset="habitat", per_scene=1, test_per_scene=3, max_steps=40,
                     random_seeds=2, ratio_rule=False, min_doors=1)
    assert run_cell(cfg, progress=False, random_only=True) == []
    work = tmp_path / "cell"
    assert not (work / "runs" / "oracle-train").exists()
    row = json.loads(random_file(work, cfg).read_text())
    seeds = [json.loads((work / "runs" / f"minos-random-s{k}" / "metrics.json").read_text())
             for k in range(2)]
    assert row["agent"] == "minos-random" and len(row["seeds"]) == 2
    for key in ("success", "spl", "speed", "steps"):
        want = sum(s["groups"]["all"][key] for s in seeds) / 2
        assert math.isclose(row["aggregate"][key], want, abs_tol=1e-9), key
    tests = minos.read_episodes(work / "eps" / "test.parquet")
    assert row["aggregate"]["episodes"] == len(tests) > 0
    # The cell's episodes keep MINOS's filter: a doorway on every shortest path.
    import pyarrow.parquet as pq

    doors = pq.read_table(work / "eps" / "test.parquet").column("path_num_doors").to_pylist()
    assert doors and min(doors) >= 1, doors


def test_a_cells_rows_name_the_policy_they_evaluated(world, tmp_path):
    # A whole cell on the test world: the oracle's LeRobot run, a cloned blind row and a
    # DAgger row with depth, each evaluated on the held-out episodes. The row names the
    # checkpoint it evaluated (for a DAgger row the policy after its rounds, not the cloned
    # one), and that checkpoint, evaluated again, gives the row's every episode.
    from minos.learn.cell import CellConfig, run_cell

    _split(world.data, "learn-rows", world.scenes)
    cfg = CellConfig(work=str(tmp_path / "cell"), data=str(world.data), split="learn-rows",
                     preset="habitat", per_scene=2, test_per_scene=2, max_steps=40, size=40,
                     random_seeds=1, ratio_rule=False, modalities=["M", "M,D"], epochs=1,
                     dagger=1, dagger_blind=False, num_envs=2)
    rows = {r["name"]: r for r in run_cell(cfg, progress=False)}
    work = tmp_path / "cell"
    assert rows["M"]["checkpoint"] == "models/M-gru-s0.pt"
    assert rows["M+D"]["checkpoint"] == "models/MD-gru-s0-dagger1-dagger.pt"
    cloned = torch.load(work / "models" / "MD-gru-s0-dagger1.pt", weights_only=False)["model"]
    after = torch.load(work / rows["M+D"]["checkpoint"], weights_only=False)["model"]
    assert any(not torch.equal(cloned[k], after[k]) for k in cloned)
    for row in rows.values():
        policy, _ = load_policy(work / row["checkpoint"])
        env = make_env(cfg.data, work / "eps" / "test.parquet", agent=cfg.preset,
                       num_envs=cfg.num_envs, size=cfg.size, seed=cfg.seed,
                       max_steps=cfg.max_steps)
        again = evaluate_policy(policy, env, seed=cfg.seed, sample=cfg.sample,
                                max_steps=cfg.max_steps)
        assert again["episodes"] == row["evaluation"]["episodes"], row["name"]


def test_a_cells_door_goals_come_from_the_starts_of_its_episode_states(world, tmp_path):
    # `states`: PointGoal episodes with a doorway on the path are the states (MINOS's
    # `pathNumDoors` filter reads them), and each ObjectGoal episode starts at one of them,
    # in order, with its own random door or arch as the goal.
    from minos.learn.cell import CellConfig, run_cell

    _split(world.data, "learn-states", world.scenes)
    cfg = CellConfig(work=str(tmp_path / "cell"), data=str(world.data), split="learn-states",
                     preset="habitat", per_scene=2, test_per_scene=4, max_steps=20,
                     random_seeds=1, ratio_rule=False, min_doors=1, task="objectgoal",
                     categories=["door", "arch"], select="random", states=True)
    run_cell(cfg, progress=False, random_only=True)
    import pyarrow.parquet as pq

    eps = tmp_path / "cell" / "eps"
    states = pq.read_table(eps / "test-states.parquet").to_pylist()
    goals = pq.read_table(eps / "test.parquet").to_pylist()
    assert states and min(s["path_num_doors"] for s in states) >= 1
    assert all(s["task"] == "pointgoal" for s in states)
    assert goals and all(g["task"] == "objectgoal" for g in goals)
    for scene in {g["scene_id"] for g in goals}:
        given = [(s["start_x"], s["start_y"], s["start_z"], s["start_yaw"])
                 for s in states if s["scene_id"] == scene]
        got = [(g["start_x"], g["start_y"], g["start_z"], g["start_yaw"])
               for g in goals if g["scene_id"] == scene]
        rest = iter(given)
        assert all(any(s == g for s in rest) for g in got), (scene, got, given)


def test_an_empty_cell_runs_the_furnished_houses_episodes_without_furniture(
        world, minos_bin, tmp_path, monkeypatch):
    # MINOS's empty configs shared the furnished ones' episode states: with
    # `episodes_on_base`, the episodes are sampled on the scenes as they are (ids without a
    # variant) and run on the `empty` variant (the runs' episode ids read `<scene>@empty`).
    from minos.learn.cell import CellConfig, run_cell

    monkeypatch.setenv("PATH", f"{minos_bin.parent}{os.pathsep}{os.environ['PATH']}")
    data = tmp_path / "DATA"
    shutil.copytree(world.data, data)
    _split(data, "learn-empty", world.scenes)
    from minos.learn.cell import _make_variant

    _make_variant(data, "empty")
    minos.bake(data, preset="habitat", previews=False, variant="empty")
    cfg = CellConfig(work=str(tmp_path / "cell"), data=str(data), split="learn-empty",
                     preset="habitat", per_scene=1, test_per_scene=2, max_steps=20,
                     random_seeds=1, variant="empty", episodes_on_base=True)
    run_cell(cfg, progress=False, random_only=True)
    test_eps = minos.read_episodes(tmp_path / "cell" / "eps" / "test.parquet")
    sampled = {e.scene_id for e in test_eps}
    assert sampled and all("@" not in s for s in sampled), sampled
    runs = tmp_path / "cell" / "runs"
    ran = json.loads((runs / "minos-random-s0" / "metrics.json").read_text())
    assert ran["episodes"] and all("@empty" in e["episode_id"] for e in ran["episodes"])


def test_datasets_mix_with_object_categories_renumbered(world, oracle_dataset, tmp_path):
    # Two exports (PointGoal oracle frames and ObjectGoal oracle frames, as a user mixes
    # oracle runs with people's `minos serve` sessions) load as one set of demonstrations:
    # every frame of both, in order, ObjectGoal categories on the union vocabulary.
    from minos.learn.data import load_many

    minos.run(world.data, world.objects, "oracle", tmp_path / "obj", size=24, format="lerobot")
    objects = tmp_path / "obj" / "lerobot"
    keys = ["goal", "goal_object"]
    a = load_lerobot(oracle_dataset, ENV_ACTIONS, keys=keys)
    b = load_lerobot(objects, ENV_ACTIONS, keys=keys)
    both = load_many([oracle_dataset, objects], ENV_ACTIONS, keys=keys)
    assert both.num_frames == a.num_frames + b.num_frames
    assert both.num_episodes == a.num_episodes + b.num_episodes
    assert torch.equal(both.frames["goal"], torch.cat([a.frames["goal"], b.frames["goal"]]))
    assert torch.equal(both.labels, torch.cat([a.labels, b.labels]))
    assert (both.frames["goal_object"][: a.num_frames] == -1).all()
    vocab = both.info["goal_objects"]
    assert vocab == sorted(set(goal_objects(objects)))
    names = [vocab[i] for i in both.frames["goal_object"][a.num_frames:].reshape(-1).tolist()]
    assert names == [goal_objects(objects)[i] for i in b.frames["goal_object"].reshape(-1).tolist()]
    e = a.num_episodes  # the first episode of the second dataset
    assert int(both.starts[e]) == a.num_frames


def test_learner_trains_on_habitat_episodes_and_people_sessions(world, oracle_dataset, minos_bin,
                                                               tmp_path):
    # Habitat: the point episodes through Habitat's episode format and back (as a user brings
    # Habitat's own episode files), rolled out by the oracle into a dataset.
    from conftest import cli
    from minos.learn.__main__ import main
    from minos.learn.data import load_many

    hab = tmp_path / "habitat"
    minos.sample_episodes(world.data, "pointgoal", tmp_path / "point.parquet", per_scene=3,
                          seed=1, max_steps=300, export_habitat=hab)
    content = sorted(hab.glob("*/content/*.json.gz"))
    assert content, list(hab.rglob("*"))
    imported = tmp_path / "imported.parquet"
    cli(minos_bin, "episodes", "import", "--from", "habitat", content[0], "--out", imported)
    scene = content[0].name[: -len(".json.gz")]
    ours = [e for e in world.episodes if e.scene_id == scene]
    back = minos.read_episodes(imported)
    assert len(back) == len(ours) and {e.scene_id for e in back} == {scene}
    rep = minos.run(world.data, imported, "oracle", tmp_path / "hab-run", size=24,
                    format="lerobot")
    assert rep["episodes"] == len(ours) and not rep["failures"]
    # People: a `minos serve` session folder is a run folder (tests/serve.rs checks the bytes
    # against `minos run`), exported with `minos export-dataset`; here a random player's.
    minos.run(world.data, world.point, "random", tmp_path / "session", size=24, max_steps=30)
    cli(minos_bin, "export-dataset", "--run", tmp_path / "session", "--out", tmp_path / "people")
    roots = [oracle_dataset, tmp_path / "hab-run" / "lerobot", tmp_path / "people"]
    keys = ["goal", "steps_left"]
    alone = [load_lerobot(r, ENV_ACTIONS, keys=keys, num_workers=0) for r in roots]
    mixed = load_many(roots, ENV_ACTIONS, keys=keys, num_workers=0)
    assert mixed.num_episodes == sum(d.num_episodes for d in alone)
    assert mixed.num_frames == sum(d.num_frames for d in alone)
    # The imported episodes' demonstrations are the original episodes' (same starts and goals,
    # the same oracle): as many frames.
    ids = _episode_ids(oracle_dataset)
    orig = [alone[0].episode(ids.index(e.episode_id))[1] for e in sorted(ours, key=lambda e: e.episode_id)]
    assert sum(len(o) for o in orig) == alone[1].num_frames
    # The learner's command line trains on the mix.
    ckpt = tmp_path / "mix.pt"
    assert main(["-q", "train", *[a for r in roots for a in ("--dataset", str(r))],
                 "--modalities", "M", "--agent", "habitat", "--epochs", "1",
                 "--out", str(ckpt)]) == 0
    assert ckpt.is_file()
