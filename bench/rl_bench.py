#!/usr/bin/env python3
"""Env-steps per second of dronetwin.rl from Python, and the Python front end's overhead.

    PYTHONPATH=build/release-native/python /usr/bin/python3 bench/rl_bench.py [--repetitions 5]

The racing task as bench/rl_bench.cpp runs it (relative-position actions, SE(3) every 1 ms, 10
physics steps per env step, auto-resets), for N = 1 ... 4096 and 1 or 2 threads. For each it
times VectorEnv.step (what a training loop calls: the C++ step plus the Python wrapper and its
info dict) and the bound C++ step alone; the difference is the front end's overhead, printed as a
percentage of the full step. Medians over repetitions.
"""

import argparse
import statistics
import time

import numpy as np

from dronetwin import rl


def timed(fn, calls, repetitions):
    runs = []
    for _ in range(repetitions):
        t0 = time.perf_counter()
        for _ in range(calls):
            fn()
        runs.append((time.perf_counter() - t0) / calls)
    return statistics.median(runs)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repetitions", type=int, default=5)
    parser.add_argument("--dtype", default="float32")
    parser.add_argument("--sizes", default="1,16,256,1024,4096")
    args = parser.parse_args()
    print(f"{'N':>6} {'threads':>7} {'env-steps/s':>14} {'C++ only':>14} {'overhead':>9} {'per call':>9}")
    for threads in (1, 2):
        for n in (int(s) for s in args.sizes.split(",")):
            env = rl.make("racing", num_envs=n, num_threads=threads, dtype=args.dtype)
            env.reset(seed=0)
            e = np.arange(n)
            actions = np.stack([np.full(n, 0.6), 0.3 * np.sin(e), 0.2 * np.cos(e)], axis=1)
            calls = max(20, 20000 // n)
            for _ in range(5):
                env.step(actions)
            # Interleaved, so that a drift in the machine's speed hits both alike.
            fulls, raws = [], []
            for _ in range(args.repetitions):
                fulls.append(timed(lambda: env.step(actions), calls, 1))
                raws.append(timed(lambda: env._env.step(actions), calls, 1))
            full, raw = statistics.median(fulls), statistics.median(raws)
            print(f"{n:>6} {threads:>7} {n / full:>14,.0f} {n / raw:>14,.0f} "
                  f"{100 * (full - raw) / full:>8.1f}% {1e6 * (full - raw):>7.1f}us")


if __name__ == "__main__":
    main()
