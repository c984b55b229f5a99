#!/usr/bin/python3
"""Figure of docs/planning.md ("A lap of the circuit"): a minimum-snap lap of the circuit.

    build/release/dronetwin run config/experiments/se3_circuit_min_snap.yaml --out /tmp/circuit_ff
    /usr/bin/python3 docs/scripts/plot_circuit_min_snap.py docs/img/circuit_min_snap.png \\
        /tmp/circuit_ff

Reads the run's log.csv (x, y, z, vx, vy, vz, qw..qz and the reference ref_x, ref_y) and the
circuit's gates (config/tracks/circuit.yaml), and draws the path seen from above with the gate
openings, and speed and tilt over the lap.
"""
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import yaml

TRACK = Path(__file__).resolve().parents[2] / "config" / "tracks" / "circuit.yaml"


def main(argv):
    if len(argv) != 2:
        print(__doc__)
        return 2
    out, run = Path(argv[0]), Path(argv[1])
    log = np.genfromtxt(run / "log.csv", delimiter=",", names=True)
    track = yaml.safe_load(TRACK.read_text())

    fig, (top, profile) = plt.subplots(1, 2, figsize=(12, 5), gridspec_kw={"width_ratios": [1.3, 1]})
    top.plot(log["ref_x"], log["ref_y"], "--", color="0.5", lw=1, label="plan (minimum snap)")
    top.plot(log["x"], log["y"], color="C0", lw=1.5, label="flown (SE(3) + feed-forward)")
    for gate in track["gates"]:
        c = np.array(gate["position"][:2])
        yaw = np.radians(gate["yaw_deg"])
        half = 0.5 * gate["width_m"] * np.array([-np.sin(yaw), np.cos(yaw)])
        ends = np.stack([c - half, c + half])
        top.plot(ends[:, 0], ends[:, 1], color="C3", lw=3)
        top.annotate(gate["name"], c, textcoords="offset points", xytext=(6, 6), fontsize=8)
    start = track["start"]["position"]
    top.plot(start[0], start[1], "ko", ms=4, label="start")
    top.set_aspect("equal")
    top.set_xlabel("x (m)")
    top.set_ylabel("y (m)")
    top.set_title("Seen from above; gate openings in red")
    top.legend(loc="center", fontsize=8)

    speed = np.sqrt(log["vx"] ** 2 + log["vy"] ** 2 + log["vz"] ** 2)
    # Tilt: the angle between body z and world z, cos = 1 - 2 (qx^2 + qy^2).
    tilt = np.degrees(np.arccos(np.clip(1 - 2 * (log["qx"] ** 2 + log["qy"] ** 2), -1, 1)))
    profile.plot(log["t"], speed, color="C0", label="speed (m/s)")
    profile.set_xlabel("t (s)")
    profile.set_ylabel("speed (m/s)")
    twin = profile.twinx()
    twin.plot(log["t"], tilt, color="C1", label="tilt (deg)")
    twin.axhline(np.degrees(0.5), color="C1", ls=":", lw=1)
    twin.set_ylabel("tilt (deg); dotted: the controller's 0.5 rad cone")
    profile.set_title("Speed and tilt over the lap")
    fig.suptitle("config/experiments/se3_circuit_min_snap.yaml: one lap, time_weight 300")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
