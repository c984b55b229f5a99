"""Parameter sweeps on Dask distributed: every point of a grid or a random sample over experiment
fields and model parameters is one run, scheduled on a Dask cluster.

    dronetwin sweep config/sweeps/freefall_mass.yaml --out out/sweep            # LocalCluster
    dronetwin sweep SWEEP.yaml --out out/sweep --scheduler tcp://10.0.0.5:8786   # a real cluster

    from dronetwin import sweep
    result = sweep.run_sweep(sweep.load_sweep("config/sweeps/freefall_mass.yaml"), "out/sweep")

A point's experiment is the sweep's experiment file with the point's fields replaced in its YAML
(so the experiment parser checks every value as it checks a file) and its model the experiment's
model with the point's `model.<parameter>` values written in (dronetwin.parameter_names()). Each
point runs exactly as `dronetwin run` does into OUT/points/<index>/; a point that fails (a value
the parser refuses, a diverged run, a worker that died) is reported in the results with its
message and the others go on. OUT/results.csv has one row per point in point order, whatever
order the workers finished in; OUT/results.md the table and one figure per axis. Format and
multi-machine use: docs/sweeps.md.
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import os
import sys
import tempfile
from dataclasses import dataclass
from dataclasses import field as dataclass_field

import numpy as np
import yaml

MAX_POINTS = 100000  # a larger sweep is split into several files, not held in memory at once
SWEEP_KEYS = {"name", "description", "experiment", "sampling", "samples", "seed", "axes"}
AXIS_KEYS = {"field", "values", "range", "count"}
# Columns of results.csv after the axes, from the RunSummary.
METRICS = ["status", "error", "steps", "simulated_s", "final_x", "final_y", "final_z",
           "max_speed_m_s", "max_tilt_rad", "rmse_x", "rmse_y", "rmse_z", "rmse_yaw",
           "wall_clock_s"]


class SweepError(ValueError):
    """A malformed sweep file: the message names the file and the field."""


@dataclass
class Axis:
    field: str
    values: list = dataclass_field(default_factory=list)  # grid values, or the random choices
    low: float | None = None  # random: uniform on [low, high]
    high: float | None = None

    @property
    def is_model(self):
        return self.field.startswith("model.")


@dataclass
class Sweep:
    name: str
    source: str
    experiment_path: str
    sampling: str
    axes: list
    samples: int = 0
    seed: int = 0
    description: str = ""

    def points(self):
        """The points in order: a list of {field: value} dicts."""
        if self.sampling == "grid":
            grids = np.meshgrid(*[np.arange(len(a.values)) for a in self.axes], indexing="ij")
            picks = np.stack([g.ravel() for g in grids], axis=1)
            return [{a.field: a.values[int(i)] for a, i in zip(self.axes, row)} for row in picks]
        rng = np.random.Generator(np.random.PCG64(self.seed))
        points = []
        for _ in range(self.samples):
            point = {}
            for a in self.axes:
                if a.values:
                    point[a.field] = a.values[int(rng.integers(len(a.values)))]
                else:
                    point[a.field] = float(rng.uniform(a.low, a.high))
            points.append(point)
        return points


def _fail(source, where, message):
    raise SweepError(f"{source}: {where}: {message}")


def _number(source, where, value):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        _fail(source, where, f"expected a finite number, got {value!r}")
    return float(value)


def parse_sweep(text, source):
    """A Sweep from YAML text; `source` names it in errors and anchors relative paths."""
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as e:
        raise SweepError(f"{source}: not valid YAML: {e}") from None
    if not isinstance(doc, dict):
        raise SweepError(f"{source}: expected a mapping of sweep fields, got {type(doc).__name__}")
    for key in doc:
        if key not in SWEEP_KEYS:
            _fail(source, key, f"unknown field (expected one of {', '.join(sorted(SWEEP_KEYS))})")
    for key in ("name", "experiment", "axes"):
        if key not in doc:
            _fail(source, key, "missing")
    if not isinstance(doc["name"], str) or not doc["name"]:
        _fail(source, "name", f"expected a non-empty string, got {doc['name']!r}")
    if not isinstance(doc["experiment"], str):
        _fail(source, "experiment", f"expected a file path, got {doc['experiment']!r}")
    experiment = os.path.join(os.path.dirname(os.path.abspath(source)), doc["experiment"])
    if not os.path.isfile(experiment):
        _fail(source, "experiment", f"no such file: {experiment}")
    sampling = doc.get("sampling", "grid")
    if sampling not in ("grid", "random"):
        _fail(source, "sampling", f"expected 'grid' or 'random', got {sampling!r}")
    samples = doc.get("samples", 0)
    seed = doc.get("seed", 0)
    if sampling == "random":
        if (isinstance(samples, bool) or not isinstance(samples, int) or samples < 1
                or samples > MAX_POINTS):
            _fail(source, "samples",
                  f"expected an integer in [1, {MAX_POINTS}] for random sampling, got {samples!r}")
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            _fail(source, "seed", f"expected an integer >= 0, got {seed!r}")
    else:
        for key in ("samples", "seed"):
            if key in doc:
                _fail(source, key, "only for sampling: random")
    axes_doc = doc["axes"]
    if not isinstance(axes_doc, list) or not axes_doc:
        _fail(source, "axes", "expected a non-empty list of {field, values | range}")
    axes = []
    for i, a in enumerate(axes_doc):
        where = f"axes[{i}]"
        if not isinstance(a, dict):
            _fail(source, where, f"expected a mapping, got {a!r}")
        for key in a:
            if key not in AXIS_KEYS:
                _fail(source, f"{where}.{key}",
                      f"unknown field (expected one of {', '.join(sorted(AXIS_KEYS))})")
        name = a.get("field")
        if not isinstance(name, str) or not name or name.startswith(".") or name.endswith("."):
            _fail(source, f"{where}.field", f"expected a dotted field name, got {name!r}")
        if name.startswith("model."):
            from . import parameter_names
            if name[len("model."):] not in parameter_names():
                _fail(source, f"{where}.field", f"unknown model parameter '{name[6:]}' "
                      f"(expected one of {', '.join(parameter_names())})")
        if any(x.field == name for x in axes):
            _fail(source, f"{where}.field", f"'{name}' is already an axis")
        if ("values" in a) == ("range" in a):
            _fail(source, where, "give exactly one of values or range")
        axis = Axis(name)
        if "values" in a:
            if "count" in a:
                _fail(source, f"{where}.count", "only with range")
            values = a["values"]
            if not isinstance(values, list) or not values:
                _fail(source, f"{where}.values", f"expected a non-empty list, got {values!r}")
            if axis.is_model:
                values = [_number(source, f"{where}.values[{j}]", v) for j, v in enumerate(values)]
            axis.values = values
        else:
            r = a["range"]
            if not isinstance(r, list) or len(r) != 2:
                _fail(source, f"{where}.range", f"expected [low, high], got {r!r}")
            low = _number(source, f"{where}.range[0]", r[0])
            high = _number(source, f"{where}.range[1]", r[1])
            if not low < high:
                _fail(source, f"{where}.range", f"expected low < high, got [{low}, {high}]")
            if sampling == "grid":
                count = a.get("count")
                if isinstance(count, bool) or not isinstance(count, int) or count < 2:
                    _fail(source, f"{where}.count",
                          f"a grid range needs count: an integer >= 2, got {count!r}")
                axis.values = [float(v) for v in np.linspace(low, high, count)]
            else:
                if "count" in a:
                    _fail(source, f"{where}.count", "only for sampling: grid")
                axis.low, axis.high = low, high
        axes.append(axis)
    sweep = Sweep(name=doc["name"], source=source, experiment_path=experiment, sampling=sampling,
                  axes=axes, samples=samples, seed=seed, description=doc.get("description", ""))
    # The product of the axes' lengths, not the points themselves: a mistyped grid must not fill
    # the memory before it is refused.
    grid_size = math.prod(len(a.values) for a in axes)
    if sampling == "grid" and grid_size > MAX_POINTS:
        _fail(source, "axes", f"the grid has {grid_size} points; at most {MAX_POINTS}")
    return sweep


def load_sweep(path):
    with open(path, encoding="utf-8") as f:
        return parse_sweep(f.read(), path)


def _set_field(doc, dotted, value, source):
    """Writes `value` at the dotted path of an experiment's YAML mapping."""
    keys = dotted.split(".")
    node = doc
    for depth, key in enumerate(keys[:-1]):
        child = node.get(key) if isinstance(node, dict) else None
        if child is None:
            child = {}
            node[key] = child
        if not isinstance(child, dict):
            raise SweepError(f"{source}: {'.'.join(keys[:depth + 1])}: is not a mapping, so "
                             f"'{dotted}' cannot be set")
        node = child
    node[keys[-1]] = value


