"""One results-table cell, end to end and resumable: houses (generated, or a DATA folder with a
split) → training and test episodes (split by house) → the oracle's run on the training
episodes exported as a LeRobot dataset → behaviour cloning (and DAgger) per modality set →
evaluation on the unseen test houses with the random agent beside it → a JSON file and a
Markdown row per modality set.

Every stage writes into the work folder and is skipped when its output is there, so an
interrupted cell resumes where it stopped (training resumes from its last epoch).
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from . import kernels
from .features import modality_name, modality_tag, parse_modalities

PRESET_ACTIONS = {
    # VectorNavEnv(agent=...).action_names (tests/test_learn.py checks them against the env)
    "habitat": ["forward", "turn_left", "turn_right", "stop"],
    "minos-gridworld": ["forward", "turn_left", "turn_right", "stop"],
    "minos-paper": ["forward", "turn_left", "turn_right", "stop"],
    "minos": ["forward", "backward", "strafe_left", "strafe_right", "turn_left", "turn_right",
              "stop"],
}


@dataclass
class CellConfig:
    """A cell: data, task, agent, learner and evaluation settings."""

    work: str
    modalities: list[str] = field(default_factory=lambda: ["M"])
    data: Optional[str] = None  # an existing DATA folder (with `split`); None: generate
    split: Optional[str] = None
    houses: int = 40
    test_houses: int = 10
    rooms: tuple[int, int] = (2, 2)
    levels: tuple[int, int] = (1, 1)
    task: str = "pointgoal"
    categories: Optional[list[str]] = None  # ObjectGoal categories, e.g. ["door", "arch"]
    select: str = "any"  # which goal instances count: any, random (one, as MINOS), closest
    min_doors: int = 0  # fewest doorways on the shortest path (MINOS's `pathNumDoors` filter)
    ratio_rule: bool = True  # Habitat's geodesic/Euclidean rule (MINOS had none)
    variant: Optional[str] = None  # a scene variant; `empty` is made here (MINOS emptyRoom)
    # Sample the episodes on the scenes as given and run them on `variant`: MINOS's empty
    # configs (`pointgoal_suncg_se`, ...) shared the furnished ones' episode states.
    episodes_on_base: bool = False
    # MINOS's episode states: the starts are those of PointGoal episodes sampled with the door
    # filter (`min_doors`), and the task's goal is drawn from each start. MINOS's ObjectGoal
    # configs filter on the states file's `pathNumDoors`, whose paths go to point goals, not
    # to the door that becomes the goal.
    states: bool = False
    # Generated houses' on-disk format: suncg, mp3d, or mp3d-scan (scan-like Matterport3D
    # houses: dense noisy meshes with holes and clutter, `scan_triangles` each).
    format: str = "suncg"
    scan_triangles: int = 300_000
    # Generated houses' furniture: `standard` (each room's recipe) or `dense` (about half the
    # floor taken, as measured in real SUNCG and 3D-FRONT rooms; docs/RESULTS.md).
    furnishing: str = "standard"
    preset: str = "minos-paper"
    per_scene: int = 10
    test_per_scene: int = 10
    max_steps: int = 500
    size: int = 84
    memory: str = "gru"
    hidden: int = 128
    epochs: int = 10
    batch_frames: int = 512
    lr: float = 1e-3
    dagger: int = 0
    beta: float = 0.5
    # Epochs of each DAgger round (None: `epochs`, a full retraining on all the frames so
    # far; fewer fine-tune the cloned policy instead, at a fraction of the cost).
    dagger_epochs: Optional[int] = None
    # Whether blind rows (no image: measurements, contact bits, the previous action) get the
    # DAgger rounds too. The tables say no: the oracle turns away from a wall before touching
    # it, which such a policy cannot observe, and DAgger made M and M+F worse
    # (docs/RESULTS.md).
    dagger_blind: bool = True
    # DART rounds (docs/RESULTS.md): passes of the oracle over the training episodes with a
    # random move instead of its action with probability `noise_eps`, labelled by the
    # oracle, added to the demonstrations of the rows that get no DAgger rounds and sense
    # contact (`noise_rounds`).
    noise: int = 0
    noise_eps: float = 0.3
    # The blind rows' teacher: `oracle` (its demonstrations, plus DART for rows with F) or
    # `wall-follower` (minos.learn.wall: Bug-style wall following from the goal vector and
    # contact bits alone, whose decisions a blind policy can observe); `teacher_passes`
    # runs of it over the training episodes replace the oracle's demonstrations for the
    # blind rows that get no DAgger rounds.
    blind_teacher: str = "oracle"
    teacher_passes: int = 2
    # Keep only the wall follower's episodes that reached the goal (filtered behaviour
    # cloning); its failed searches run to the step limit.
    teacher_successes: bool = False
    num_envs: int = 8
    sample: bool = True
    seed: int = 0
    # The policy's own draws (initial weights, batch order, the DART and DAgger rollouts,
    # the evaluation's sampled actions); None: `seed`. Houses, episodes and the random row
    # keep `seed`, so the draws of one row differ only in what training drew.
    train_seed: Optional[int] = None
    # The random row: `minos-random` is MINOS's baseline (each button pressed with
    # probability ½), `random` uniform over the moves; averaged over this many seeds.
    random_agent: str = "minos-random"
    random_seeds: int = 5
    device: str = "auto"


#: The modalities that are images; a row with none of them is blind.
IMAGE_MODALITIES = frozenset({"V", "D", "S"})


def has_image(mods: tuple[str, ...]) -> bool:
    """Whether a row with modalities ``mods`` sees an image (else it is blind)."""
    return bool(set(mods) & IMAGE_MODALITIES)


#: The teachers of blind rows (``CellConfig.blind_teacher``).
BLIND_TEACHERS = ("oracle", "wall-follower")


def dagger_rounds(cfg: CellConfig, mods: tuple[str, ...]) -> int:
    """The DAgger rounds of a row with modalities ``mods``: ``cfg.dagger``, except for blind
    rows (no image among ``mods``) when ``cfg.dagger_blind`` is off."""
    if not cfg.dagger_blind and not has_image(mods):
        return 0
    return cfg.dagger


def wall_passes(cfg: CellConfig, mods: tuple[str, ...]) -> int:
    """The wall follower's passes over the training episodes that a row with modalities
    ``mods`` is cloned from instead of the oracle's demonstrations: ``cfg.teacher_passes``
    for a blind row without DAgger rounds when ``cfg.blind_teacher`` is ``wall-follower``,
    else none."""
    if cfg.blind_teacher not in BLIND_TEACHERS:
        raise ValueError(f"blind_teacher: {cfg.blind_teacher!r} is not one of "
                         f"{', '.join(BLIND_TEACHERS)}")
    if cfg.blind_teacher != "wall-follower" or dagger_rounds(cfg, mods) or has_image(mods):
        return 0
    return cfg.teacher_passes


def noise_rounds(cfg: CellConfig, mods: tuple[str, ...]) -> int:
    """The DART rounds of a row with modalities ``mods``: ``cfg.noise`` for a row that gets
    no DAgger rounds (:func:`dagger_rounds`), senses contact (F) and learns from the oracle
    (not :func:`wall_passes`), else none. The perturbed oracle's corrections are learnable
    only by a policy that observes the state they correct: with measurements alone a policy
    pressed against a wall sees what it saw before touching it (DART gave M 84.4 % against
    87.2 % cloned, docs/RESULTS.md)."""
    if dagger_rounds(cfg, mods) or "F" not in mods or wall_passes(cfg, mods):
        return 0
    return cfg.noise


def round_epochs(cfg: CellConfig) -> Optional[int]:
    """The epochs of each DAgger round when they differ from the cloning's
    (``cfg.dagger_epochs``), else None: rounds as long as the cloning are the default."""
    if cfg.dagger_epochs is None or cfg.dagger_epochs == cfg.epochs:
        return None
    return cfg.dagger_epochs


def policy_seed(cfg: CellConfig) -> int:
    """The seed of the policy's own draws: ``cfg.train_seed``, or ``cfg.seed`` when unset."""
    return cfg.seed if cfg.train_seed is None else cfg.train_seed


