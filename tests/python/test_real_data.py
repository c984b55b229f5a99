"""Real data from Python: the PX4 ULog reader, the Crazyflie thrust-stand fit (checked against an
independent numpy least-squares solution) and a real-flight mass fit."""

import glob
import json
import resource
import struct
import subprocess
import sys

import numpy as np
import pytest

import dronetwin as dt
from conftest import source_path

REAL = source_path("tests", "data", "real")
STAND = source_path("tests", "data", "real", "crazyflie-system-id", "data", "bitcraze2021",
                    "cf2.1-stock-prop.csv")
ULOG = source_path("tests", "data", "real", "px4-ulog-rs", "esc_status_log.ulg")


def test_ulog_topics_read_as_numpy():
    log = dt.read_ulog(ULOG)
    assert log.version >= 0
    names = dict(log.topic_names())
    assert "vehicle_attitude" in names and "esc_status" in names
    att = log.topic("vehicle_attitude")
    t = att["timestamp"]
    assert np.all(np.diff(t) > 0)
    q = np.column_stack([att[f"q[{i}]"] for i in range(4)])
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-6)  # unit quaternions
    with pytest.raises(ValueError, match="no_such_topic"):
        log.topic("no_such_topic")


def test_ulog_errors_name_the_file(tmp_path):
    bad = tmp_path / "truncated.ulg"
    bad.write_bytes(open(ULOG, "rb").read()[:10])
    with pytest.raises(ValueError, match="truncated.ulg"):
        dt.read_ulog(str(bad))


def huge_array_ulog(path):
    """~100 bytes declaring 2e9 floats per message (before the caps: > 12 GB or bad_alloc)."""
    def message(kind, payload):
        return struct.pack("<HB", len(payload), ord(kind)) + payload
    data = (b"ULog\x01\x12\x35\x01" + struct.pack("<Q", 1000)
            + message("F", b"huge:uint64_t timestamp;float[2000000000] x")
            + message("A", struct.pack("<BH", 0, 0) + b"huge")
            + message("D", struct.pack("<HQf", 0, 1, 1.0)))
    path.write_bytes(data)
    return path


_REFUSE_IN_CHILD = """
import json, sys
import dronetwin as dt
out = []
for call in (lambda: dt.read_ulog(sys.argv[1]), lambda: dt.import_ulog(sys.argv[1], sys.argv[2])):
    try:
        call()
        out.append("accepted")
    except ValueError as e:
        out.append("ValueError: " + str(e))
    except MemoryError as e:
        out.append("MemoryError: " + str(e))
print(json.dumps(out))
"""


def test_ulog_huge_array_is_refused_in_bounded_memory(tmp_path):
    ulg = huge_array_ulog(tmp_path / "huge.ulg")
    stem = tmp_path / "out"

    def limit_address_space():  # 2 GiB: far below what the unbounded reader asked for
        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))

    run = subprocess.run([sys.executable, "-c", _REFUSE_IN_CHILD, str(ulg), str(stem)],
                         capture_output=True, text=True, timeout=120,
                         preexec_fn=limit_address_space)
    assert run.returncode == 0, run.stderr
    expected = (f"ValueError: {ulg}: byte 16: format 'huge', field 'float[2000000000] x': "
                "2000000000 elements exceed the limit of a ULog message (65535 bytes)")
    assert json.loads(run.stdout) == [expected, expected]
    assert not stem.with_suffix(".csv").exists()


def test_thrust_stand_fit_matches_independent_least_squares():
    fit = dt.fit_thrust_stand(STAND)
    # Independent computation: the same rows, tare and units, solved with numpy's lstsq.
    data = np.genfromtxt(STAND, delimiter=",", names=True)
    rpm = np.column_stack([data[f"rpm{i}"] for i in range(1, 5)])
    rest = (data["pwm"] == 0) & np.all(rpm == 0, axis=1)
    tare = data["weightg"][rest].mean()
    used = (data["pwm"] > 0) & np.all(rpm > 0, axis=1)
    w = rpm[used].mean(axis=1) * 2 * np.pi / 60
    thrust = (data["weightg"][used] - tare) * 9.81 / 4000.0
    coef, *_ = np.linalg.lstsq(np.column_stack([w * w, w, np.ones_like(w)]), thrust, rcond=None)
    assert fit.tare_g == pytest.approx(tare, rel=1e-12)
    assert np.allclose(fit.thrust.coefficients, coef, rtol=1e-6, atol=1e-9)
    assert fit.thrust.num_points == used.sum()


def test_real_flight_mass_fit(tmp_path):
    flight = glob.glob(f"{REAL}/CrazyPAD/**/*.fixedFrequency.csv", recursive=True)
    assert flight, "CrazyPAD flight fixture missing"
    log = dt.import_crazypad(flight[0], STAND, str(tmp_path / "e8"))
    model = dt.load_model(source_path("models", "crazyflie21.yaml"))
    r = dt.fit_vertical(log, model)
    # The Crazyflie 2.1 with battery weighs 27-35 g (data README); the fit must predict the
    # held-out 30 % better than the model's prior mass.
    assert 0.027 < r.mass_kg < 0.035
    assert r.rms_test_m_s2 < r.rms_test_prior_m_s2
