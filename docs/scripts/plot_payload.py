#!/usr/bin/python3
"""Numbers and figure of docs/validation.md ("Slung payload"): the SE(3) circle with a 0.5 kg
payload (se3_circle_payload.yaml, thesis Table 3.9) and the 3 m transport move flown by the plain
and by the payload-aware SE(3) controller (se3_payload_move.yaml, se3_payload_move_aware.yaml).

    PYTHONPATH=build/release/python /usr/bin/python3 docs/scripts/plot_payload.py docs/img

Prints the circle's RMSE and the swing of both moves, and writes payload_move.png (a few seconds).
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


def fly(name, scratch):
    e = dt.load_experiment(str(ROOT / "config" / "experiments" / (name + ".yaml")))
    s = dt.run_experiment(e, str(Path(scratch) / name))
    assert s.ok, name
    return s, dt.read_log(Path(scratch) / name / "log.csv")


def main(out):
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as scratch:
        s, _ = fly("se3_circle_payload", scratch)
        x, y, z, yaw = s.closed_loop.rmse
        print(f"se3_circle_payload: RMSE x {x:.4f} m, y {y:.4f} m, z {z:.4f} m, yaw {yaw:.4f} rad"
              " (Table 3.9: 0.036, 0.042, 0.053, 0.011)")
        logs = {}
        for name in ("se3_payload_move", "se3_payload_move_aware"):
            s, log = fly(name, scratch)
            logs[name] = log
            t = log["t"]
            swing = np.hypot(log["swing_1"], log["swing_2"])
            late = t >= 5.0
            print(f"{name}: largest swing {swing.max():.3f} rad, after 5 s {swing[late].max():.3f}"
                  f" rad, RMS after 5 s {np.sqrt(np.mean(swing[late] ** 2)):.4f} rad,"
                  f" RMSE x {s.closed_loop.rmse[0]:.3f} m, z {s.closed_loop.rmse[2]:.3f} m")
    fig, (ax_swing, ax_x) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    labels = {"se3_payload_move": "SE(3), se3.yaml",
              "se3_payload_move_aware": "payload-aware SE(3), se3_payload.yaml"}
    for name, log in logs.items():
        ax_swing.plot(log["t"], log["swing_1"], label=labels[name])
        ax_x.plot(log["t"], log["x"], label=labels[name])
    ax_swing.set_ylabel("swing angle γ1 [rad]")
    ax_x.set_ylabel("vehicle x [m]")
    ax_x.set_xlabel("t [s]")
    ax_swing.legend()
    ax_swing.set_title("3 m move with a 0.5 kg payload on a 0.5 m tether")
    for ax in (ax_swing, ax_x):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "payload_move.png", dpi=100)
    print("wrote", out / "payload_move.png")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "docs/img")
