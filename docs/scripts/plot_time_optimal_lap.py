#!/usr/bin/python3
"""Figure of docs/planning.md ("The time-optimal lap"): the circuit's time-optimal flying lap.

    PYTHONPATH=build/release/python /usr/bin/python3 docs/scripts/plot_time_optimal_lap.py \\
        docs/img/time_optimal_lap.png [EPISODE_LOG]

Solves the time-optimal lap of config/tracks/circuit.yaml for models/qdrone2.yaml with the default
options (warm starts: the minimum-snap plan flown by SE(3) at several speeds), and, given a racing
policy's recorded episode (`dronetwin evaluate ... --record DIR`, then DIR/episode_000/log.csv),
also from that flight. Draws the paths seen from above with the gate openings, the rotor speeds of
the lap against their limits, and speed over the lap; prints the numbers docs/planning.md quotes.
"""
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import yaml

import dronetwin as dt

ROOT = Path(__file__).resolve().parents[2]
TRACK = ROOT / "config" / "tracks" / "circuit.yaml"
MODEL = ROOT / "models" / "qdrone2.yaml"


def saturated(lap, lo, hi):
    """Fraction of rotor-speed samples within 1 % of the speed range of a limit."""
    u = lap["rotor_speeds_rad_s"]
    band = 0.01 * (hi - lo)
    return float(np.mean((u < lo + band) | (u > hi - band)))


def report(name, lap, lo, hi):
    speed = np.linalg.norm(lap["states"][:, 3:6], axis=1)
    print(f"{name}: lap {lap['lap_time_s']:.3f} s from a flown {lap['warm_start_lap_time_s']:.3f} s "
          f"(minimum snap {lap['min_snap_lap_time_s']:.3f} s); violation {lap['max_violation']:.1e}; "
          f"top speed {speed.max():.2f} m/s; rotors {lap['rotor_speeds_rad_s'].min():.0f}.."
          f"{lap['rotor_speeds_rad_s'].max():.0f} rad/s, {100 * saturated(lap, lo, hi):.0f} % of samples "
          f"within 1 % of a limit; {lap['outer_iterations']} solves, {lap['inner_iterations']} "
          f"Levenberg-Marquardt iterations, {lap['solve_time_s']:.1f} s")


def main(argv):
    if len(argv) not in (1, 2):
        print(__doc__)
        return 2
    out = Path(argv[0])
    track = dt.load_track(str(TRACK))
    model = dt.load_model(str(MODEL))
    lo, hi = 0.0, 3400.0  # models/qdrone2.yaml's rotor speed limits
    lap = dt.planning.time_optimal_lap(track, model)
    report("from the minimum-snap plan", lap, lo, hi)
    policy = None
    if len(argv) == 2:
        log = np.genfromtxt(argv[1], delimiter=",", names=True)
        states = np.stack([log[c] for c in ("x", "y", "z", "vx", "vy", "vz", "qw", "qx", "qy", "qz",
                                            "wx", "wy", "wz")], axis=1)
        speeds = np.stack([log[f"omega_{r}"] for r in range(4)], axis=1)
        policy = dt.planning.time_optimal_lap(track, model, flight_times_s=np.array(log["t"]),
                                              flight_states=states, flight_rotor_speeds_rad_s=speeds)
        report("from the policy's episode", policy, lo, hi)

    gates = yaml.safe_load(TRACK.read_text())["gates"]
    fig, (top, rotors, profile) = plt.subplots(
        1, 3, figsize=(16, 5), gridspec_kw={"width_ratios": [1.2, 1, 1]})
    plan = lap["min_snap_trajectory"]
    p = plan.sample(np.linspace(0.0, plan.duration_s, 400))["position_m"]
    top.plot(p[:, 0], p[:, 1], "--", color="0.5", lw=1,
             label=f"minimum snap at the rotor limits, {lap['min_snap_lap_time_s']:.2f} s")
    top.plot(lap["states"][:, 0], lap["states"][:, 1], color="C0", lw=1.8,
             label=f"time-optimal, {lap['lap_time_s']:.2f} s")
    if policy is not None:
        top.plot(policy["states"][:, 0], policy["states"][:, 1], color="C2", lw=1.2,
                 label=f"time-optimal from the policy's lap, {policy['lap_time_s']:.2f} s")
    for gate in gates:
        c = np.array(gate["position"][:2])
        yaw = np.radians(gate["yaw_deg"])
        half = 0.5 * gate["width_m"] * np.array([-np.sin(yaw), np.cos(yaw)])
        ends = np.stack([c - half, c + half])
        top.plot(ends[:, 0], ends[:, 1], color="C3", lw=3)
        top.annotate(gate["name"], c, textcoords="offset points", xytext=(6, 6), fontsize=8)
    top.set_aspect("equal")
    top.set_xlabel("x (m)")
    top.set_ylabel("y (m)")
    top.set_title("Seen from above; gate openings in red")
    top.legend(loc="center", fontsize=7)

    t = lap["times_s"]
    for r in range(4):
        rotors.step(t[:-1], lap["rotor_speeds_rad_s"][:, r], where="post", lw=1, label=f"rotor {r}")
    for limit in (lo, hi):
        rotors.axhline(limit, color="k", ls=":", lw=1)
    rotors.set_xlabel("t (s) from the last gate")
    rotors.set_ylabel("rotor speed (rad/s); dotted: limits")
    rotors.set_title("Rotor speeds of the time-optimal lap")
    rotors.legend(fontsize=7, loc="lower right")

    speed = np.linalg.norm(lap["states"][:, 3:6], axis=1)
    profile.plot(t, speed, color="C0", label="time-optimal")
    s = np.linspace(0.0, plan.duration_s, 400)
    v = plan.sample(s)["velocity_m_s"]
    profile.plot(s, np.linalg.norm(v, axis=1), "--", color="0.5", label="minimum snap")
    for k in lap["gate_nodes"]:
        profile.axvline(t[k], color="C3", lw=0.5)
    profile.set_xlabel("t (s) from the last gate; red: gate passages")
    profile.set_ylabel("speed (m/s)")
    profile.set_title("Speed over the lap")
    profile.legend(fontsize=7)
    fig.suptitle("Time-optimal flying lap of config/tracks/circuit.yaml, QDrone2 full force model")
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