def row_file(work: Path, cfg: CellConfig, mods: tuple[str, ...]) -> Path:
    """Where a row's result is written:
    ``WORK/results/<MODS>-<memory>-s<seed>[-train<T>][-dagger<N>[e<E>]|-noise<N>[e<ε>]|-wall<N>[s]].json``
    (a row trained with DAgger or DART, or cloned from the wall follower's N passes — ``s``:
    their successful episodes only — is another row than its behaviour-cloned one; a DAgger
    row's tag also names its epochs a round when they are not the cloning's, a DART row's
    its ε when it is not 0.3;
    ``-train<T>`` names a training seed other than the cell's seed: another draw of the
    same row; ``-native``: a row with an image trained with the native CPU kernels,
    :mod:`minos.learn.kernels`)."""
    tag = f"{modality_tag(mods)}-{cfg.memory}-s{cfg.seed}"
    if policy_seed(cfg) != cfg.seed:
        tag += f"-train{policy_seed(cfg)}"
    if dagger_rounds(cfg, mods):
        tag += f"-dagger{dagger_rounds(cfg, mods)}"
        if round_epochs(cfg) is not None:
            tag += f"e{round_epochs(cfg)}"
    elif noise_rounds(cfg, mods):
        tag += f"-noise{noise_rounds(cfg, mods)}"
        if cfg.noise_eps != 0.3:
            tag += f"e{cfg.noise_eps:g}"
    elif wall_passes(cfg, mods):
        tag += f"-wall{wall_passes(cfg, mods)}" + ("s" if cfg.teacher_successes else "")
    if has_image(mods) and kernels.mode() == "native":
        tag += "-native"
    return Path(work) / "results" / f"{tag}.json"


