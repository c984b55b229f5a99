"""Parameter identification from Python (dronetwin.fit_model): the same fit as `dronetwin fit`,
recovering a changed QDrone2 from its own flight, numpy views of the flight, errors named."""

import math

import numpy as np
import pytest

import dronetwin as dt
from conftest import source_path


def changed_flight(tmp_path, changes, duration_s=8.0):
    spec = dt.load_spec(source_path("models", "qdrone2.yaml"))
    for name, factor in changes.items():
        dt.set_parameter_value(spec, name, factor * dt.parameter_value(spec, name))
    exp = dt.load_experiment(source_path("config", "experiments", "identification_flight.yaml"))
    exp.duration_s = duration_s
    summary = dt.run_experiment(exp, str(tmp_path), dt.VehicleModel(spec))
    assert summary.ok
    return spec, dt.read_flight(str(tmp_path / "log.csv"), 4)


def test_fit_recovers_a_changed_vehicle(tmp_path, qdrone2):
    changes = {"thrust_k1": 1.2, "inertia_xx": 1.2, "rotor_drag": 1.2, "tau_fall": 0.8}
    truth, flight = changed_flight(tmp_path, changes)
    assert flight.state.shape == (len(flight), 13)
    assert flight.rotor_speed_rad_s.shape == (len(flight), 4)
    r = dt.fit_model(qdrone2, flight, list(changes), method="equation")
    est = r.estimates()
    for name in changes:
        assert est[name][0] / dt.parameter_value(truth, name) == pytest.approx(1.0, abs=0.01), r.report()
        assert math.isfinite(est[name][1])
    assert r.holdout_after["linear_acceleration_m_s2"] < 0.01 * r.holdout_before["linear_acceleration_m_s2"]
    fitted = dt.VehicleModel(r.fitted_spec)
    assert fitted.num_rotors == 4
    # inertia_xx brings the angular channel and with it 3 free speed-sensor gains (the 4th is
    # 4 minus their sum): 4 parameters + 3 gains
    assert np.asarray(r.correlation).shape == (7, 7)
    assert '"estimate"' in r.to_json()


def test_fit_errors_are_value_errors(tmp_path, qdrone2):
    _, flight = changed_flight(tmp_path, {}, duration_s=1.0)
    with pytest.raises(ValueError, match="unknown parameter 'mas'"):
        dt.fit_model(qdrone2, flight, "mas")
    with pytest.raises(ValueError, match="method"):
        dt.fit_model(qdrone2, flight, "mass", method="fast")
    with pytest.raises(TypeError, match="params"):
        dt.fit_model(qdrone2, flight, ["mass", 3])
    bad = tmp_path / "bad.csv"
    bad.write_text("t,x,y,z\n0,0,0,0\n")
    with pytest.raises(ValueError, match="vx"):
        dt.read_flight(str(bad), 4)
    assert "drag_moment" in dt.parameter_names()
    spec = dt.load_spec(source_path("models", "qdrone2.yaml"))
    with pytest.raises(ValueError, match="'thrust' names a group of 3 parameters"):
        dt.parameter_value(spec, "thrust")


def test_fit_options_of_the_cli(tmp_path, qdrone2):
    """The options of `dronetwin fit` (issue "Reliability", item 2) and their checks."""
    truth, flight = changed_flight(tmp_path, {"thrust_k1": 1.1, "inertia_xx": 1.1}, duration_s=4.0)
    assert flight.nbytes == len(flight) * (8 + 13 * 8 + 4 * 8 + 4 * 8 + 1)  # t, state, speeds, refs
    r = dt.fit_model(qdrone2, flight, "thrust_k1,inertia_xx", method="equation",
                     channels="linear,angular", loss="cauchy", speed_gains="fit", num_threads=2)
    assert r.channels == ["linear", "angular"]
    assert r.loss == "cauchy" and r.loss_scale == pytest.approx(2.385)
    gains = r.speed_sensor_gains
    assert len(gains) == 4
    for gain, std_error in gains:  # the log's speeds are the true ones
        assert gain == pytest.approx(1.0, abs=1e-3), r.report()
    est = r.estimates()
    for name in ("thrust_k1", "inertia_xx"):
        assert est[name][0] / dt.parameter_value(truth, name) == pytest.approx(1.0, abs=0.01), r.report()
    check = r.holdout_check
    assert check["available"] and not check["worse"] and not r.holdout_worse
    assert set(check["channels"]) == {"linear acceleration", "angular acceleration"}
    before, after = check["channels"]["linear acceleration"]
    assert after < before

    r = dt.fit_model(qdrone2, flight, "thrust_k1", method="equation", loss="none",
                     speed_gains="off")
    assert r.channels == ["linear"] and r.loss == "none" and r.speed_sensor_gains == []
    assert r.holdout_check["channels"].keys() == {"linear acceleration"}
    assert r.coarse_stride == 1  # a short log is fitted on all its intervals from the start


def test_fit_options_out_of_range_are_value_errors(tmp_path, qdrone2):
    _, flight = changed_flight(tmp_path, {}, duration_s=1.0)
    cases = [
        (dict(channels="rotational"), "channels: expected auto, linear, angular or linear,angular"),
        (dict(loss="l2"), "loss: expected none, huber or cauchy, got 'l2'"),
        (dict(speed_gains="yes"), "expected auto, fit or off, got 'yes'"),
        (dict(loss_scale=0.0), "loss_scale must be a finite number of noise levels > 0"),
        (dict(loss_scale=math.nan), "loss_scale must be a finite number of noise levels > 0"),
        (dict(window_s=math.nan), "window_s must be a finite length in s > 0"),
        (dict(max_windows=0), "max_windows must be >= 1, got 0"),
        (dict(min_height_m=math.nan), "min_height_m must be a height in m"),
        (dict(holdout=math.inf), "holdout_fraction must be in"),
        (dict(num_threads=0), "num_threads must be in"),
        (dict(coarse_intervals=-1), "coarse_intervals must be >= 0, got -1"),
        (dict(window_s=1e-5), "shorter than two log intervals"),
    ]
    for kwargs, message in cases:
        with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
            dt.fit_model(qdrone2, flight, "thrust_k1", **kwargs)
