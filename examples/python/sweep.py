#!/usr/bin/env python3
"""A small parameter sweep: SE(3) position gain x wind speed on the thesis circle, in parallel.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/sweep.py \
        [--duration S] [--threads N] [--out out/py_sweep]

Every case builds its own Simulator and controller (cheap: they share the immutable model) and
flies with ClosedLoop.record, which releases the GIL, so a thread pool runs the cases on all
cores. Results are deterministic: the same table comes out whatever the thread count. Writes
a results table (markdown to stdout, CSV to the out directory).
"""

import argparse
import concurrent.futures
import csv
import os
import sys

import numpy as np

import dronetwin as dt

GAIN_SCALES = (0.5, 1.0, 2.0)
WINDS_M_S = (0.0, 2.0, 4.0)


def fly(model, base, gain_scale, wind, duration):
    gains = base.gains
    gains.position_p = gains.position_p * gain_scale
    gains.position_d = gains.position_d * np.sqrt(gain_scale)  # keep the damping ratio
    controller = dt.Se3Controller(model, gains, base.options)
    reference = dt.CircleReference()  # Eq. 3.28
    sim = dt.Simulator(model, dt.SimConfig(noise=True, seed=7))
    start = reference.at(0.0)
    state = dt.Simulator.hover_state(start.position_m)
    state[3:6] = start.velocity_m_s
    sim.reset(state, model.hover_speeds_rad_s())
    sim.set_wind([wind, 0.0, 0.0])
    log = dt.ClosedLoop(sim, controller, reference, 1000.0).record(duration, every_n_steps=10)
    ok = log["status"] == dt.StepStatus.OK
    return gain_scale, wind, ok, dt.rmse(log, window_s=(2.0, duration))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=21.0)
    parser.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--out", default="out/py_sweep")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    root = dt.default_data_dir() or os.getcwd()
    model = dt.load_model(os.path.join(root, "models", "qdrone2.yaml"))
    base = dt.load_controller(os.path.join(root, "config", "controllers", "se3.yaml"), model, 1000.0)

    cases = [(g, w) for g in GAIN_SCALES for w in WINDS_M_S]
    with concurrent.futures.ThreadPoolExecutor(args.threads) as pool:
        results = list(pool.map(lambda c: fly(model, base, c[0], c[1], args.duration), cases))

    print("| K_p scale | wind (m/s) | ok | RMSE x (m) | RMSE y (m) | RMSE z (m) | RMSE yaw (rad) |")
    print("|---|---|---|---|---|---|---|")
    with open(os.path.join(args.out, "sweep.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["gain_scale", "wind_m_s", "ok", "rmse_x", "rmse_y", "rmse_z", "rmse_yaw"])
        for g, wind, ok, r in results:
            print(f"| {g:g} | {wind:g} | {'yes' if ok else 'NO'} | " + " | ".join(f"{v:.4f}" for v in r) + " |")
            w.writerow([g, wind, int(ok), *(f"{v:.17g}" for v in r)])
    print("wrote", os.path.join(args.out, "sweep.csv"))
    # Stiffer position gains must reject the wind better (a physics expectation, not a tuned number).
    by = {(g, w): r for g, w, _, r in results}
    worse = by[(GAIN_SCALES[0], WINDS_M_S[-1])][:2].max() > by[(GAIN_SCALES[-1], WINDS_M_S[-1])][:2].max()
    return 0 if all(ok for _, _, ok, _ in results) and worse else 1


if __name__ == "__main__":
    sys.exit(main())