def _log(msg: str) -> None:
    print(f"[minos.learn] {msg}", flush=True)


def _prepare_data(cfg: CellConfig, work: Path) -> tuple[Path, str]:
    """The DATA folder and the split name (generating, ingesting, baking and splitting the
    houses when no DATA folder is given)."""
    import minos

    if cfg.data is not None:
        if cfg.split is None:
            raise ValueError("--data needs --split (a split with train and test subsets)")
        return Path(cfg.data), cfg.split
    gen, data = work / "gen", work / "DATA"
    split = f"learn-s{cfg.seed}"
    lists = data / "splits" / split
    if (lists / "test.txt").is_file():
        return data, split
    t0 = time.perf_counter()
    minos.generate(gen, houses=cfg.houses, seed=cfg.seed, rooms=cfg.rooms, levels=cfg.levels,
                   furnishing=cfg.furnishing, format=cfg.format, force=True,
                   scan_triangles=cfg.scan_triangles)
    minos.ingest(gen, data, dataset="suncg" if cfg.format == "suncg" else "mp3d", force=True)
    minos.bake(data, preset=cfg.preset, previews=False)
    if cfg.variant:
        _make_variant(data, cfg.variant)
        minos.bake(data, preset=cfg.preset, previews=False, variant=cfg.variant)
    import pyarrow.parquet as pq

    table = pq.read_table(data / "houses.parquet", columns=["id", "error"]).to_pylist()
    ids = sorted(r["id"] for r in table if not r["error"])
    order = np.random.default_rng(cfg.seed).permutation(len(ids))
    test = sorted(ids[i] for i in order[:cfg.test_houses])
    train = sorted(ids[i] for i in order[cfg.test_houses:])
    minos.split(data, split, lists={"train": train, "val": [], "test": test})
    _log(f"{len(ids)} houses ({len(train)} train, {len(test)} test) in "
         f"{time.perf_counter() - t0:.1f} s -> {data}")
    return data, split


def _make_variant(data: Path, name: str) -> None:
    """Defines the variant ``name`` in ``data`` (only ``empty``, MINOS's emptyRoom: doors,
    arches and windows kept)."""
    import minos

    if name != "empty":
        raise ValueError(f"variant `{name}`: only `empty` is made here; define others with "
                         "minos.variants(...) and pass --data/--split")
    minos.variants(data, name=name, empty=True)


def _episodes(cfg: CellConfig, data: Path, split: str, subset: str, out: Path,
              per_scene: int, seed: int) -> Path:
    import minos

    if not out.is_file():
        kw = {}
        if cfg.categories:
            kw["categories"] = cfg.categories
        on = None if cfg.episodes_on_base else cfg.variant
        common = dict(split=split, subset=subset, variant=on, preset=cfg.preset,
                      per_scene=per_scene, seed=seed, max_steps=cfg.max_steps,
                      ratio_rule=cfg.ratio_rule)
        min_doors = cfg.min_doors
        if cfg.states and cfg.task != "pointgoal":
            states = out.with_name(f"{out.stem}-states.parquet")
            if not states.is_file():
                st = minos.sample_episodes(data, "pointgoal", states, min_doors=min_doors,
                                           **common)
                _log(f"{subset} episode states -> {states} ({st.get('total', '?')} starts)")
            kw["starts"] = states
            min_doors = 0
        stats = minos.sample_episodes(data, cfg.task, out, select=cfg.select,
                                      min_doors=min_doors, **common, **kw)
        _log(f"{subset} episodes -> {out} ({stats.get('total', '?')} episodes)")
    return out


