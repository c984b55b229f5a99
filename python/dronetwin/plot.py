"""Thesis-style figures from a dronetwin flight log.

Usage:  /usr/bin/python3 -m dronetwin.plot RUN_DIR [--out OUT_DIR]
        (or `dronetwin plot RUN_DIR`, which calls this module)

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


def make_figures(log: dict[str, np.ndarray], out_dir: str, title: str = "") -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(out_dir, exist_ok=True)
    written = []
    t = log["t"]
    yaw = yaw_from_quaternion(log["qw"], log["qx"], log["qy"], log["qz"])
    actual = {"x": log["x"], "y": log["y"], "z": log["z"], "yaw": yaw}
    units = {"x": "m", "y": "m", "z": "m", "yaw": "rad"}
    has_ref = all(f"ref_{k}" in log for k in actual)

    fig, axes = plt.subplots(4, 1, sharex=True, figsize=(8, 9))
    for ax, key in zip(axes, actual):
        ax.plot(t, actual[key], label="actual")
        if has_ref:
            ax.plot(t, log[f"ref_{key}"], "--", label="reference")
        ax.set_ylabel(f"{key} [{units[key]}]")
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper right")
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(f"{title} tracking".strip())
    fig.tight_layout()
    path = os.path.join(out_dir, "tracking.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    written.append(path)

    if has_ref:
        fig, axes = plt.subplots(4, 1, sharex=True, figsize=(8, 9))
        for ax, key in zip(axes, actual):
            err = log[f"ref_{key}"] - actual[key]
            if key == "yaw":
                err = (err + np.pi) % (2 * np.pi) - np.pi
            ax.plot(t, err)
            ax.set_ylabel(f"e_{key} [{units[key]}]")
            ax.grid(True, alpha=0.3)
        axes[-1].set_xlabel("t [s]")
        fig.suptitle(f"{title} tracking errors".strip())
        fig.tight_layout()
        path = os.path.join(out_dir, "errors.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)

    n = _rotor_count(log)
    if n:
        fig, axes = plt.subplots(n, 1, sharex=True, figsize=(8, 1.8 * n + 1))
        axes = np.atleast_1d(axes)
        for i, ax in enumerate(axes):
            if f"omega_ref_{i}" in log:
                ax.plot(t, log[f"omega_ref_{i}"], "--", label="commanded")
            ax.plot(t, log[f"omega_{i}"], label="achieved")
            ax.set_ylabel(f"w_{i} [rad/s]")
            ax.grid(True, alpha=0.3)
        axes[0].legend(loc="upper right")
        axes[-1].set_xlabel("t [s]")
        fig.suptitle(f"{title} rotor speeds".strip())
        fig.tight_layout()
        path = os.path.join(out_dir, "rotors.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)

    force_cols = ["u_T", "u_tau_x", "u_tau_y", "u_tau_z"]
    if all(c in log for c in force_cols):
        fig, axes = plt.subplots(4, 1, sharex=True, figsize=(8, 9))
        for ax, c, unit in zip(axes, force_cols, ["N", "N m", "N m", "N m"]):
            ax.plot(t, log[c])
            ax.set_ylabel(f"{c[2:]} [{unit}]")
            ax.grid(True, alpha=0.3)
        axes[-1].set_xlabel("t [s]")
        fig.suptitle(f"{title} generalized forces".strip())
        fig.tight_layout()
        path = os.path.join(out_dir, "forces.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)

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
