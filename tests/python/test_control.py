"""Controllers from Python: Python subclasses of ControllerBase fly the C++ simulator; the C++
controllers and references are usable directly."""

import numpy as np
import pytest

import dronetwin as dt
from conftest import source_path

G = 9.81


class PythonGeometric(dt.ControllerBase):
    """A position + attitude controller written in Python (the SE(3) law of thesis Eq. 3.27-3.28
    with gravity compensation; gains chosen for a ~1 s position response on the QDrone2)."""

    def __init__(self, model, kp=6.0, kd=4.5, kr=6.0, kw=1.2):
        super().__init__(model)
        self.m = model.mass_kg
        self.kp, self.kd, self.kr, self.kw = kp, kd, kr, kw
        self.calls = 0

    def name(self):
        return "python_geometric"

    def calculate_u(self, inp):
        self.calls += 1
        x, ref = inp.state, inp.reference
        p, v = x[0:3], x[3:6]
        qw, qx, qy, qz = x[6:10] / np.linalg.norm(x[6:10])
        R = np.array([
            [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qw * qz), 2 * (qx * qz + qw * qy)],
            [2 * (qx * qy + qw * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qw * qx)],
            [2 * (qx * qz - qw * qy), 2 * (qy * qz + qw * qx), 1 - 2 * (qx * qx + qy * qy)]])
        F = self.m * (self.kp * (ref.position_m - p) + self.kd * (ref.velocity_m_s - v)
                      + ref.acceleration_m_s2 + np.array([0.0, 0.0, G]))
        b3 = F / np.linalg.norm(F)
        b1d = np.array([np.cos(ref.yaw_rad), np.sin(ref.yaw_rad), 0.0])
        b2 = np.cross(b3, b1d)
        b2 /= np.linalg.norm(b2)
        Rd = np.column_stack([np.cross(b2, b3), b2, b3])
        E = 0.5 * (Rd.T @ R - R.T @ Rd)
        e_R = np.array([E[2, 1], E[0, 2], E[1, 0]])
        w = x[10:13]
        J = self.model.inertia_kgm2
        M = -self.kr * e_R - self.kw * w + np.cross(w, J @ w)
        return np.array([F @ R[:, 2], M[0], M[1], M[2]])


class HoverSpeeds(dt.ControllerBase):
    """Commands the rotors directly (calculate_actuator_cmd only)."""

    def calculate_actuator_cmd(self, inp):
        return self.model.hover_speeds_rad_s()


def start_hovering(model, z=1.0, config=None):
    sim = dt.Simulator(model, config or dt.SimConfig())
    sim.reset(dt.Simulator.hover_state([0.0, 0.0, z]), model.hover_speeds_rad_s())
    return sim


def test_python_controller_tracks_a_setpoint(qdrone2):
    sim = start_hovering(qdrone2)
    ctrl = PythonGeometric(qdrone2)
    target = np.array([0.5, -0.3, 1.5])
    loop = dt.ClosedLoop(sim, ctrl, dt.SetpointReference(target), 200.0)
    log = loop.record(8.0, every_n_steps=10)
    assert log["status"] == dt.StepStatus.OK
    assert np.linalg.norm(sim.state[:3] - target) < 0.02
    assert np.abs(sim.state[3:6]).max() < 0.02
    # It ran at the configured control rate: one call at t = 0 and one per 5 ms.
    assert ctrl.calls == 8.0 * 200.0 + 1
    assert loop.control_updates == ctrl.calls
    assert ctrl.name() == "python_geometric"


def test_python_controller_hovers_under_noise(qdrone2):
    sim = start_hovering(qdrone2, 1.0, dt.SimConfig(noise=True, seed=5))
    loop = dt.ClosedLoop(sim, PythonGeometric(qdrone2), dt.SetpointReference([0.0, 0.0, 1.0]), 100.0)
    log = loop.record(5.0, every_n_steps=10)
    assert dt.rmse(log, window_s=(1.0, 5.0))[:3].max() < 0.05


def test_rotor_speed_level_python_controller(qdrone2):
    ctrl = HoverSpeeds(qdrone2)
    assert ctrl.level() == dt.ControlLevel.ROTOR_SPEED
    assert ctrl.name() == "HoverSpeeds"
    config = dt.SimConfig()
    config.disturbances.ground_effect = False
    sim = start_hovering(qdrone2, 3.0, config)
    loop = dt.ClosedLoop(sim, ctrl, dt.SetpointReference([0.0, 0.0, 3.0]), 100.0)
    loop.run(2.0)
    assert abs(sim.state[2] - 3.0) < 1e-6


