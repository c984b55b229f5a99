"""Models from Python: loading, inspection, editing, allocation, errors."""

import numpy as np
import pytest

import dronetwin as dt
from conftest import source_path


def test_qdrone2_parameters_match_the_model_file(qdrone2):
    assert qdrone2.name == "qdrone2"
    assert qdrone2.num_rotors == 4
    assert qdrone2.mass_kg == pytest.approx(1.504)  # thesis Table 2.1
    assert qdrone2.inertia_kgm2.shape == (3, 3)
    assert qdrone2.rotor(0).thrust_coefficients[0] == pytest.approx(1.9533e-6)


def test_hover_speeds_balance_gravity(qdrone2):
    w = qdrone2.hover_speeds_rad_s()
    thrust = sum(qdrone2.rotor(i).thrust(w[i]) for i in range(4))
    assert thrust == pytest.approx(qdrone2.mass_kg * 9.81, rel=1e-12)
    assert np.allclose(qdrone2.hover_thrusts_N(), [qdrone2.rotor(i).thrust(w[i]) for i in range(4)])


def test_allocation_matrix_and_its_pseudo_inverse(qdrone2):
    a, a_pinv = qdrone2.allocation_matrix, qdrone2.allocation_pseudo_inverse
    assert a.shape == (4, 4) and a_pinv.shape == (4, 4)
    assert np.allclose(a @ a_pinv, np.eye(4), atol=1e-12)
    u = np.array([15.0, 0.1, -0.2, 0.05])
    assert np.allclose(a @ qdrone2.thrusts_for(u), u, atol=1e-12)
    r = qdrone2.allocate(u)
    assert not r.saturated
    assert np.allclose(r.achieved, u, atol=1e-9)


def test_allocation_reports_saturation(qdrone2):
    r = qdrone2.allocate([200.0, 0.0, 0.0, 0.0])  # far beyond four rotors at full speed
    assert r.saturated
    assert np.all(r.speeds_rad_s <= qdrone2.rotor(0).max_speed_rad_s)


def test_an_edited_spec_builds_a_new_model(qdrone2):
    spec = qdrone2.spec
    spec.mass_kg = 2.0 * qdrone2.mass_kg
    heavy = dt.VehicleModel(spec)
    # Hover thrust is proportional to mass; the original model is untouched (immutable).
    assert heavy.hover_thrusts_N().sum() == pytest.approx(2.0 * qdrone2.hover_thrusts_N().sum())
    assert qdrone2.mass_kg == pytest.approx(1.504)


def test_spec_round_trips_through_yaml(qdrone2, tmp_path):
    path = tmp_path / "copy.yaml"
    qdrone2.spec.save(str(path))
    again = dt.load_model(str(path))
    assert np.array_equal(again.allocation_matrix, qdrone2.allocation_matrix)
    assert np.array_equal(again.hover_speeds_rad_s(), qdrone2.hover_speeds_rad_s())


def test_model_errors_name_file_and_field(tmp_path):
    with pytest.raises(ValueError, match="nonexistent.yaml"):
        dt.load_model(str(tmp_path / "nonexistent.yaml"))
    text = open(source_path("models", "qdrone2.yaml")).read().replace("mass_kg: 1.504", "mass_kg: -1.0")
    with pytest.raises(ValueError, match=r"broken\.yaml.*mass_kg"):
        dt.parse_model(text, "broken.yaml")
    spec = dt.load_spec(source_path("models", "qdrone2.yaml"))
    spec.rotors = spec.rotors[:1]
    with pytest.raises(ValueError):
        dt.VehicleModel(spec)


def test_rotor_index_out_of_range(qdrone2):
    with pytest.raises(IndexError, match="rotor index 4"):
        qdrone2.rotor(4)
