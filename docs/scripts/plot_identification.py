#!/usr/bin/python3
"""Figures of docs/identification.md ("Real data") from the CLI outputs.

    build/release/dronetwin identify stand tests/data/real/crazyflie-system-id/data/bitcraze2021/cf2.1-stock-prop.csv --out /tmp/id
    build/release/dronetwin import crazypad tests/data/real/CrazyPAD/data/motor_data/normal_flight/E8_log00.fixedFrequency.csv \
        --stand tests/data/real/crazyflie-system-id/data/bitcraze2021/cf2.1-stock-prop.csv --out /tmp/id
    build/release/dronetwin identify vertical /tmp/id/E8_log00.csv --model models/crazyflie21.yaml --prior-mass 0.031 --no-drag --out /tmp/id
    /usr/bin/python3 docs/scripts/plot_identification.py /tmp/id docs/img

Reads stand_points.csv, stand_fit.json, vertical_points.csv, vertical_fit.json from the first
directory and writes stand_thrust.png, stand_speed_map.png, flight_vertical.png to the second.
"""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def load_csv(path):
    data = np.genfromtxt(path, delimiter=",", names=True)
    return data


def main(src, out):
    src, out = Path(src), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    pts = load_csv(src / "stand_points.csv")
    fit = json.loads((src / "stand_fit.json").read_text())
    used = pts["used"] == 1
    w = pts["omega_rad_s"][used]
    T = pts["thrust_N"][used]
    k = fit["thrust"]
    K1, K2, K3 = k["K1"]["value"], k["K2"]["value"], k["K3"]["value"]
    ww = np.linspace(w.min(), w.max(), 200)

    fig, (a0, a1) = plt.subplots(2, 1, figsize=(6.4, 5.2), sharex=True,
                                 gridspec_kw={"height_ratios": [3, 1.3]})
    # The sweep goes up to the top PWM and back down; colour the two directions.
    up = np.arange(len(pts))[used] <= np.argmax(pts["pwm"])
    a0.plot(w[up], T[up], ".", ms=2, alpha=0.4, label="stand, PWM sweep up (weight/4 - tare)")
    a0.plot(w[~up], T[~up], ".", ms=2, alpha=0.4, label="stand, PWM sweep down")
    a0.plot(ww, (K1 * ww + K2) * ww + K3, "k-", lw=1.2,
            label=f"Eq. 2.22 fit: {K1:.4g} w² {K2:+.3g} w {K3:+.2g}")
    a0.set_ylabel("thrust per motor T (N)")
    a0.legend(fontsize=8)
    a0.grid(alpha=0.3)
    a0.set_title("Crazyflie 2.1 thrust stand (Bitcraze 2021)")
    res = T - ((K1 * w + K2) * w + K3)
    a1.plot(w[up], res[up], ".", ms=2, alpha=0.4)
    a1.plot(w[~up], res[~up], ".", ms=2, alpha=0.4)
    a1.axhline(0, color="k", lw=0.8)
    a1.set_ylabel("residual (N)")
    a1.set_xlabel("mean rotor speed w (rad/s)")
    a1.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "stand_thrust.png", dpi=90)
    plt.close(fig)

    u = pts["u_V"][used]
    s = fit["speed_map"]
    q = fit["speed_map_quadratic"]
    uu = np.linspace(u.min(), u.max(), 200)
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    for m in range(1, 5):
        ax.plot(u, pts[f"omega_{m}"][used], ".", ms=1.5, alpha=0.25, label=f"motor M{m}")
    ax.plot(uu, s["a"]["value"] * uu + s["b"]["value"], "k-", lw=1.2,
            label=f"w = {s['a']['value']:.1f} u + {s['b']['value']:.0f}  (RMS {s['residual_rms']:.0f} rad/s)")
    ax.plot(uu, q["c2"]["value"] * uu**2 + q["c1"]["value"] * uu + q["c0"]["value"], "r--", lw=1,
            label=f"quadratic in u (RMS {q['residual_rms']:.0f} rad/s)")
    ax.set_xlabel("u = pwm / 65535 · vbat (V)")
    ax.set_ylabel("rotor speed (rad/s)")
    ax.set_title("Speed map w(PWM, Vbat)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, markerscale=4)
    fig.tight_layout()
    fig.savefig(out / "stand_speed_map.png", dpi=90)
    plt.close(fig)

    v = load_csv(src / "vertical_points.csv")
    # Break the lines where samples were skipped (on the ground between the two hops).
    gap = np.concatenate([[False], np.diff(v["t"]) > 0.1])
    for name in ("acc_z", "fit", "prior"):
        v[name][gap] = np.nan
    vf = json.loads((src / "vertical_fit.json").read_text())
    train = v["train"] == 1
    fig, ax = plt.subplots(figsize=(7.0, 4.0))
    ax.plot(v["t"], v["acc_z"], "-", color="0.4", lw=0.8, label="estimator: dvz/dt + g")
    ax.plot(v["t"], v["fit"], "-", color="C0", lw=1.0,
            label=f"fit c R33 ΣT{' − d vz' if 'd' in vf['fit'] else ''} "
                  f"(m = {vf['mass_kg'] * 1000:.1f} g), held-out RMS "
                  f"{vf['rms_test_m_s2']:.2f}")
    ax.plot(v["t"], v["prior"], "--", color="C3", lw=0.8,
            label=f"no fit (m = {vf['prior_mass_kg'] * 1000:.0f} g), held-out RMS "
                  f"{vf['rms_test_prior_m_s2']:.2f}")
    ax.axvspan(vf["t_split_s"], v["t"].max(), color="0.9", label="held out (last 30 %)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("vertical specific force (m/s²)")
    ax.set_title("CrazyPAD E8 flight: vertical force balance")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(out / "flight_vertical.png", dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