class ReturnsNaN(dt.ControllerBase):
    def calculate_u(self, inp):
        return [float("nan"), 0.0, 0.0, 0.0]


class WrongLength(dt.ControllerBase):
    def calculate_u(self, inp):
        return [1.0, 0.0]


class Raises(dt.ControllerBase):
    def calculate_u(self, inp):
        raise KeyError("inside the controller")


def test_bad_python_controllers_are_reported_not_flown(qdrone2):
    ref = dt.SetpointReference([0.0, 0.0, 1.0])
    sim = start_hovering(qdrone2)
    with pytest.raises(RuntimeError, match="ReturnsNaN.*non-finite"):
        dt.ClosedLoop(sim, ReturnsNaN(qdrone2), ref, 100.0).step()
    with pytest.raises(ValueError, match=r"calculate_u result: expected .*shape \(4,\).*length 2"):
        dt.ClosedLoop(sim, WrongLength(qdrone2), ref, 100.0).step()
    with pytest.raises(KeyError, match="inside the controller"):
        dt.ClosedLoop(sim, Raises(qdrone2), ref, 100.0).run(1.0)
    assert np.all(np.isfinite(sim.state))


def test_a_controller_without_an_implementation_says_so(qdrone2):
    sim = start_hovering(qdrone2)
    with pytest.raises(Exception, match="calculate_u"):
        dt.ClosedLoop(sim, dt.ControllerBase(qdrone2), dt.SetpointReference([0, 0, 1]), 100.0).step()


def test_python_reference_subclass(qdrone2):
    class Climb(dt.Reference):
        def at(self, t):
            return dt.ReferencePoint([0.0, 0.0, 1.0 + 0.1 * t], velocity_m_s=[0.0, 0.0, 0.1])

        def describe(self):
            return "climb at 0.1 m/s"

    sim = start_hovering(qdrone2)
    loop = dt.ClosedLoop(sim, PythonGeometric(qdrone2), Climb(), 100.0)
    log = loop.record(6.0, every_n_steps=100)
    assert log["reference"][-1, 2] == pytest.approx(1.6)
    assert abs(sim.state[2] - 1.6) < 0.02


def test_pid_built_in_python_equals_pid_from_file(qdrone2):
    from_file = dt.load_controller(source_path("config", "controllers", "pid_tuned.yaml"), qdrone2, 1000.0)
    assert isinstance(from_file, dt.CascadedPid)
    built = dt.CascadedPid(qdrone2, from_file.gains, from_file.options, 1e-3)
    logs = []
    for ctrl in (from_file, built):
        sim = start_hovering(qdrone2, 1.0, dt.SimConfig(noise=True, seed=9))
        logs.append(dt.ClosedLoop(sim, ctrl, dt.PiecewiseConstantReference.thesis_pulse(), 1000.0).record(3.0))
    for key in ("state", "measured_state", "u", "rotor_speed_reference_rad_s"):
        assert np.array_equal(logs[0][key], logs[1][key]), key


def test_thesis_references_follow_their_equations():
    eight = dt.FigureEightReference()
    t = 7.5
    p = eight.at(t).position_m
    # Eq. 3.25
    assert p[0] == pytest.approx(0.8 * np.sin(2 * np.pi * t / 60))
    assert p[1] == pytest.approx(0.6 * np.sin(4 * np.pi * t / 60))
    assert p[2] == pytest.approx(1.2)
    circle = dt.CircleReference()
    assert np.linalg.norm(circle.at(1.3).position_m[:2] - [0.0, 0.0]) == pytest.approx(2.0)


def test_unknown_controller_type_is_named(qdrone2):
    with pytest.raises(ValueError, match="type"):
        dt.controller_from_yaml("type: lqr\n", qdrone2, 100.0, "mine.yaml")


