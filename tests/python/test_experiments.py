"""The experiment runner from Python, parity with the CLI, and logs as numpy / pandas."""

import filecmp
import os
import subprocess

import numpy as np
import pytest

import dronetwin as dt
from conftest import source_path

PULSE = source_path("config", "experiments", "pid_tuned_pulse.yaml")


def short(path, seconds):
    e = dt.load_experiment(path)
    e.duration_s = seconds
    return e


def test_python_and_cli_runs_give_bitwise_identical_logs(cli, tmp_path):
    s = dt.run_experiment(short(PULSE, 4.0), str(tmp_path / "py"))
    assert s.ok
    subprocess.run([cli, "run", PULSE, "--duration", "4", "--out", str(tmp_path / "cli")],
                   check=True, capture_output=True)
    assert filecmp.cmp(tmp_path / "py" / "log.csv", tmp_path / "cli" / "log.csv", shallow=False)


def test_runs_are_deterministic_and_seeded(tmp_path):
    a = dt.run_experiment(short(PULSE, 3.0), str(tmp_path / "a"))
    b = dt.run_experiment(short(PULSE, 3.0), str(tmp_path / "b"))
    other = short(PULSE, 3.0)
    other.seed += 1
    c = dt.run_experiment(other, str(tmp_path / "c"))
    assert filecmp.cmp(a.log_path, b.log_path, shallow=False)
    assert not filecmp.cmp(a.log_path, c.log_path, shallow=False)
    assert np.array_equal(a.final_state, b.final_state)


def test_summary_and_log_agree(tmp_path):
    e = short(PULSE, 5.0)
    e.log.every_n_steps = 1
    s = dt.run_experiment(e, str(tmp_path / "run"))
    cl = s.closed_loop
    assert cl is not None and cl.controller_name == "cascaded_pid"
    log = dt.read_log(str(tmp_path / "run"))
    assert len(log["t"]) == s.log_rows
    # The summary's RMSE is over every physics step; the log here has every step too.
    ex, ey, ez = (log["ref_" + a] - log[a] for a in "xyz")
    window = (log["t"] >= cl.rmse_window_s[0]) & (log["t"] <= cl.rmse_window_s[1])
    for err, rmse in zip((ex, ey, ez), cl.rmse[:3]):
        assert np.sqrt(np.mean(err[window] ** 2)) == pytest.approx(rmse, rel=1e-9, abs=1e-15)
    import json
    assert json.loads(s.to_json())["status"] == "ok"


def test_logs_read_as_numpy_and_pandas(tmp_path):
    s = dt.run_experiment(short(PULSE, 1.0), str(tmp_path / "run"))
    log = dt.read_log(s.log_path)
    assert log["z"].dtype == np.float64
    columns, values = dt.read_log_table(s.log_path)
    assert values.shape == (s.log_rows, len(columns))
    assert columns[:14] == ["t"] + list(dt.STATE_COLUMNS)
    pd = pytest.importorskip("pandas")
    frame = dt.read_log(s.log_path, as_frame=True)
    assert isinstance(frame, pd.DataFrame)
    assert np.array_equal(frame["z"].to_numpy(), log["z"])


def test_experiment_errors_name_file_and_field(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(open(PULSE).read().replace("duration_s:", "duration_seconds:"))
    with pytest.raises(ValueError, match="bad.yaml"):
        dt.load_experiment(str(bad))
    e = short(PULSE, 1.0)
    e.duration_s = float("nan")
    with pytest.raises(ValueError, match="duration_s"):
        dt.run_experiment(e, str(tmp_path / "nan"))
    with pytest.raises(ValueError, match="not a controller"):
        dt.load_experiment(source_path("config", "experiments", "hover_open_loop.yaml")).controller_path
    with pytest.raises(ValueError, match="log.csv"):
        dt.read_log(str(tmp_path / "missing" / "log.csv"))


def test_wind_sweep_changes_the_outcome(tmp_path):
    finals = []
    for wind in (0.0, 3.0):
        e = short(PULSE, 4.0)
        e.wind_m_s = [wind, 0.0, 0.0]
        finals.append(dt.run_experiment(e, str(tmp_path / f"w{wind}")).closed_loop.rmse)
    assert not np.array_equal(finals[0], finals[1])


def test_an_earlier_run_is_kept_unless_overwrite(tmp_path):
    out = str(tmp_path / "run")
    first = dt.run_experiment(short(PULSE, 0.5), out)
    before = open(first.log_path, "rb").read()
    with pytest.raises(ValueError, match=r"log.csv: exists \(an earlier run\?\).*overwrite=True"):
        dt.run_experiment(short(PULSE, 0.2), out)
    assert open(first.log_path, "rb").read() == before  # untouched by the refused run
    again = dt.run_experiment(short(PULSE, 0.2), out, overwrite=True)
    assert again.steps == 200
    assert not [f for f in os.listdir(out) if "partial" in f]


def test_an_experiment_without_a_name_is_refused(tmp_path):
    e = short(PULSE, 0.1)
    e.name = ""
    with pytest.raises(ValueError, match="name"):
        dt.run_experiment(e, str(tmp_path / "noname"))
    assert not (tmp_path / "noname" / "log.csv").exists()
