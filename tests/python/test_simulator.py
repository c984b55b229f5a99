"""The Simulator from Python: numpy views, determinism, threads, physics checks, errors."""

import copy
import gc
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import dronetwin as dt
from conftest import source_path

G = 9.81


def hovering(model, config=None, z=1.0):
    sim = dt.Simulator(model, config or dt.SimConfig())
    w = model.hover_speeds_rad_s()
    sim.reset(dt.Simulator.hover_state([0.0, 0.0, z]), w)
    sim.set_rotor_speed_reference(w)
    return sim


def thrustless(model):
    """The QDrone2 with no thrust at rest ('K3 = 0) and no frame drag: stopped rotors, free fall."""
    spec = model.spec
    rotors = spec.rotors
    for r in rotors:
        r.thrust_coefficients = [r.thrust_coefficients[0], 0.0, 0.0]
    spec.rotors = rotors
    spec.body_drag_Ns_per_m = np.zeros((3, 3))
    return dt.VehicleModel(spec)


def test_free_fall_matches_the_analytic_solution(qdrone2):
    # Rotors stopped, no drag: z(t) = z0 - g t^2 / 2 (RK4 integrates a quadratic exactly).
    sim = dt.Simulator(thrustless(qdrone2))
    sim.reset(dt.Simulator.hover_state([0.0, 0.0, 100.0]))
    sim.step(2000)
    t = sim.time_s
    assert t == pytest.approx(2.0)
    assert sim.state[2] == pytest.approx(100.0 - 0.5 * G * t * t, abs=1e-9)
    assert sim.state[5] == pytest.approx(-G * t, abs=1e-9)


def test_hover_holds_position(qdrone2):
    config = dt.SimConfig()
    config.disturbances.ground_effect = False
    sim = hovering(qdrone2, config)
    assert sim.step(5000).ok
    assert np.abs(sim.state[:3] - [0.0, 0.0, 1.0]).max() < 1e-6


def test_state_is_a_live_view_onto_the_simulator(qdrone2):
    sim = hovering(qdrone2)
    view = sim.state
    assert view.dtype == np.float64 and view.shape == (13,)
    assert not view.flags.owndata
    z_before = view[2]
    sim.set_rotor_speed_reference(np.zeros(4))
    sim.step(100)
    assert view[2] < z_before  # the same array now shows the falling vehicle
    assert view[2] == sim.state[2]


def test_writes_through_the_state_view_reach_the_simulator(qdrone2):
    sim = hovering(qdrone2)
    sim.state[0] = 3.0  # move the vehicle 3 m along x
    sim.step(1)
    assert sim.state[0] == pytest.approx(3.0, abs=1e-6)
    assert sim.measured_state[0] == pytest.approx(3.0, abs=1e-6)  # refreshed by the step


def test_rotor_reference_view_actuates(qdrone2):
    sim = hovering(qdrone2)
    sim.rotor_speed_reference_rad_s[:] = 0.0  # zero-copy command: cut the motors
    sim.step(300)
    assert sim.state[5] < -1.0
    assert np.all(sim.rotor_speeds_rad_s < 0.5 * qdrone2.hover_speeds_rad_s())


def test_read_only_views_refuse_writes(qdrone2):
    sim = hovering(qdrone2)
    with pytest.raises(ValueError):
        sim.measured_state[0] = 1.0
    with pytest.raises(ValueError):
        sim.rotor_speeds_rad_s[0] = 1.0


def test_views_keep_the_simulator_alive(qdrone2):
    sim = hovering(qdrone2, z=2.5)
    view = sim.state
    del sim
    gc.collect()
    assert view[2] == pytest.approx(2.5)  # memory still owned by the (unreachable) simulator
    assert view.base is not None


def test_measured_state_is_noisy_only_with_noise_on(qdrone2):
    quiet = hovering(qdrone2)
    quiet.step(50)
    assert np.array_equal(quiet.measured_state, quiet.state)
    noisy = hovering(qdrone2, dt.SimConfig(noise=True, seed=4))
    noisy.step(50)
    assert not np.array_equal(noisy.measured_state, noisy.state)
    assert np.abs(noisy.measured_state - noisy.state).max() < 0.5


def run_noisy(model, seed, steps=3000):
    sim = hovering(model, dt.SimConfig(noise=True, seed=seed))
    sim.step(steps)
    return sim.state.copy(), sim.measured_state.copy()


