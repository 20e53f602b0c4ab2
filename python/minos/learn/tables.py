"""The MINOS paper's two tables (Savva et al. 2017, "complexity" and "modalities") as cells of
:func:`minos.learn.cell.run_cell`, each resumable and run on its own:

    python -m minos.learn tables --root tables --list
    python -m minos.learn tables --root tables --cell point-suncg-furnished-small
    python -m minos.learn tables --root tables            # every cell not yet done, in order
    python -m minos.learn tables --root tables --report   # ROOT/tables.md from what is done

Every cell uses the paper's agent (``--preset minos-paper``: forward / turn left / turn right,
0.4 m point radius, 1.09 m eye, grey 90° camera), 84² images, a 500-step limit and 10 test
episodes per unseen house (train/test split by house), sampled as MINOS's environment configs
(``minos/config/envs/*.py``) did: at least one doorway on the shortest path in small (2-room)
houses and two in medium (3–5-room) houses, no geodesic/Euclidean rule, one random door or
arch (ObjectGoal) or room (RoomGoal) as the goal (``select: random``), and the empty cells'
episodes sampled in the furnished houses and run with the furniture removed (MINOS's empty and
furnished configs shared one states file). The random
rows are MINOS's random agent (``minos-random``: each button pressed with probability ½ per
step), averaged over five seeds. Every row that sees an image (V or D) is
behaviour-cloned from the oracle and then trained in three DAgger rounds of three epochs
(the oracle labelling the states the policy reaches in the training houses); blind rows
(M, M+F) are cloned without DAgger: in the complexity table from the oracle, in the
modality table from the successful episodes of two passes of the wall follower over the
training episodes (:mod:`minos.learn.wall`: a teacher that decides from what a blind policy
senses). The data sizes are chosen so that a cell's training and
evaluation fit about 10 minutes of a 2-core CPU (docs/RESULTS.md says what each cell chose and
what it took). ``--random-only`` stops each cell after its random row: the task-difficulty
check in minutes, without training. A modality-table cell is one row of one column; the rows
of a column share its houses, episodes and oracle dataset (made by the first one run).
"""

from __future__ import annotations

import json
import statistics
from dataclasses import replace
from pathlib import Path
from typing import Optional

from .cell import (CellConfig, dagger_rounds, noise_rounds, policy_seed, random_file,
                   round_epochs, row_file, run_cell, wall_passes)
from .features import parse_modalities

#: The paper's numbers: complexity cells → (random success %, best agent success %, agent).
PAPER_COMPLEXITY = {
    "point-suncg-empty-small": (23.8, 80.3, "DFP"),
    "point-suncg-empty-medium": (8.6, 64.1, "DFP"),
    "point-suncg-furnished-small": (9.5, 64.5, "DFP"),
    "point-suncg-furnished-medium": (6.3, 45.3, "UNREAL"),
    "point-mp3d-small": (0.0, 38.0, "UNREAL"),
    "point-mp3d-medium": (0.0, 20.0, "UNREAL"),
    "room-suncg-furnished-small": (10.0, 58.6, "UNREAL"),
    "room-suncg-furnished-medium": (3.1, 32.0, "UNREAL"),
    "room-mp3d-small": (5.0, 14.0, "?"),
}

#: The modality table (DFP, ObjectGoal door): row → {column: (success %, speed %)}. The
#: columns are MINOS's ``objectgoal_suncg_{se,me,sf,mf}`` configs: small (2 rooms) and medium
#: (3–5 rooms) houses, empty and furnished.
MOD_COLUMNS = ("small-empty", "medium-empty", "small-furnished", "medium-furnished")
PAPER_MODALITIES = {
    "random": [(23.1, 12.7), (18.8, 11.3), (9.5, 5.2), (6.5, 3.1)],
    "M": [(90.6, 68.1), (66.5, 49.5), (46.2, 27.2), (25.8, 12.2)],
    "M+V": [(86.8, 71.2), (68.7, 53.7), (48.4, 38.6), (30.4, 19.6)],
    "M+D": [(92.7, 77.6), (74.8, 63.7), (64.2, 51.7), (43.7, 28.5)],
    "M+F": [(96.7, 78.7), (70.3, 56.3), (56.0, 37.8), (39.9, 29.1)],
    "M+V+F": [(94.8, 80.4), (74.3, 61.1), (54.4, 41.7), (41.8, 29.3)],
    "M+D+V+F": [(94.4, 80.0), (78.1, 65.3), (64.7, 52.4), (48.0, 35.0)],
}
MOD_ROWS = [r for r in PAPER_MODALITIES if r != "random"]

