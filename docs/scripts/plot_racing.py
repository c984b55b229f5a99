#!/usr/bin/python3
"""3-D picture of docs/rl.md ("Trained here"): the shipped racing policies flown from C++.

    build/release/dronetwin run config/experiments/racing_policy.yaml --out /tmp/racing
    build/release/dronetwin run config/experiments/racing_ctbr_policy.yaml --out /tmp/racing_ctbr
    PYTHONPATH=build/release/python /usr/bin/python3 docs/scripts/plot_racing.py \
        docs/img/racing_path.png /tmp/racing "relative position" /tmp/racing_ctbr CTBR

Reads each run's log.csv (columns x, y, z, ctrl_laps) and draws the paths, up to the end of the
third lap, through the gates of the racing env's circuit (config/rl/racing.yaml).
"""
import sys
from pathlib import Path

import numpy as np

from dronetwin import rl


def main(argv):
    if len(argv) < 3 or len(argv) % 2 != 1:
        print(__doc__)
        return 2
    out, runs = Path(argv[0]), argv[1:]
    paths, labels = [], []
    for run, label in zip(runs[0::2], runs[1::2]):
        log = np.genfromtxt(Path(run) / "log.csv", delimiter=",", names=True)
        done = np.flatnonzero(log["ctrl_laps"] >= 3)
        end = done[0] + 1 if len(done) else len(log)
        paths.append(np.stack([log["x"][:end], log["y"][:end], log["z"][:end]], axis=1))
        labels.append(label)
    gates = rl.make("racing").gates
    rl.render_path(paths, gates, str(out), title="Shipped racing policies flown by dronetwin run (3 laps)",
                   labels=labels)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