def test_same_seed_gives_bitwise_identical_runs(qdrone2):
    a = run_noisy(qdrone2, 11)
    b = run_noisy(qdrone2, 11)
    c = run_noisy(qdrone2, 12)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert not np.array_equal(a[1], c[1])


def test_copies_are_independent_and_continue_identically(qdrone2):
    sim = hovering(qdrone2, dt.SimConfig(noise=True, seed=3))
    sim.step(100)
    twin = copy.deepcopy(sim)
    sim.step(500)
    assert twin.step_count == 100
    twin.step(500)
    assert np.array_equal(sim.state, twin.state)
    assert np.array_equal(sim.measured_state, twin.measured_state)


def test_threads_step_in_parallel_with_identical_results(qdrone2):
    # step(n) releases the GIL: simulators on several threads give the same bits as in sequence.
    seeds = [1, 2, 3, 4]
    sequential = [run_noisy(qdrone2, s, 4000) for s in seeds]
    sims = [hovering(qdrone2, dt.SimConfig(noise=True, seed=s)) for s in seeds]
    threads = [threading.Thread(target=s.step, args=(4000,)) for s in sims]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for sim, (state, measured) in zip(sims, sequential):
        assert np.array_equal(sim.state, state)
        assert np.array_equal(sim.measured_state, measured)


def test_wrench_breakdown_at_hover_sums_to_zero(qdrone2):
    config = dt.SimConfig()
    config.disturbances.ground_effect = False
    sim = hovering(qdrone2, config, z=5.0)
    b = sim.wrench_breakdown()
    assert b["thrust"][2] == pytest.approx(qdrone2.mass_kg * G, rel=1e-12)
    assert b["gravity"][2] == pytest.approx(-qdrone2.mass_kg * G, rel=1e-12)
    assert np.abs(b["total"]).max() < 1e-9
    assert np.allclose(sum(v for k, v in b.items() if k != "total"), b["total"], atol=1e-12)


def test_state_derivative_at_hover_is_zero(qdrone2):
    config = dt.SimConfig()
    config.disturbances.ground_effect = False
    sim = hovering(qdrone2, config, z=5.0)
    xdot = sim.state_derivative()
    assert xdot.shape == (13,)
    assert np.abs(xdot).max() < 1e-9