#: The trained rows of a complexity cell (measurements alone, and with depth).
COMPLEXITY_ROWS = ["M", "M+D"]

#: Epochs of each DAgger round: the rounds fine-tune the cloned policy rather than retrain
#: it (rounds of the cloning's 8 epochs on every frame so far would give door-small-empty
#: M+D about 12 minutes of training on a quiet 2-core box; with 3 it trained in 359 s with
#: the same 93.9 % success; docs/RESULTS.md, "Cost").
DAGGER_EPOCHS = 3


def _complexity() -> dict[str, CellConfig]:
    # MINOS's episode filters: `pathNumDoors > 0` in 2-room SUNCG houses, `> 1` in 3–5-room
    # ones, `pathNumRooms > 0` for Matterport3D; no geodesic/Euclidean ratio rule; RoomGoal's
    # goal is one random room (`select: random`, success in that room only).
    base = CellConfig(work="", modalities=list(COMPLEXITY_ROWS), preset="minos-paper",
                      per_scene=10, test_per_scene=10, max_steps=500, size=84, epochs=10,
                      ratio_rule=False, dagger=3, dagger_blind=False,
                      dagger_epochs=DAGGER_EPOCHS)
    small = dict(houses=40, test_houses=10, rooms=(2, 2), min_doors=1)
    medium = dict(houses=30, test_houses=10, rooms=(3, 5), epochs=8, min_doors=2)
    mp_small = dict(houses=24, test_houses=8, rooms=(3, 10), format="mp3d", epochs=8)
    mp_medium = dict(houses=16, test_houses=6, rooms=(11, 24), format="mp3d", epochs=6,
                     per_scene=8)
    c = {
        "point-suncg-empty-small": replace(base, variant="empty", episodes_on_base=True,
                                           **small),
        "point-suncg-empty-medium": replace(base, variant="empty", episodes_on_base=True,
                                            **medium),
        "point-suncg-furnished-small": replace(base, **small),
        "point-suncg-furnished-medium": replace(base, **medium),
        "point-mp3d-small": replace(base, **mp_small),
        "point-mp3d-medium": replace(base, **mp_medium),
        "room-suncg-furnished-small": replace(base, task="roomgoal", select="random", **small),
        "room-suncg-furnished-medium": replace(base, task="roomgoal", select="random",
                                               **medium),
        "room-mp3d-small": replace(base, task="roomgoal", select="random", **mp_small),
    }
    return c


def _modalities() -> dict[str, CellConfig]:
    # MINOS's objectgoal_suncg_* configs: one random instance of `['arch', 'door']` is the
    # goal (`select: random`), from the starts of the episode states (`states`), which have
    # `pathNumDoors > 0` in 2-room houses and `> 1` in 3–5-room ones on their PointGoal
    # paths; no ratio rule. The blind rows (M, M+F) are cloned from the wall follower
    # (minos.learn.wall), whose decisions they can observe: cloned from the oracle (M+F with
    # DART) they stayed 10–16 points below the paper in the empty columns (docs/RESULTS.md).
    # Only its successful episodes: its failed searches, run to the step limit, were 57 % of
    # medium-empty's frames, and cloned with them M was below the paper there.
    base = CellConfig(work="", task="objectgoal", categories=["door", "arch"], select="random",
                      preset="minos-paper", per_scene=10, test_per_scene=10, max_steps=500,
                      size=84, epochs=8, ratio_rule=False, dagger=3, dagger_blind=False,
                      dagger_epochs=DAGGER_EPOCHS, states=True, noise=2,
                      blind_teacher="wall-follower", teacher_passes=2,
                      teacher_successes=True)
    small = dict(rooms=(2, 2), min_doors=1, houses=100, test_houses=30)
    # Medium houses keep fewer of their starts (two doorways on the path), so more houses
    # for a training set and a test set the size of the small columns'.
    medium = dict(rooms=(3, 5), min_doors=2, houses=80, test_houses=24)
    cols = {
        "small-empty": dict(variant="empty", episodes_on_base=True, **small),
        "medium-empty": dict(variant="empty", episodes_on_base=True, **medium),
        "small-furnished": dict(**small),
        "medium-furnished": dict(**medium),
    }
    out = {}
    for col, kw in cols.items():
        for row in MOD_ROWS:
            out[f"door-{col}/{row}"] = replace(base, modalities=[row], **kw)
    return out


