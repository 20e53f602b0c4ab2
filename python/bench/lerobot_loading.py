"""How fast a minos LeRobot export loads through the real LeRobot reader.

    python python/bench/lerobot_loading.py --root DATASET [--frames 1000] [--workers 2]
    python python/bench/lerobot_loading.py --minos target/release/minos --run RUN [--out DIR]

Reads the LeRobot v3.0 dataset DATASET (or first exports the minos run RUN with
`minos export-dataset`) with `lerobot.datasets.lerobot_dataset.LeRobotDataset(repo_id,
root=DATASET)` — the class a LeRobot user trains from — and prints frames per second (wall
time) for:

1. plain iteration: `ds[i]` for the first `--frames` frames, in one process;
2. a torch `DataLoader` (`--workers` workers, batches of `--batch`, shuffled, seed 0) over
   every frame (or `--loader-frames` drawn at random), one epoch;
3. the same with a 4-step action chunk, the way action-chunking policies read:
   `delta_timestamps={"action": [0, 1/fps, 2/fps, 3/fps]}`.

A fourth row repeats 3. with `minos.lerobot.LeRobotDataset` (when the minos package is
importable), the subclass that reads a chunk's column alone: LeRobot 0.4.4 reads a chunk with
`hf_dataset[key][indices]`, which in `datasets` 4 decodes every column of those rows (every
camera of the four chunk frames).

The DataLoader figures are for a whole epoch including starting the workers, and, in
brackets, after the first batch (steady state). Each batch's tensors are checked for shape so
that a loader that silently drops features cannot look fast.
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import torch
from lerobot.datasets.lerobot_dataset import LeRobotDataset


def plain(ds, frames):
    n = min(frames, len(ds))
    ds[0]  # opens the data files
    t = time.perf_counter()
    for i in range(n):
        ds[i]
    return n, time.perf_counter() - t, None


def loader(ds, workers, batch, chunk, frames):
    g = torch.Generator()
    g.manual_seed(0)
    if frames is not None and frames < len(ds):
        ds = torch.utils.data.Subset(ds, torch.randperm(len(ds), generator=g)[:frames].tolist())
    dl = torch.utils.data.DataLoader(
        ds, batch_size=batch, shuffle=True, num_workers=workers, generator=g
    )
    n = 0
    t0 = time.perf_counter()
    t1 = None
    first = 0
    for b in dl:
        if t1 is None:
            t1 = time.perf_counter()
            first = len(b["index"])
        act = b["action"]
        assert act.shape[1:] == ((chunk, act.shape[-1]) if chunk else (act.shape[-1],)), act.shape
        n += len(b["index"])
    end = time.perf_counter()
    steady = (n - first) / (end - t1) if n > first else None
    return n, end - t0, steady


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--root", type=Path, help="a LeRobot dataset folder")
    ap.add_argument("--run", type=Path, help="a minos run folder to export first")
    ap.add_argument("--minos", default="minos", help="the minos binary (with --run)")
    ap.add_argument("--out", type=Path, help="where to export --run (default: a temp folder)")
    ap.add_argument("--frames", type=int, default=1000, help="frames of plain iteration")
    ap.add_argument("--loader-frames", type=int,
                    help="frames of each DataLoader pass, drawn at random (default: every frame)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--batch", type=int, default=64)
    ap.add_argument("--chunk", type=int, default=4, help="action chunk length")
    args = ap.parse_args()
    if (args.root is None) == (args.run is None):
        ap.error("give exactly one of --root and --run")
    tmp = None
    root = args.root
    if args.run is not None:
        if args.out is None:
            tmp = tempfile.TemporaryDirectory()
            args.out = Path(tmp.name) / "lerobot"
        subprocess.run(
            [args.minos, "export-dataset", "-q", "--run", str(args.run), "--out", str(args.out)],
            check=True,
        )
        root = args.out

    info = json.loads((root / "meta/info.json").read_text())
    fps = info["fps"]
    ds = LeRobotDataset("minos/bench", root=root)
    item = ds[0]
    shapes = {k: tuple(v.shape) for k, v in item.items() if isinstance(v, torch.Tensor)}
    print(f"{root}: {len(ds)} frames, {ds.num_episodes} episodes, {fps} fps, "
          f"torch {torch.__version__}, {torch.get_num_threads()} threads")
    for k, s in shapes.items():
        if len(s) > 1:
            print(f"  {k}: {item[k].dtype} {s}")

    rows = []
    n, secs, _ = plain(ds, args.frames)
    rows.append(("plain iteration ds[i]", n, secs, None))
    n, secs, steady = loader(ds, args.workers, args.batch, 0, args.loader_frames)
    rows.append((f"DataLoader({args.workers} workers, batch {args.batch})", n, secs, steady))
    chunked = LeRobotDataset(
        "minos/bench",
        root=root,
        delta_timestamps={"action": [k / fps for k in range(args.chunk)]},
    )
    n, secs, steady = loader(chunked, args.workers, args.batch, args.chunk, args.loader_frames)
    rows.append((f"  + {args.chunk}-step action chunk", n, secs, steady))
    try:
        from minos.lerobot import LeRobotDataset as MinosLeRobotDataset
    except ImportError as e:
        print(f"minos.lerobot not importable ({e}): its row is left out")
    else:
        chunked = MinosLeRobotDataset(
            "minos/bench",
            root=root,
            delta_timestamps={"action": [k / fps for k in range(args.chunk)]},
        )
        n, secs, steady = loader(chunked, args.workers, args.batch, args.chunk, args.loader_frames)
        rows.append(("    minos.lerobot.LeRobotDataset", n, secs, steady))
    for name, n, secs, steady in rows:
        extra = f"  ({steady:,.0f} after the first batch)" if steady else ""
        print(f"{name:<40} {n:>6} frames {secs:>8.2f} s {n / secs:>9,.0f} frames/s{extra}")
    sys.stdout.flush()
    if tmp is not None:
        tmp.cleanup()


if __name__ == "__main__":
    main()
