"""The run log's JSON sidecar from Python: written next to log.csv, read as LogMetadata through
dronetwin.read_log_metadata / read_log(metadata=True), units for every column, the model hash
against an independent FNV-1a, byte-identical sidecars for identical runs, errors naming file and
field, and read_log unchanged for callers that do not ask for metadata."""

import json
import os
import shutil

import numpy as np
import pytest

import dronetwin as dt
from conftest import source_path

HOVER = source_path("config", "experiments", "hover_open_loop.yaml")
PULSE = source_path("config", "experiments", "pid_tuned_pulse.yaml")
MODEL = source_path("models", "qdrone2.yaml")


def fnv1a64(data):
    """FNV-1a, 64 bit, from the specification (offset basis, prime 2^40 + 2^8 + 0xb3)."""
    h = 0xCBF29CE484222325
    for byte in data:
        h = ((h ^ byte) * 0x100000001B3) % 2**64
    return h


def hover_run(out, seed=3, every_n_steps=4):
    e = dt.load_experiment(HOVER)
    e.duration_s = 0.2
    e.seed = seed
    e.log.every_n_steps = every_n_steps
    return dt.run_experiment(e, str(out))


def test_fnv1a64_test_vectors():
    assert dt.fnv1a64(b"") == 0xCBF29CE484222325
    assert dt.fnv1a64(b"a") == 0xAF63DC4C8601EC8C
    assert dt.fnv1a64(b"foobar") == 0x85944171F73967E8
    data = bytes(range(256))
    assert dt.fnv1a64(data) == fnv1a64(data)


def test_sidecar_is_written_and_reads_back(tmp_path):
    s = hover_run(tmp_path / "run")
    assert s.metadata_path == str(tmp_path / "run" / "log.json")
    meta = dt.read_log_metadata(str(tmp_path / "run"))
    assert isinstance(meta, dt.LogMetadata)
    assert meta.format == "dronetwin.run_log" and meta.format_version == 1
    assert meta.dronetwin_version == dt.__version__
    assert meta.seed == 3
    assert meta.dt_s == 0.001
    assert meta.log_every_n_steps == 4
    assert meta.log_rate_hz == pytest.approx(250.0, rel=1e-15)
    assert meta.integrator == dt.Integrator.RK4
    assert meta.control_rate_hz is None and meta.controller_path is None
    assert meta.num_rotors == 4
    assert meta.model == "qdrone2"
    # The same sidecar from the CSV path and from the file itself.
    assert dt.read_log_metadata(s.log_path).to_json() == meta.to_json()
    assert dt.read_log_metadata(s.metadata_path).to_json() == meta.to_json()

    log, meta2 = dt.read_log(s.log_path, metadata=True)
    assert list(log) == meta2.column_names()
    assert np.allclose(np.diff(log["t"]), 1.0 / meta2.log_rate_hz, rtol=0, atol=1e-12)
    units = meta2.units()
    assert set(units) == set(log)
    assert all(units[c] for c in units)
    expected = {"t": "s", "z": "m", "vx": "m/s", "qw": "1", "wz": "rad/s", "omega_2": "rad/s",
                "omega_ref_0": "rad/s", "in_contact": "bool", "crashed": "bool"}
    for name, unit in expected.items():
        assert units[name] == unit, name
        assert meta2.column(name).meaning
    # Plain JSON: any reader gets the same fields.
    raw = json.load(open(s.metadata_path))
    assert raw["seed"] == 3 and raw["dt_s"] == 0.001 and raw["log_rate_hz"] == meta.log_rate_hz
    assert [c["name"] for c in raw["columns"]] == list(log)


def test_model_hash_matches_an_independent_fnv1a(tmp_path):
    s = hover_run(tmp_path / "run")
    meta = dt.read_log_metadata(s.metadata_path)
    with open(MODEL, "rb") as f:
        expected = "fnv1a64:%016x" % fnv1a64(f.read())
    assert meta.model_hash == expected
    assert dt.file_hash(meta.model_path) == expected


