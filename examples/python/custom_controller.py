#!/usr/bin/env python3
"""Write a controller in Python and fly it on the C++ simulator.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/custom_controller.py \
        [--duration S] [--out out/py_controller]

The controller below is a compact geometric (SE(3)) tracking law with gravity compensation,
written in numpy. Subclassing dronetwin.ControllerBase and implementing calculate_u(inp) is all it
takes: the ClosedLoop calls it at the control rate on the measured (noisy) state, allocates its
generalized force to rotor speeds and flies the result. It tracks the thesis's figure eight
(Eq. 3.25) at 100 Hz with OU noise on.
"""

import argparse
import os
import sys

import numpy as np

import dronetwin as dt

G = 9.81


def rotation(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


class NumpyGeometric(dt.ControllerBase):
    def __init__(self, model, kp=(6.0, 6.0, 8.0), kd=(4.0, 4.0, 5.0), kr=6.0, kw=1.2):
        super().__init__(model)  # required: binds the C++ half
        self.kp, self.kd = np.array(kp), np.array(kd)
        self.kr, self.kw = kr, kw
        self.J = model.inertia_kgm2

    def name(self):
        return "numpy_geometric"

    def calculate_u(self, inp):
        x, ref = inp.state, inp.reference
        R = rotation(x[6:10])
        m = self.model.mass_kg
        F = m * (self.kp * (ref.position_m - x[0:3]) + self.kd * (ref.velocity_m_s - x[3:6])
                 + ref.acceleration_m_s2 + [0.0, 0.0, G])
        b3 = F / np.linalg.norm(F)
        b2 = np.cross(b3, [np.cos(ref.yaw_rad), np.sin(ref.yaw_rad), 0.0])
        b2 /= np.linalg.norm(b2)
        Rd = np.column_stack([np.cross(b2, b3), b2, b3])
        E = 0.5 * (Rd.T @ R - R.T @ Rd)
        w = x[10:13]
        M = -self.kr * np.array([E[2, 1], E[0, 2], E[1, 0]]) - self.kw * w + np.cross(w, self.J @ w)
        return np.array([F @ R[:, 2], *M])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=60.0)
    parser.add_argument("--out", default="out/py_controller")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)

    root = dt.default_data_dir() or os.getcwd()
    model = dt.load_model(os.path.join(root, "models", "qdrone2.yaml"))
    reference = dt.FigureEightReference()  # Eq. 3.25, z = 1.2 m, 60 s period
    sim = dt.Simulator(model, dt.SimConfig(noise=True, seed=1))
    start = reference.at(0.0)
    state = dt.Simulator.hover_state(start.position_m)
    state[3:6] = start.velocity_m_s
    sim.reset(state, model.hover_speeds_rad_s())

    controller = NumpyGeometric(model)
    loop = dt.ClosedLoop(sim, controller, reference, control_rate_hz=100.0)
    log = loop.record(args.duration, every_n_steps=10)
    if log["status"] != dt.StepStatus.OK:
        print("flight failed:", log["failure_message"], file=sys.stderr)
        return 1
    rmse = dt.rmse(log)
    print(f"{controller.name()} on the figure eight, {args.duration:g} s at 100 Hz, noise on")
    print("RMSE x, y, z (m), yaw (rad): " + ", ".join(f"{v:.4f}" for v in rmse))
    print(f"controller calls: {loop.control_updates}, saturated: {loop.saturated_updates}")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(log["reference"][:, 0], log["reference"][:, 1], "k--", label="reference (Eq. 3.25)")
    ax.plot(log["state"][:, 0], log["state"][:, 1], label="flown")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.axis("equal")
    ax.legend()
    ax.set_title("Python controller on the C++ twin")
    path = os.path.join(args.out, "figure_eight.png")
    fig.savefig(path, dpi=110)
    print("wrote", path)
    # The figure eight needs < 0.2 m/s^2: a well-damped 1 s position loop stays within centimetres.
    return 0 if rmse[:3].max() < 0.05 else 1


if __name__ == "__main__":
    sys.exit(main())
