"""dronetwin.planning from Python: minimum-snap plans against the closed-form rest-to-rest
polynomial, the optimality conditions and the two-waypoint cost and time allocation; flat states
against hover, constant acceleration and finite differences; time scaling; feasibility against a
thrust bound; TrajectoryReference against the trajectory it wraps; and the error messages.

Expected values come from the formulas (numpy polynomials), not from running the planner."""

import math

import numpy as np
import pytest

import dronetwin as dt
from conftest import flying_se3, source_path
from test_docs import undocumented

pl = dt.planning
G = 9.81

# The rest-to-rest septic: P(0) = 0, P(1) = 1, derivatives 1..3 zero at both ends. With the ends
# at rest and nothing in between, the minimum-snap segment is x(t) = x0 + P(t / T) (x1 - x0).
SEPTIC = np.polynomial.Polynomial([0, 0, 0, 0, 35, -84, 70, -20])
# Integral over [0, 1] of P''''(s)^2 (numpy's exact polynomial integration).
SEPTIC_SNAP_INTEGRAL = float((SEPTIC.deriv(4) ** 2).integ()(1.0) - (SEPTIC.deriv(4) ** 2).integ()(0.0))


def two_waypoints():
    p0, p1 = np.array([0.0, 0.0, 1.0]), np.array([2.0, -1.0, 1.5])
    return pl.Waypoint(p0, 0.0), pl.Waypoint(p1, 0.8), p0, p1


def four_waypoint_plan():
    w = [pl.Waypoint([0.0, 0.0, 1.0]), pl.Waypoint([1.0, 0.5, 1.2], 0.4),
         pl.Waypoint([2.0, 0.0, 1.0], 0.9), pl.Waypoint([2.5, 1.0, 1.1], 0.2)]
    times_s = [1.0, 1.2, 0.9]
    return w, times_s, pl.plan_min_snap(w, times_s)


def gentle_plan():
    w = [pl.Waypoint([0.0, 0.0, 1.0]), pl.Waypoint([0.8, 0.4, 1.2], 0.3),
         pl.Waypoint([1.2, 1.2, 1.1], 0.6)]
    return pl.plan_min_snap(w, [1.0, 1.0])


# ---- minimum snap ---------------------------------------------------------------------------

def test_rest_to_rest_two_waypoints_is_the_septic_polynomial():
    w0, w1, p0, p1 = two_waypoints()
    T = 2.0
    traj = pl.plan_min_snap([w0, w1], [T])
    assert traj.num_segments == 1
    assert traj.duration_s == T
    np.testing.assert_array_equal(traj.knot_times_s, [0.0, T])
    # Halfway: the midpoint, at the peak speed P'(1/2) = 35/16 times the mean speed, no acceleration.
    mid = traj.at(T / 2)
    np.testing.assert_allclose(mid.position_m, (p0 + p1) / 2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(mid.velocity_m_s, 35 / 16 * (p1 - p0) / T, rtol=0, atol=1e-12)
    np.testing.assert_allclose(mid.acceleration_m_s2, 0.0, rtol=0, atol=1e-11)
    # A quarter of the way in time: P(1/4) written out.
    quarter = 35 / 256 - 84 / 1024 + 70 / 4096 - 20 / 16384
    np.testing.assert_allclose(traj.at(T / 4).position_m, p0 + quarter * (p1 - p0), rtol=0, atol=1e-12)
    # Every derivative the trajectory has, all four axes (yaw 0 -> 0.8 rad the same way).
    step = np.append(p1 - p0, 0.8)
    start = np.append(p0, 0.0)
    for s in (0.0, 0.1, 0.25, 0.5, 0.7, 0.95, 1.0):
        for order in range(8):
            expected = SEPTIC.deriv(order)(s) / T**order * step + (start if order == 0 else 0.0)
            got = traj.evaluate(s * T, order)
            assert got.shape == (4,)
            scale = 1.0 + np.abs(expected).max()
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-10 * scale,
                                       err_msg=f"s = {s}, order {order}")
    f = traj.at(0.3 * T)
    np.testing.assert_allclose(f.jerk_m_s3, SEPTIC.deriv(3)(0.3) / T**3 * (p1 - p0), atol=1e-10)
    np.testing.assert_allclose(f.snap_m_s4, SEPTIC.deriv(4)(0.3) / T**4 * (p1 - p0), atol=1e-9)
    assert f.yaw_rad == pytest.approx(0.8 * SEPTIC(0.3), abs=1e-12)
    assert f.yaw_rate_rad_s == pytest.approx(0.8 * SEPTIC.deriv(1)(0.3) / T, abs=1e-12)
    assert f.yaw_acceleration_rad_s2 == pytest.approx(0.8 * SEPTIC.deriv(2)(0.3) / T**2, abs=1e-11)


