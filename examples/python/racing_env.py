#!/usr/bin/env python3
"""Racing environments from Python (docs/rl.md): many envs of the thesis's racing task at once,
flown by a scripted pilot instead of a trained policy, with the episode statistics and a plot.

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/racing_env.py --out out/racing

The pilot (relative-position actions, Eq. 4.19) heads for a point on the next gate's axis 1 m
ahead of its projection onto it, read from the Eq. 4.18 observation alone (the gate corners),
with per-env start randomisation. Prints env-steps per second, laps and lap times; writes
racing.png (env 0's path through the gates). Exits 1 unless some env completes a lap.
"""

import argparse
import os
import sys
import time

import numpy as np

from dronetwin import rl


def pilot(obs, scale=(1.0, 1.0, 1.5)):
    """Relative-position actions from the gate-corner piece of (N, 45) observations."""
    corners = obs[:, 21:33].reshape(-1, 4, 3)            # next gate's corners - p
    normal = np.cross(corners[:, 0] - corners[:, 1], corners[:, 0] - corners[:, 3])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    centre = corners.mean(axis=1)
    along = -np.einsum("ij,ij->i", centre, normal)       # where the vehicle is along the axis
    aim = centre + np.minimum(along + 1.0, 0.5)[:, None] * normal
    fit = np.min(np.asarray(scale) / np.maximum(np.abs(aim), 1e-9), axis=1)
    return aim * (0.6 * np.minimum(1.0, fit))[:, None]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--num-envs", type=int, default=64)
    parser.add_argument("--duration", type=float, default=40.0, help="simulated seconds")
    parser.add_argument("--out", default="out/racing")
    args = parser.parse_args()

    env = rl.make("racing", num_envs=args.num_envs, num_threads=2, episode_time_s=25.0,
                  racing={"laps": 1},
                  randomization={"position_m": [0.3, 0.3, 0.2], "mass_scale": [0.95, 1.05]})
    obs, _ = env.reset(seed=0)
    path, laps, lap_times, causes = [], [], [], []
    steps = int(args.duration / env.dt)
    t0 = time.perf_counter()
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(pilot(obs))
        path.append(env.states()[0, :3])
        if "episode" in info:
            done = info["_episode"]
            laps += list(info["episode"]["laps"][done])
            best = info["episode"]["best_lap_s"][done]
            lap_times += list(best[np.isfinite(best)])
            causes += env.end_cause_names(info["episode"]["cause"][done])
    wall = time.perf_counter() - t0
    print(f"{args.num_envs} envs x {steps} steps in {wall:.2f} s: "
          f"{args.num_envs * steps / wall:,.0f} env-steps/s (with the pilot in numpy)")
    print(f"episodes ended: {len(causes)}; causes: "
          f"{ {c: causes.count(c) for c in sorted(set(causes))} }")
    if lap_times:
        print(f"laps per ended episode: mean {np.mean(laps):.2f}; best lap {min(lap_times):.2f} s, "
              f"median {np.median(lap_times):.2f} s")
    os.makedirs(args.out, exist_ok=True)
    png = os.path.join(args.out, "racing.png")
    rl.render_path(np.array(path), env.gates, png, title="env 0, scripted pilot")
    print(f"wrote {png}")
    return 0 if lap_times else 1


if __name__ == "__main__":
    sys.exit(main())
