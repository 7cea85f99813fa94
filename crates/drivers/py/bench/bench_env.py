"""Robot-steps per second of madenet's Python environments (primitive mode), and the 40 NF
trials of the paper's maps from Python — the figures of BENCHMARKS.md's Python section.

    python crates/drivers/py/bench/bench_env.py [--seconds 5] [--threads 1]

`--threads` sets RAYON_NUM_THREADS for the VectorEnv and the study. With `--threads 1` (the
issue's yardstick, "one core") the process also pins itself to one CPU, so nothing of it runs
on a second core. Prints one JSON object.
"""

import argparse
import json
import os
import platform
import sys
import time


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=5.0, help="minimum measuring time per figure")
    ap.add_argument("--threads", type=int, default=1, help="rayon threads for VectorEnv and the study")
    ap.add_argument("--map", default="paper:3")
    args = ap.parse_args()
    os.environ["RAYON_NUM_THREADS"] = str(args.threads)  # read when rayon's pool starts
    pinned = None
    if args.threads == 1 and hasattr(os, "sched_setaffinity"):
        pinned = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {pinned})
    import numpy as np
    import madenet

    out = {"python": sys.version.split()[0], "machine": platform.machine(), "threads": args.threads, "pinned_cpu": pinned, "map": args.map}
    rng = np.random.default_rng(0)

    # One ExplorationEnv, primitive mode, a Python loop over dict actions (PettingZoo API).
    env = madenet.ExplorationEnv(map=args.map, mode="primitive")
    env.reset(seed=1)
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < args.seconds:
        if not env.agents:
            env.reset()
        env.step({a: int(rng.integers(0, 9)) for a in env.agents})
        steps += 1
    dt = time.perf_counter() - start
    out["env1_steps_per_s"] = steps / dt
    out["env1_robot_steps_per_s"] = steps * len(env.possible_agents) / dt

    # VectorEnv of 64, actions pre-drawn so the loop measures the environments.
    for n in (64,):
        venv = madenet.VectorEnv(n, map=args.map, mode="primitive", seed=1)
        venv.reset()
        actions = rng.integers(0, 9, size=(256, n, venv.num_robots))
        steps, start = 0, time.perf_counter()
        while time.perf_counter() - start < args.seconds:
            venv.step(actions[steps % 256])
            steps += 1
        dt = time.perf_counter() - start
        out[f"vec{n}_steps_per_s"] = steps / dt
        out[f"vec{n}_robot_steps_per_s"] = steps * n * venv.num_robots / dt

    # The authors' anchor: 40 NF trials (10 paper maps x 4 corners, CSP 1, one seed).
    start = time.perf_counter()
    table = madenet.compare(methods=["nf"], maps=["paper"], csp=[1.0], seeds=1, threads=args.threads)
    out["nf40_s"] = time.perf_counter() - start
    out["nf40_mean_tns"] = float(table["tns"].mean())
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