def test_waypoints_as_an_array_plan_the_same_trajectory():
    w0, w1, p0, p1 = two_waypoints()
    from_list = pl.plan_min_snap([w0, w1], [2.0])
    from_array = pl.plan_min_snap(np.array([[*p0, 0.0], [*p1, 0.8]]), np.array([2.0]))
    t = np.linspace(0.0, 2.0, 9)
    for key, value in from_list.sample(t).items():
        np.testing.assert_array_equal(from_array.sample(t)[key], value, err_msg=key)
    # (N, 3): yaw 0 throughout.
    flat = pl.plan_min_snap(np.array([p0, p1]), (2.0,))
    np.testing.assert_array_equal(flat.sample(t)["yaw_rad"], np.zeros(9))


def test_interior_waypoints_are_met_and_the_optimum_is_smooth_to_the_sixth_derivative():
    w, times_s, traj = four_waypoint_plan()
    knots = np.concatenate([[0.0], np.cumsum(times_s)])
    np.testing.assert_allclose(traj.knot_times_s, knots, rtol=0, atol=1e-15)
    assert traj.duration_s == pytest.approx(sum(times_s), abs=1e-15)
    assert traj.num_segments == 3
    for j, waypoint in enumerate(w):
        f = traj.at(knots[j])
        np.testing.assert_allclose(f.position_m, waypoint.position_m, rtol=0, atol=1e-12)
        assert f.yaw_rad == pytest.approx(waypoint.yaw_rad, abs=1e-12)
    # Minimising the snap integral with free velocity, acceleration and jerk at an interior
    # waypoint makes derivatives 4, 5 and 6 continuous there (integration by parts), on top of
    # the C3 of the construction. Compared on the coefficients with numpy's own polynomials.
    c = traj.coefficients
    assert c.shape == (3, 8, 4)
    for i in (1, 2):
        for axis in range(4):
            left = np.polynomial.Polynomial(c[i - 1, :, axis])
            right = np.polynomial.Polynomial(c[i, :, axis])
            for order in range(7):
                a, b = left.deriv(order)(times_s[i - 1]), right.deriv(order)(0.0)
                assert a == pytest.approx(b, abs=1e-7 * (1.0 + abs(b))), (i, axis, order)