def test_bad_inputs_raise_clear_errors(qdrone2):
    sim = hovering(qdrone2)
    with pytest.raises(TypeError, match=r"float64 array of shape \(4,\).*an int64 array"):
        sim.set_rotor_speed_reference(np.array([1, 2, 3, 4]))
    with pytest.raises(ValueError, match=r"shape \(4,\).*length 3"):
        sim.set_rotor_speed_reference([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match=r"shape \(4,\).*shape \(2,2\)"):
        sim.set_rotor_speed_reference(np.ones((2, 2)))
    with pytest.raises(ValueError, match="finite"):
        sim.set_rotor_speed_reference([1000.0, float("nan"), 1000.0, 1000.0])
    with pytest.raises(ValueError, match=r"state\[6:10\]"):
        sim.set_state(np.zeros(13))
    with pytest.raises(TypeError, match=r"set_generalized_force\[1\]: expected a number"):
        sim.set_generalized_force([1.0, "x", 0.0, 0.0])
    with pytest.raises(ValueError, match="dt_s"):
        dt.SimConfig(dt_s=-1.0)


def test_divergence_is_reported_and_stops_the_run(qdrone2):
    config = dt.SimConfig()
    config.divergence.max_speed_m_s = 1.0
    sim = dt.Simulator(thrustless(qdrone2), config)
    sim.reset(dt.Simulator.hover_state([0.0, 0.0, 50.0]))
    result = sim.step(1000)
    # Falling from rest exceeds 1 m/s after 1 / g = 0.102 s: the step that would cross is refused.
    assert result.status == dt.StepStatus.DIVERGED
    assert result.steps_taken == int(1.0 / G / 1e-3)
    assert "|v|" in sim.failure_message and "limit 1)" in sim.failure_message
    assert np.all(np.isfinite(sim.state))
    with pytest.raises(RuntimeError, match="reset"):
        sim.step()
    sim.reset(dt.Simulator.hover_state([0.0, 0.0, 50.0]))
    assert sim.step().ok


def test_non_finite_state_written_through_the_view_is_caught(qdrone2):
    sim = hovering(qdrone2)
    sim.rotor_speed_reference_rad_s[0] = np.nan  # unchecked path
    result = sim.step(5)
    assert result.status != dt.StepStatus.OK
    assert np.all(np.isfinite(sim.state))


def test_help_is_useful():
    doc = dt.Simulator.__doc__
    assert "deterministic" in doc and "view" in doc
    assert dt.Simulator.step.__doc__ and dt.ClosedLoop.record.__doc__


class _Parked(dt.ControllerBase):
    """Hovers; on its first call it says so and waits until released, holding its loop mid-run."""

    def __init__(self, model):
        super().__init__(model)
        self.inside, self.release = threading.Event(), threading.Event()

    def calculate_actuator_cmd(self, inp):
        if not self.inside.is_set():
            self.inside.set()
            assert self.release.wait(60.0)
        return self.model.hover_speeds_rad_s()


def _parked_run(model):
    sim = hovering(model)
    ctrl = _Parked(model)
    loop = dt.ClosedLoop(sim, ctrl, dt.SetpointReference([0.0, 0.0, 1.0]), 100.0)
    return sim, ctrl, loop


def test_a_simulator_in_use_by_another_thread_says_so_and_is_not_corrupted(qdrone2):
    # The reference: the same run with nobody interfering.
    sim_ref, ctrl_ref, loop_ref = _parked_run(qdrone2)
    ctrl_ref.release.set()
    assert loop_ref.run(0.2).ok

    sim, ctrl, loop = _parked_run(qdrone2)
    results = []
    worker = threading.Thread(target=lambda: results.append(loop.run(0.2)))
    worker.start()
    try:
        assert ctrl.inside.wait(60.0)
        # The worker's loop holds the simulator and the controller: every use from here is refused.
        with pytest.raises(RuntimeError, match="in use by another thread"):
            sim.step()
        with pytest.raises(RuntimeError, match="in use by another thread"):
            sim.step(100)
        with pytest.raises(RuntimeError, match="in use by another thread"):
            sim.reset(dt.Simulator.hover_state([0.0, 0.0, 3.0]))
        with pytest.raises(RuntimeError, match="in use by another thread"):
            loop.run(0.1)
    finally:
        ctrl.release.set()
        worker.join(60.0)
    assert results and results[0].ok
    # Nothing the refused calls tried reached the run: bitwise the undisturbed flight.
    np.testing.assert_array_equal(sim.state, sim_ref.state)
    assert sim.time_s == sim_ref.time_s
    # Free again once the loop is done.
    assert sim.step().ok


def test_step_n_can_be_interrupted(tmp_path):
    # Ctrl-C (SIGINT) reaches a long step(n): it raises KeyboardInterrupt within a chunk of steps.
    script = tmp_path / "long_step.py"
    script.write_text(
        "import sys, dronetwin as dt\n"
        f"model = dt.load_model({source_path('models', 'qdrone2.yaml')!r})\n"
        "sim = dt.Simulator(model, dt.SimConfig())\n"
        "sim.reset(dt.Simulator.hover_state([0, 0, 1]), model.hover_speeds_rad_s())\n"
        "print('stepping', flush=True)\n"
        "try:\n"
        "    sim.step(10**11)\n"  # ~8 hours of wall time if never interrupted
        "except KeyboardInterrupt:\n"
        "    print('interrupted at', sim.time_s, flush=True)\n"
        "    sys.exit(7)\n")
    child = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True,
                             env=dict(os.environ))
    try:
        assert child.stdout.readline().strip() == "stepping"
        time.sleep(0.5)
        child.send_signal(signal.SIGINT)
        out, _ = child.communicate(timeout=120)
    finally:
        if child.poll() is None:
            child.kill()
    assert child.returncode == 7, out
    assert out.startswith("interrupted at")
    assert 0.0 < float(out.split()[-1]) < 1e7


def test_hover_state_refuses_non_finite_values():
    with pytest.raises(ValueError, match="hover_state: position.*finite"):
        dt.Simulator.hover_state([float("nan"), 0.0, 1.0])
    with pytest.raises(ValueError, match="yaw"):
        dt.Simulator.hover_state([0.0, 0.0, 1.0], float("inf"))


def test_a_zero_quaternion_written_through_the_view_is_refused_at_the_next_step(qdrone2):
    sim = hovering(qdrone2)
    before = sim.state.copy()
    sim.state[6:10] = 0.0
    result = sim.step()
    assert result.status == dt.StepStatus.INVALID_STATE
    assert result.steps_taken == 0
    assert "quaternion" in sim.failure_message
    assert sim.time_s == 0.0
    with pytest.raises(RuntimeError, match="reset"):
        sim.step()
    sim.reset(before)
    assert sim.step().ok
