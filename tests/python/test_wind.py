"""The wind field from Python (SimConfig.wind, Simulator.wind_W_m_s, set_wind_field, Experiment.wind):
the wind at the vehicle is the sheared mean plus the 1 - cos gusts (computed here from their
formulas), turbulence is seeded, experiments log the wind, bad settings are named."""

import math

import numpy as np
import pytest

import dronetwin as dt
from conftest import source_path


def hovering(model, cfg):
    sim = dt.Simulator(model, cfg)
    sim.reset(dt.Simulator.hover_state([0.0, 0.0, 1.5]), model.hover_speeds_rad_s())
    sim.set_rotor_speed_reference(model.hover_speeds_rad_s())
    return sim


def test_the_wind_at_the_vehicle_is_the_sheared_mean_plus_the_gusts(qdrone2):
    cfg = dt.SimConfig()
    cfg.environment.wind_W_m_s = np.array([4.0, 0.0, 0.0])
    cfg.wind = dt.WindSettings(shear=dt.WindShear(enabled=True),
                               gusts=[dt.Gust(0.2, 0.4, [0.0, 2.0, 0.0])])
    assert cfg.wind.varies and len(cfg.wind.gusts) == 1
    sim = hovering(qdrone2, cfg)
    for _ in range(600):
        h, t = sim.state[2], sim.time_s
        factor = math.log(max(h, 2 * 0.04572) / 0.04572) / math.log(6.096 / 0.04572)
        x = (t - 0.2) / 0.4
        gust = 1.0 * (1 - math.cos(2 * math.pi * x)) if 0 <= x <= 1 else 0.0
        np.testing.assert_allclose(sim.wind_W_m_s, [4.0 * factor, gust, 0.0], rtol=1e-12,
                                   atol=1e-12)
        assert sim.step().ok


def test_turbulence_is_seeded_and_set_wind_field_acts_mid_run(qdrone2):
    cfg = dt.SimConfig(seed=3)
    cfg.environment.wind_W_m_s = np.array([3.0, 0.0, 0.0])
    cfg.wind.turbulence = dt.TurbulenceSettings.of("light")  # a view: edited in place
    assert cfg.wind.turbulence.wind_at_20ft_m_s == pytest.approx(15 * 1852 / 3600)
    a, b = hovering(qdrone2, cfg), hovering(qdrone2, cfg)
    a.step(300)
    b.step(300)
    np.testing.assert_array_equal(a.state, b.state)
    assert np.linalg.norm(a.wind_W_m_s - [3.0, 0.0, 0.0]) > 0.0
    calm = hovering(qdrone2, dt.SimConfig(seed=3))
    calm.set_wind_field(dt.WindSettings(gusts=[dt.Gust(0.0, 1.0, [0.0, 0.0, 1.0])]))
    np.testing.assert_array_equal(calm.wind_W_m_s, [0.0, 0.0, 0.0])  # the gust starts at zero
    calm.step(500)
    np.testing.assert_allclose(calm.wind_W_m_s, [0.0, 0.0, 1.0], atol=1e-12)  # its peak


def test_bad_wind_settings_are_named(qdrone2):
    with pytest.raises(ValueError, match="expected 'light', 'moderate' or 'severe'"):
        dt.TurbulenceSettings.of("strong")
    with pytest.raises(ValueError, match="at most 8 gusts, got 9"):
        dt.WindSettings(gusts=[dt.Gust(0.0, 1.0, [1.0, 0.0, 0.0])] * 9)
    cfg = dt.SimConfig()
    cfg.wind.gusts = [dt.Gust(0.0, -1.0, [1.0, 0.0, 0.0])]
    with pytest.raises(ValueError, match=r"wind.gusts\[0\].duration_s: expected > 0, got -1"):
        dt.Simulator(qdrone2, cfg)


def test_a_batch_flies_the_wind_field_lane_by_lane(qdrone2):
    cfg = dt.SimConfig(seed=2)
    cfg.environment.wind_W_m_s = np.array([3.0, 0.0, 0.0])
    cfg.wind = dt.WindSettings(turbulence=dt.TurbulenceSettings.of("light"))
    batch = dt.BatchSimulator(qdrone2, cfg, 2)
    for lane in range(2):
        batch.reset(lane, dt.Simulator.hover_state([0.0, 0.0, 1.5]), qdrone2.hover_speeds_rad_s())
    batch.step(200)
    np.testing.assert_array_equal(batch.wind, [[3.0, 0.0, 0.0]] * 2)  # the lanes' mean wind
    a, b = batch.air_velocity(0), batch.air_velocity(1)
    assert a.shape == (3,) and not np.array_equal(a, b)  # each lane its own gusts


def test_an_experiment_logs_the_wind_it_flies_in(tmp_path):
    e = dt.load_experiment(source_path("config", "experiments", "se3_hover_turbulence.yaml"))
    assert e.wind.shear.enabled and e.wind.turbulence.enabled and len(e.wind.gusts) == 1
    e.duration_s = 2.0
    e.wind.turbulence = dt.TurbulenceSettings()  # a view: the experiment changes
    assert not e.wind.turbulence.enabled
    summary = dt.run_experiment(e, str(tmp_path / "run"))
    assert summary.ok
    log = dt.read_log(tmp_path / "run" / "log.csv")
    # No turbulence and no gust before 30 s: the sheared mean at the logged height.
    factor = np.log(np.maximum(log["z"], 2 * 0.04572) / 0.04572) / np.log(6.096 / 0.04572)
    np.testing.assert_allclose(log["wind_x"], 5.0 * factor, rtol=1e-12)
    np.testing.assert_array_equal(log["wind_y"], 0.0)
