"""The battery from Python (BatteryPack, BatterySettings, SimConfig.battery, Simulator.battery,
Experiment.battery): a hover drains the pack at the current its power needs, the state of charge
falls by the charge drawn, experiments log the pack, the batch drains one pack per lane as the
Simulator does, bad settings are named."""

import numpy as np
import pytest

import dronetwin as dt
from conftest import hovering, source_path


def test_a_hover_drains_the_pack_by_the_charge_it_draws(qdrone2):
    cfg = dt.SimConfig()
    cfg.battery = dt.BatterySettings()
    pack = cfg.battery.pack
    assert cfg.battery.enabled and pack.cells_in_series == 6 and pack.capacity_Ah == 2.2
    sim = hovering(qdrone2, cfg)
    currents = []
    for _ in range(1000):
        sim.step()
        currents.append(sim.battery.current_A)
    b = sim.battery
    # dSoC/dt = -I / (3600 Q): the charge drawn over 1 s of 1 ms steps.
    assert b.soc == pytest.approx(1.0 - np.sum(currents) * 1e-3 / (3600 * pack.capacity_Ah), rel=1e-12)
    # A steady hover: the energy delivered over 1 s is the terminal power times 1 s.
    assert b.energy_drawn_J == pytest.approx(b.voltage_V * b.current_A * 1.0, rel=1e-3)
    assert 10.0 < b.current_A < 30.0  # ~360 W at ~25 V
    assert pack.open_circuit_voltage_V(1.0) == pytest.approx(6 * 4.2)


def test_an_experiment_logs_its_pack(tmp_path):
    e = dt.load_experiment(source_path("config", "experiments", "hover_battery_empty.yaml"))
    assert e.battery.enabled
    e.battery.pack.initial_soc = 0.02  # empty in ~10 s
    e.duration_s = 12.0
    s = dt.run_experiment(e, str(tmp_path / "run"))
    log = dt.read_log(tmp_path / "run" / "log.csv")
    assert {"battery_soc", "battery_voltage", "battery_current"} <= set(log)
    assert log["battery_soc"][0] <= 0.02 and np.all(np.diff(log["battery_soc"]) <= 0)
    # The pack cut off: no voltage, no current, and the vehicle came down.
    assert log["battery_voltage"][-1] == 0.0 and log["battery_current"][-1] == 0.0
    assert log["z"][-1] < 0.1
    assert s.ok and s.crashed  # a 1.5 m fall onto the ground: the run goes on, marked crashed


def test_bad_battery_settings_are_named(qdrone2):
    pack = dt.BatteryPack()
    with pytest.raises(ValueError, match=r"ocv_cell_V: expected 11 cell voltages"):
        pack.ocv_cell_V = [3.7] * 10
    pack.efficiency = 0.0
    with pytest.raises(ValueError, match=r"battery.efficiency: expected a fraction in \(0, 1\], got 0"):
        dt.Simulator(qdrone2, dt.SimConfig()).set_battery(dt.BatterySettings(pack=pack))


def test_the_batch_drains_a_pack_per_lane_as_the_simulator(qdrone2):
    cfg = dt.SimConfig()
    cfg.battery = dt.BatterySettings()
    cfg.battery.pack.capacity_Ah = 0.05
    hover = qdrone2.hover_speeds_rad_s()
    refs = np.array([hover * 0.95, hover * 1.1, hover * 1.6])
    starts = np.array([dt.Simulator.hover_state([float(k), 0.0, 30.0]) for k in range(3)])
    batch = dt.BatchSimulator(qdrone2, cfg, 3)
    batch.reset(None, starts, np.tile(hover, (3, 1)))
    batch.rotor_speed_reference[:] = refs
    assert batch.step(1500) == 0
    socs = batch.battery_soc()
    assert socs.shape == (3,) and np.all(np.diff(socs) < 0)  # more speed, more charge drawn
    for k in range(3):
        sim = dt.Simulator(qdrone2, cfg)
        sim.reset(starts[k], hover)
        sim.set_rotor_speed_reference(refs[k])
        sim.step(1500)
        assert batch.battery(k).soc == pytest.approx(sim.battery.soc, abs=1e-12)
        assert batch.battery_voltage_V()[k] == pytest.approx(sim.battery.voltage_V, abs=1e-9)
        np.testing.assert_allclose(batch.state[k], sim.state, atol=1e-9)
    batch.reset(0, starts[0], hover)
    assert batch.battery(0).soc == 1.0  # a full pack again
