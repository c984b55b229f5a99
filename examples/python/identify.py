#!/usr/bin/env python3
"""Identify a vehicle's parameters from its flight: fly a QDrone2 whose parameters are off by
+-20 %, then fit them back from the unchanged model file with dronetwin.fit_model.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/identify.py \
        [--duration S] [--noise] [--out out/py_identify]

The flight is config/experiments/identification_flight.yaml (random min-jerk waypoints under the
SE(3) controller, 1 kHz log); with --noise the thesis OU measurement noise is on and the fit uses
the measured state. Prints the table of true, starting and fitted values with standard errors,
the residuals on the held-out end of the flight, the fit's warnings, and draws the errors.
"""

import argparse
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import dronetwin as dt  # noqa: E402

CHANGES = {"inertia_xx": 1.2, "inertia_yy": 1.2, "inertia_zz": 0.8, "thrust_k1": 0.8,
           "thrust_k2": 1.2, "thrust_k3": 0.8, "rotor_drag": 1.2, "yaw_moment_per_thrust": 0.8,
           "body_drag_x": 1.2, "body_drag_y": 0.8, "body_drag_z": 1.2, "tau_rise": 0.8,
           "tau_fall": 1.2}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=60.0, help="flight length, s")
    parser.add_argument("--noise", action="store_true", help="OU measurement noise on")
    parser.add_argument("--out", default="out/py_identify")
    args = parser.parse_args()
    root = dt.default_data_dir() or os.getcwd()
    os.makedirs(args.out, exist_ok=True)

    nominal = dt.load_model(os.path.join(root, "models", "qdrone2.yaml"))
    truth = dt.load_spec(os.path.join(root, "models", "qdrone2.yaml"))
    for name, factor in CHANGES.items():
        dt.set_parameter_value(truth, name, factor * dt.parameter_value(truth, name))
    flight_file = "identification_flight_noise.yaml" if args.noise else "identification_flight.yaml"
    e = dt.load_experiment(os.path.join(root, "config", "experiments", flight_file))
    e.duration_s = min(e.duration_s, args.duration)
    summary = dt.run_experiment(e, args.out, dt.VehicleModel(truth), overwrite=True)
    if not summary.ok:
        print(summary.failure_message, file=sys.stderr)
        return 1

    flight = dt.read_flight(os.path.join(args.out, "log.csv"), nominal.num_rotors)
    r = dt.fit_model(nominal, flight, list(CHANGES))
    print(f"{len(flight)} rows ({'measured' if flight.used_measured else 'true'} state), "
          f"{r.iterations} Ceres iterations, {r.solve_time_s:.2f} s")
    print(f"{'parameter':<22} {'true':>12} {'start':>12} {'fitted':>12} {'error':>8} {'std err':>10}")
    errors = {}
    for p in r.parameters:
        true = dt.parameter_value(truth, p.name)
        errors[p.name] = 100.0 * (p.estimate / true - 1.0)
        print(f"{p.name:<22} {true:12.5g} {p.initial:12.5g} {p.estimate:12.5g} "
              f"{errors[p.name]:7.3f}% {p.std_error:10.3g}")
    for key, unit in (("linear_acceleration_m_s2", "m/s^2"), ("angular_acceleration_rad_s2", "rad/s^2")):
        print(f"held-out {key}: {r.holdout_before[key]:.4g} -> {r.holdout_after[key]:.4g} {unit}")
    for w in r.warnings:
        print("warning:", w)

    fig, ax = plt.subplots(figsize=(8, 4))
    ax.bar(list(errors), list(errors.values()))
    ax.set_ylabel("fitted / true - 1 (%)")
    ax.set_title("Recovered parameters (started 20 % off)")
    ax.tick_params(axis="x", rotation=70)
    fig.tight_layout()
    path = os.path.join(args.out, "fit_errors.png")
    fig.savefig(path)
    print("wrote", path)
    worst = max(abs(v) for k, v in errors.items() if k != "thrust_k3")
    return 0 if worst < (5.0 if args.noise else 1.0) else 1


if __name__ == "__main__":
    sys.exit(main())
