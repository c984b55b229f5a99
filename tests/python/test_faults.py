"""Rotor faults from Python (RotorFault, SimConfig.faults, Simulator.set_faults, Experiment.faults):
a stopped rotor spins down, a stuck one ignores its reference, the fault acts from its start,
experiments carry them, bad settings are named."""

import numpy as np
import pytest

import dronetwin as dt
from conftest import hovering, source_path


def test_faults_act_from_their_start(qdrone2):
    cfg = dt.SimConfig()
    cfg.faults = [dt.RotorFault.stop(2, 0.05), dt.RotorFault.stuck(0, 0.05)]
    assert [f.kind for f in cfg.faults] == [dt.RotorFaultKind.STOP, dt.RotorFaultKind.STUCK]
    sim, nominal = hovering(qdrone2, cfg), hovering(qdrone2, dt.SimConfig())
    sim.step(50)
    nominal.step(50)
    np.testing.assert_array_equal(sim.state, nominal.state)  # nothing before the start
    hover = qdrone2.hover_speeds_rad_s()
    sim.set_rotor_speed_reference(hover * 1.2)
    sim.step(20)
    w = sim.rotor_speeds_rad_s
    assert w[2] < 1.0  # stopped
    assert w[0] == hover[0]  # stuck at its speed when the fault began
    assert w[1] == pytest.approx(1.2 * hover[1])


def test_lost_effectiveness_and_set_faults(qdrone2):
    sim, nominal = hovering(qdrone2, dt.SimConfig()), hovering(qdrone2, dt.SimConfig())
    sim.set_faults([dt.RotorFault.degraded(1, 0.0, 0.5)])
    gap = sim.state_derivative() - nominal.state_derivative()
    assert gap[5] < -1.0  # half a rotor's thrust lost: about -1.2 m/s^2 upwards
    sim.set_faults([])
    np.testing.assert_array_equal(sim.state_derivative(), nominal.state_derivative())


def test_bad_faults_are_named(qdrone2):
    cfg = dt.SimConfig()
    cfg.faults = [dt.RotorFault.stop(7, 1.0)]
    with pytest.raises(ValueError, match=r"faults\[0\].rotor: expected 0 .. 3 \(rotors of 'qdrone2'\), got 7"):
        dt.Simulator(qdrone2, cfg)
    with pytest.raises(ValueError, match="at most 8 rotor faults, got 9"):
        cfg.faults = [dt.RotorFault.stop(0, 1.0)] * 9
    cfg.faults = [dt.RotorFault.stuck(5, 1.0)]
    with pytest.raises(ValueError, match=r"faults\[0\]\.rotor: expected 0 \.\. 3"):
        dt.BatchSimulator(qdrone2, cfg, 2)


def test_an_experiment_carries_its_faults(tmp_path):
    e = dt.load_experiment(source_path("config", "experiments", "fault_rotor50_se3.yaml"))
    (f,) = e.faults
    assert (f.kind, f.rotor, f.start_s, f.effectiveness) == (dt.RotorFaultKind.EFFECTIVENESS, 0, 10.0, 0.5)
    e.duration_s = 10.5
    s = dt.run_experiment(e, str(tmp_path / "run"))
    assert s.ok
    log = dt.read_log(tmp_path / "run" / "log.csv")
    # The controller answers the lost thrust: rotor 0 speeds up after 10 s.
    before = log["omega_0"][log["t"] < 9.99][-1]
    assert log["omega_0"][-1] > before * 1.05
