#!/usr/bin/python3
"""Figure of docs/sensors.md ("An obstacle course"): the flight of obstacle_course_ekf.yaml seen
from above with the scene's objects, the downward range finder over the crate, and one frame of
the forward depth camera.

    build/release/dronetwin run config/experiments/obstacle_course_ekf.yaml --out /tmp/oc
    PYTHONPATH=build/release/python /usr/bin/python3 docs/scripts/plot_obstacle_course.py /tmp/oc docs/img

Reads log.csv, summary.json and depth.npy of the run folder and writes sensors_course.png.
"""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.patches as patches  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import dronetwin as dt  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
FRAME_AT_S = 4.5  # approaching the pillar


def main(run, out):
    run, out = Path(run), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    summary = json.loads((run / "summary.json").read_text())
    track = dt.load_track(str(ROOT / "config" / "tracks" / "obstacle_course.yaml"))
    radius = dt.load_model(str(ROOT / "models" / "qdrone2.yaml")).collision_shape.radius_m
    log = dt.read_log(str(run))
    depth = np.load(summary["depth_frames"][0]["path"])

    fig = plt.figure(figsize=(9.0, 7.2))
    top = fig.add_subplot(2, 1, 1)
    for o in track.obstacles:
        (cx, cy, _), (hx, hy, _) = o["center"], o["half_size"]
        if o["type"] == "box":
            shape = patches.Rectangle((cx - hx, cy - hy), 2 * hx, 2 * hy)
        else:
            shape = patches.Circle((cx, cy), hx)
        above_path = o["name"] == "ball"  # flown under it
        shape.set(facecolor="none" if above_path else "0.75", edgecolor="0.3",
                  linestyle="--" if above_path else "-")
        top.add_patch(shape)
        label = f"{o['name']} (overhead)" if above_path else o["name"]
        y = cy + hy + 0.15 if not above_path else cy - hy - 0.35
        top.annotate(label, (cx, y), ha="center", fontsize=8)
    # The entry gate (along y at x = 2): its opening between the bars.
    top.plot([2, 2], [-0.85, -0.75], "k-", lw=4)
    top.plot([2, 2], [0.75, 0.85], "k-", lw=4)
    top.annotate("entry gate", (2.0, 0.95), ha="center", fontsize=8)
    top.plot(log["x"], log["y"], "k-", lw=2.0, label="flown (truth)")
    top.plot(log["est_x"], log["est_y"], "C1--", lw=1.0, label="EKF estimate")
    top.plot(log["ref_x"], log["ref_y"], "C0:", lw=1.0, label="reference")
    k = int(np.argmin(np.abs(log["t"] - FRAME_AT_S)))
    top.add_patch(patches.Circle((log["x"][k], log["y"][k]), radius, fill=False, ec="C3"))
    top.annotate(f"collision sphere at t = {FRAME_AT_S} s", (log["x"][k], log["y"][k] - 0.45),
                 ha="center", fontsize=8, color="C3")
    top.set_aspect("equal")
    top.set_xlim(-0.5, 12.8)
    top.set_ylim(-2.2, 2.3)
    top.set_xlabel("x (m)")
    top.set_ylabel("y (m)")
    top.legend(fontsize=8, loc="lower right")
    top.set_title("obstacle_course_ekf.yaml: SE(3) on the EKF through the course, seen from above",
                  fontsize=9)

    rng = fig.add_subplot(2, 2, 3)
    rng.plot(log["x"], log["z"], "k-", lw=2.0, label="height z")
    rng.plot(log["x"], log["range_d"], "C2.", ms=2, label="range finder (down)")
    rng.axvspan(9.5, 10.5, color="0.85", label="crate (0.5 m tall)")
    rng.set_xlabel("x (m)")
    rng.set_ylabel("m")
    rng.set_ylim(0.0, 1.6)
    rng.legend(fontsize=8, loc="lower left")

    cam = fig.add_subplot(2, 2, 4)
    frame = int(log["depth_frame"][k])
    im = cam.imshow(depth[frame], cmap="viridis_r", vmin=0.0, vmax=20.0)
    fig.colorbar(im, ax=cam, label="depth (m)")
    cam.set_title(f"depth camera, frame {frame} (t = {log['depth_t'][k]:.2f} s): the pillar ahead",
                  fontsize=9)
    cam.set_xticks([])
    cam.set_yticks([])
    fig.tight_layout()
    fig.savefig(out / "sensors_course.png", dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