def cells(dagger: Optional[int] = None) -> dict[str, CellConfig]:
    """Every cell by name (work folders relative to the root). ``dagger``: the DAgger rounds
    of the rows with an image instead of the tables' three (its rows are other rows,
    written as ``-dagger<N>e3``, so a folder keeps the rows of every number of rounds)."""
    if dagger is not None and dagger < 1:
        raise ValueError(f"dagger: {dagger} rounds; at least 1")
    out = {}
    for name, cfg in {**_complexity(), **_modalities()}.items():
        out[name] = replace(cfg, work=name.split("/")[0],
                            dagger=cfg.dagger if dagger is None else dagger)
    return out


#: The training seeds the report looks for: a row's draws are those of seeds below this.
MAX_DRAWS = 32


def check_draws(draws: int) -> None:
    """ValueError unless ``draws`` is a number of training draws :func:`run` can make and
    :func:`report` finds (1 … :data:`MAX_DRAWS`)."""
    if not 1 <= draws <= MAX_DRAWS:
        raise ValueError(f"draws: {draws}; must be 1..{MAX_DRAWS}")


def _row_file(root: Path, cfg: CellConfig, row: str) -> Path:
    return row_file(root / cfg.work, cfg, parse_modalities(row))


def _draw(cfg: CellConfig, k: int) -> CellConfig:
    """The cell's ``k``-th draw: training seed ``seed + k`` (the cell's own seed for k = 0,
    whose rows keep their names)."""
    return replace(cfg, train_seed=None if k == 0 else cfg.seed + k)


def is_done(root: Path, name: str, cfg: CellConfig, draws: int = 1) -> bool:
    """Whether every row of the cell has its first ``draws`` draws."""
    return all(_row_file(root, _draw(cfg, k), r).is_file()
               for r in cfg.modalities for k in range(draws))


def run(root: str | Path, names: Optional[list[str]] = None, device: str = "auto",
        progress: bool = True, random_only: bool = False, draws: int = 1,
        dagger: Optional[int] = None) -> None:
    """Runs the named cells (default: every cell not done yet), then rewrites the report.
    With ``random_only``, each cell stops after its random row (the task-difficulty check:
    houses, episodes and the random agent's runs, minutes for all cells). ``draws``: train
    and evaluate each row this many times, with training seeds ``seed`` … ``seed + draws −
    1`` (same houses and episodes); the report gives their mean and spread. ``dagger``: the
    rows with an image get this many DAgger rounds (:func:`cells`)."""
    check_draws(draws)
    root = Path(root)
    all_cells = cells(dagger)
    if random_only:
        todo = names or [n for n, c in all_cells.items()
                         if not random_file(root / c.work, c).is_file()]
    else:
        todo = names or [n for n, c in all_cells.items() if not is_done(root, n, c, draws)]
    for name in todo:
        if name not in all_cells:
            raise SystemExit(f"no cell `{name}` (see --list)")
        cfg = replace(all_cells[name], work=str(root / all_cells[name].work), device=device)
        for k in range(1 if random_only else draws):
            print(f"[minos.learn tables] cell {name}"
                  + (f", training seed {policy_seed(_draw(cfg, k))}" if draws > 1 else ""),
                  flush=True)
            run_cell(_draw(cfg, k), progress=progress, random_only=random_only)
            (root / "tables.md").write_text(report(root, dagger))
    if not todo:
        (root / "tables.md").write_text(report(root, dagger))


def _load(path: Path) -> Optional[dict]:
    return json.loads(path.read_text()) if path.is_file() else None


def _draws(root: Path, cfg: CellConfig, row: str) -> list[dict]:
    """Every draw of a row that is done (training seeds ``seed`` … ``seed + MAX_DRAWS − 1``),
    the cell's own seed first."""
    found = (_load(_row_file(root, _draw(cfg, k), row)) for k in range(MAX_DRAWS))
    return [d for d in found if d is not None]


def summary(draws: list[dict], key: str) -> Optional[tuple[float, float, int]]:
    """Mean and sample standard deviation of ``key`` over a row's draws, and their number
    (sd 0 for one draw; None for none)."""
    if not draws:
        return None
    vals = [float(d[key]) for d in draws]
    return statistics.fmean(vals), statistics.stdev(vals) if len(vals) > 1 else 0.0, len(vals)


def _spread(s: Optional[tuple[float, float, int]]) -> str:
    """`` ±sd ×n`` (percentage points) when a row has more than one draw."""
    return f" ±{100 * s[1]:.1f} ×{s[2]}" if s and s[2] > 1 else ""


