#!/usr/bin/python3
"""Numbers and figure of docs/validation.md ("Hover until the pack is empty"):
config/experiments/hover_battery_empty.yaml, the PID holding the QDrone2 1.5 m up on a full
6S 2200 mAh pack until it cuts off.

    PYTHONPATH=build/release/python /usr/bin/python3 docs/scripts/plot_battery.py docs/img

Prints the flight time against its bounds from energy over power (independent of the simulator's
battery code: the integral of the open-circuit voltage table and the hover's shaft power by hand)
and writes battery_hover.png (about 10 s).
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


def chemical_energy_J(pack):
    """3600 Q n_s times the integral of the cell voltage over SoC 0 .. initial (trapezoids are
    exact on the piecewise-linear table)."""
    soc = np.linspace(0.0, 1.0, 11)
    grid = np.linspace(0.0, pack.initial_soc, 100001)
    cell = np.interp(grid, soc, np.asarray(pack.ocv_cell_V))
    return 3600.0 * pack.capacity_Ah * pack.cells_in_series * np.trapz(cell, grid)


def hover_shaft_power_W(model):
    p = 0.0
    for i, w in enumerate(model.hover_speeds_rad_s()):
        r = model.rotor(i)
        k = r.thrust_coefficients
        p += (k[0] * w * w + k[1] * w + k[2]) * r.yaw_moment_per_thrust_m * w
    return p


def main(out):
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    e = dt.load_experiment(str(ROOT / "config" / "experiments" / "hover_battery_empty.yaml"))
    pack = e.battery.pack
    model = dt.load_model(str(ROOT / "models" / "qdrone2.yaml"))
    with tempfile.TemporaryDirectory() as tmp:
        s = dt.run_experiment(e, str(Path(tmp) / "run"))
        log = dt.read_log(Path(tmp) / "run" / "log.csv")
    t = log["t"]
    on = log["battery_voltage"] > 0.0
    t_cut = t[on][-1]
    chem = chemical_energy_J(pack)
    p_el = hover_shaft_power_W(model) / pack.efficiency
    i_max = log["battery_current"][on].max()
    loss_max = (pack.series_resistance_ohm + pack.rc_resistance_ohm) * i_max**2
    print(f"outcome: {'crashed' if s.crashed else s.status.name.lower()}")
    print(f"chemical energy of a full pack: {chem / 1e3:.1f} kJ ({chem / 3600:.1f} Wh)")
    print(f"hover: shaft {hover_shaft_power_W(model):.1f} W, electrical {p_el:.1f} W, "
          f"current {log['battery_current'][1]:.2f} A at start, {i_max:.2f} A at most")
    print(f"cut off at t = {t_cut:.1f} s (last logged row with voltage; log every "
          f"{e.log.every_n_steps * e.physics_dt_s:.2f} s)")
    print(f"bounds: {chem / (p_el + loss_max):.1f} s <= t <= {chem / p_el:.1f} s")
    print(f"voltage {log['battery_voltage'][1]:.2f} V at start, "
          f"{log['battery_voltage'][on][-1]:.2f} V before the cut-off; "
          f"height RMSE before the cut-off {np.sqrt(np.mean((log['z'][on] - 1.5) ** 2)):.4f} m")
    fig, ax = plt.subplots(3, 1, figsize=(7.5, 7.5), sharex=True)
    ax[0].plot(t, log["battery_soc"], "C0")
    ax[0].set_ylabel("state of charge")
    ax[1].plot(t, log["battery_voltage"], "C1", label="terminal voltage (V)")
    ax[1].plot(t, log["battery_current"], "C2", label="current (A)")
    ax[1].legend(fontsize=8)
    ax[2].plot(t, log["z"], "C3")
    ax[2].set_ylabel("height (m)")
    ax[2].set_xlabel("t (s)")
    ax[0].set_title("QDrone2 hover on a 6S 2200 mAh pack (PID, 1.5 m) until the cut-off",
                    fontsize=9)
    for a in ax:
        a.axvline(t_cut, color="k", lw=0.6, ls="--")
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "battery_hover.png", dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
