#!/usr/bin/env python3
"""Fly the NMPC (Ceres) on the thesis figure eight and plot its predicted horizons.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/nmpc_horizon.py \
        [--duration S] [--out out/py_nmpc]

Loads config/controllers/nmpc.yaml (Eq. 3.23 model, Eq. 3.24 weights, N = 100 at 10 ms, SE(3)
inner loop at 1 kHz), flies the Eq. 3.25 figure eight with OU noise, and every 2.5 s takes the
controller's current plan (predicted_states(), (N + 1) x 13 over the next second). Draws the
flown path with those predicted horizons, and the solve statistics logged per control step.
"""

import argparse
import os
import sys

import numpy as np

import dronetwin as dt

THESIS_TABLE_3_4 = np.array([0.080, 0.060, 0.0355, 0.012])  # NMPC RMSE x, y, z (m), yaw (rad)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=60.0)
    parser.add_argument("--out", default="out/py_nmpc")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    root = dt.default_data_dir() or os.getcwd()

    model = dt.load_model(os.path.join(root, "models", "qdrone2.yaml"))
    nmpc = dt.load_controller(os.path.join(root, "config", "controllers", "nmpc.yaml"), model, 1000.0)
    reference = dt.FigureEightReference()  # Eq. 3.25
    sim = dt.Simulator(model, dt.SimConfig(noise=True, seed=1))
    start = reference.at(0.0)
    state = dt.Simulator.hover_state(start.position_m)
    state[3:6] = start.velocity_m_s
    sim.reset(state, model.hover_speeds_rad_s())
    loop = dt.ClosedLoop(sim, nmpc, reference, 1000.0)

    chunk_s, logs, plans = 2.5, [], []
    t = 0.0
    while t < args.duration - 1e-9:
        step = min(chunk_s, args.duration - t)
        logs.append(loop.record(step, every_n_steps=10))
        t += step
        plans.append((nmpc.plan_start_time_s, nmpc.predicted_states()))
    if any(log["status"] != dt.StepStatus.OK for log in logs):
        print("flight failed:", logs[-1]["failure_message"], file=sys.stderr)
        return 1
    # Each record() starts with a row at its first instant; drop the duplicates at the seams.
    keys = ("t", "state", "reference", "diagnostics")
    log = {k: np.concatenate([lg[k][(1 if i else 0):] for i, lg in enumerate(logs)]) for k in keys}
    names = logs[0]["diagnostic_names"]
    diag = {n: log["diagnostics"][:, i] for i, n in enumerate(names)}

    rmse = dt.rmse(log)
    print(f"NMPC on the figure eight, {args.duration:g} s, noise on")
    print("RMSE x, y, z (m), yaw (rad): " + ", ".join(f"{v:.4f}" for v in rmse))
    print("thesis Table 3.4:            " + ", ".join(f"{v:.4f}" for v in THESIS_TABLE_3_4))
    solve_ms = diag["solve_time_ms"][np.isfinite(diag["solve_time_ms"])]
    print(f"logged solves: {solve_ms.size}, solve time median {np.median(solve_ms):.2f} ms, "
          f"max {solve_ms.max():.2f} ms (wall clock, this machine)")
    print("diagnostics:", ", ".join(names))

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    ax.plot(log["reference"][:, 0], log["reference"][:, 1], "k--", lw=1, label="reference (Eq. 3.25)")
    ax.plot(log["state"][:, 0], log["state"][:, 1], lw=1.2, label="flown")
    for i, (t0, xs) in enumerate(plans):
        ax.plot(xs[:, 0], xs[:, 1], "r-", lw=2, alpha=0.7, label="predicted horizon (1 s)" if i == 0 else None)
        ax.plot(xs[0, 0], xs[0, 1], "ro", ms=3)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.axis("equal")
    ax.legend(fontsize=8)
    ax.set_title("NMPC plans along the figure eight")
    ax2.plot(log["t"], diag["solve_time_ms"], ".", ms=2)
    ax2.set_xlabel("t (s)")
    ax2.set_ylabel("solve time (ms)")
    ax2.set_title("Ceres solve per control step")
    fig.tight_layout()
    path = os.path.join(args.out, "nmpc_horizon.png")
    fig.savefig(path, dpi=110)
    print("wrote", path)
    # Every solve must succeed (the tracking bounds are asserted by tests/control/nmpc_test.cpp).
    return 0 if nmpc.last_solve().total_failures == 0 and np.all(np.isfinite(rmse)) else 1


if __name__ == "__main__":
    sys.exit(main())