#: The settings that make a cell's houses, episodes and random row: a work folder made with
#: other values of these cannot be resumed (its stages would be skipped as done).
DATA_FIELDS = ("data", "split", "houses", "test_houses", "rooms", "levels", "task",
               "categories", "select", "min_doors", "ratio_rule", "variant",
               "episodes_on_base", "states", "format", "scan_triangles", "furnishing", "preset",
               "per_scene", "test_per_scene", "max_steps", "seed", "random_agent",
               "random_seeds")


def check_same_data(cfg: CellConfig, work: Path) -> None:
    """Raises ValueError when ``work`` holds a cell made with other data settings
    (:data:`DATA_FIELDS`; a setting its ``cell.json`` lacks counts as the default), naming
    each one that differs."""
    previous = work / "cell.json"
    if not previous.is_file():
        return
    before = json.loads(previous.read_text())
    now = json.loads(json.dumps(asdict(cfg)))
    defaults = json.loads(json.dumps(asdict(CellConfig(work=""))))
    changed = [f"{k} {before.get(k, defaults[k])!r} -> {now[k]!r}" for k in DATA_FIELDS
               if before.get(k, defaults[k]) != now[k]]
    if changed:
        raise ValueError(f"{work}: made with other settings ({'; '.join(changed)}); its "
                         "houses and episodes would be reused: use another folder or "
                         "delete this one")


def random_file(work: Path, cfg: CellConfig) -> Path:
    """Where the cell's random row is written."""
    return Path(work) / "results" / f"{cfg.random_agent}-s{cfg.seed}.json"


def _random_row(cfg: CellConfig, data: Path, test_eps: Path, work: Path) -> dict:
    """The random agent's row: ``minos run --agent <random_agent>`` on the test episodes,
    once per seed (``seed`` … ``seed + random_seeds − 1``); the aggregate is the mean over
    seeds, each seed's aggregate kept under ``"seeds"``. The agent never looks at an image,
    so the runs render 16² frames."""
    import minos

    t0 = time.perf_counter()
    per_seed = []
    for k in range(cfg.random_seeds):
        out = work / "runs" / f"{cfg.random_agent}-s{cfg.seed + k}"
        if not (out / "metrics.json").is_file():
            minos.run(data, test_eps, cfg.random_agent, out, variant=cfg.variant,
                      preset=cfg.preset, size=16, max_steps=cfg.max_steps, seed=cfg.seed + k,
                      resume=True)
        per_seed.append(json.loads((out / "metrics.json").read_text())["groups"]["all"])
    keys = ("success", "spl", "soft_spl", "speed", "steps", "collisions", "path_length")
    agg = {k: float(np.mean([a[k] for a in per_seed])) for k in keys}
    agg["episodes"] = per_seed[0]["episodes"]
    agg["failed"] = max(a["failed"] for a in per_seed)
    return {"agent": cfg.random_agent, "aggregate": agg, "seeds": per_seed,
            "seconds": time.perf_counter() - t0}