def test_closed_loop_sidecar(tmp_path):
    e = dt.load_experiment(PULSE)
    e.duration_s = 0.1
    s = dt.run_experiment(e, str(tmp_path / "pid"))
    meta = dt.read_log_metadata(str(tmp_path / "pid"))
    assert meta.input_type == "controller"
    assert meta.control_rate_hz == e.control_rate_hz
    assert meta.controller_path == e.controller_path
    assert meta.noise == e.noise.enabled
    assert meta.units()["u_T"] == "N" and meta.units()["ref_yaw"] == "rad"
    assert meta.column_names() == dt.read_log_table(s.log_path)[0]


def test_identical_runs_give_identical_sidecars(tmp_path):
    a = hover_run(tmp_path / "a")
    b = hover_run(tmp_path / "b")
    assert open(a.metadata_path, "rb").read() == open(b.metadata_path, "rb").read()


def test_malformed_sidecar_names_file_and_field(tmp_path):
    s = hover_run(tmp_path / "run")
    text = open(s.metadata_path).read()
    bad = tmp_path / "bad.json"
    bad.write_text(text.replace('"dt_s": 0.001', '"dt_s": "1 ms"'))
    with pytest.raises(ValueError, match=r"bad\.json: dt_s: expected a number"):
        dt.read_log_metadata(str(bad))
    bad.write_text(text.replace('"seed": 3,\n', ""))
    with pytest.raises(ValueError, match=r"bad\.json.*missing required key 'seed'"):
        dt.read_log_metadata(str(bad))
    bad.write_text(text.replace('"unit": "m/s"', '"unit": 5', 1))
    with pytest.raises(ValueError, match=r"bad\.json: columns\[4\]\.unit"):
        dt.read_log_metadata(str(bad))
    # A sidecar describing other columns than the CSV holds.
    with open(s.metadata_path, "w") as f:
        f.write(text.replace('{"name": "vx"', '{"name": "v_x"'))
    with pytest.raises(ValueError, match="columns"):
        dt.read_log(s.log_path, metadata=True)


def test_read_log_without_sidecar(tmp_path):
    s = hover_run(tmp_path / "run")
    os.remove(s.metadata_path)
    log, meta = dt.read_log(str(tmp_path / "run"), metadata=True)
    assert meta is None
    assert len(log["t"]) == s.log_rows
    # Callers that do not ask for metadata get the dict as before.
    plain = dt.read_log(s.log_path)
    assert isinstance(plain, dict) and np.array_equal(plain["z"], log["z"])
    with pytest.raises(ValueError, match="log.json"):
        dt.read_log_metadata(str(tmp_path / "run"))


def test_read_log_metadata_with_frame(tmp_path):
    pd = pytest.importorskip("pandas")
    s = hover_run(tmp_path / "run")
    frame, meta = dt.read_log(s.log_path, as_frame=True, metadata=True)
    assert isinstance(frame, pd.DataFrame)
    assert list(frame.columns) == meta.column_names()


def test_importer_sidecar_has_the_core_fields(tmp_path):
    ulg = source_path("tests", "data", "real", "px4-ulog-rs", "esc_status_log.ulg")
    if not hasattr(dt, "import_ulog"):
        pytest.skip("no ULog importer bound")
    shutil.copy(ulg, tmp_path / "f.ulg")
    dt.import_ulog(str(tmp_path / "f.ulg"), str(tmp_path / "f"))
    raw = json.load(open(tmp_path / "f.json"))
    assert raw["format"] == "dronetwin.imported_log" and raw["format_version"] == 1
    columns, _ = dt.read_log_table(str(tmp_path / "f.csv"))
    assert [c["name"] for c in raw["columns"]] == columns
    assert all(c["unit"] and c["meaning"] for c in raw["columns"])
    with pytest.raises(ValueError, match="format"):
        dt.read_log_metadata(str(tmp_path / "f.json"))
