#!/usr/bin/python3
"""Figures of docs/sensors.md: sensor traces of a closed-loop hover, the Allan deviation of a
simulated static IMU against the curves its configuration predicts, and one depth-camera frame of
the racing circuit.

    build/release/dronetwin run config/experiments/hover_sensors.yaml --out /tmp/hs
    build/release/dronetwin run config/experiments/se3_circle_ekf.yaml --out /tmp/ekf
    PYTHONPATH=build/release/python /usr/bin/python3 docs/scripts/plot_sensors.py /tmp/hs /tmp/ekf docs/img

Reads log.csv from the first two directories and writes sensors_hover.png, sensors_allan.png,
sensors_depth.png and sensors_ekf.png to the third. The Allan deviation flies its own
simulation (a QDrone2 resting on the ground with its rotors stopped, physics at 200 Hz, the
default IMU at 200 Hz, 4 hours simulated); the whole script takes under 10 s.
"""
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import yaml  # noqa: E402

import dronetwin as dt  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]

# The default IMU (include/dronetwin/sensors/imu.hpp, ImuParameters): per triad the white-noise
# density N (u/sqrt(Hz)), bias random walk K (u/sqrt(s)), bias instability B (u) and the
# Gauss-Markov correlation time T (s); u = rad/s for the gyro, m/s^2 for the accelerometer.
GYRO = {"N": 2.44e-4, "K": 2.0e-5, "B": 9.7e-6, "T": 100.0}
ACCEL = {"N": 1.72e-3, "K": 1.0e-4, "B": 3.9e-4, "T": 100.0}


def gm_ratio(x):
    """Allan variance of a first-order Gauss-Markov process over its variance, tau = x T
    (bias_process.hpp)."""
    x = np.asarray(x, dtype=float)
    small = x < 1e-3
    xs = np.where(small, 1.0, x)
    full = (2.0 * xs - 3.0 + 4.0 * np.exp(-xs) - np.exp(-2.0 * xs)) / xs**2
    return np.where(small, x * (2.0 / 3.0 - 0.5 * x), full)


def gm_peak_ratio():
    """The largest Allan deviation of a Gauss-Markov process over sigma (dense scan in log x)."""
    x = np.exp(np.linspace(math.log(0.1), math.log(100.0), 200001))
    return float(np.sqrt(gm_ratio(x).max()))


def predicted(triad, tau):
    """The Allan deviation the configuration predicts, and its three parts."""
    sigma_gm = triad["B"] * math.sqrt(2.0 * math.log(2.0) / math.pi) / gm_peak_ratio()
    white = triad["N"] / np.sqrt(tau)
    walk = triad["K"] * np.sqrt(tau / 3.0)
    markov = sigma_gm * np.sqrt(gm_ratio(tau / triad["T"]))
    return np.sqrt(white**2 + walk**2 + markov**2), white, walk, markov


