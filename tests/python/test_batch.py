"""The batched engine from Python: (N, 13) views, per-lane parameters, equality with the
Simulator, statuses, threads and errors."""

import threading

import numpy as np
import pytest

import dronetwin as dt
from conftest import flying_se3


def test_state_is_a_live_lane_by_row_view(qdrone2):
    batch = dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=5)
    assert batch.state.shape == (5, 13)
    assert batch.state.dtype == np.float64
    # At rest on the ground at the origin, identity attitude.
    np.testing.assert_array_equal(batch.state[:, 6], np.ones(5))
    batch.state[3, 2] = 1.5  # a write through the view is the lane's state
    assert batch.state[3, 2] == 1.5
    assert batch.rotor_speeds.shape == (5, 4)
    assert not batch.rotor_speeds.flags.writeable
    assert batch.rotor_speed_reference.flags.writeable
    assert batch.wind.shape == (5, 3)
    f32 = dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=3, dtype=np.float32)
    assert f32.state.dtype == np.float32 and f32.state.shape == (3, 13)
    # 1024 lanes: rows padded to an odd number of 64-byte lines (docs/batch.md, "Layout"); the
    # view's strides follow, so lane 1023 is still row 1023.
    big = dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=1024, dtype=np.float32)
    item, row = big.state.strides
    assert item == 4 and row >= 1024 * 4 and row % 64 == 0 and (row // 64) % 2 == 1
    x = np.arange(13, dtype=np.float64) / 8.0
    x[6:10] = [1.0, 0.0, 0.0, 0.0]
    big.reset([1023], x[None, :], None)  # written by the engine at k * stride + 1023
    np.testing.assert_array_equal(big.state[1023], x.astype(np.float32))
    np.testing.assert_array_equal(big.state[1022, :3], np.zeros(3, dtype=np.float32))


def test_every_lane_equals_the_simulator_bit_for_bit(qdrone2):
    """Lanes with different masses, winds and references against one Simulator each."""
    n = 6
    rng = np.random.default_rng(3)
    hover = qdrone2.hover_speeds_rad_s()
    starts = [dt.Simulator.hover_state([0.0, 0.0, 1.0 + 0.1 * k], 0.3 * k) for k in range(n)]
    refs = hover * (1.0 + 0.01 * rng.standard_normal((n, 4)))
    winds = rng.standard_normal((n, 3))
    masses = qdrone2.mass_kg * (1.0 + 0.05 * rng.standard_normal(n))
    batch = dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=n, num_threads=2)
    batch.set_parameter("mass", masses)
    batch.reset(None, np.array(starts), np.tile(hover, (n, 1)))
    batch.rotor_speed_reference[:] = refs
    batch.wind[:] = winds
    assert batch.step(1500) == 0
    for k in range(n):
        spec = qdrone2.spec
        spec.mass_kg = masses[k]
        cfg = dt.SimConfig()
        cfg.environment.wind_W_m_s = winds[k]
        sim = dt.Simulator(dt.VehicleModel(spec), cfg)
        sim.reset(starts[k], hover)
        sim.set_rotor_speed_reference(refs[k])
        sim.step(1500)
        np.testing.assert_array_equal(batch.state[k], sim.state)
    np.testing.assert_array_equal(batch.step_count, np.full(n, 1500))


