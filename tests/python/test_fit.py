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
    assert np.asarray(r.correlation).shape == (4, 4)
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
