"""Thesis-style figures from a dronetwin flight log.

Usage:  /usr/bin/python3 python/dronetwin/plot.py RUN_DIR [--out OUT_DIR]
        (or `dronetwin plot RUN_DIR`, which runs this file; from Python:
        dronetwin.plot.make_figures(dronetwin.read_log(RUN_DIR), OUT_DIR))

Reads RUN_DIR/log.csv (docs/experiment-format.md) and writes PNGs next to it (or to OUT_DIR):
tracking.png (x, y, z, yaw against the reference), errors.png, rotors.png (commanded against
achieved rotor speeds), forces.png (generalized-force commands) and path3d.png. Figures whose
columns are missing from the log (e.g. an open-loop run has no reference) are skipped.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np


def read_log(path: str) -> dict[str, np.ndarray]:
    """Columns of a dronetwin log.csv as float arrays keyed by header name."""
    with open(path, encoding="utf-8") as f:
        header = f.readline().strip().split(",")
        has_rows = any(line.strip() for line in f)
    if header == [""]:
        raise ValueError(f"{path}: empty file (no header)")
    if not has_rows:
        raise ValueError(f"{path}: the log has a header but no rows: nothing to plot "
                         "(did the run stop before its first step?)")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if data.shape[1] != len(header):
        raise ValueError(f"{path}: header has {len(header)} columns, rows have {data.shape[1]}")
    return {name: data[:, i] for i, name in enumerate(header)}


def yaw_from_quaternion(qw, qx, qy, qz):
    """ZYX yaw (rad) of quaternions given as arrays, atan2 form (thesis Eq. 3.16, notes #23)."""
    return np.arctan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def _rotor_count(log: dict[str, np.ndarray]) -> int:
    n = 0
    while f"omega_{n}" in log:
        n += 1
    return n


def _stacked(plt, out_dir, name, title, t, panels):
    """One figure of time series stacked vertically and saved as out_dir/name.

    panels: list of (ylabel, [(values, style, label), ...]); a label of None draws no legend entry.
    """
    fig, axes = plt.subplots(len(panels), 1, sharex=True, figsize=(8, 1.8 * len(panels) + 1.8))
    axes = np.atleast_1d(axes)
    for ax, (ylabel, lines) in zip(axes, panels):
        for values, style, label in lines:
            ax.plot(t, values, style, label=label)
        ax.set_ylabel(ylabel)
        ax.grid(True, alpha=0.3)
    if any(label for _, lines in panels[:1] for _, _, label in lines):
        axes[0].legend(loc="upper right")
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(title.strip())
    fig.tight_layout()
    path = os.path.join(out_dir, name)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def make_figures(log: dict[str, np.ndarray], out_dir: str, title: str = "") -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(out_dir, exist_ok=True)
    t = log["t"]
    yaw = yaw_from_quaternion(log["qw"], log["qx"], log["qy"], log["qz"])
    actual = {"x": log["x"], "y": log["y"], "z": log["z"], "yaw": yaw}
    units = {"x": "m", "y": "m", "z": "m", "yaw": "rad"}
    has_ref = all(f"ref_{k}" in log for k in actual)

    tracking = []
    for key, values in actual.items():
        lines = [(values, "-", "actual")]
        if has_ref:
            lines.append((log[f"ref_{key}"], "--", "reference"))
        tracking.append((f"{key} [{units[key]}]", lines))
    written = [_stacked(plt, out_dir, "tracking.png", f"{title} tracking", t, tracking)]

    if has_ref:
        errors = []
        for key, values in actual.items():
            err = log[f"ref_{key}"] - values
            if key == "yaw":
                err = (err + np.pi) % (2 * np.pi) - np.pi
            errors.append((f"e_{key} [{units[key]}]", [(err, "-", None)]))
        written.append(_stacked(plt, out_dir, "errors.png", f"{title} tracking errors", t, errors))

    rotors = []
    for i in range(_rotor_count(log)):
        lines = [(log[f"omega_ref_{i}"], "--", "commanded")] if f"omega_ref_{i}" in log else []
        lines.append((log[f"omega_{i}"], "-", "achieved"))
        rotors.append((f"w_{i} [rad/s]", lines))
    if rotors:
        written.append(_stacked(plt, out_dir, "rotors.png", f"{title} rotor speeds", t, rotors))

    force_cols = {"u_T": "N", "u_tau_x": "N m", "u_tau_y": "N m", "u_tau_z": "N m"}
    if all(c in log for c in force_cols):
        forces = [(f"{c[2:]} [{unit}]", [(log[c], "-", None)]) for c, unit in force_cols.items()]
        written.append(
            _stacked(plt, out_dir, "forces.png", f"{title} generalized forces", t, forces))

    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    ax.plot(log["x"], log["y"], log["z"], label="actual")
    if has_ref:
        ax.plot(log["ref_x"], log["ref_y"], log["ref_z"], "--", label="reference")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.legend()
    fig.suptitle(f"{title} path".strip())
    path = os.path.join(out_dir, "path3d.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    written.append(path)
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="dronetwin plot", description=__doc__.splitlines()[0])
    parser.add_argument("run_dir", help="directory holding log.csv (written by `dronetwin run`)")
    parser.add_argument("--out", help="where to write the PNGs (default: run_dir)")
    args = parser.parse_args(argv)
    log_path = os.path.join(args.run_dir, "log.csv")
    if not os.path.isfile(log_path):
        print(f"error: {log_path}: no such file (run `dronetwin run ... --out {args.run_dir}`)",
              file=sys.stderr)
        return 2
    try:
        log = read_log(log_path)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for path in make_figures(log, args.out or args.run_dir, os.path.basename(args.run_dir.rstrip("/"))):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