def test_rotor_faults_act_in_every_lane_on_its_own_clock(qdrone2):
    """The config's faults in every lane, from its own reset, as in a Simulator with them."""
    n = 3
    hover = qdrone2.hover_speeds_rad_s()
    cfg = dt.SimConfig()
    cfg.faults = [dt.RotorFault.degraded(0, 0.2, 0.5), dt.RotorFault.stop(2, 0.4),
                  dt.RotorFault.stuck(1, 0.1)]
    starts = np.array([dt.Simulator.hover_state([0.3 * k, 0.0, 10.0]) for k in range(n)])
    refs = hover * (1.0 + 0.02 * np.arange(n))[:, None]
    batch = dt.BatchSimulator(qdrone2, cfg, num_vehicles=n, num_threads=2)
    batch.reset(None, starts, np.tile(hover, (n, 1)))
    batch.rotor_speed_reference[:] = refs
    assert batch.step(300) == 0
    batch.reset(1, starts[1], hover)  # lane 1 starts again: its faults with it
    batch.rotor_speed_reference[1] = refs[1]
    assert batch.step(400) == 0
    for k, steps in ((0, 700), (1, 400), (2, 700)):
        sim = dt.Simulator(qdrone2, cfg)
        sim.reset(starts[k], hover)
        sim.set_rotor_speed_reference(refs[k])
        sim.step(steps)
        np.testing.assert_allclose(batch.state[k], sim.state, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(batch.rotor_speeds[k], sim.rotor_speeds_rad_s, rtol=1e-12)
    assert batch.rotor_speeds[0, 2] < 0.3 * hover[2]  # stopped at 0.4 s


def test_a_lane_with_a_nan_written_into_it_stops_alone(qdrone2):
    batch = dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=4)
    hover = qdrone2.hover_speeds_rad_s()
    batch.reset(None, dt.Simulator.hover_state([0, 0, 1]), hover)
    batch.rotor_speed_reference[:] = hover
    batch.state[1, 0] = np.nan
    batch.rotor_speed_reference[2, 0] = np.inf
    assert batch.step(10) == 2
    assert batch.status[1] == int(dt.StepStatus.INVALID_STATE)
    assert batch.status[2] == int(dt.StepStatus.INVALID_INPUT)
    np.testing.assert_array_equal(batch.step_count, [10, 0, 0, 10])
    batch.reset([1, 2], dt.Simulator.hover_state([0, 0, 1]), hover)
    batch.rotor_speed_reference[2] = hover
    assert batch.step(10) == 0


def test_parameters_by_name_and_their_errors(qdrone2):
    batch = dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=3)
    batch.set_parameter("thrust_k1", 1.1 * batch.parameter("thrust_k1")[0], lanes=[2])
    k1 = batch.parameter("thrust_k1")
    assert k1[0] == k1[1] and k1[2] == pytest.approx(1.1 * k1[0])
    with pytest.raises(ValueError, match="unknown parameter 'massive'"):
        batch.set_parameter("massive", 1.0)
    with pytest.raises(ValueError, match="group"):
        batch.set_parameter("thrust", 1.0)
    with pytest.raises(ValueError, match=r"mass\[lane 0\]: expected > 0"):
        batch.set_parameter("mass", -1.0)
    with pytest.raises(ValueError, match="one per lane addressed"):
        batch.set_parameter("mass", [1.0, 2.0])
    with pytest.raises(ValueError, match="lane 7 is out of range"):
        batch.reset(7, dt.Simulator.hover_state([0, 0, 1]))
    with pytest.raises(ValueError, match="num_vehicles"):
        dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=0)
    with pytest.raises(ValueError, match="dtype"):
        dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=2, dtype=np.int32)