def point_experiment_text(sweep, point):
    """The YAML text of a point's experiment: the sweep's experiment with the point's fields."""
    with open(sweep.experiment_path, encoding="utf-8") as f:
        doc = yaml.safe_load(f)
    for name, value in point.items():
        if not name.startswith("model."):
            _set_field(doc, name, value, sweep.experiment_path)
    return yaml.safe_dump(doc, sort_keys=False)


def _summary_row(s):
    # StepStatus.NON_FINITE -> "non_finite", as summary.json writes it.
    row = {"status": s.status.name.lower(), "error": s.failure_message, "steps": s.steps,
           "simulated_s": s.duration_s, "max_speed_m_s": s.max_speed_m_s,
           "max_tilt_rad": s.max_tilt_rad, "wall_clock_s": s.wall_clock_s}
    final = np.asarray(s.final_state)
    row["final_x"], row["final_y"], row["final_z"] = (float(v) for v in final[:3])
    loop = s.closed_loop
    if loop is not None:
        row["rmse_x"], row["rmse_y"], row["rmse_z"], row["rmse_yaw"] = (float(v) for v in loop.rmse)
    return row


def run_point(sweep, index, point, out_dir):
    """Runs one point into out_dir/points/<index>; returns its results row (never raises)."""
    import dronetwin as dt

    row = {"index": index, **{a.field: point[a.field] for a in sweep.axes}}
    try:
        e = dt.parse_experiment(point_experiment_text(sweep, point), sweep.experiment_path)
        model = None
        if any(name.startswith("model.") for name in point):
            spec = dt.load_model(e.model_path).spec
            for name, value in point.items():
                if name.startswith("model."):
                    dt.set_parameter_value(spec, name[len("model."):], float(value))
            model = dt.VehicleModel(spec)
        s = dt.run_experiment(e, os.path.join(out_dir, "points", str(index)), model=model)
        row.update(_summary_row(s))
    except Exception as e:  # a bad value or a failed run is this point's result, not the sweep's
        row.update({"status": "error", "error": f"{type(e).__name__}: {e}"})
    return row


