"""Several vehicles from Python (run_fleet_experiment, DownwashSettings, wake_velocity,
downwash_effect, Simulator.set_interaction): the wake's momentum flux, integrated here with numpy,
is the thrust at every distance; an interaction applied by hand is what a fleet applies; the
crossing dips the lower vehicle only with the wake on; the CLI runs fleet files."""

import json
import os
import subprocess

import numpy as np
import pytest

import dronetwin as dt
from conftest import hovering, source_path


def test_momentum_flux_of_the_wake_is_the_thrust(qdrone2):
    settings = dt.DownwashSettings()
    state = dt.Simulator.hover_state([0.0, 0.0, 5.0])
    source = dt.wake_source(settings, qdrone2, state, qdrone2.hover_speeds_rad_s())
    assert source.thrust_N == pytest.approx(qdrone2.mass_kg * 9.81, rel=1e-9)
    for below in (0.3, 1.0, 4.0):
        half = settings.spreading_rate * below + source.half_width_m
        x = np.linspace(-6 * half, 6 * half, 241)
        dx = x[1] - x[0]
        flux = 0.0
        for xi in x:
            for yi in x:
                u = dt.wake_velocity(settings, source, [xi, yi, 5.0 - below])
                flux += settings.air_density_kg_m3 * float(u @ u) * dx * dx
        assert flux == pytest.approx(source.thrust_N, rel=1e-6), below


def test_an_interaction_set_by_hand_moves_the_vehicle(qdrone2):
    cfg = dt.SimConfig()
    cfg.disturbances = dt.DisturbanceSwitches.none()
    cfg.motor_dynamics = False
    cfg.ground.enabled = False
    settings = dt.DownwashSettings()
    upper = dt.wake_source(settings, qdrone2, dt.Simulator.hover_state([0.0, 0.0, 3.2]),
                           qdrone2.hover_speeds_rad_s())
    sim = hovering(qdrone2, cfg)
    effect = dt.downwash_effect(settings, qdrone2, sim.state, qdrone2.hover_speeds_rad_s(), [upper])
    assert effect.wrench_B[2] < -1.0 and effect.flow_W_m_s[2] < -1.0
    sim.set_interaction(effect.flow_W_m_s, effect.wrench_B)
    flow, wrench = sim.interaction
    np.testing.assert_array_equal(wrench, effect.wrench_B)
    sim.step(100)
    # No drag terms, level: dv_z = F_z / m over 0.1 s.
    assert sim.state[5] == pytest.approx(effect.wrench_B[2] / qdrone2.mass_kg * 0.1, rel=1e-9)
    with pytest.raises(ValueError, match="set_interaction: wrench_B"):
        sim.set_interaction([0, 0, 0], [0, 0, 0])


def test_the_crossing_dips_the_lower_vehicle_only_with_the_wake(tmp_path):
    path = source_path("config", "experiments", "crossing_downwash.yaml")
    on = dt.run_fleet_experiment(path, str(tmp_path / "on"), duration_s=7.0)
    off = dt.run_fleet_experiment(path, str(tmp_path / "off"), duration_s=7.0,
                                  downwash=dt.DownwashSettings(enabled=False))
    assert on.ok and off.ok
    assert [v.name for v in on.vehicles] == ["upper", "lower"]
    assert on.vehicles[1].max_thrust_loss_N > 1.0
    assert off.vehicles[1].max_thrust_loss_N == 0.0
    assert on.vehicles[1].run.min_z_m < off.vehicles[1].run.min_z_m - 0.01
    np.testing.assert_array_equal(on.vehicles[0].run.final_state, off.vehicles[0].run.final_state)
    summary = json.loads((tmp_path / "on" / "fleet_summary.json").read_text())
    assert summary["vehicles"][1]["name"] == "lower"
    assert summary["downwash"]["spreading_rate"] == 0.094


def test_the_cli_runs_fleet_files(cli, tmp_path):
    path = source_path("config", "experiments", "crossing_no_downwash.yaml")
    out = tmp_path / "crossing"
    r = subprocess.run([cli, "run", path, "--out", str(out), "--duration", "3"],
                       capture_output=True, text=True, check=False)
    assert r.returncode == 0, r.stderr
    assert "downwash off" in r.stdout
    for name in ("upper", "lower"):
        assert (out / name / "log.csv").exists()
    r = subprocess.run([cli, "run", path, "--out", str(tmp_path / "x"), "--seed", "3"],
                       capture_output=True, text=True, check=False)
    assert r.returncode != 0 and "--seed" in r.stderr
    r = subprocess.run([cli, "run", path, "--out", str(tmp_path / "y"), "--real-time"],
                       capture_output=True, text=True, check=False)
    assert r.returncode != 0 and "--real-time" in r.stderr
    assert not (tmp_path / "y").exists()
