"""The slung payload from Python (SlungPayload, PayloadSettings, SimConfig.payload,
Simulator.payload / set_payload_state / payload_tension_N / swing_angles, Experiment.payload):
hanging it pulls with the reduced mass, without outside forces the pair keeps its momentum,
experiments log the payload and the swing, the batch refuses it, bad settings are named."""

import numpy as np
import pytest

import dronetwin as dt
from conftest import hovering, source_path


def payload_config(gravity=(0.0, 0.0, -9.81)):
    cfg = dt.SimConfig()
    cfg.payload = dt.PayloadSettings(payload=dt.SlungPayload(mass_kg=0.5, tether_length_m=0.5))
    cfg.disturbances = dt.DisturbanceSwitches.none()
    cfg.motor_dynamics = False
    cfg.ground.enabled = False
    cfg.environment.gravity_W_m_s2 = np.array(gravity)
    return cfg


def test_hanging_it_pulls_with_the_reduced_mass_times_the_relative_acceleration(qdrone2):
    # The vehicle's own hover thrust holds it alone: the pair sinks, and the taut cable carries
    # mu g with mu = m_Q m_L / (m_Q + m_L), not the payload's weight.
    sim = hovering(qdrone2, payload_config())
    p = sim.payload
    assert p.taut and not p.on_ground
    np.testing.assert_allclose(p.position_W_m, [0.0, 0.0, 1.5], atol=1e-15)
    mu = qdrone2.mass_kg * 0.5 / (qdrone2.mass_kg + 0.5)
    assert sim.payload_tension_N() == pytest.approx(mu * 9.81, rel=1e-9)
    assert sim.swing_angles().gamma1_rad == 0.0
    # With the rotors stopped both fall freely: the cable carries nothing.
    sim.reset(dt.Simulator.hover_state([0.0, 0.0, 2.0]))
    assert sim.payload_tension_N() == pytest.approx(0.0, abs=1e-3)


def test_without_outside_forces_the_pair_keeps_its_momentum(qdrone2):
    sim = dt.Simulator(qdrone2, payload_config(gravity=(0.0, 0.0, 0.0)))
    k = qdrone2.rotor(0).thrust_coefficients
    w0 = (-k[1] + np.sqrt(k[1] ** 2 - 4 * k[0] * k[2])) / (2 * k[0])  # zero thrust
    x = dt.Simulator.hover_state([0.0, 0.0, 5.0])
    x[3:6] = [1.0, 0.5, 0.0]
    speeds = np.full(4, w0)
    sim.reset(x, speeds)
    sim.set_rotor_speed_reference(speeds)
    sim.set_payload_state(dt.PayloadState([0.0, 0.0, 4.5], [0.0, 0.0, 0.0]))
    m_q, m_l = qdrone2.mass_kg, 0.5

    def momentum():
        return m_q * sim.state[3:6] + m_l * sim.payload.velocity_W_m_s

    before = momentum()
    assert sim.step(2000).ok
    np.testing.assert_allclose(momentum(), before, rtol=0, atol=1e-12 * np.linalg.norm(before))
    r = sim.payload.position_W_m - sim.state[0:3]
    assert np.linalg.norm(r) == pytest.approx(0.5, abs=1e-12)


def test_an_experiment_logs_the_payload_and_its_swing(tmp_path):
    e = dt.load_experiment(source_path("config", "experiments", "se3_payload_move.yaml"))
    assert e.payload.enabled and e.payload.payload.mass_kg == 0.5
    e.duration_s = 4.0
    s = dt.run_experiment(e, str(tmp_path / "run"))
    assert s.ok
    log = dt.read_log(tmp_path / "run" / "log.csv")
    columns = {"payload_x", "payload_y", "payload_z", "payload_vx", "swing_1", "swing_2",
               "swing_rate_1", "swing_rate_2", "tension"}
    assert columns <= set(log)
    # The logged payload is the tether's length from the vehicle, and the swing angles say where.
    r = np.stack([log["payload_x"] - log["x"], log["payload_y"] - log["y"],
                  log["payload_z"] - log["z"]], axis=1)
    np.testing.assert_allclose(np.linalg.norm(r, axis=1), 0.5, atol=1e-9)
    np.testing.assert_allclose(np.arctan2(r[:, 0], -r[:, 2]), log["swing_1"], atol=1e-9)
    # The move (1 .. 3 s, 3 m along x) swings the payload, and the cable stays taut.
    assert np.max(np.abs(log["swing_1"])) > 0.2
    assert np.all(log["tension"] > 0.0)


def test_bad_payload_settings_are_named(qdrone2):
    cfg = dt.SimConfig()
    cfg.payload = dt.PayloadSettings(payload=dt.SlungPayload(tether_length_m=0.0))
    with pytest.raises(ValueError, match=r"payload.tether_length_m: expected > 0, got 0"):
        dt.Simulator(qdrone2, cfg)
    cfg.payload = dt.PayloadSettings()
    with pytest.raises(ValueError, match="payload"):
        dt.BatchSimulator(qdrone2, cfg, 2)
    sim = dt.Simulator(qdrone2, cfg)
    sim.reset(dt.Simulator.hover_state([0.0, 0.0, 2.0]))
    with pytest.raises(ValueError, match=r"beyond the tether length 0.5 m"):
        sim.set_payload_state(dt.PayloadState([0.0, 0.0, 0.0]))


def test_the_payload_aware_controller_halves_the_swing_of_a_move(tmp_path):
    # The same 3 m move flown by plain SE(3) (se3.yaml) and by the payload-aware one
    # (se3_payload.yaml: mass feedforward and input shaping). The issue asks for at least half
    # the swing amplitude; the threshold is the issue's, not fitted to the result.
    swing = {}
    for name in ("se3_payload_move", "se3_payload_move_aware"):
        e = dt.load_experiment(source_path("config", "experiments", name + ".yaml"))
        assert dt.run_experiment(e, str(tmp_path / name)).ok
        log = dt.read_log(tmp_path / name / "log.csv")
        swing[name] = np.hypot(log["swing_1"], log["swing_2"])
        assert abs(log["x"][-1] - 3.0) < 0.05  # both arrive
    assert np.max(swing["se3_payload_move_aware"]) <= 0.5 * np.max(swing["se3_payload_move"])