def _write_atomic(path, text):
    folder = os.path.dirname(path)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", dir=folder)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _format(v):
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def results_csv(sweep, rows):
    out = io.StringIO()
    columns = ["index"] + [a.field for a in sweep.axes] + METRICS
    writer = csv.DictWriter(out, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({c: (_format(row[c]) if c in row else "") for c in columns})
    return out.getvalue()


def _plot(sweep, rows, out_dir):
    """One figure per axis with a numeric value: the final position or the RMSE against it."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r.get("status") == "ok"]
    closed = any("rmse_x" in r for r in ok)
    metrics = ["rmse_x", "rmse_y", "rmse_z"] if closed else ["final_x", "final_y", "final_z"]
    figures = []
    for a in sweep.axes:
        if not ok or not all(isinstance(r[a.field], (int, float)) for r in ok):
            continue
        fig, ax = plt.subplots(figsize=(6, 4))
        for m in metrics:
            pairs = sorted((float(r[a.field]), r[m]) for r in ok if m in r)
            ax.plot([p[0] for p in pairs], [p[1] for p in pairs], "o", label=m)
        ax.set_xlabel(a.field)
        ax.set_ylabel("RMSE [m]" if closed else "final position [m]")
        ax.set_title(f"{sweep.name}: {len(ok)} of {len(rows)} points ok")
        ax.grid(True, alpha=0.3)
        ax.legend()
        name = "sweep_" + a.field.replace(".", "_") + ".png"
        fd, tmp = tempfile.mkstemp(prefix="." + name + ".", suffix=".png", dir=out_dir)
        os.close(fd)
        fig.savefig(tmp, dpi=100)
        plt.close(fig)
        os.replace(tmp, os.path.join(out_dir, name))
        figures.append(name)
    return figures


def results_markdown(sweep, rows, figures, cluster):
    failed = [r for r in rows if r.get("status") != "ok"]
    lines = [f"# Sweep {sweep.name}", "",
             f"{len(rows)} points ({sweep.sampling}) of `{sweep.experiment_path}` on {cluster}; "
             f"{len(rows) - len(failed)} ok, {len(failed)} failed.", ""]
    shown = ["index"] + [a.field for a in sweep.axes] + [
        m for m in METRICS if m != "error" and any(m in r for r in rows)]
    lines.append("| " + " | ".join(shown) + " |")
    lines.append("|" + "---|" * len(shown))
    for r in rows:
        lines.append("| " + " | ".join(_format(r.get(c, "")) for c in shown) + " |")
    if failed:
        lines += ["", "## Failed points", ""]
        lines += [f"- point {r['index']}: {r.get('error', '')}" for r in failed]
    for name in figures:
        lines += ["", f"![{name}]({name})"]
    return "\n".join(lines) + "\n"


def run_sweep(sweep, out_dir, scheduler=None, workers=2, progress=None):
    """Runs every point on Dask and writes results.csv and results.md into out_dir (which must
    not exist: a sweep never writes over earlier results). Returns the rows in point order."""
    from distributed import Client, LocalCluster, as_completed

    if os.path.lexists(out_dir):
        raise SweepError(f"--out {out_dir}: already exists; a sweep writes a new folder "
                         "(choose another, or remove the old one yourself)")
    if scheduler is None and (isinstance(workers, bool) or not isinstance(workers, int)
                              or workers < 1):
        raise SweepError(f"--workers: expected an integer >= 1, got {workers!r}")
    points = sweep.points()
    os.makedirs(os.path.join(out_dir, "points"))
    cluster = None
    if scheduler is None:
        # One thread per worker process: a run holds one core, and the processes keep the
        # runs apart (a crashing point takes down its worker, not the sweep).
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
        where = f"a LocalCluster of {workers} workers"
    else:
        client = Client(scheduler)
        where = f"the Dask cluster at {scheduler}"
    try:
        futures = [client.submit(run_point, sweep, i, p, os.path.abspath(out_dir), pure=False,
                                 key=f"dronetwin-sweep-{sweep.name}-{i}")
                   for i, p in enumerate(points)]
        index_of = {f.key: i for i, f in enumerate(futures)}
        rows = [None] * len(points)
        done = 0
        for future in as_completed(futures):
            i = index_of[future.key]
            try:
                rows[i] = future.result()
            except Exception as e:  # the worker died or the task could not run
                rows[i] = {"index": i, **{a.field: points[i][a.field] for a in sweep.axes},
                           "status": "error", "error": f"{type(e).__name__}: {e}"}
            done += 1
            if progress is not None:
                progress(done, len(points), rows[i])
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    _write_atomic(os.path.join(out_dir, "results.csv"), results_csv(sweep, rows))
    figures = _plot(sweep, rows, out_dir)
    _write_atomic(os.path.join(out_dir, "results.md"),
                  results_markdown(sweep, rows, figures, where))
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="dronetwin sweep",
        description="Run a grid or random sweep over experiment fields and model parameters on "
                    "Dask distributed (docs/sweeps.md).")
    parser.add_argument("sweep", help="sweep file (YAML)")
    parser.add_argument("--out", "-o", required=True, help="output folder (must not exist)")
    parser.add_argument("--scheduler", help="address of a running Dask scheduler "
                        "(default: a LocalCluster on this machine)")
    parser.add_argument("--workers", type=int, default=2,
                        help="worker processes of the LocalCluster (default 2)")
    parser.add_argument("--quiet", "-q", action="store_true", help="print nothing on success")
    args = parser.parse_args(argv)
    try:
        sweep = load_sweep(args.sweep)
        tty = sys.stderr.isatty() and not args.quiet

        def progress(done, total, row):
            if tty:
                print(f"\r{sweep.name}: {done}/{total} points", end="", file=sys.stderr, flush=True)

        rows = run_sweep(sweep, args.out, args.scheduler, args.workers, progress)
        if tty:
            print(file=sys.stderr)
    except (SweepError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    failed = [r for r in rows if r.get("status") != "ok"]
    if not args.quiet:
        print(f"{sweep.name}: {len(rows) - len(failed)} of {len(rows)} points ok; results in "
              f"{os.path.join(args.out, 'results.csv')} and results.md")
    for r in failed:
        print(f"point {r['index']} failed: {r.get('error', '')}", file=sys.stderr)
    return 3 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
