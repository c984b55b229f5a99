"""Sweeps on Dask distributed (dronetwin.sweep, `dronetwin sweep`): a grid over a model parameter
and an experiment field flown on a real 2-worker LocalCluster, every point against the analytic
free fall; the same results on 1 and 2 workers; random sampling reproducible from its seed and
inside its ranges; a failing point reported while the others finish; bad sweep files and an
existing output folder refused with the field named."""

import csv
import os
import subprocess

import pytest

from dronetwin import sweep as sw
from conftest import source_path

SWEEP = source_path("config", "sweeps", "freefall_mass.yaml")
K3_N = -0.0121  # thrust of a stopped rotor, models/qdrone2.yaml (thesis Eq. 2.22)


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def free_fall(mass_kg, t_s):
    """z(t) and |v(t)| from 10 m with four stopped rotors: a = -g + 4 K3 / m."""
    a = -9.81 + 4 * K3_N / mass_kg
    return 10.0 + 0.5 * a * t_s**2, abs(a) * t_s


def test_the_cli_flies_every_grid_point_on_a_two_worker_cluster(cli, tmp_path):
    out = tmp_path / "sweep"
    r = subprocess.run([cli, "sweep", SWEEP, "--out", str(out), "--workers", "2"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "6 of 6 points ok" in r.stdout
    rows = read_rows(out / "results.csv")
    # The grid in order: mass outer, duration inner.
    assert [(float(x["model.mass"]), float(x["duration_s"])) for x in rows] == [
        (m, t) for m in (0.8, 1.504, 3.0) for t in (0.5, 1.0)]
    for row in rows:
        m, t = float(row["model.mass"]), float(row["duration_s"])
        z, speed = free_fall(m, t)
        assert row["status"] == "ok"
        assert int(row["steps"]) == round(t / 0.001)
        # RK4 integrates a constant acceleration exactly; the CSV keeps 6 significant digits.
        assert float(row["final_z"]) == pytest.approx(z, rel=1e-6)
        assert float(row["max_speed_m_s"]) == pytest.approx(speed, rel=1e-6)
        # Each point is a complete run folder, as `dronetwin run` writes it.
        assert (out / "points" / row["index"] / "summary.json").exists()
    md = (out / "results.md").read_text()
    assert "6 ok, 0 failed" in md and "LocalCluster of 2 workers" in md
    assert (out / "sweep_model_mass.png").stat().st_size > 1000
    assert (out / "sweep_duration_s.png").stat().st_size > 1000


def test_results_do_not_depend_on_the_number_of_workers(tmp_path):
    sweep = sw.load_sweep(SWEEP)
    one = sw.run_sweep(sweep, str(tmp_path / "one"), workers=1)
    two = sw.run_sweep(sweep, str(tmp_path / "two"), workers=2)
    for a, b in zip(one, two):
        a = {k: v for k, v in a.items() if k != "wall_clock_s"}
        b = {k: v for k, v in b.items() if k != "wall_clock_s"}
        assert a == b  # bitwise: the same floats


def test_random_sampling_is_reproducible_and_inside_its_ranges(tmp_path):
    text = f"""
name: random_mass
experiment: {source_path("config", "experiments", "freefall.yaml")}
sampling: random
samples: 5
seed: 11
axes:
  - field: model.mass
    range: [1.0, 2.0]
  - field: duration_s
    values: [0.2, 0.3]
"""
    sweep = sw.parse_sweep(text, str(tmp_path / "random.yaml"))
    points = sweep.points()
    assert points == sw.parse_sweep(text, str(tmp_path / "random.yaml")).points()
    assert len(points) == 5
    assert all(1.0 <= p["model.mass"] <= 2.0 for p in points)
    assert all(p["duration_s"] in (0.2, 0.3) for p in points)
    assert len({p["model.mass"] for p in points}) == 5
    other = sw.parse_sweep(text.replace("seed: 11", "seed: 12"), str(tmp_path / "r.yaml"))
    assert other.points() != points
    rows = sw.run_sweep(sweep, str(tmp_path / "out"), workers=2)
    for p, row in zip(points, rows):
        z, _ = free_fall(p["model.mass"], p["duration_s"])
        assert row["status"] == "ok" and row["final_z"] == pytest.approx(z, rel=1e-12)


def test_a_failing_point_is_reported_and_the_others_finish(cli, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(f"""
name: with_a_bad_point
experiment: {source_path("config", "experiments", "freefall.yaml")}
axes:
  - field: duration_s
    values: [0.2, -1.0, 0.3]
""")
    out = tmp_path / "out"
    r = subprocess.run([cli, "sweep", str(bad), "--out", str(out)], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 3, r.stderr
    assert "2 of 3 points ok" in r.stdout
    assert "point 1 failed" in r.stderr and "duration_s" in r.stderr
    rows = read_rows(out / "results.csv")
    assert [row["status"] for row in rows] == ["ok", "error", "ok"]
    assert "duration_s" in rows[1]["error"]
    assert "## Failed points" in (out / "results.md").read_text()


@pytest.mark.parametrize("body, where", [
    ("axes: [{field: duration_s, values: [1]}]\nbogus: 1", "bogus: unknown field"),
    ("axes: [{field: model.heft, values: [1]}]", "axes[0].field: unknown model parameter 'heft'"),
    ("axes: [{field: duration_s, range: [0.1, 0.2]}]", "axes[0].count: a grid range needs count"),
    ("axes: [{field: duration_s, values: [1], range: [0, 1]}]", "axes[0]: give exactly one of"),
    ("axes: [{field: model.mass, values: [nan]}]", "axes[0].values[0]: expected a finite number"),
    ("axes: [{field: duration_s, values: [1]}, {field: duration_s, values: [2]}]",
     "axes[1].field: 'duration_s' is already an axis"),
    ("sampling: random\naxes: [{field: duration_s, values: [1]}]", "samples: expected an integer"),
    ("axes: []", "axes: expected a non-empty list"),
    ("sampling: sobol\naxes: [{field: duration_s, values: [1]}]",
     "sampling: expected 'grid' or 'random', got 'sobol'"),
    ("axes: [{field: model.mass, range: [2.0, 1.0], count: 3}]",
     "axes[0].range: expected low < high, got [2.0, 1.0]"),
    ("sampling: random\nsamples: 100001\naxes: [{field: duration_s, values: [1]}]",
     "samples: expected an integer in [1, 100000]"),
    # 1000^3 points: refused from the axes' lengths, without building them.
    ("axes: [{field: model.mass, range: [1, 2], count: 1000},"
     " {field: model.thrust_k1, range: [1, 2], count: 1000},"
     " {field: duration_s, range: [1, 2], count: 1000}]",
     "axes: the grid has 1000000000 points; at most 100000"),
])
def test_bad_sweep_files_name_the_field(tmp_path, body, where):
    experiment = source_path("config", "experiments", "freefall.yaml")
    text = f"name: bad\nexperiment: {experiment}\n" + body
    with pytest.raises(sw.SweepError) as e:
        sw.parse_sweep(text, "bad.yaml")
    assert str(e.value).startswith("bad.yaml: ") and where in str(e.value)


def test_a_missing_experiment_file_and_a_bad_worker_count_are_named(tmp_path):
    with pytest.raises(sw.SweepError, match=r"bad.yaml: experiment: no such file: .*nowhere.yaml"):
        sw.parse_sweep("name: x\nexperiment: nowhere.yaml\naxes: [{field: seed, values: [1]}]",
                       str(tmp_path / "bad.yaml"))
    with pytest.raises(sw.SweepError, match=r"--workers: expected an integer >= 1, got 0"):
        sw.run_sweep(sw.load_sweep(SWEEP), str(tmp_path / "out"), workers=0)
    assert not (tmp_path / "out").exists()


def test_an_existing_output_folder_is_never_written_into(cli, tmp_path):
    out = tmp_path / "earlier"
    out.mkdir()
    (out / "results.csv").write_text("precious\n")
    r = subprocess.run([cli, "sweep", SWEEP, "--out", str(out)], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 2
    assert "already exists" in r.stderr
    assert (out / "results.csv").read_text() == "precious\n"
    assert sorted(os.listdir(out)) == ["results.csv"]
