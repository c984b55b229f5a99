#!/usr/bin/python3
"""Table and figure of docs/validation.md ("A rotor at half thrust"): the four experiments
config/experiments/fault_rotor50_{pid,se3,nmpc,policy}.yaml, rotor 0 of the QDrone2 at 50 %
thrust from 10 s while each shipped controller holds a hover 1.5 m up.

    PYTHONPATH=build/release/python /usr/bin/python3 docs/scripts/plot_faults.py docs/img

Prints the markdown table and writes faults_rotor50.png (about 1 min, the NMPC most of it).
"""
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import dronetwin as dt  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
CONTROLLERS = (("pid", "PID (pid_tuned)"), ("se3", "SE(3)"), ("nmpc", "NMPC"),
               ("policy", "PPO hover policy"))


def yaw_of(log):
    return dt.yaw_from_quaternions(np.stack([log["qw"], log["qx"], log["qy"], log["qz"]], axis=1))


def main(out):
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(3, 1, figsize=(7.5, 8.5), sharex=True)
    print("| controller | RMSE x (m) | RMSE y (m) | RMSE z (m) | RMSE yaw (rad) | "
          "max \\|p − p_ref\\| after 10 s (m) | \\|p − p_ref\\| at 30 s (m) | yaw at 30 s (rad) | "
          "outcome |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for k, (name, label) in enumerate(CONTROLLERS):
            e = dt.load_experiment(str(ROOT / "config" / "experiments" / f"fault_rotor50_{name}.yaml"))
            s = dt.run_experiment(e, str(Path(tmp) / name))
            log = dt.read_log(Path(tmp) / name / "log.csv")
            err = np.linalg.norm(np.stack([log["x"] - log["ref_x"], log["y"] - log["ref_y"],
                                           log["z"] - log["ref_z"]], axis=1), axis=1)
            yaw = yaw_of(log)
            after = log["t"] >= 10.0
            r = s.closed_loop.rmse
            outcome = ("crashed" if s.crashed else s.status.name.lower())
            print(f"| {label} | {r[0]:.3f} | {r[1]:.3f} | {r[2]:.3f} | {r[3]:.3f} | "
                  f"{err[after].max():.3f} | {err[-1]:.3f} | {yaw[-1]:.3f} | {outcome} |")
            ax[0].semilogy(log["t"], np.maximum(err, 1e-4), f"C{k}", lw=0.9, label=label)
            ax[1].plot(log["t"], yaw, f"C{k}", lw=0.9, label=label)
            ax[2].plot(log["t"], log["omega_0"], f"C{k}", lw=0.9, label=label)
    for a in ax:
        a.axvline(10.0, color="k", lw=0.6, ls="--")
        a.grid(alpha=0.3)
    ax[0].set_ylabel("|p − p_ref| (m)")
    ax[0].set_title("Rotor 0 at 50 % thrust from 10 s (dashed), hover 1.5 m, noise off", fontsize=9)
    ax[0].legend(fontsize=8, ncol=2)
    ax[1].set_ylabel("yaw (rad)")
    ax[2].set_ylabel("rotor 0 speed (rad/s)")
    ax[2].set_xlabel("t (s)")
    fig.tight_layout()
    fig.savefig(out / "faults_rotor50.png", dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
