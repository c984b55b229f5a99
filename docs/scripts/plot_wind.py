#!/usr/bin/python3
"""Figures of docs/wind.md and docs/validation.md.

    PYTHONPATH=build/release/python /usr/bin/python3 docs/scripts/plot_wind.py docs/img

Writes wind_dryden.png: Welch power spectral densities of generated Dryden gusts against the
MIL-F-8785C spectra, and a minute of the gusts (severe turbulence 3 m above the ground, 10 m/s
through the air, 50 Hz, 2^21 samples: the record of tests/noise/dryden_test.cpp).

Writes wind_hover.png and prints the table of docs/validation.md: the experiment
config/experiments/se3_hover_turbulence.yaml flown with no, light, moderate and severe turbulence
(same seed, shear and gust), the wind at the vehicle and the position error (about 1 min).
"""
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import dronetwin as dt  # noqa: E402

HEIGHT, AIRSPEED, DT, N, M = 3.0, 10.0, 0.02, 1 << 21, 4096


def welch(x):
    """One-sided PSD in rad/s of Hann-windowed segments of M samples."""
    w = np.hanning(M + 1)[:-1]
    seg = x[: (len(x) // M) * M].reshape(-1, M) * w
    p = np.mean(np.abs(np.fft.rfft(seg, axis=1)) ** 2, axis=0) * DT / (np.pi * np.sum(w * w))
    omega = 2 * np.pi * np.fft.rfftfreq(M, DT)
    return omega[1:], p[1:]


ROOT = Path(__file__).resolve().parents[2]
EXPERIMENT = ROOT / "config" / "experiments" / "se3_hover_turbulence.yaml"
SEVERITIES = ("none", "light", "moderate", "severe")


def fly(severity, tmp):
    e = dt.load_experiment(str(EXPERIMENT))
    e.wind.turbulence = (dt.TurbulenceSettings() if severity == "none"
                         else dt.TurbulenceSettings.of(severity))
    summary = dt.run_experiment(e, str(Path(tmp) / severity))
    return summary, dt.read_log(Path(tmp) / severity / "log.csv")


def hover_figure(out):
    fig, ax = plt.subplots(2, 1, figsize=(7.5, 7.0), sharex=True)
    print("| turbulence | RMSE x (m) | RMSE y (m) | RMSE z (m) | max |p - p_ref| (m) | status |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for k, severity in enumerate(SEVERITIES):
            summary, log = fly(severity, tmp)
            err = np.stack([log["x"] - log["ref_x"], log["y"] - log["ref_y"],
                            log["z"] - log["ref_z"]], axis=1)
            r = summary.closed_loop.rmse
            print(f"| {severity} | {r[0]:.3f} | {r[1]:.3f} | {r[2]:.3f} | "
                  f"{np.max(np.linalg.norm(err, axis=1)):.3f} | {summary.status.name.lower()} |")
            if severity == "light":  # the experiment as shipped
                for j, axis in enumerate("xyz"):
                    ax[0].plot(log["t"], log[f"wind_{axis}"], f"C{j}", lw=0.7,
                               label=f"wind {axis}")
            ax[1].semilogy(log["t"], np.linalg.norm(err, axis=1), f"C{k}", lw=0.8,
                           label=severity)
    ax[0].set_ylabel("air velocity at the vehicle (m/s)")
    ax[0].set_title("se3_hover_turbulence.yaml: 5 m/s at 20 ft, sheared, gust at 30 s; "
                    "light turbulence (as shipped)", fontsize=9)
    ax[0].legend(fontsize=8, ncol=3)
    ax[0].grid(alpha=0.3)
    ax[1].set_xlabel("t (s)")
    ax[1].set_ylabel("|p - p_ref| (m)")
    ax[1].set_ylim(1e-2, None)
    ax[1].set_title("SE(3) hover error by turbulence severity (same seed, shear and gust)",
                    fontsize=9)
    ax[1].legend(fontsize=8, ncol=4)
    ax[1].grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "wind_hover.png", dpi=90)
    plt.close(fig)


def main(out):
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    hover_figure(out)
    g = dt.dryden_gusts(HEIGHT, AIRSPEED, DT, N, severity="severe", seed=20261204)
    fig, ax = plt.subplots(2, 1, figsize=(7.5, 7.0))
    for k, name in enumerate("uvw"):
        omega, p = welch(g[:, k])
        ax[0].loglog(omega, p, f"C{k}", lw=0.6, alpha=0.7, label=f"{name}: generated (Welch)")
        ax[0].loglog(omega, dt.dryden_psd(HEIGHT, AIRSPEED, omega, severity="severe")[:, k], "k--",
                     lw=1.0, label="Dryden spectrum" if k == 0 else None)
    ax[0].set_xlim(0.08, 157)
    ax[0].set_xlabel("ω (rad/s)")
    ax[0].set_ylabel("PSD (m²/s² per rad/s)")
    ax[0].set_title("Dryden (MIL-F-8785C), severe, 3 m above ground, 10 m/s airspeed, 50 Hz",
                    fontsize=9)
    ax[0].legend(fontsize=8)
    ax[0].grid(alpha=0.3, which="both")
    t = np.arange(3000) * DT
    for k, name in enumerate("uvw"):
        ax[1].plot(t, g[:3000, k], f"C{k}", lw=0.8, label=name)
    ax[1].set_xlabel("t (s)")
    ax[1].set_ylabel("gust (m/s)")
    ax[1].legend(fontsize=8, ncol=3)
    ax[1].grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "wind_dryden.png", dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
