#!/usr/bin/env python3
"""Python call overhead of the dronetwin bindings.

    PYTHONPATH=build/release/python /usr/bin/python3 bench/python_bench.py [--repetitions 7]

Measures, per physics step (QDrone2, RK4, all force terms, motor lag, noise off):
  - sim.step() called once per step from a Python loop,
  - sim.step(1000) (one call, the loop in C++, GIL released),
  - a ClosedLoop with the C++ PID, and with a Python controller, at 1 kHz via record(),
and prints the median (and min/max) over repetitions. Compare with the C++ benchmark
bench/step_bench.cpp for the pure engine cost; the difference is the binding overhead.
"""

import argparse
import os
import statistics
import time

import dronetwin as dt


def timed(fn, steps, repetitions):
    per_step = []
    for _ in range(repetitions):
        t0 = time.perf_counter()
        fn()
        per_step.append((time.perf_counter() - t0) / steps * 1e9)
    return statistics.median(per_step), min(per_step), max(per_step)


def fresh(model):
    sim = dt.Simulator(model)
    sim.reset(dt.Simulator.hover_state([0.0, 0.0, 1.0]), model.hover_speeds_rad_s())
    sim.set_rotor_speed_reference(model.hover_speeds_rad_s())
    return sim


class PyHover(dt.ControllerBase):
    def calculate_u(self, inp):
        e = inp.reference.position_m - inp.state[:3]
        return [self.model.mass_kg * 9.81 + 4.0 * e[2] - 3.0 * inp.state[5], 0.0, 0.0, 0.0]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repetitions", type=int, default=7)
    parser.add_argument("--steps", type=int, default=100_000)
    args = parser.parse_args()
    root = dt.default_data_dir() or os.getcwd()
    model = dt.load_model(os.path.join(root, "models", "qdrone2.yaml"))
    n = args.steps

    sim = fresh(model)

    def python_loop():
        step = sim.step
        for _ in range(n):
            step()

    def batched():
        for _ in range(n // 1000):
            sim.step(1000)

    pid = dt.load_controller(os.path.join(root, "config", "controllers", "pid_tuned.yaml"), model, 1000.0)
    ref = dt.SetpointReference([0.0, 0.0, 1.0])

    def closed_loop(controller):
        def run():
            s = fresh(model)
            dt.ClosedLoop(s, controller, ref, 1000.0).record(n * 1e-3, every_n_steps=1000)
        return run

    rows = [("sim.step() from a Python loop", timed(python_loop, n, args.repetitions)),
            ("sim.step(1000)", timed(batched, n, args.repetitions)),
            ("ClosedLoop C++ PID @1 kHz (record)", timed(closed_loop(pid), n, args.repetitions)),
            ("ClosedLoop Python controller @1 kHz", timed(closed_loop(PyHover(model)), n, args.repetitions))]
    print(f"dronetwin {dt.__version__}, {n} steps x {args.repetitions} repetitions, ns per physics step")
    print(f"{'case':<40} {'median':>9} {'min':>9} {'max':>9}")
    for name, (med, lo, hi) in rows:
        print(f"{name:<40} {med:9.0f} {lo:9.0f} {hi:9.0f}")


if __name__ == "__main__":
    main()
