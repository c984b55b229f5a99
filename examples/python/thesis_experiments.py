#!/usr/bin/env python3
"""Fly the thesis's PID and SE(3) experiments from Python and compare with the thesis tables.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/thesis_experiments.py \
        [--duration S] [--out out/py_thesis]

Runs config/experiments/pid_tuned_pulse.yaml (Eq. 3.14 pulse) and se3_circle.yaml (Eq. 3.28
circle) with the same runner as `dronetwin run`, prints an RMSE table next to thesis Tables 3.1
and 3.8, reads the logs back as numpy arrays and draws the tracking figures.
"""

import argparse
import os
import sys

import numpy as np

import dronetwin as dt
from dronetwin import plot

# Thesis Table 3.1 (PID, simulation) and Table 3.8 (SE(3), simulation): RMSE x, y, z (m), yaw (rad).
THESIS = {"pid_tuned_pulse": (0.1213, 0.0385, 0.0377, 0.1179),
          "se3_circle": (0.1594, 0.14099, 0.0835, 0.0347)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, help="shorten every run to S seconds")
    parser.add_argument("--out", default="out/py_thesis")
    args = parser.parse_args()
    root = dt.default_data_dir() or os.getcwd()

    print(f"{'experiment':<18} {'':>8} {'x':>8} {'y':>8} {'z':>8} {'yaw':>8}")
    for name, thesis in THESIS.items():
        e = dt.load_experiment(os.path.join(root, "config", "experiments", name + ".yaml"))
        if args.duration:
            e.duration_s = min(e.duration_s, args.duration)
        out = os.path.join(args.out, name)
        summary = dt.run_experiment(e, out, overwrite=True)  # GIL released while it flies
        if not summary.ok:
            print(f"{name}: {summary.failure_message}", file=sys.stderr)
            return 1
        rmse = summary.closed_loop.rmse
        print(f"{name:<18} {'ours':>8} " + " ".join(f"{v:8.4f}" for v in rmse))
        print(f"{'':<18} {'thesis':>8} " + " ".join(f"{v:8.4f}" for v in thesis))

        log = dt.read_log(out)  # {column: numpy array}
        worst = np.abs(log["ref_z"] - log["z"]).max()
        print(f"{'':<18} {'':>8} max |z error| {worst:.3f} m over {log['t'][-1]:.1f} s, "
              f"{summary.real_time_factor:,.0f}x real time")
        for path in plot.make_figures(log, out, name):
            print(f"{'':<18} wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