def test_two_python_threads_stepping_one_batch_are_refused(qdrone2):
    batch = dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=4096)
    batch.reset(None, dt.Simulator.hover_state([0, 0, 1]), qdrone2.hover_speeds_rad_s())
    errors = []

    def run():
        try:
            for _ in range(20):
                batch.step(50)
        except RuntimeError as e:
            errors.append(str(e))

    threads = [threading.Thread(target=run) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    # Either the two threads overlapped (and one was told so) or they never did; the step
    # counts say every step that ran was counted once.
    counts = batch.step_count
    assert np.all(counts == counts[0])
    assert counts[0] % 50 == 0
    for e in errors:
        assert "BatchSimulator::step" in e


def test_noise_gives_a_read_only_measured_state_seeded_per_lane(qdrone2):
    cfg = dt.SimConfig()
    cfg.noise.enabled = True
    cfg.seed = 4
    hover = qdrone2.hover_speeds_rad_s()
    batch = dt.BatchSimulator(qdrone2, cfg, num_vehicles=6, num_threads=2)
    assert batch.noise_enabled
    batch.reset(None, dt.Simulator.hover_state([0, 0, 1]), hover)
    np.testing.assert_array_equal(batch.measured_state, batch.state)  # zero noise after reset
    batch.set_seed([10, 11, 12], lanes=[0, 1, 2])
    np.testing.assert_array_equal(batch.seeds(), [10, 11, 12, 4, 4, 4])
    batch.step(200)
    noise = batch.measured_state - batch.state
    assert not batch.measured_state.flags.writeable
    # Thesis Sigma = B(0.005, 0.003): after 200 steps every element has moved, no two lanes alike.
    assert np.all(np.abs(noise).max(axis=1) > 1e-4)
    assert len({row.tobytes() for row in noise}) == 6
    # A lane's noise depends on its seed, index and step count only: a batch of one agrees.
    one = dt.BatchSimulator(qdrone2, cfg, num_vehicles=1)
    one.set_seed(10)
    one.reset(0, dt.Simulator.hover_state([0, 0, 1]), hover)
    one.step(200)
    np.testing.assert_array_equal(one.measured_state[0], batch.measured_state[0])
    with pytest.raises(ValueError, match=r"seeds\[1\]: expected an integer in \[0, 2\*\*64\), got -3"):
        batch.set_seed([1, -3], lanes=[0, 1])
    with pytest.raises(ValueError, match="expected one seed or 2"):
        batch.set_seed([1, 2, 3], lanes=[0, 1])


def test_batched_se3_flies_every_lane_to_its_setpoint_like_the_closed_loop(qdrone2):
    n = 5
    gains, options = flying_se3()
    batch = dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=n, num_threads=2)
    se3 = dt.BatchSe3Controller(qdrone2, gains, options, n)
    batch.reset(None, dt.Simulator.hover_state([0, 0, 1]), qdrone2.hover_speeds_rad_s())
    targets = np.array([[0.2 * k, -0.1 * k, 1.5] for k in range(n)])
    se3.reference[:, 0:3] = targets
    se3.set_reference(4, [1.0, 1.0, 2.0], yaw=0.5)
    targets[4] = [1.0, 1.0, 2.0]
    np.testing.assert_allclose(se3.reference[4, 9:11], [np.cos(0.5), np.sin(0.5)])
    assert batch.step(5000, se3) == 0
    np.testing.assert_allclose(batch.state[:, 0:3], targets, atol=5e-3)
    # Lane 4 against the scalar controller through ClosedLoop at the physics rate.
    sim = dt.Simulator(qdrone2, dt.SimConfig())
    sim.reset(dt.Simulator.hover_state([0, 0, 1]), qdrone2.hover_speeds_rad_s())
    ctrl = dt.Se3Controller(qdrone2, gains, options)
    loop = dt.ClosedLoop(sim, ctrl, dt.SetpointReference([1.0, 1.0, 2.0], 0.5), 1000.0)
    loop.run(5.0)
    np.testing.assert_allclose(batch.state[4], sim.state, rtol=0, atol=1e-12)
    with pytest.raises(TypeError, match="batched controller of the batch's dtype"):
        batch.step(1, "se3")
    f32 = dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=n, dtype=np.float32)
    with pytest.raises(TypeError, match="float32"):
        f32.step(1, se3)


def test_generalized_forces_for_every_lane_flag_saturation(qdrone2):
    batch = dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=3)
    weight = qdrone2.mass_kg * 9.81
    u = np.array([[weight, 0, 0, 0], [weight, 5.0, 0, 0], [np.nan, 0, 0, 0]])
    flags = batch.set_generalized_forces(u)
    np.testing.assert_array_equal(flags, [0, 1, 2])
    np.testing.assert_allclose(batch.rotor_speed_reference[0], qdrone2.hover_speeds_rad_s(), rtol=1e-12)
    with pytest.raises(ValueError, match=r"expected shape \(3, 4\)"):
        batch.set_generalized_forces(np.zeros((2, 4)))


def test_batched_body_rates_equal_the_scalar_controller_in_a_closed_loop(qdrone2):
    n = 4
    # Without the aerodynamic moments the rate loop is the first-order law w' = K (w_cmd - w):
    # after 0.5 s (10 time constants in roll and pitch) the rates sit on their commands.
    cfg = dt.SimConfig()
    cfg.disturbances = dt.DisturbanceSwitches.none()
    batch = dt.BatchSimulator(qdrone2, cfg, num_vehicles=n)
    rates = dt.BatchBodyRateController(qdrone2, dt.BodyRateGains(), n)
    hover = qdrone2.hover_speeds_rad_s()
    batch.reset(None, dt.Simulator.hover_state([0, 0, 3]), hover)
    thrust = qdrone2.mass_kg * 9.81
    commands = np.array([[thrust, 0.5 * k, -0.2 * k, 0.3] for k in range(n)])
    rates.command[:] = commands
    assert batch.step(500, rates) == 0
    sim = dt.Simulator(qdrone2, cfg)
    sim.reset(dt.Simulator.hover_state([0, 0, 3]), hover)
    scalar = dt.BodyRateController(qdrone2)
    scalar.set_command(commands[2, 0], commands[2, 1:])
    dt.ClosedLoop(sim, scalar, dt.SetpointReference([0, 0, 0]), 1000.0).run(0.5)
    np.testing.assert_array_equal(batch.state[2], sim.state)
    np.testing.assert_allclose(batch.state[:, 10:12], commands[:, 1:3], atol=1e-3)
    rates.command[1, 0] = np.nan
    assert batch.step(1, rates) == 1
    assert batch.status[1] == int(dt.StepStatus.CONTROLLER_FAILED)
    with pytest.raises(ValueError, match="thrust"):
        rates.set_command(0, -1.0, [0, 0, 0])


