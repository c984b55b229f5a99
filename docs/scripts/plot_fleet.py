#!/usr/bin/python3
"""Numbers and figure of docs/validation.md ("Two vehicles and downwash"): the crossing of two
QDrone2 1.2 m apart vertically (crossing_downwash.yaml) against the same flight without the wake
(crossing_no_downwash.yaml).

    PYTHONPATH=build/release/python /usr/bin/python3 docs/scripts/plot_fleet.py docs/img

Prints what the lower vehicle felt and how far it dipped, and writes crossing_downwash.png.
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
    s = dt.run_fleet_experiment(str(ROOT / "config" / "experiments" / (name + ".yaml")),
                                str(Path(scratch) / name))
    assert s.ok, s.failure_message
    return s, {v.name: dt.read_log(Path(v.folder) / "log.csv") for v in s.vehicles}


def main(out):
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as scratch:
        on, logs_on = fly("crossing_downwash", scratch)
        off, logs_off = fly("crossing_no_downwash", scratch)
    lower, lower_off = logs_on["lower"], logs_off["lower"]
    t = lower["t"]
    dz = lower["z"] - lower_off["z"]
    for v in on.vehicles:
        print(f"{v.name}: largest wake {v.max_downwash_flow_m_s:.3f} m/s, largest thrust loss "
              f"{v.max_thrust_loss_N:.3f} N, RMSE xyz {np.round(v.run.closed_loop.rmse[:3], 4)}")
    k = np.argmin(dz)
    print(f"lower: deepest dip against the flight without wake {-dz[k] * 100:.2f} cm at "
          f"t = {t[k]:.3f} s; largest tilt change "
          f"{np.degrees(np.max(np.abs(lower['qx'] - lower_off['qx'])) * 2):.2f} deg; "
          f"RMSE z {on.vehicles[1].run.closed_loop.rmse[2]:.4f} m with wake, "
          f"{off.vehicles[1].run.closed_loop.rmse[2]:.4f} m without")
    fig, (ax_f, ax_z) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    window = (t > 3.5) & (t < 6.5)
    ax_f.plot(t[window], lower["downwash_force_z"][window], label="thrust change F_z [N]")
    ax_f.plot(t[window], lower["downwash_flow_z"][window], label="wake at the CoM, w_z [m/s]")
    ax_f.plot(t[window], lower["downwash_moment_x"][window] * 10, label="roll moment ×10 [N m]")
    ax_f.set_title("lower QDrone2 passing 1.2 m below the upper one at t = 5 s")
    ax_f.legend()
    ax_z.plot(t[window], lower["z"][window], label="with the wake")
    ax_z.plot(t[window], lower_off["z"][window], label="without")
    ax_z.set_ylabel("lower vehicle z [m]")
    ax_z.set_xlabel("t [s]")
    ax_z.legend()
    fig.tight_layout()
    fig.savefig(out / "crossing_downwash.png", dpi=110)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "docs/img")