def report(root: str | Path, dagger: Optional[int] = None) -> str:
    """Both tables in Markdown, minos's numbers beside the paper's (`—`: not run yet), of
    the rows with ``dagger`` DAgger rounds (None: the tables' three; :func:`cells`)."""
    root = Path(root)
    allc = cells(dagger)
    pct = lambda v: "—" if v is None else f"{100 * v:.1f}"  # noqa: E731
    def how(cfg: CellConfig, row: str) -> str:
        mods = parse_modalities(row)
        if dagger_rounds(cfg, mods):
            per = "" if round_epochs(cfg) is None else f" of {round_epochs(cfg)} epochs"
            return f"cloned + {dagger_rounds(cfg, mods)} DAgger rounds{per}"
        if noise_rounds(cfg, mods):
            return f"cloned with {noise_rounds(cfg, mods)} DART rounds (ε {cfg.noise_eps:g})"
        if wall_passes(cfg, mods):
            kept = " (its successful episodes)" if cfg.teacher_successes else ""
            return f"cloned from {wall_passes(cfg, mods)} passes of the wall follower{kept}"
        return "cloned"

    first = next(iter(allc.values()))
    lines = ["## Complexity (success %; a row trained more than once: the mean over its draws, "
             "±sd ×draws)", "",
             "| cell | rooms | houses (train/test) | test eps | paper random | minos random | "
             f"paper best | minos M ({how(first, 'M')}) | minos M+D, {how(first, 'M+D')} (SPL) "
             "| oracle frames | cell s |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, (prand, pbest, agent) in PAPER_COMPLEXITY.items():
        cfg = allc[name]
        m_draws, md_draws = _draws(root, cfg, "M"), _draws(root, cfg, "M+D")
        m = m_draws[0] if m_draws else None
        row = md_draws[0] if md_draws else None
        rand = _load(random_file(root / cfg.work, cfg))
        rs = rand["aggregate"]["success"] if rand else None
        ms, mds = summary(m_draws, "success"), summary(md_draws, "success")
        md = "—"
        if mds:
            md = f"{pct(mds[0])}{_spread(mds)} ({pct(summary(md_draws, 'spl')[0])})"
        m_cell = f"{pct(ms[0])}{_spread(ms)}" if ms else "—"
        some = row or m
        frames = some["train_frames"] if some else "—"
        eps = some["test_episodes"] if some else "—"
        # The cell's wall time: data, oracle, loading, random, and each row's train + eval.
        # (rows run so far; a row that resumed counts only this run's stages).
        secs = "—"
        if some and rand:
            sh = some["seconds"]
            total = sum(sh[k] for k in ("data", "oracle", "load")) + rand["seconds"] + \
                sum(r["seconds"]["train"] + r["seconds"]["eval"] for r in (m, row) if r)
            secs = f"{total:.0f}"
        lines.append(
            f"| {name} | {cfg.rooms[0]}–{cfg.rooms[1]} ({cfg.format}) | "
            f"{cfg.houses - cfg.test_houses}/{cfg.test_houses} | {eps} | {prand} | {pct(rs)} | "
            f"{pbest} ({agent}) | {m_cell} | {md} | {frames} | "
            f"{secs} |")
    door = allc[f"door-{MOD_COLUMNS[0]}/M+D"]
    lines += ["", "## Modalities (ObjectGoal door, success / speed %, the mean over a row's draws "
              "with ±sd of success ×draws when more than one; paper DFP in brackets; "
              f"M {how(door, 'M')}, M+F {how(door, 'M+F')}, the rows with an image "
              f"{how(door, 'M+D')})",
              "",
              "| row | " + " | ".join(MOD_COLUMNS) + " |",
              "|---|" + "---|" * len(MOD_COLUMNS)]
    for row_name, paper in PAPER_MODALITIES.items():
        cols = []
        for j, col in enumerate(MOD_COLUMNS):
            ps, pv = paper[j]
            cfg = allc[f"door-{col}/{MOD_ROWS[0]}"]
            if row_name == "random":
                r = _load(random_file(root / cfg.work, cfg))
                got = (r["aggregate"]["success"], r["aggregate"]["speed"]) if r else None
                mine = f"{pct(got[0])} / {pct(got[1])}" if got else "—"
            else:
                draws = _draws(root, cfg, row_name)
                s, v = summary(draws, "success"), summary(draws, "speed")
                mine = f"{pct(s[0])} / {pct(v[0])}{_spread(s)}" if s else "—"
            cols.append(f"{mine} ({ps} / {pv})")
        lines.append(f"| {row_name} | " + " | ".join(cols) + " |")
    return "\n".join(lines) + "\n"


__all__ = ["PAPER_COMPLEXITY", "PAPER_MODALITIES", "cells", "check_draws", "report", "run",
           "summary"]
