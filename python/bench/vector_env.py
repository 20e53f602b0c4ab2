"""VectorNavEnv against the Rust rollout, on the same episodes, in one process.

    python python/bench/vector_env.py [--houses 8] [--per-scene 4] [--envs 8] [--threads 1]

Sets up what `cargo bench --bench rollout` does (generated furnished houses, seed 5, baked at
5 cm for Habitat's body; PointGoal, ObjectGoal and RoomGoal episodes, 4 per scene, seed 2),
then measures, on the same episodes and thread count:

1. the Rust rollout: `minos.run(agent="oracle")`, the library call `minos run` and the bench
   make (oracle, RGB-D-semantic 84² on the CPU renderer, Parquet tables written);
2. `minos.gym.VectorNavEnv` (RGB-D-semantic 84², `--envs` environments, `--threads` Rust
   threads) driven by the same oracle (`oracle_actions()`), every episode run once, batched
   NumPy observations returned to Python at every step.

Prints both rates in steps per second (wall time) and their ratio.
"""

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

import minos
from minos.gym import VectorNavEnv


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--houses", type=int, default=8)
    ap.add_argument("--per-scene", type=int, default=4)
    ap.add_argument("--envs", type=int, default=8)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--size", type=int, default=84)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        minos.generate(d / "suncg", houses=args.houses, seed=5)
        minos.ingest(d / "suncg", d / "DATA")
        minos.bake(d / "DATA", previews=False)
        files = []
        for task in ["pointgoal", "objectgoal", "roomgoal"]:
            f = d / f"{task}.parquet"
            minos.sample_episodes(d / "DATA", task, f, per_scene=args.per_scene, seed=2)
            files.append(f)
        episodes = [e for f in files for e in minos.read_episodes(f)]
        print(f"{len(episodes)} episodes on {args.houses} houses, {args.threads} thread(s)")

        steps, secs = 0, 0.0
        for f in files:
            t = time.perf_counter()
            r = minos.run(d / "DATA", f, "oracle", d / f"run-{f.stem}", size=args.size,
                          reward="geodesic", threads=args.threads)
            secs += time.perf_counter() - t
            steps += r["steps"]
            assert not r["failures"], r["failures"]
        rust = steps / secs
        print(f"rust rollout (minos.run, oracle, Parquet): {steps} steps in {secs:.2f} s: "
              f"{rust:.0f} steps/s")

        venv = VectorNavEnv(data=d / "DATA", episodes=episodes, num_envs=args.envs,
                            size=args.size, reward="geodesic", require_stop=True,
                            threads=args.threads)
        t = time.perf_counter()
        venv.reset()
        done = set()
        vsteps = 0
        while len(done) < len(episodes):
            a = venv.oracle_actions()
            current = [e.episode_id for e in venv.current_episodes()]
            obs, rew, term, trunc, info = venv.step(a)
            vsteps += int((~info["reset"]).sum())
            for k in np.flatnonzero(term | trunc):
                done.add(current[k])
        vsecs = time.perf_counter() - t
        vec = vsteps / vsecs
        print(f"VectorNavEnv ({args.envs} envs, oracle actions, batched NumPy): {vsteps} steps "
              f"in {vsecs:.2f} s: {vec:.0f} steps/s")
        print(f"ratio VectorNavEnv / rust rollout: {100 * vec / rust:.0f} %")


if __name__ == "__main__":
    main()
