#!/usr/bin/env python3
"""Wall-clock time of a training run from scratch, and how good its policy is.

    PYTHONPATH=build/release/python /usr/bin/python3 bench/train_bench.py \\
        config/training/hover_ctbr.yaml --out runs/bench_hover [--episodes 100]

Trains the configuration into --out (a new folder) exactly as ``dronetwin train`` does, then
evaluates the exported policy.dtpolicy with the C++ evaluator (no torch in the loop) over
--episodes randomised episodes with the evaluation seed of the configuration, and prints one JSON
object: wall-clock time, environment steps, samples per second, the thread count, and the
evaluation (success fraction, crashes, return; for hover the largest distance to the setpoint in
the last 2 s; for racing lap times). The same object is written to --out/bench.json. Run it on an
otherwise idle machine: the figures in docs/rl.md come from here.
"""

import argparse
import json
import os
import platform
import sys
import time

import numpy as np


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config")
    parser.add_argument("--out", required=True)
    parser.add_argument("--episodes", type=int, default=100)
    args = parser.parse_args(argv)

    from dronetwin import policy, ppo, train, training

    t0 = time.perf_counter()
    summary = ppo.train(args.config, args.out, progress=False)
    wall_s = time.perf_counter() - t0
    c = training.load_config(args.config)
    p = policy.load(os.path.join(args.out, "policy.dtpolicy"))
    train.check_layout(p, c)
    ev = training.evaluate(p.evaluate, c, episodes=args.episodes, seed=c["evaluation"]["seed"],
                          overrides=c["evaluation"]["overrides"])
    report = {
        "config": args.config,
        "machine": f"{platform.machine()}, {os.cpu_count()} logical CPUs",
        "num_threads": c["num_threads"],
        "num_envs": c["num_envs"],
        "wall_clock_s": round(wall_s, 1),
        "training_s": round(summary["wall_clock_s"], 1),
        "env_steps": summary["env_steps"],
        "samples_per_s": round(summary["samples_per_s"]),
        "evaluation": {k: v for k, v in ev.items() if not isinstance(v, list)},
    }
    h = np.asarray(ev.get("hold_max_m", []), dtype=float)
    if np.isfinite(h).any():  # tasks with a target (hover, trajectory)
        report["evaluation"]["hold_max_m_percentiles_50_90_100"] = [
            round(float(np.nanpercentile(h, q)), 4) for q in (50, 90, 100)]
    laps = np.asarray(ev.get("best_lap_s", []), dtype=float)
    if laps.size and np.isfinite(laps).any():
        report["evaluation"]["best_lap_s_min_median"] = [round(float(np.nanmin(laps)), 3),
                                                         round(float(np.nanmedian(laps)), 3)]
    text = json.dumps(report, indent=2)
    policy.atomic_write_bytes(os.path.join(args.out, "bench.json"), (text + "\n").encode())
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