def test_nmpc_from_python_exposes_its_plan_and_solve_statistics(qdrone2):
    nmpc = dt.load_controller(source_path("config", "controllers", "nmpc.yaml"), qdrone2, 1000.0)
    assert isinstance(nmpc, dt.NmpcController)
    n = nmpc.options.horizon_steps
    reference = dt.FigureEightReference()
    start = reference.at(0.0)
    sim = start_hovering(qdrone2, 1.2)
    state = dt.Simulator.hover_state(start.position_m)
    state[3:6] = start.velocity_m_s
    sim.reset(state, qdrone2.hover_speeds_rad_s())
    log = dt.ClosedLoop(sim, nmpc, reference, 1000.0).record(1.0, every_n_steps=10)
    assert log["status"] == dt.StepStatus.OK
    xs = nmpc.predicted_states()
    assert xs.shape == (n + 1, 13) and nmpc.predicted_inputs().shape == (n, 6)
    # The plan starts at the state the last solve saw: within one control period of now.
    assert abs(nmpc.plan_start_time_s - sim.time_s) <= nmpc.options.step_s + 1e-12
    stats = nmpc.last_solve()
    assert stats.termination != dt.NmpcTermination.FAILURE and stats.total_failures == 0
    assert stats.solve_index == 100  # solves at t = 0, 0.01, ..., 1.0
    names = log["diagnostic_names"]
    assert "solve_time_ms" in names and log["diagnostics"].shape == (len(log["t"]), len(names))
    assert np.all(log["diagnostics"][:, names.index("failed")] == 0)
    # nmpc.yaml's moment observer: on, and its estimate within its bound.
    assert nmpc.options.moment_observer_time_constant_s == 0.05
    md = nmpc.moment_disturbance_estimate
    assert md.shape == (3,) and np.linalg.norm(md) <= nmpc.options.max_moment_disturbance_Nm


def test_nmpc_falls_back_and_reports_it(qdrone2):
    nmpc = dt.load_controller(source_path("config", "controllers", "nmpc.yaml"), qdrone2, 1000.0)
    nmpc.inject_solve_failures(10, 1000)
    sim = start_hovering(qdrone2, 1.0)
    log = dt.ClosedLoop(sim, nmpc, dt.SetpointReference([0.0, 0.0, 1.0]), 1000.0).record(2.0, 10)
    assert log["status"] == dt.StepStatus.OK
    assert nmpc.mode != dt.NmpcMode.PLAN
    assert nmpc.last_solve().total_failures > 0
    assert np.abs(sim.state[:3] - [0.0, 0.0, 1.0]).max() < 0.1  # still flying safely


def test_python_reference_drives_a_previewing_controller(qdrone2):
    # ClosedLoop hands the NMPC a copy of the reference for its preview: a Python reference is
    # shared (not copied) and called back with the GIL.
    class Hold(dt.Reference):
        def __init__(self):
            super().__init__()
            self.calls = 0

        def at(self, t):
            self.calls += 1
            return dt.ReferencePoint([0.0, 0.0, 1.0])

    ref = Hold()
    nmpc = dt.load_controller(source_path("config", "controllers", "nmpc.yaml"), qdrone2, 1000.0)
    sim = start_hovering(qdrone2, 1.0)
    loop = dt.ClosedLoop(sim, nmpc, ref, 1000.0)
    loop.run(0.2)
    assert ref.calls > 200  # the loop and the preview over the horizon both asked
    assert abs(sim.state[2] - 1.0) < 0.01


class WithDiagnostics(PythonGeometric):
    def diagnostic_names(self):
        return ["thrust_N"]

    def diagnostics(self):
        return [self.last_thrust]

    def calculate_u(self, inp):
        u = super().calculate_u(inp)
        self.last_thrust = float(u[0])
        return u


def test_python_controller_diagnostics_are_recorded(qdrone2):
    sim = start_hovering(qdrone2)
    ctrl = WithDiagnostics(qdrone2)
    log = dt.ClosedLoop(sim, ctrl, dt.SetpointReference([0.0, 0.0, 1.0]), 100.0).record(0.5, 10)
    assert log["diagnostic_names"] == ["thrust_N"]
    assert np.allclose(log["diagnostics"][:, 0], log["u"][:, 0])


class TurnsNaN(dt.ControllerBase):
    """Hover thrust until t = 0.05 s, then NaN."""

    def calculate_u(self, inp):
        if inp.time_s >= 0.05 - 1e-12:
            return [float("nan"), 0.0, 0.0, 0.0]
        return [self.model.mass_kg * 9.81, 0.0, 0.0, 0.0]


