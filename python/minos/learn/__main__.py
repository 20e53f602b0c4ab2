"""``python -m minos.learn {train,eval,cell,tables}``: the reference learner from the command line.

    python -m minos.learn train --dataset runs/oracle/lerobot --modalities M,D --out m.pt
    python -m minos.learn eval --checkpoint m.pt --data DATA --episodes eps/test.parquet
    python -m minos.learn cell --work cells/point-small --modalities M --modalities M,D
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path

from . import kernels
from .cell import PRESET_ACTIONS, CellConfig, run_cell


def _range(text: str) -> tuple[int, int]:
    lo, _, hi = text.partition("..")
    return int(lo), int(hi or lo)


def _common_train(p: argparse.ArgumentParser) -> None:
    p.add_argument("--memory", choices=["gru", "none"], default="gru",
                   help="recurrent GRU (default) or feed-forward")
    p.add_argument("--hidden", type=int, default=128)
    p.add_argument("--epochs", type=int, default=10)
    p.add_argument("--batch-frames", type=int, default=512,
                   help="frames per optimiser step (whole episodes)")
    p.add_argument("--lr", type=float, default=1e-3)
    p.add_argument("--dagger", type=int, default=0, metavar="N",
                   help="DAgger rounds after behaviour cloning (needs the training episodes)")
    p.add_argument("--beta", type=float, default=0.5, help="DAgger's first oracle mixture")
    p.add_argument("--dagger-epochs", type=int, default=None, metavar="E",
                   help="epochs of each DAgger round (default: --epochs)")
    p.add_argument("--noise", type=int, default=0, metavar="N",
                   help="DART rounds before cloning: the oracle over the training episodes "
                        "with random moves, labelled by the oracle (train: needs the training "
                        "episodes; cell: rows without DAgger rounds)")
    p.add_argument("--noise-eps", type=float, default=0.3,
                   help="DART's probability of a random move per step")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--device", default="auto", help="auto (CUDA when present), cpu, cuda")
    p.add_argument("--size", type=int, default=84, help="image size the policy sees")


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m minos.learn", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    ap.add_argument("--kernels", choices=list(kernels.MODES), default=None,
                    help="torch's CPU kernels: portable (the same bits on AVX2 and AVX-512 "
                         "processors; the default, or $MINOS_LEARN_KERNELS) or native "
                         "(fastest)")
    sub = ap.add_subparsers(dest="command", required=True)

    t = sub.add_parser("train", help="behaviour cloning (and DAgger) from a LeRobot dataset")
    t.add_argument("--dataset", required=True, action="append",
                   help="LeRobot dataset root (minos run --format lerobot, minos "
                        "export-dataset); repeat to mix datasets, e.g. oracle runs and "
                        "people's minos serve sessions")
    t.add_argument("--repo-id", default="minos/run")
    t.add_argument("--modalities", default="M", help="any of M,V,D,F,S,A, e.g. M,D")
    t.add_argument("--agent", default="minos-paper", choices=sorted(PRESET_ACTIONS),
                   help="the preset whose discrete actions the policy chooses")
    t.add_argument("--use-stop", action="store_true",
                   help="learn and use `stop` (for --require-stop evaluation)")
    t.add_argument("--out", required=True, help="checkpoint file")
    t.add_argument("--resume", action="store_true", help="continue from --out")
    t.add_argument("--decode", choices=["arrow", "lerobot"], default="arrow")
    t.add_argument("--data", help="DATA folder (DAgger)")
    t.add_argument("--train-episodes", help="training episode file (DAgger)")
    _common_train(t)

    e = sub.add_parser("eval", help="evaluate a checkpoint (or the random agent) on episodes")
    e.add_argument("--checkpoint", help="a checkpoint from `train`; omit with --random")
    e.add_argument("--random", action="store_true", help="the random agent")
    e.add_argument("--data", required=True)
    e.add_argument("--episodes", required=True, help="held-out episode file")
    e.add_argument("--agent", default=None, help="preset (default: the checkpoint's actions' "
                   "preset, minos-paper)")
    e.add_argument("--num-envs", type=int, default=8)
    e.add_argument("--max-steps", type=int, default=None)
    e.add_argument("--require-stop", action="store_true")
    e.add_argument("--greedy", action="store_true", help="argmax actions (default: sample)")
    e.add_argument("--size", type=int, default=84)
    e.add_argument("--seed", type=int, default=0,
                   help="the episodes' order among the environments and the sampled actions")
    e.add_argument("--variant", default=None,
                   help="run the episodes on this variant of their scenes (e.g. empty)")
    e.add_argument("--device", default="auto")
    e.add_argument("--out", help="write the results (JSON) here")

    tb = sub.add_parser("tables", help="the MINOS paper's tables, one resumable cell at a time")
    tb.add_argument("--root", required=True, help="folder of the cells (made if missing)")
    tb.add_argument("--cell", action="append", help="run this cell (repeatable; default: "
                    "every cell not done yet)")
    tb.add_argument("--list", action="store_true", help="list the cells, done or not")
    tb.add_argument("--report", action="store_true", help="only write ROOT/tables.md")
    tb.add_argument("--random-only", action="store_true", help="stop each cell after its "
                    "random row (the task-difficulty check: no oracle dataset, no training)")
    tb.add_argument("--dagger", type=int, default=None, metavar="N",
                    help="DAgger rounds of the rows with an image (default: the tables' 3); "
                    "other rows than the three-round ones, which are kept")
    tb.add_argument("--draws", type=int, default=1, metavar="N",
                    help="train and evaluate each row N times, with training seeds 0..N-1 "
                         "(same houses and episodes); the report gives the mean and spread")
    tb.add_argument("--device", default="auto")

    c = sub.add_parser("cell", help="DATA → episodes → oracle → LeRobot → train → eval → table")
    c.add_argument("--work", required=True, help="work folder (resumable)")
    c.add_argument("--modalities", action="append", help="a modality set (repeatable), e.g. "
                   "--modalities M --modalities M,D (default: M)")
    c.add_argument("--data", help="an existing DATA folder (with --split); default: generate")
    c.add_argument("--split", help="split of --data with train and test subsets")
    c.add_argument("--houses", type=int, default=40)
    c.add_argument("--test-houses", type=int, default=10)
    c.add_argument("--rooms", type=_range, default=(2, 2), help="MIN..MAX rooms (default 2..2)")
    c.add_argument("--task", default="pointgoal", choices=["pointgoal", "objectgoal", "roomgoal"])
    c.add_argument("--categories", nargs="*", help="ObjectGoal categories, e.g. door arch")
    c.add_argument("--select", default="any", choices=["any", "random", "closest"],
                   help="which goal instances count (random: one, as MINOS)")
    c.add_argument("--min-doors", type=int, default=0,
                   help="fewest doorways on an episode's shortest path (MINOS's filter)")
    c.add_argument("--no-ratio-rule", action="store_true",
                   help="keep straight-line episodes (no geodesic/Euclidean rule, as MINOS)")
    c.add_argument("--states", action="store_true",
                   help="MINOS's episode states: starts of PointGoal episodes sampled with "
                        "--min-doors, the task's goal drawn from each")
    c.add_argument("--episodes-on-base", action="store_true",
                   help="sample on the scenes as given and run on --variant (MINOS's empty "
                        "configs shared the furnished ones' episode states)")
    c.add_argument("--random-agent", default="minos-random", choices=["minos-random", "random"],
                   help="the random row's agent (minos-random: MINOS's baseline)")
    c.add_argument("--variant", help="scene variant (`empty` is made here)")
    c.add_argument("--format", default="suncg", choices=["suncg", "mp3d", "mp3d-scan"],
                   help="generated houses' format (mp3d: Matterport3D-format houses; "
                        "mp3d-scan: scan-like ones, dense noisy meshes with clutter)")
    c.add_argument("--scan-triangles", type=int, default=300_000,
                   help="triangles per mp3d-scan house")
    c.add_argument("--furnishing", default="standard", choices=["standard", "dense"],
                   help="generated houses' furniture (dense: about half the floor taken, as "
                        "in real SUNCG and 3D-FRONT rooms)")
    c.add_argument("--preset", default="minos-paper", choices=sorted(PRESET_ACTIONS))
    c.add_argument("--per-scene", type=int, default=10, help="training episodes per house")
    c.add_argument("--test-per-scene", type=int, default=10)
    c.add_argument("--max-steps", type=int, default=500)
    c.add_argument("--num-envs", type=int, default=8)
    c.add_argument("--greedy", action="store_true")
    c.add_argument("--blind-teacher", default="oracle", choices=["oracle", "wall-follower"],
                   help="blind rows' teacher without DAgger (wall-follower: Bug-style wall "
                        "following from the goal vector and contact bits, minos.learn.wall)")
    c.add_argument("--teacher-passes", type=int, default=2, metavar="N",
                   help="the wall follower's passes over the training episodes")
    c.add_argument("--teacher-successes-only", action="store_true",
                   help="clone only the wall follower's episodes that reached the goal")
    c.add_argument("--train-seed", type=int, default=None, metavar="T",
                   help="seed of the policies' own draws (weights, batch order, DAgger/DART "
                        "rollouts, evaluation's sampled actions; default: --seed); houses, "
                        "episodes and the random row keep --seed")
    c.add_argument("--random-only", action="store_true",
                   help="stop after the random row (the task-difficulty check)")
    _common_train(c)
    return ap


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    kernels.select(args.kernels)
    logging.basicConfig(level=logging.WARNING, format="%(name)s: %(message)s")
    progress = not args.quiet
    if args.command == "tables":
        from . import tables

        root = Path(args.root)
        try:
            all_cells = tables.cells(args.dagger)
            tables.check_draws(args.draws)
        except ValueError as e:
            raise SystemExit(str(e)) from None
        if args.list:
            for name, cfg in all_cells.items():
                done = "done" if tables.is_done(root, name, cfg) else "not run"
                print(f"{name:34s} {done:8s} {cfg.task} rooms {cfg.rooms[0]}..{cfg.rooms[1]} "
                      f"{cfg.format} {cfg.furnishing} variant={cfg.variant or '-'} houses {cfg.houses} "
                      f"(test {cfg.test_houses}) rows {','.join(cfg.modalities)} "
                      f"epochs {cfg.epochs}")
            return 0
        if args.report:
            root.mkdir(parents=True, exist_ok=True)
            text = tables.report(root, args.dagger)
            (root / "tables.md").write_text(text)
            print(text)
            return 0
        tables.run(root, args.cell, device=args.device, progress=progress,
                   random_only=args.random_only, draws=args.draws, dagger=args.dagger)
        return 0
    if args.command == "cell":
        cfg = CellConfig(
            work=args.work, modalities=args.modalities or ["M"], data=args.data,
            split=args.split, houses=args.houses, test_houses=args.test_houses,
            rooms=args.rooms, task=args.task, categories=args.categories,
            select=args.select, min_doors=args.min_doors, ratio_rule=not args.no_ratio_rule,
            states=args.states, episodes_on_base=args.episodes_on_base,
            random_agent=args.random_agent,
            variant=args.variant, format=args.format, scan_triangles=args.scan_triangles,
            furnishing=args.furnishing, preset=args.preset, per_scene=args.per_scene,
            test_per_scene=args.test_per_scene, max_steps=args.max_steps, size=args.size,
            memory=args.memory, hidden=args.hidden, epochs=args.epochs,
            batch_frames=args.batch_frames, lr=args.lr, dagger=args.dagger, beta=args.beta,
            dagger_epochs=args.dagger_epochs, noise=args.noise, noise_eps=args.noise_eps,
            num_envs=args.num_envs, sample=not args.greedy, seed=args.seed,
            train_seed=args.train_seed, blind_teacher=args.blind_teacher,
            teacher_passes=args.teacher_passes,
            teacher_successes=args.teacher_successes_only, device=args.device)
        run_cell(cfg, progress=progress, random_only=args.random_only)
        return 0

    from .evaluate import evaluate_policy, evaluate_random, make_env
    from .train import TrainConfig, load_policy, make_policy, train_bc

    if args.command == "train":
        from .data import available_keys, dataset_tasks, load_many
        from .features import keys_for, parse_modalities

        mods = parse_modalities(args.modalities)
        have, camera = available_keys(args.dataset[0], args.repo_id)
        tasks: set[str] = set()
        for root in args.dataset:
            tasks |= dataset_tasks(root)
            have &= available_keys(root, args.repo_id)[0]
        keys = keys_for(mods, have, camera, tasks)
        demos = load_many(args.dataset, PRESET_ACTIONS[args.agent], keys=keys,
                          repo_id=args.repo_id, decode=args.decode)
        print(f"{demos.num_frames} frames, {demos.num_episodes} episodes; actions "
              f"{demos.label_counts()}", file=sys.stderr)
        policy = make_policy(demos, mods, memory=args.memory, hidden=args.hidden,
                             image_size=args.size, use_stop=args.use_stop, seed=args.seed)
        if (args.dagger or args.noise) and not (args.data and args.train_episodes):
            raise SystemExit("--dagger and --noise need --data and --train-episodes")
        if args.noise:
            from .dart import noisy_demonstrations

            demos.frames = {k: demos.frames[k] for k in policy.spec.keys}
            noisy_demonstrations(demos, make_env(args.data, args.train_episodes,
                                                 agent=args.agent, size=args.size,
                                                 seed=args.seed, require_stop=args.use_stop),
                                 rounds=args.noise, eps=args.noise_eps, seed=args.seed,
                                 progress=progress,
                                 callback=lambda r: print(json.dumps(r), file=sys.stderr))
        tc = TrainConfig(epochs=args.epochs, batch_frames=args.batch_frames, lr=args.lr,
                         seed=args.seed, device=args.device)
        hist = train_bc(policy, demos, tc, checkpoint=args.out, resume=args.resume,
                        progress=progress,
                        callback=lambda r: print(json.dumps(r), file=sys.stderr))
        if args.dagger:
            from .dagger import dagger

            venv = make_env(args.data, args.train_episodes, agent=args.agent, size=args.size,
                            seed=args.seed, require_stop=args.use_stop)
            recs = dagger(policy, demos, venv, tc, iterations=args.dagger, beta=args.beta,
                          checkpoint=args.out, progress=progress, epochs=args.dagger_epochs,
                          callback=lambda r: print(json.dumps(r), file=sys.stderr))
            print(json.dumps({"history": hist, "dagger": recs}))
        else:
            print(json.dumps({"history": hist}))
        return 0

    # eval
    if args.random == bool(args.checkpoint):
        raise SystemExit("give --checkpoint or --random")
    policy = None
    agent = args.agent or "minos-paper"
    require_stop = args.require_stop
    if args.checkpoint:
        policy, _ = load_policy(args.checkpoint, args.device)
        require_stop = require_stop or policy.spec.use_stop
    venv = make_env(args.data, args.episodes, agent=agent, num_envs=args.num_envs,
                    size=args.size, seed=args.seed, max_steps=args.max_steps,
                    require_stop=require_stop, variant=args.variant)
    if policy is None:
        res = evaluate_random(venv, seed=args.seed, max_steps=args.max_steps, progress=progress)
    else:
        res = evaluate_policy(policy, venv, seed=args.seed, sample=not args.greedy,
                              max_steps=args.max_steps, device=args.device, progress=progress)
    if args.out:
        Path(args.out).write_text(json.dumps(res, indent=1))
    print(json.dumps(res["aggregate"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