def hover_traces(src, out):
    log = dt.read_log(str(src))
    t = log["t"]
    fig, axes = plt.subplots(6, 1, figsize=(7.0, 11.0), sharex=True)
    a = axes[0]
    a.plot(t, log["imu_fz"], "-", color="C0", lw=0.4, label="IMU f_z (1 kHz)")
    a.set_ylabel("f_z (m/s²)")
    a.set_ylim(8.0, 13.0)
    a.text(0.01, 0.92, f"takeoff: up to {np.nanmax(log['imu_fz']):.0f} m/s² in the first 0.1 s"
           " (off scale)",
           transform=a.transAxes, fontsize=7, va="top")
    a.legend(fontsize=7, loc="upper right")

    a = axes[1]
    a.plot(t, log["imu_wx"], "-", color="C0", lw=0.4, label="IMU w_x (1 kHz)")
    a.plot(t, log["wx"], "-", color="k", lw=0.8, label="true w_x")
    a.set_ylabel("w_x (rad/s)")
    a.legend(fontsize=7, loc="upper right")

    a = axes[2]
    altitude = np.array([dt.isa_altitude_m(p) for p in log["baro_p"]]) - 400.0
    a.plot(t, altitude, "-", color="C1", lw=0.6,
           label="barometer: isa_altitude_m(p) − 400 m (50 Hz)")
    a.plot(t, log["z"], "-", color="k", lw=0.8, label="true z")
    a.set_ylabel("z (m)")
    a.legend(fontsize=7, loc="lower right")

    a = axes[3]
    ok = ~np.isnan(log["mocap_z"])
    rms = float(np.sqrt(np.mean((log["mocap_z"][ok] - log["z"][ok]) ** 2)))
    a.plot(t, log["gps_z"], "-", color="C2", lw=0.8, label="GPS z (10 Hz, 0.1 s late)")
    a.plot(t, log["mocap_z"], "-", color="C4", lw=0.8,
           label=f"motion capture z (100 Hz, 5 ms late; RMS error {rms * 1000:.1f} mm)")
    a.plot(t, log["z"], "--", color="k", lw=0.8, label="true z")
    a.set_ylabel("z (m)")
    a.legend(fontsize=7, loc="lower right")

    a = axes[4]
    a.plot(t, log["range_d"], ".", color="C3", ms=1.0,
           label="range finder (50 Hz; gaps: below 4 cm, 1 % dropouts)")
    a.plot(t, log["z"], "-", color="k", lw=0.8, label="true z")
    a.set_ylabel("distance (m)")
    a.legend(fontsize=7, loc="lower right")

    a = axes[5]
    a.plot(t, log["flow_x"], "-", color="C5", lw=0.4, label="optical flow x (100 Hz)")
    a.set_ylabel("flow_x (rad/s)")
    a.set_xlabel("time (s)")
    a.legend(fontsize=7, loc="upper right")
    for a in axes:
        a.grid(alpha=0.3)
    axes[0].set_title("hover_sensors.yaml: PID from the ground to 1 m, one sensor of each type",
                      fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "sensors_hover.png", dpi=90)
    plt.close(fig)


def allan(out, hours=4.0, rate_hz=200.0):
    dt_s = 1.0 / rate_hz
    model = dt.load_model(str(ROOT / "models" / "qdrone2.yaml"))
    sim = dt.Simulator(model, dt.SimConfig(dt_s=dt_s))  # resting on the ground, rotors stopped
    sensors = dt.SensorSuite([{"type": "imu", "rate_hz": rate_hz}], dt_s=dt_s, num_rotors=4,
                             seed=1)
    _, values = sensors.run(sim, int(hours * 3600 * rate_hz))["imu"]
    if not sim.contact.in_contact:
        sys.exit("the vehicle left the ground: not a static IMU")
    fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.6))
    for a, column, triad, unit, title in (
            (axes[0], 3, GYRO, "rad/s", "gyro x"),
            (axes[1], 2, ACCEL, "m/s²", "accelerometer z")):
        r = dt.allan_deviation(values[:, column], dt_s)
        keep = r["windows"] >= 10  # fewer windows: an estimate worse than ±25 %
        tau, dev, windows = r["tau_s"][keep], r["deviation"][keep], r["windows"][keep]
        err = dev / np.sqrt(2.0 * (windows - 1))
        tt = np.logspace(math.log10(tau[0]), math.log10(tau[-1]), 200)
        total, white, walk, markov = predicted(triad, tt)
        a.loglog(tt, white, ":", color="C0", lw=1.0, label=f"white: N/√τ, N = {triad['N']:.3g}")
        a.loglog(tt, walk, ":", color="C2", lw=1.0,
                 label=f"bias random walk: K √(τ/3), K = {triad['K']:.3g}")
        a.loglog(tt, markov, ":", color="C3", lw=1.0,
                 label=f"Gauss-Markov, B = {triad['B']:.3g}, T = {triad['T']:.0f} s "
                       f"(peak 0.664 B)")
        a.loglog(tt, total, "-", color="k", lw=1.0, label="predicted: the three added")
        a.errorbar(tau, dev, yerr=err, fmt="o", ms=3, color="C1", elinewidth=0.8,
                   label=f"simulated, {hours:.0f} h at {rate_hz:.0f} Hz")
        a.axhline(0.664 * triad["B"], color="C3", lw=0.6, alpha=0.5)
        a.set_xlabel("averaging time τ (s)")
        a.set_ylabel(f"Allan deviation ({unit})")
        a.set_title(f"static default IMU (BMI088 class): {title}")
        a.grid(alpha=0.3, which="both")
        a.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(out / "sensors_allan.png", dpi=90)
    plt.close(fig)