def test_record_keeps_the_flight_up_to_a_failing_controller(qdrone2):
    sim = start_hovering(qdrone2)
    loop = dt.ClosedLoop(sim, TurnsNaN(qdrone2), dt.SetpointReference([0.0, 0.0, 1.0]), 1000.0)
    log = loop.record(1.0)
    assert log["status"] == dt.StepStatus.CONTROLLER_FAILED
    assert "TurnsNaN" in log["failure_message"] and "non-finite" in log["failure_message"]
    assert loop.failure_message == log["failure_message"]
    # rows at t = 0 .. 49 ms, then the last good state (t = 50 ms), nothing after
    assert log["t"].shape == (51,)
    np.testing.assert_allclose(log["t"], np.arange(51) * 1e-3, atol=1e-12)
    assert np.all(np.isfinite(log["state"]))


def test_rmse_is_the_runners_metric_to_the_bit(qdrone2, tmp_path):
    # The same flight through the runner (summary.json) and through the log it wrote
    # (dronetwin.rmse over its rows): identical numbers, window edges included.
    e = dt.load_experiment(source_path("config", "experiments", "se3_circle_noise_off.yaml"))
    e.duration_s = 3.0
    e.log.every_n_steps = 1  # a row at every physics step, where the runner takes its RMSE
    s = dt.run_experiment(e, str(tmp_path / "run"))
    log = dt.read_log(tmp_path / "run")
    record = {
        "t": log["t"],
        "state": np.column_stack([log[c] for c in dt.STATE_COLUMNS]),
        "reference": np.column_stack([log[c] for c in ("ref_x", "ref_y", "ref_z", "ref_yaw")]),
        "dt_s": e.physics_dt_s,
    }
    np.testing.assert_array_equal(dt.rmse(record), s.closed_loop.rmse)
    # a window whose ends fall on steps (and one a hair before a step) is the same in both
    for i, window in enumerate([(0.5, 2.0), (0.5 - 1e-13, 2.0)]):
        e.metrics.window_s = window
        w = dt.run_experiment(e, str(tmp_path / f"window{i}"))
        np.testing.assert_array_equal(dt.rmse(record, window_s=window), w.closed_loop.rmse)


class TurnsNaNReference(dt.Reference):
    """Hover at 1 m until t = 0.05 s, then a non-finite position."""

    def at(self, t_s):
        x = 0.0 if t_s < 0.05 - 1e-12 else float("nan")
        return dt.ReferencePoint([x, 0.0, 1.0])


def test_record_keeps_the_flight_up_to_a_non_finite_reference(qdrone2):
    sim = start_hovering(qdrone2)
    loop = dt.ClosedLoop(sim, dt.load_controller(source_path("config", "controllers", "pid.yaml"),
                                                 qdrone2, 1000.0), TurnsNaNReference(), 1000.0)
    log = loop.record(1.0)
    assert log["status"] != dt.StepStatus.OK
    assert "reference" in log["failure_message"] and "finite" in log["failure_message"]
    assert log["t"].shape == (51,)
    assert np.all(np.isfinite(log["state"]))


class ReturnsText(dt.ControllerBase):
    def calculate_u(self, inp):
        return "thrust"


class NamesItselfWithANumber(HoverSpeeds):
    def name(self):
        return 42


class AtReturnsAFloat(dt.Reference):
    def at(self, t_s):
        return 1.0


def test_callbacks_returning_the_wrong_type_name_the_method_and_the_type(qdrone2):
    ref = dt.SetpointReference([0.0, 0.0, 1.0])
    with pytest.raises(TypeError, match=r"calculate_u result: expected .*, got a str"):
        dt.ClosedLoop(start_hovering(qdrone2), ReturnsText(qdrone2), ref, 100.0).step()
    with pytest.raises(TypeError, match=r"ControllerBase\.name\(\) returned .*int.*expected a str"):
        dt.ClosedLoop(start_hovering(qdrone2), NamesItselfWithANumber(qdrone2), ref, 100.0).step()
    with pytest.raises(TypeError, match=r"Reference\.at\(\) returned .*float.*ReferencePoint"):
        dt.ClosedLoop(start_hovering(qdrone2), HoverSpeeds(qdrone2), AtReturnsAFloat(), 100.0).step()