def run_cell(cfg: CellConfig, progress: bool = True, random_only: bool = False) -> list[dict]:
    """Runs (or resumes) the cell; returns one result dict per modality set (also written to
    ``WORK/results/<name>.json`` and, as Markdown, to ``WORK/results.md``). With
    ``random_only``, stops after the random row (houses, episodes and the random runs: the
    task-difficulty check, without the oracle's dataset or any training)."""
    import minos

    from .data import load_lerobot
    from .dagger import dagger
    from .dart import noisy_demonstrations
    from .evaluate import evaluate_policy, make_env
    from .features import keys_for
    from .train import TrainConfig, make_policy, train_bc
    from .wall import wall_demonstrations

    work = Path(cfg.work)
    work.mkdir(parents=True, exist_ok=True)
    check_same_data(cfg, work)
    (work / "cell.json").write_text(json.dumps(asdict(cfg), indent=1))
    times: dict[str, float] = {}
    t0 = time.perf_counter()
    data, split = _prepare_data(cfg, work)
    train_eps = _episodes(cfg, data, split, "train", work / "eps" / "train.parquet",
                          cfg.per_scene, cfg.seed)
    test_eps = _episodes(cfg, data, split, "test", work / "eps" / "test.parquet",
                         cfg.test_per_scene, cfg.seed + 1)
    times["data"] = time.perf_counter() - t0

    results_dir = work / "results"
    results_dir.mkdir(exist_ok=True)
    rfile = random_file(work, cfg)
    if rfile.is_file():
        rand = json.loads(rfile.read_text())
    else:
        rand = _random_row(cfg, data, test_eps, work)
        rfile.write_text(json.dumps(rand, indent=1))
    ra = rand["aggregate"]
    _log(f"random ({cfg.random_agent}, {cfg.random_seeds} seeds): success {ra['success']:.3f} "
         f"SPL {ra['spl']:.3f} speed {ra['speed']:.3f}")
    if random_only:
        return []

    t0 = time.perf_counter()
    run_dir = work / "runs" / "oracle-train"
    dataset = run_dir / "lerobot"
    if not (dataset / "meta" / "info.json").is_file():
        rep = minos.run(data, train_eps, "oracle", run_dir, variant=cfg.variant,
                        preset=cfg.preset, size=cfg.size, max_steps=cfg.max_steps,
                        seed=cfg.seed, resume=True, format="lerobot")
        _log(f"oracle: {rep['episodes']} episodes, {rep['steps']} steps, "
             f"{len(rep['failures'])} failed, in {rep['seconds']:.1f} s")
    times["oracle"] = time.perf_counter() - t0

    env_actions = PRESET_ACTIONS[cfg.preset]
    sets = [parse_modalities(m) for m in cfg.modalities]
    from .data import available_keys, dataset_tasks

    have, camera = available_keys(dataset)
    tasks = dataset_tasks(dataset)
    keys = sorted({k for mods in sets for k in keys_for(mods, have, camera, tasks)})
    t0 = time.perf_counter()
    demos = load_lerobot(dataset, env_actions, keys=keys)
    times["load"] = time.perf_counter() - t0
    _log(f"dataset: {demos.num_frames} frames, {demos.num_episodes} episodes, loaded in "
         f"{times['load']:.1f} s; actions {demos.label_counts()}")

    env = make_env(data, test_eps, agent=cfg.preset, num_envs=cfg.num_envs, size=cfg.size,
                   seed=cfg.seed, max_steps=cfg.max_steps, variant=cfg.variant)

    drawn = policy_seed(cfg)
    rows = []
    for mods in sets:
        name = modality_name(mods)
        rounds = dagger_rounds(cfg, mods)
        out_file = row_file(work, cfg, mods)
        tag = out_file.stem
        if out_file.is_file():
            rows.append(json.loads(out_file.read_text()))
            continue
        ckpt = work / "models" / f"{tag}.pt"
        tc = TrainConfig(epochs=cfg.epochs, batch_frames=cfg.batch_frames, lr=cfg.lr,
                         seed=drawn, device=cfg.device)
        t0 = time.perf_counter()
        policy = make_policy(demos, mods, memory=cfg.memory, hidden=cfg.hidden,
                             image_size=cfg.size, seed=drawn)

        def training_env():
            return make_env(data, train_eps, agent=cfg.preset, num_envs=cfg.num_envs,
                            size=cfg.size, seed=cfg.seed, max_steps=cfg.max_steps,
                            variant=cfg.variant)

        cloned_from, noise, walls = demos, [], []
        if wall_passes(cfg, mods):
            cloned_from, walls = wall_demonstrations(
                _subset(demos, policy.spec.keys), training_env(),
                passes=wall_passes(cfg, mods), seed=drawn,
                successes_only=cfg.teacher_successes, progress=progress)
            rates = ", ".join(f"{w['teacher_success']:.3f}" for w in walls)
            _log(f"{name}: the wall follower's {cloned_from.num_frames} frames replace the "
                 f"oracle's (its success on the training episodes: {rates})")
        elif noise_rounds(cfg, mods):
            cloned_from = _subset(demos, policy.spec.keys)
            noise = noisy_demonstrations(cloned_from, training_env(),
                                         rounds=noise_rounds(cfg, mods), eps=cfg.noise_eps,
                                         seed=drawn, progress=progress)
            _log(f"{name}: DART added {cloned_from.num_frames - demos.num_frames} frames")
        history = train_bc(policy, cloned_from, tc, checkpoint=ckpt, resume=True,
                           progress=progress)
        train_s = time.perf_counter() - t0
        dag = []
        evaluated = ckpt
        if rounds:
            train_env = training_env()
            sub = _subset(demos, policy.spec.keys)
            evaluated = ckpt.with_name(ckpt.stem + "-dagger.pt")
            dag = dagger(policy, sub, train_env, tc, iterations=rounds, beta=cfg.beta,
                         checkpoint=evaluated, progress=progress, epochs=cfg.dagger_epochs)
            train_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        ev = evaluate_policy(policy, env, seed=drawn, sample=cfg.sample,
                             max_steps=cfg.max_steps, device=cfg.device, progress=progress)
        eval_s = time.perf_counter() - t0
        a = ev["aggregate"]
        row = {
            "name": name, "modalities": list(mods), "task": cfg.task, "preset": cfg.preset,
            "memory": cfg.memory, "seed": cfg.seed, "train_seed": drawn, "houses": cfg.houses,
            "test_houses": cfg.test_houses, "rooms": list(cfg.rooms),
            "train_episodes": demos.num_episodes, "train_frames": demos.num_frames,
            "epochs": cfg.epochs, "dagger_epochs": cfg.dagger_epochs if dag else None,
            "dagger": dag, "noise": noise, "wall": walls,
            "final_loss": history[-1]["loss"] if history else None,
            "train_accuracy": history[-1]["accuracy"] if history else None,
            "test_episodes": a["episodes"], "success": a["success"], "spl": a["spl"],
            "soft_spl": a["soft_spl"], "speed": a["speed"],
            "random": {k: ra[k] for k in ("success", "spl", "soft_spl", "speed")},
            "seconds": {**times, "train": train_s, "eval": eval_s},
            "inputs": list(policy.spec.keys), "cpu_kernels": kernels.settings(),
            "checkpoint": str(evaluated.relative_to(work)), "evaluation": ev,
        }
        out_file.write_text(json.dumps(row, indent=1))
        rows.append(row)
        _log(f"{name}: success {a['success']:.3f} SPL {a['spl']:.3f} speed {a['speed']:.3f} "
             f"(random {ra['success']:.3f}); train {train_s:.0f} s, eval {eval_s:.0f} s")
    table = markdown(rows)
    (work / "results.md").write_text(table)
    print(table, flush=True)
    return rows