def depth_frame(out):
    path = ROOT / "config" / "tracks" / "circuit.yaml"
    track = dt.load_track(str(path))
    start = yaml.safe_load(path.read_text())["start"]  # Track in Python has no start pose
    state = np.asarray(dt.Simulator.hover_state(start["position"], math.radians(start["yaw_deg"])),
                       dtype=float)
    cam = dt.DepthCamera(width_px=160, height_px=120, horizontal_fov_deg=90.0, max_range_m=20.0)
    frame = cam.render(state.reshape(1, 13), track)[0]
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    im = ax.imshow(frame, cmap="viridis_r", vmin=0.0, vmax=20.0)
    fig.colorbar(im, ax=ax, label="depth: z in the camera frame (m); 20 m = nothing hit")
    ax.set_title("DepthCamera 160 × 120, 90°: circuit.yaml from its start, facing g1", fontsize=9)
    ax.set_xlabel("u (px)")
    ax.set_ylabel("v (px)")
    fig.tight_layout()
    fig.savefig(out / "sensors_depth.png", dpi=90)
    plt.close(fig)


def estimate_vs_truth(ekf, out):
    log = dt.read_log(str(ekf))
    t = log["t"]
    fig, ax = plt.subplots(3, 1, figsize=(7.5, 7.0), sharex=True)
    ax[0].plot(t, log["x"], "k-", lw=2.5, label="true x")
    ax[0].plot(t, log["est_x"], "C1--", lw=1.0, label="EKF estimate of x")
    ax[0].plot(t, log["ref_x"], "C0:", lw=1.0, label="reference x")
    ax[0].set_ylabel("x (m)")
    ax[0].set_title("se3_circle_ekf.yaml: SE(3) on the circle, flying on the EKF (IMU 1 kHz + "
                    "mocap 100 Hz)", fontsize=9)
    ax[0].legend(fontsize=8, loc="upper right")
    for k, c in enumerate("xyz"):
        ax[1].plot(t, 1000.0 * (log["est_" + c] - log[c]), lw=0.8, label=c)
    ax[1].set_ylabel("estimate - truth (mm)")
    ax[1].legend(fontsize=8, ncol=3)
    q_est = np.stack([log["est_q" + c] for c in "wxyz"], axis=1)
    q_true = np.stack([log["q" + c] for c in "wxyz"], axis=1)
    dot = np.clip(np.abs(np.sum(q_est * q_true, axis=1)), 0.0, 1.0)
    ax[2].plot(t, np.degrees(2.0 * np.arccos(dot)), "C3", lw=0.8)
    ax[2].set_ylabel("attitude error (deg)")
    ax[2].set_xlabel("t (s)")
    for a in ax[1:]:
        a.grid(alpha=0.3)
    ax[0].grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "sensors_ekf.png", dpi=90)
    plt.close(fig)


def main(src, ekf, out):
    src, ekf, out = Path(src), Path(ekf), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    hover_traces(src, out)
    allan(out)
    depth_frame(out)
    estimate_vs_truth(ekf, out)


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2], sys.argv[3])