def test_batched_pid_equals_the_scalar_pid_in_a_closed_loop(qdrone2):
    n = 3
    gains = dt.PidGains.thesis_simulation()
    options = dt.PidOptions()
    options.max_tilt_rad = 0.2
    batch = dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=n)
    pid = dt.BatchCascadedPid(qdrone2, gains, options, batch.dt_s, n)
    batch.reset(None, dt.Simulator.hover_state([0, 0, 1]), qdrone2.hover_speeds_rad_s())
    pid.reference[:, 0:3] = [[0.3, 0.0, 1.2], [0.0, -0.3, 1.0], [0.2, 0.2, 0.8]]
    assert batch.step(2000, pid) == 0
    sim = dt.Simulator(qdrone2, dt.SimConfig())
    sim.reset(dt.Simulator.hover_state([0, 0, 1]), qdrone2.hover_speeds_rad_s())
    scalar = dt.CascadedPid(qdrone2, gains, options, 1e-3)
    loop = dt.ClosedLoop(sim, scalar, dt.SetpointReference([0.2, 0.2, 0.8]), 1000.0)
    for _ in range(2000):
        loop.step()
    np.testing.assert_array_equal(batch.state[2], sim.state)
    np.testing.assert_array_equal(pid.integral[2], scalar.integral)
    assert not pid.integral.flags.writeable
    pid.reset_integral(2)
    np.testing.assert_array_equal(pid.integral[2], np.zeros(4))


def test_batched_pid_with_feed_forward_equals_the_scalar_pid_on_a_moving_reference(qdrone2):
    options = dt.PidOptions()
    options.max_tilt_rad = 0.6
    options.velocity_feedforward = True
    options.acceleration_feed_forward = True
    options.angular_feed_forward = True
    options.drag_feed_forward = True
    gains = dt.PidGains.thesis_simulation()
    point = dt.ReferencePoint([0.5, -0.2, 1.2], [0.4, 0.1, 0.0], [0.8, -0.5, 0.2], 0.3, 0.2)
    point.jerk_m_s3 = np.array([0.5, 0.3, -0.1])
    point.snap_m_s4 = np.array([-1.0, 0.4, 0.2])
    point.yaw_acceleration_rad_s2 = 0.1

    class Fixed(dt.Reference):
        def at(self, t_s):
            return point

    batch = dt.BatchSimulator(qdrone2, dt.SimConfig(), num_vehicles=2)
    pid = dt.BatchCascadedPid(qdrone2, gains, options, batch.dt_s, 2)
    assert pid.reference.shape == (2, 17)
    pid.set_reference(1, point)
    # Without drag feed-forward the acceleration columns are the reference's; with it they add
    # the acceleration that cancels the drag, which points along the velocity.
    options.drag_feed_forward = False
    plain = dt.BatchCascadedPid(qdrone2, gains, options, 1e-3, 2)
    options.drag_feed_forward = True
    plain.set_reference(1, point)
    np.testing.assert_array_equal(plain.reference[1, 8:11], point.acceleration_m_s2)
    drag_part = pid.reference[1, 8:11] - point.acceleration_m_s2
    assert np.dot(drag_part, point.velocity_m_s) > 0.0
    assert np.any(pid.reference[1, 11:17] != 0.0), "the flat body rates and accelerations are set"
    assert np.all(pid.reference[0, 8:17] == 0.0), "lane 0 keeps its own reference"
    batch.reset(None, dt.Simulator.hover_state([0, 0, 1]), qdrone2.hover_speeds_rad_s())
    assert batch.step(1500, pid) == 0
    sim = dt.Simulator(qdrone2, dt.SimConfig())
    sim.reset(dt.Simulator.hover_state([0, 0, 1]), qdrone2.hover_speeds_rad_s())
    scalar = dt.CascadedPid(qdrone2, gains, options, 1e-3)
    loop = dt.ClosedLoop(sim, scalar, Fixed(), 1000.0)
    for _ in range(1500):
        loop.step()
    np.testing.assert_array_equal(batch.state[1], sim.state)
    with pytest.raises(ValueError, match="lane 2 is out of range"):
        pid.set_reference(2, point)