def test_given_velocity_and_acceleration_at_a_waypoint_are_flown_through():
    w = [pl.Waypoint([0.0, 0.0, 1.0]),
         pl.Waypoint([1.0, 0.0, 1.0], velocity_m_s=[1.0, 0.2, 0.0], acceleration_m_s2=[0.0, 0.5, 0.0]),
         pl.Waypoint([2.0, 1.0, 1.0])]
    traj = pl.plan_min_snap(w, [1.5, 1.5])
    f = traj.at(1.5)
    np.testing.assert_allclose(f.velocity_m_s, [1.0, 0.2, 0.0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(f.acceleration_m_s2, [0.0, 0.5, 0.0], rtol=0, atol=1e-10)
    # The ends are at rest when nothing is given.
    for t in (0.0, 3.0):
        end = traj.at(t)
        np.testing.assert_allclose(end.velocity_m_s, 0.0, atol=1e-12)
        np.testing.assert_allclose(end.acceleration_m_s2, 0.0, atol=1e-11)
        np.testing.assert_allclose(end.jerk_m_s3, 0.0, atol=1e-10)


def test_yaw_unwrapping_turns_the_short_way():
    w = [pl.Waypoint([0.0, 0.0, 1.0], 3.1), pl.Waypoint([1.0, 0.0, 1.0], -3.1)]
    long_way = pl.plan_min_snap(w, [2.0])
    short_way = pl.plan_min_snap(w, [2.0], pl.MinSnapOptions(unwrap_yaw=True))
    assert long_way.at(2.0).yaw_rad == pytest.approx(-3.1, abs=1e-12)
    # -3.1 rad is 2 pi - 6.2 rad past +3.1 rad going counter-clockwise.
    assert short_way.at(2.0).yaw_rad == pytest.approx(3.1 + (2 * math.pi - 6.2), abs=1e-12)
    assert pl.MinSnapOptions().unwrap_yaw is False


def test_sample_equals_at_pointwise_and_times_are_clamped():
    _, _, traj = four_waypoint_plan()
    T = traj.duration_s
    t = np.concatenate([[-1.0, 0.0], traj.knot_times_s, np.linspace(0.01, T - 0.01, 37), [T + 2.0]])
    s = traj.sample(t)
    fields = {"position_m": (3,), "velocity_m_s": (3,), "acceleration_m_s2": (3,), "jerk_m_s3": (3,),
              "snap_m_s4": (3,), "yaw_rad": (), "yaw_rate_rad_s": (), "yaw_acceleration_rad_s2": ()}
    assert set(s) == set(fields)
    for name, shape in fields.items():
        assert s[name].shape == (len(t),) + shape, name
        assert s[name].dtype == np.float64
        for i, ti in enumerate(t):
            np.testing.assert_array_equal(s[name][i], getattr(traj.at(ti), name),
                                          err_msg=f"{name} at {ti}")
    # Outside [0, T] the trajectory holds its ends (it never extrapolates).
    np.testing.assert_array_equal(s["position_m"][0], traj.at(0.0).position_m)
    np.testing.assert_array_equal(s["position_m"][-1], traj.at(T).position_m)
    # evaluate() agrees with at() field by field; a list works like an array.
    f = traj.at(1.7)
    np.testing.assert_array_equal(traj.evaluate(1.7, 1)[:3], f.velocity_m_s)
    np.testing.assert_array_equal(traj.evaluate(1.7, 4)[:3], f.snap_m_s4)
    assert traj.evaluate(1.7, 2)[3] == f.yaw_acceleration_rad_s2
    np.testing.assert_array_equal(traj.sample([1.7])["jerk_m_s3"][0], f.jerk_m_s3)
    assert traj.sample(np.zeros(0))["position_m"].shape == (0, 3)


def test_a_trajectory_rebuilt_from_its_coefficients_is_the_same():
    _, times_s, traj = four_waypoint_plan()
    copy = pl.Trajectory(times_s, traj.coefficients)
    t = np.linspace(-0.5, traj.duration_s + 0.5, 41)
    for key, value in traj.sample(t).items():
        np.testing.assert_array_equal(copy.sample(t)[key], value, err_msg=key)
    assert "3 segments" in repr(traj)


def test_two_waypoint_snap_cost_and_its_time_gradient():
    w0, w1, p0, p1 = two_waypoints()
    T = 1.7
    # J = sum over axes of (step^2 / T^7) * integral of P''''^2; yaw counts yaw_weight times.
    for yaw_weight in (1.0, 0.0, 2.5):
        expected = (np.sum((p1 - p0) ** 2) + yaw_weight * 0.8**2) * SEPTIC_SNAP_INTEGRAL / T**7
        cost, gradient = pl.min_snap_cost([w0, w1], [T], yaw_weight)
        assert cost == pytest.approx(expected, rel=1e-10)
        assert gradient.shape == (1,)
        assert gradient[0] == pytest.approx(-7.0 * expected / T, rel=1e-9)  # J ~ T^-7


def test_two_waypoint_time_allocation_has_the_closed_form_optimum():
    w0, w1, p0, p1 = two_waypoints()
    rho = 50.0
    # F(T) = J1 T^-7 + rho T is smallest where 7 J1 T^-8 = rho.
    j1 = (np.sum((p1 - p0) ** 2) + 0.8**2) * SEPTIC_SNAP_INTEGRAL
    optimum = (7.0 * j1 / rho) ** 0.125
    times_s = pl.allocate_segment_times([w0, w1], rho)
    assert times_s.shape == (1,)
    assert times_s[0] == pytest.approx(optimum, rel=1e-5)
    result = pl.optimize_segment_times([w0, w1], rho, pl.TimeAllocationOptions(nominal_speed_m_s=2.0))
    assert result.converged
    assert result.segment_times_s[0] == pytest.approx(optimum, rel=1e-5)
    assert result.total_cost == pytest.approx(8.0 * rho * optimum / 7.0, rel=1e-8)
    assert result.total_cost <= result.initial_total_cost


# ---- differential flatness ------------------------------------------------------------------

def test_flat_state_at_hover_is_the_weight_and_the_hover_rotor_speeds(qdrone2):
    m = qdrone2.mass_kg
    for psi in (0.0, 0.7, -2.5, 3.0):
        s = pl.flat_state(pl.FlatOutput(position_m=[1.0, -2.0, 3.0], yaw_rad=psi), qdrone2)
        assert s.thrust_N == pytest.approx(m * G, rel=1e-14)
        assert s.thrust_per_mass_m_s2 == pytest.approx(G, rel=1e-14)
        assert s.thrust_rate_N_s == 0.0
        np.testing.assert_allclose(s.q_WB, [math.cos(psi / 2), 0.0, 0.0, math.sin(psi / 2)], atol=1e-14)
        rot_z = np.array([[math.cos(psi), -math.sin(psi), 0.0], [math.sin(psi), math.cos(psi), 0.0],
                          [0.0, 0.0, 1.0]])
        np.testing.assert_allclose(s.R_WB, rot_z, atol=1e-14)
        np.testing.assert_allclose(s.angular_velocity_B_rad_s, 0.0, atol=1e-15)
        np.testing.assert_allclose(s.torque_B_Nm, 0.0, atol=1e-15)
        np.testing.assert_allclose(s.generalized_force, [m * G, 0.0, 0.0, 0.0], atol=1e-12)
        assert not s.allocation_saturated
        np.testing.assert_allclose(s.rotor_speeds_rad_s, qdrone2.hover_speeds_rad_s(), rtol=0, atol=1e-7)
        assert s.rotor_thrusts_N.sum() == pytest.approx(m * G, rel=1e-12)


def test_steady_flight_against_frame_drag_tilts_by_atan_of_drag_over_weight(qdrone2):
    # At a constant velocity u along +x the frame drag -A v_B, the thrust and the weight balance in
    # the body frame: along x, A_xx u cos(theta) = m g sin(theta); along z, T = m g cos(theta)
    # + A_zz u sin(theta).
    m = qdrone2.mass_kg
    A = qdrone2.body_drag_Ns_per_m
    for u in (0.5, 3.0, 8.0):
        f = pl.FlatOutput(position_m=[0.0, 0.0, 2.0], velocity_m_s=[u, 0.0, 0.0])
        s = pl.flat_state(f, qdrone2, body_drag=True)
        theta = math.atan(A[0, 0] * u / (m * G))
        np.testing.assert_allclose(s.q_WB, [math.cos(theta / 2), 0.0, math.sin(theta / 2), 0.0],
                                   atol=1e-14)
        assert s.thrust_N == pytest.approx(m * G * math.cos(theta) + A[2, 2] * u * math.sin(theta),
                                           rel=1e-13)
        # Without drag the same flat output is a level hover at the weight.
        assert pl.flat_state(f, qdrone2).thrust_N == pytest.approx(m * G, rel=1e-14)
        # Rotor drag tilts it further (it adds to the frame's in-plane drag).
        both = pl.flat_state(f, qdrone2, body_drag=True, rotor_drag=True)
        assert math.atan2(both.R_WB[0, 2], both.R_WB[2, 2]) > theta
    limits = pl.FeasibilityLimits(body_drag=True, rotor_drag=True)
    assert limits.body_drag and limits.rotor_drag


def test_constant_acceleration_tilts_by_atan_of_a_over_g(qdrone2):
    m = qdrone2.mass_kg
    a = 3.0
    # Along +x with yaw 0: pitch by atan(a / g) about +y (nose down), thrust m sqrt(a^2 + g^2).
    s = pl.flat_state(pl.FlatOutput(acceleration_m_s2=[a, 0.0, 0.0]), qdrone2)
    theta = math.atan(a / G)
    np.testing.assert_allclose(s.q_WB, [math.cos(theta / 2), 0.0, math.sin(theta / 2), 0.0], atol=1e-14)
    assert s.thrust_N == pytest.approx(m * math.hypot(a, G), rel=1e-14)
    # Any direction and heading: tilt from |a| only, thrust along a + g e3.
    for psi, direction in ((0.3, 1.0), (-1.2, 2.5), (2.9, -2.0)):
        acc = 4.5 * np.array([math.cos(direction), math.sin(direction), 0.0])
        f = pl.FlatOutput(position_m=[0, 0, 1.0], acceleration_m_s2=acc, yaw_rad=psi)
        s = pl.flat_state(f, qdrone2)
        assert math.acos(s.R_WB[2, 2]) == pytest.approx(math.atan(4.5 / G), abs=1e-12)
        np.testing.assert_allclose(s.R_WB @ [0.0, 0.0, s.thrust_N] / m, acc + [0.0, 0.0, G], atol=1e-12)
        np.testing.assert_allclose(s.angular_velocity_B_rad_s, 0.0, atol=1e-14)
    # The same from a Trajectory built by hand: x = a t^2 / 2 at z = 1 m, for 2 s.
    c = np.zeros((1, 8, 4))
    c[0, 0, 2] = 1.0
    c[0, 2, 0] = a / 2
    traj = pl.Trajectory([2.0], c)
    f = traj.at(1.2)
    np.testing.assert_allclose(f.position_m, [a * 1.2**2 / 2, 0.0, 1.0], atol=1e-14)
    np.testing.assert_allclose(f.velocity_m_s, [a * 1.2, 0.0, 0.0], atol=1e-14)
    s = pl.flat_state(f, qdrone2)
    assert math.acos(s.R_WB[2, 2]) == pytest.approx(theta, abs=1e-12)


def test_body_rates_and_thrust_rate_are_the_derivatives_of_attitude_and_thrust(qdrone2):
    _, _, traj = four_waypoint_plan()
    h = 1e-5
    for t in (0.4, 1.3, 2.05, 2.8):  # inside segments, away from the knots
        before, now, after = (pl.flat_state(traj.at(t + d), qdrone2) for d in (-h, 0.0, h))
        R_dot = (after.R_WB - before.R_WB) / (2 * h)
        W = now.R_WB.T @ R_dot  # skew(w_B) for R_dot = R skew(w_B)
        w_fd = np.array([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]]) / 2
        np.testing.assert_allclose(now.angular_velocity_B_rad_s, w_fd, rtol=0, atol=1e-7)
        thrust_rate_fd = (after.thrust_N - before.thrust_N) / (2 * h)
        assert now.thrust_rate_N_s == pytest.approx(thrust_rate_fd, abs=1e-6)
        w_dot_fd = (after.angular_velocity_B_rad_s - before.angular_velocity_B_rad_s) / (2 * h)
        np.testing.assert_allclose(now.angular_acceleration_B_rad_s2, w_dot_fd, rtol=0, atol=1e-5)
        # Euler's equation for the torques.
        J, w = qdrone2.inertia_kgm2, now.angular_velocity_B_rad_s
        euler = J @ now.angular_acceleration_B_rad_s2 + np.cross(w, J @ w)
        np.testing.assert_allclose(now.torque_B_Nm, euler, rtol=0, atol=1e-12)


# ---- time scaling and feasibility -----------------------------------------------------------

def test_time_scaled_is_the_same_path_slower():
    _, _, traj = four_waypoint_plan()
    slow = pl.time_scaled(traj, 2.0)
    assert slow.duration_s == pytest.approx(2.0 * traj.duration_s, rel=1e-15)
    np.testing.assert_allclose(slow.knot_times_s, 2.0 * traj.knot_times_s, rtol=1e-15)
    for t in np.linspace(0.0, traj.duration_s, 13):
        a, b = traj.at(t), slow.at(2.0 * t)
        np.testing.assert_allclose(b.position_m, a.position_m, rtol=0, atol=1e-12)
        np.testing.assert_allclose(b.velocity_m_s, a.velocity_m_s / 2, rtol=0, atol=1e-12)
        np.testing.assert_allclose(b.acceleration_m_s2, a.acceleration_m_s2 / 4, rtol=0, atol=1e-11)
        np.testing.assert_allclose(b.snap_m_s4, a.snap_m_s4 / 16, rtol=0, atol=1e-9)
        assert b.yaw_rate_rad_s == pytest.approx(a.yaw_rate_rad_s / 2, abs=1e-12)


def test_a_gentle_trajectory_is_feasible_at_every_sample(qdrone2):
    r = pl.check_feasibility(gentle_plan(), qdrone2, pl.FeasibilityLimits(), 0.125)
    assert r.feasible, r.message
    assert r.samples == 17  # 0, 0.125, ..., 2 s
    assert r.violation == pl.FeasibilityViolation.NONE
    assert r.message == ""
    assert pl.feasible_time_scale(gentle_plan(), qdrone2, pl.FeasibilityLimits(), 0.125) == 1.0


def test_a_too_fast_climb_is_infeasible_until_slowed_down(qdrone2):
    # 8 m up in 1 s: the septic's peak acceleration 8 P''max = 60 m/s^2 needs more than the rotors.
    climb = [pl.Waypoint([0.0, 0.0, 1.0]), pl.Waypoint([0.3, 0.0, 9.0])]
    traj = pl.plan_min_snap(climb, [1.0])
    limits = pl.FeasibilityLimits(max_tilt_rad=3.0, max_body_rate_rad_s=1e3)
    dt_s = 1.0 / 256
    r = pl.check_feasibility(traj, qdrone2, limits, dt_s)
    assert not r.feasible
    assert r.violation == pl.FeasibilityViolation.ROTOR_SPEED_ABOVE_MAX
    rotor = qdrone2.rotors[r.rotor]
    assert r.limit == rotor.max_speed_rad_s
    assert r.value > rotor.max_speed_rad_s
    assert f"rotor {r.rotor} speed" in r.message and r.message.startswith("t = ")
    # The report is the first sample where that rotor's thrust exceeds what its top speed gives,
    # and the sample before is within every limit.
    assert r.samples == round(r.time_s / dt_s) + 1
    at_report = pl.flat_state(traj.at(r.time_s), qdrone2)
    assert at_report.rotor_thrusts_N[r.rotor] > rotor.thrust(rotor.max_speed_rad_s)
    before = pl.flat_state(traj.at(r.time_s - dt_s), qdrone2)
    for i, params in enumerate(qdrone2.rotors):
        assert params.thrust(params.min_speed_rad_s) <= before.rotor_thrusts_N[i] <= params.thrust(
            params.max_speed_rad_s)

    factor = pl.feasible_time_scale(traj, qdrone2, limits, dt_s, relative_tolerance=1e-3)
    assert pl.check_feasibility(pl.time_scaled(traj, factor), qdrone2, limits, dt_s).feasible
    just_faster = pl.time_scaled(traj, factor * (1 - 1e-3))
    assert not pl.check_feasibility(just_faster, qdrone2, limits, dt_s).feasible
    # Necessary: the collective thrust m (g + a_z / factor^2) within the rotors' total maximum.
    total_max_N = sum(p.thrust(p.max_speed_rad_s) for p in qdrone2.rotors)
    peak_az = 8.0 * SEPTIC.deriv(2)(np.linspace(0.0, 1.0, 100001)).max()
    assert factor >= 0.99 * math.sqrt(peak_az / (total_max_N / qdrone2.mass_kg - G))


# ---- TrajectoryReference --------------------------------------------------------------------

def test_trajectory_reference_is_the_trajectory_shifted_by_its_start():
    _, _, traj = four_waypoint_plan()
    start = 1.5
    ref = dt.TrajectoryReference(traj, start_time_s=start)
    assert isinstance(ref, dt.Reference)
    assert ref.start_time_s == start
    assert ref.end_time_s == pytest.approx(start + traj.duration_s, rel=1e-15)
    assert ref.trajectory.duration_s == traj.duration_s
    assert "trajectory" in ref.describe()
    names = ("position_m", "velocity_m_s", "acceleration_m_s2", "jerk_m_s3", "snap_m_s4", "yaw_rad",
             "yaw_rate_rad_s", "yaw_acceleration_rad_s2")
    for t in np.linspace(start + 0.01, ref.end_time_s - 0.01, 23):
        p, f = ref.at(t), traj.at(t - start)
        for name in names:
            np.testing.assert_allclose(getattr(p, name), getattr(f, name), rtol=0, atol=1e-12,
                                       err_msg=f"{name} at {t}")
    # Outside the plan: its first and last point, at rest.
    first, last = ref.at(0.0), ref.at(ref.end_time_s + 3.0)
    np.testing.assert_allclose(first.position_m, traj.at(0.0).position_m, atol=1e-15)
    np.testing.assert_allclose(last.position_m, traj.at(traj.duration_s).position_m, atol=1e-15)
    assert last.yaw_rad == pytest.approx(traj.at(traj.duration_s).yaw_rad, abs=1e-15)
    for p in (first, last):
        np.testing.assert_array_equal(p.velocity_m_s, 0.0)
        np.testing.assert_array_equal(p.acceleration_m_s2, 0.0)
    assert dt.TrajectoryReference(traj).start_time_s == 0.0


def test_se3_flies_a_trajectory_reference_to_its_end(qdrone2):
    traj = gentle_plan()
    ref = dt.TrajectoryReference(traj, start_time_s=0.5)
    gains, options = flying_se3()
    sim = dt.Simulator(qdrone2, dt.SimConfig())
    sim.reset(dt.Simulator.hover_state([0.0, 0.0, 1.0]), qdrone2.hover_speeds_rad_s())
    loop = dt.ClosedLoop(sim, dt.Se3Controller(qdrone2, gains, options), ref, 500.0)
    log = loop.record(6.0, every_n_steps=10)
    assert log["status"] == dt.StepStatus.OK
    # The recorded reference is the plan, shifted by the start time.
    expected = traj.sample(log["t"] - 0.5)
    np.testing.assert_allclose(log["reference"][:, :3], expected["position_m"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(log["reference"][:, 3], expected["yaw_rad"], rtol=0, atol=1e-12)
    # 3.5 s after the end the vehicle holds the last waypoint.
    np.testing.assert_allclose(sim.state[:3], [1.2, 1.2, 1.1], rtol=0, atol=0.02)


# ---- plain data, imports, documentation -----------------------------------------------------

def test_waypoint_and_flat_output_fields():
    w = pl.Waypoint([1.0, 2.0, 3.0], 0.5)
    np.testing.assert_array_equal(w.position_m, [1.0, 2.0, 3.0])
    assert w.yaw_rad == 0.5
    assert w.velocity_m_s is None and w.acceleration_m_s2 is None
    w.velocity_m_s = np.array([0.1, 0.0, 0.0])
    np.testing.assert_array_equal(w.velocity_m_s, [0.1, 0.0, 0.0])
    w.velocity_m_s = None
    assert w.velocity_m_s is None
    assert "Waypoint(position_m=" in repr(w)
    f = pl.FlatOutput()
    for name in ("position_m", "velocity_m_s", "acceleration_m_s2", "jerk_m_s3", "snap_m_s4"):
        np.testing.assert_array_equal(getattr(f, name), np.zeros(3))
    f.snap_m_s4 = [0.0, 1.0, 0.0]
    np.testing.assert_array_equal(f.snap_m_s4, [0.0, 1.0, 0.0])
    limits = pl.FeasibilityLimits()
    assert (limits.max_tilt_rad, limits.max_body_rate_rad_s, limits.gravity_m_s2) == (1.0, 10.0, 9.81)


def test_planning_is_importable_as_a_module():
    import dronetwin.planning
    from dronetwin.planning import Waypoint

    assert dronetwin.planning is dt.planning
    assert Waypoint is pl.Waypoint
    # The control layer's timed Waypoint is a different class.
    assert dt.Waypoint is not pl.Waypoint


# ---- the time-optimal lap -------------------------------------------------------------------

@pytest.fixture(scope="module")
def circuit_lap(qdrone2):
    # One warm start and 120 intervals: seconds (the default search is in docs/performance.md).
    track = dt.load_track(source_path("config", "tracks", "circuit.yaml"))
    return track, pl.time_optimal_lap(track, qdrone2, intervals=120, warm_start_time_factors=[0.6])


def test_time_optimal_lap_is_a_closed_feasible_lap_faster_than_minimum_snap(qdrone2, circuit_lap):
    _, lap = circuit_lap
    assert lap["converged"] and lap["max_violation"] <= 1e-6
    n = len(lap["times_s"])
    assert lap["states"].shape == (n, 13)
    assert lap["rotor_speeds_rad_s"].shape == (n - 1, 4)
    assert lap["times_s"][-1] == pytest.approx(lap["lap_time_s"], abs=1e-9)
    assert lap["segment_times_s"].sum() == pytest.approx(lap["lap_time_s"], abs=1e-12)
    assert len(lap["gate_nodes"]) == 8 and lap["gate_nodes"][-1] == n - 1
    # Every rotor inside its limits; the lap closes on itself.
    assert lap["rotor_speeds_rad_s"].min() >= 0.0
    assert lap["rotor_speeds_rad_s"].max() <= 3400.0
    np.testing.assert_allclose(lap["states"][-1][:6], lap["states"][0][:6], atol=1e-5)
    # The minimum-snap lap slowed to its rotor limits is a feasible lap of the same circuit.
    assert lap["lap_time_s"] < lap["min_snap_lap_time_s"]
    assert lap["min_snap_trajectory"].duration_s == pytest.approx(lap["min_snap_lap_time_s"])


def test_time_optimal_lap_from_its_own_flight_is_no_slower(qdrone2, circuit_lap):
    track, lap = circuit_lap
    # The lap twice round as a recorded flight: nodes as samples, the rotor speeds held over
    # each interval (repeated at the interval's end, so the interpolation keeps them).
    t, x, u = lap["times_s"], lap["states"], lap["rotor_speeds_rad_s"]
    times, states, speeds = [], [], []
    for r in range(2):
        for k in range(len(u)):
            for frac in (0.0, 0.5):
                times.append(r * lap["lap_time_s"] + t[k] + frac * (t[k + 1] - t[k]))
                states.append(x[k] + frac * (x[k + 1] - x[k]))
                speeds.append(u[k])
    # The end of the second round, so that its last gate passage is in the flight.
    times.append(2 * lap["lap_time_s"])
    states.append(x[-1])
    speeds.append(u[-1])
    # On the lap's own grid: intervals per segment from its gate nodes.
    per_segment = np.diff(np.concatenate([[0], lap["gate_nodes"]])).tolist()
    again = pl.time_optimal_lap(track, qdrone2, intervals=120, flight_times_s=np.array(times),
                                flight_states=np.array(states),
                                flight_rotor_speeds_rad_s=np.array(speeds),
                                intervals_per_segment=per_segment)
    assert again["converged"]
    assert again["lap_time_s"] <= lap["lap_time_s"] * (1 + 1e-3)


def test_time_optimal_lap_refuses_bad_input_by_name(qdrone2):
    track = dt.load_track(source_path("config", "tracks", "circuit.yaml"))
    with pytest.raises(ValueError, match="needs all of flight_times_s, flight_states and"):
        pl.time_optimal_lap(track, qdrone2, flight_times_s=np.zeros(3))
    with pytest.raises(ValueError, match=r"flight_states: expected a 2-D float64 array with 13 columns"):
        pl.time_optimal_lap(track, qdrone2, flight_times_s=np.zeros(3), flight_states=np.zeros((3, 12)),
                            flight_rotor_speeds_rad_s=np.zeros((3, 4)))
    with pytest.raises(TypeError, match=r"flight_times_s: expected a 1-D float64 array"):
        pl.time_optimal_lap(track, qdrone2, flight_times_s=[0.0, 1.0], flight_states=np.zeros((2, 13)),
                            flight_rotor_speeds_rad_s=np.zeros((2, 4)))
    with pytest.raises(ValueError, match=r"times_s\[1\]: expected finite and above the one before"):
        pl.time_optimal_lap(track, qdrone2, flight_times_s=np.zeros(2), flight_states=np.zeros((2, 13)),
                            flight_rotor_speeds_rad_s=np.zeros((2, 4)))
    with pytest.raises(ValueError, match=r"warm_start_time_factors\[0\]: expected in \[0.1, 10\], got 0"):
        pl.time_optimal_lap(track, qdrone2, warm_start_time_factors=[0.0])
    with pytest.raises(ValueError, match="time_optimal_lap: model: expected a VehicleModel, got None"):
        pl.time_optimal_lap(track, None)
    with pytest.raises(ValueError, match=r"intervals_per_segment: expected one count per segment \(8 "
                                         r"for the gates of 'circuit'\), got 3"):
        pl.time_optimal_lap(track, qdrone2, intervals_per_segment=[20, 20, 20])
    with pytest.raises(ValueError, match=r"intervals_per_segment\[7\]: expected a count in \[4, 100000\], got 0"):
        pl.time_optimal_lap(track, qdrone2, intervals_per_segment=[20] * 7 + [0])


def test_everything_in_planning_is_documented():
    assert undocumented(pl) == []


# ---- errors ---------------------------------------------------------------------------------

def test_bad_plans_are_refused_by_name():
    w0, w1, _, _ = two_waypoints()
    with pytest.raises(ValueError, match="plan_min_snap: expected at least 2 waypoints, got 1"):
        pl.plan_min_snap([w0], [])
    with pytest.raises(ValueError, match=r"waypoints\[0\] and waypoints\[1\] are the same point"):
        pl.plan_min_snap([w0, pl.Waypoint(w0.position_m, w0.yaw_rad)], [1.0])
    with pytest.raises(ValueError, match=r"plan_min_snap: segment_times_s: expected 1 values .*, got 2"):
        pl.plan_min_snap([w0, w1], [1.0, 1.0])
    with pytest.raises(ValueError, match=r"segment_times_s\[0\]: expected a positive finite duration, got 0"):
        pl.plan_min_snap([w0, w1], [0.0])
    with pytest.raises(ValueError, match=r"segment_times_s\[0\]: expected a positive finite duration, got -1"):
        pl.plan_min_snap([w0, w1], np.array([-1.0]))
    with pytest.raises(ValueError, match=r"segment_times_s: expected a 1-D float64 array .*shape \(1,1\)"):
        pl.plan_min_snap([w0, w1], np.ones((1, 1)))
    with pytest.raises(TypeError, match=r"segment_times_s: expected .*got an int64 array"):
        pl.plan_min_snap([w0, w1], np.array([2]))
    with pytest.raises(ValueError, match=r"plan_min_snap: waypoints: expected .*shape \(N, 3\) or \(N, 4\)"):
        pl.plan_min_snap(np.zeros((2, 2)), [1.0])
    with pytest.raises(TypeError, match=r"plan_min_snap: waypoints\[1\]: expected a planning.Waypoint, got a tuple"):
        pl.plan_min_snap([w0, (1.0, 2.0, 3.0)], [1.0])
    with pytest.raises(ValueError, match=r"waypoints\[1\]\.position_m: expected finite numbers"):
        pl.plan_min_snap([w0, pl.Waypoint([np.nan, 0.0, 0.0])], [1.0])
    with pytest.raises(ValueError, match=r"Waypoint\.position_m: expected a float64 array of shape \(3,\)"):
        pl.Waypoint([1.0, 2.0])
    with pytest.raises(TypeError, match=r"Waypoint\.velocity_m_s: expected .*got an int64 array"):
        pl.Waypoint([1.0, 2.0, 3.0], velocity_m_s=np.array([1, 0, 0]))
    with pytest.raises(ValueError, match="min_snap_cost: yaw_weight: expected a finite number >= 0, got -1"):
        pl.min_snap_cost([w0, w1], [1.0], -1.0)
    with pytest.raises(ValueError, match="allocate_segment_times: rho: expected a positive finite number, got 0"):
        pl.allocate_segment_times([w0, w1], 0.0)


def test_bad_trajectory_and_flatness_inputs_are_refused_by_name(qdrone2):
    traj = gentle_plan()
    with pytest.raises(ValueError, match=r"derivative order: expected 0\.\.7, got 8"):
        traj.evaluate(1.0, 8)
    with pytest.raises(ValueError, match=r"Trajectory\.sample: times_s\[1\]: expected a time, got nan"):
        traj.sample([0.0, np.nan])
    with pytest.raises(ValueError, match=r"Trajectory\.sample: times_s: expected a 1-D float64 array"):
        traj.sample(np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"Trajectory: coefficients: expected a float64 array of shape \(1, 8, 4\)"):
        pl.Trajectory([1.0], np.zeros((1, 8, 3)))
    with pytest.raises(ValueError, match=r"segments\[0\]\.duration_s: expected a positive finite duration, got 0"):
        pl.Trajectory([0.0], np.zeros((1, 8, 4)))
    with pytest.raises(ValueError, match="Trajectory: expected at least 1 segment, got 0"):
        pl.Trajectory([], np.zeros((0, 8, 4)))
    with pytest.raises(ValueError, match="time_scaled: factor: expected a positive finite number, got 0"):
        pl.time_scaled(traj, 0.0)
    with pytest.raises(ValueError, match="check_feasibility: sample_dt_s: expected a positive finite time step, got 0"):
        pl.check_feasibility(traj, qdrone2, pl.FeasibilityLimits(), 0.0)
    with pytest.raises(ValueError, match="limits.max_tilt_rad: expected a positive finite angle, got 0"):
        pl.check_feasibility(traj, qdrone2, pl.FeasibilityLimits(max_tilt_rad=0.0), 0.01)
    with pytest.raises(ValueError, match="check_feasibility: model: expected a VehicleModel, got None"):
        pl.check_feasibility(traj, None, pl.FeasibilityLimits(), 0.01)
    with pytest.raises(ValueError, match=r"relative_tolerance: expected a number in \(0, 1\), got 0"):
        pl.feasible_time_scale(traj, qdrone2, pl.FeasibilityLimits(), 0.01, relative_tolerance=0.0)
    with pytest.raises(ValueError, match=r"flat_state: zero thrust \(free fall\)"):
        pl.flat_state(pl.FlatOutput(acceleration_m_s2=[0.0, 0.0, -G]), qdrone2)
    with pytest.raises(ValueError, match="flat_state: gravity_m_s2: expected a finite value >= 0, got -9.81"):
        pl.flat_state(pl.FlatOutput(), qdrone2, -9.81)
    with pytest.raises(ValueError, match="flat_state: model: expected a VehicleModel, got None"):
        pl.flat_state(pl.FlatOutput(), None)
    with pytest.raises(ValueError, match=r"FlatOutput\.acceleration_m_s2: expected a float64 array of shape \(3,\)"):
        pl.FlatOutput(acceleration_m_s2=[1.0, 2.0])
    with pytest.raises(ValueError, match="start_time_s: expected a finite time, got nan"):
        dt.TrajectoryReference(traj, float("nan"))