def _subset(demos, keys: Sequence[str]):
    """A copy of ``demos`` holding only ``keys`` (DAgger appends to it)."""
    from .data import Demonstrations

    return Demonstrations({k: demos.frames[k] for k in keys}, demos.labels.clone(),
                          demos.starts.clone(), demos.lengths.clone(), list(demos.env_actions),
                          demos.camera, dict(demos.info))


def markdown(rows: Sequence[dict]) -> str:
    """Result rows as a Markdown table (percentages). ``oracle frames`` are the oracle's
    demonstrations the row was cloned from (0 when the wall follower's replace them);
    ``frames added`` those its DAgger or DART rounds or the wall follower's passes added
    before its last training."""
    head = ("| task | preset | modalities | memory | oracle frames | frames added | epochs | "
            "DAgger | DART | wall follower | success % | SPL % | speed % | random success % | "
            "random SPL % | random speed % | train s | eval s |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    lines = []
    for r in rows:
        pct = lambda v: f"{100 * v:.1f}"  # noqa: E731
        walls = list(r.get("wall", []))
        rounds = list(r["dagger"]) + list(r.get("noise", [])) + walls
        added = sum(rec["frames_added"] for rec in rounds)
        oracle = 0 if walls else r["train_frames"]
        lines.append(
            f"| {r['task']} | {r['preset']} | {r['name']} | {r['memory']} | {oracle} "
            f"| {added} | {r['epochs']} | {len(r['dagger'])} | {len(r.get('noise', []))} | "
            f"{len(walls)} | "
            f"{pct(r['success'])} | {pct(r['spl'])} | "
            f"{pct(r['speed'])} | {pct(r['random']['success'])} | {pct(r['random']['spl'])} | "
            f"{pct(r['random']['speed'])} | {r['seconds']['train']:.0f} | "
            f"{r['seconds']['eval']:.0f} |")
    return head + "\n".join(lines) + "\n"


__all__ = ["CellConfig", "PRESET_ACTIONS", "markdown", "run_cell"]
