#!/usr/bin/env python3
"""minos's pipeline fanned out over a Ray cluster: ingest, then bake, episodes and run in
shards (one Ray task per shard), each merged into the files one process would write.

    python scripts/ray_pipeline.py --address auto --dataset suncg --root /data/suncg \\
        --work /shared/minos-work --shards 64 --per-scene 100 --agent oracle

Every node must see --work (a shared filesystem) and have the `minos` binary (--minos, or
`minos` on PATH). Each task runs one `minos` command; minos writes every file under a
temporary name and renames it when complete, and the shards' seeds come from (seed, scene,
purpose), so the outputs do not depend on the shard count, the nodes or retries.

A task whose worker dies (node lost, OOM kill, `kill -9`) is retried by Ray (max_retries);
its minos process dies with it (Linux: PR_SET_PDEATHSIG), and the retry resumes: `run
--resume` keeps the episodes the dead attempt finished, bake keeps the grids it wrote, and
episodes are rewritten whole. A minos command that fails (bad data) is not retried: its error
is raised with minos's one-line message.

Prints one JSON line per stage (name, shards, seconds) and the merged outputs' paths.
"""

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import ray


def _die_with_parent():
    """In the minos child: get SIGKILL when the Ray worker that started it dies."""
    if sys.platform.startswith("linux"):
        import ctypes

        PR_SET_PDEATHSIG = 1
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGKILL)


class MinosError(RuntimeError):
    """A minos command failed (its stderr's last line is the message)."""


@ray.remote(max_retries=3, retry_exceptions=False)
def minos(binary, args):
    """Runs `minos ARGS` on a worker; returns its stdout, raises MinosError on failure."""
    proc = subprocess.run(
        [binary, "-q", "--wait", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_die_with_parent,
    )
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["(no message)"])[-1]
        raise MinosError(f"minos {' '.join(args[:1])}: {last}")
    return proc.stdout


def shards(n):
    return [f"{i}/{n}" for i in range(n)]


def pipeline(a):
    """Runs the stages; returns {stage: seconds}."""
    work = os.path.abspath(a.work)
    data = os.path.join(work, "DATA")
    timings = {}

    def stage(name, commands):
        start = time.monotonic()
        ray.get([minos.remote(a.minos, c) for c in commands])
        timings[name] = round(time.monotonic() - start, 3)
        print(json.dumps({"stage": name, "tasks": len(commands), "seconds": timings[name]}), flush=True)

    n = a.shards
    stage("ingest", [["ingest", "--dataset", a.dataset, "--root", os.path.abspath(a.root), "--out", data]])
    stage("bake", [["bake", "--data", data, "--no-preview", "--shard", s] for s in shards(n)])
    parts = [os.path.join(work, "episodes", f"part-{i}.parquet") for i in range(n)]
    stage(
        "episodes",
        [
            ["episodes", "--data", data, "--task", a.task, "--per-scene", str(a.per_scene),
             "--seed", str(a.seed), "--shard", s, "--out", p]
            for s, p in zip(shards(n), parts)
        ],
    )
    episodes = os.path.join(work, "episodes.parquet")
    stage("merge-episodes", [["merge", "--out", episodes, *parts]])
    runs = [os.path.join(work, "runs", f"shard-{i}") for i in range(n)]
    run_args = ["--agent", a.agent, "--seed", str(a.seed), "--size", str(a.size)]
    if a.max_steps:
        run_args += ["--max-steps", str(a.max_steps)]
    if a.lerobot:
        run_args += ["--format", "lerobot"]
    stage(
        "run",
        [
            ["run", "--data", data, "--episodes", episodes, *run_args, "--threads", str(a.threads),
             "--resume", "--shard", s, "--out", r]
            for s, r in zip(shards(n), runs)
        ],
    )
    stage("merge-run", [["merge", "--out", os.path.join(work, "run"), *runs]])
    return timings


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--address", default=None, help="Ray cluster address (default: start a local one)")
    ap.add_argument("--minos", default=shutil.which("minos") or "minos", help="the minos binary on every node")
    ap.add_argument("--dataset", default="suncg")
    ap.add_argument("--root", required=True, help="the dataset's root (shared filesystem)")
    ap.add_argument("--work", required=True, help="the work folder (shared filesystem)")
    ap.add_argument("--shards", type=int, default=8)
    ap.add_argument("--task", default="pointgoal")
    ap.add_argument("--per-scene", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--agent", default="oracle")
    ap.add_argument("--size", type=int, default=84)
    ap.add_argument("--max-steps", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1, help="minos threads per task (one task per CPU)")
    ap.add_argument("--lerobot", action="store_true", help="also write the LeRobot copy")
    a = ap.parse_args(argv)
    ray.init(address=a.address, log_to_driver=False)
    timings = pipeline(a)
    print(json.dumps({"done": True, "run": os.path.join(os.path.abspath(a.work), "run"), "seconds": timings}))


if __name__ == "__main__":
    main()
