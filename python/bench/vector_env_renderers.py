"""VectorNavEnv steps per second with random actions, CPU renderer against wgpu.

    python python/bench/vector_env_renderers.py DATA EPISODES.parquet [--envs 256,1024]
        [--threads 16] [--seconds 4] [--size 84]

Random actions other than ``stop`` (episodes end on arrival or at the step limit, and the
environments reset themselves), RGB-D-semantic cameras. For each renderer and environment
count: reset, three warm-up steps, then steps for ``--seconds``; prints steps per second by
the wall clock. With ``renderer="wgpu"`` every environment's cameras of a step are rendered
in one GPU submission. Figures in docs/PERFORMANCE.md (GPU section).
"""

import argparse
import time

import numpy as np

from minos.gym import VectorNavEnv


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("data")
    ap.add_argument("episodes")
    ap.add_argument("--envs", default="256,1024")
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--size", type=int, default=84)
    ap.add_argument("--renderers", default="cpu,wgpu")
    args = ap.parse_args()
    for renderer in args.renderers.split(","):
        for n in [int(x) for x in args.envs.split(",")]:
            env = VectorNavEnv(data=args.data, episodes=args.episodes, num_envs=n,
                               renderer=renderer, threads=args.threads, size=args.size)
            env.reset(seed=0)
            rng = np.random.default_rng(0)
            k = env.single_action_space.n  # the last action is `stop`
            for _ in range(3):
                env.step(rng.integers(0, k - 1, size=n))
            steps, t = 0, time.perf_counter()
            while time.perf_counter() - t < args.seconds:
                env.step(rng.integers(0, k - 1, size=n))
                steps += n
            rate = steps / (time.perf_counter() - t)
            print(f"VectorNavEnv renderer={renderer} num_envs={n} threads={args.threads}: "
                  f"{rate:,.0f} steps/s", flush=True)
            env.close()


if __name__ == "__main__":
    main()
