// Differential flatness: hover and constant acceleration against their closed forms, body rates,
// angular accelerations and thrust rate against finite differences of the flat attitude and
// thrust, a simulator flown open loop on the flat rotor speeds, feasibility against a brute-force
// scan of flat_state, time scaling against p(t / factor), and errors.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/vehicle_dynamics.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/model/allocation.hpp"
#include "dronetwin/planning/flatness.hpp"
#include "dronetwin/planning/min_snap.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin::planning {
namespace {

using test::error_of;

constexpr double kG = 9.81;

void expect_message(const std::string& message, const std::string& part) {
  EXPECT_NE(message.find(part), std::string::npos)
      << "message: " << message << "\nexpected: " << part;
}

std::shared_ptr<const VehicleModel> qdrone2() {
  static const auto model = test::load_model("qdrone2");
  return model;
}

FlatOutput at_rest(const Vec3& position_m, double yaw_rad) {
  FlatOutput f;
  f.position_m = position_m;
  f.yaw_rad = yaw_rad;
  return f;
}

// Smooth flat outputs with every derivative non-zero: each axis A sin(w t + phase) + offset, so
// the k-th derivative is A w^k sin(w t + phase + k pi / 2), exactly.
FlatOutput sine_flat(double t) {
  struct Sine {
    double amplitude, omega, phase, offset;
    double d(double time, int k) const {
      return amplitude * std::pow(omega, k) *
                 std::sin(omega * time + phase + k * std::numbers::pi / 2) +
             (k == 0 ? offset : 0.0);
    }
  };
  const Sine x{0.8, 1.3, 0.0, 0.0}, y{0.6, 0.9, 0.4, 0.0}, z{0.4, 1.7, 1.0, 1.5};
  const Sine yaw{0.9, 0.8, 0.3, 0.5};
  FlatOutput f;
  f.position_m = Vec3(x.d(t, 0), y.d(t, 0), z.d(t, 0));
  f.velocity_m_s = Vec3(x.d(t, 1), y.d(t, 1), z.d(t, 1));
  f.acceleration_m_s2 = Vec3(x.d(t, 2), y.d(t, 2), z.d(t, 2));
  f.jerk_m_s3 = Vec3(x.d(t, 3), y.d(t, 3), z.d(t, 3));
  f.snap_m_s4 = Vec3(x.d(t, 4), y.d(t, 4), z.d(t, 4));
  f.yaw_rad = yaw.d(t, 0);
  f.yaw_rate_rad_s = yaw.d(t, 1);
  f.yaw_acceleration_rad_s2 = yaw.d(t, 2);
  return f;
}

// Angle between body z and world z, computed without acos (independent of the library's way).
double tilt_of(const Mat3& R_WB) {
  const Vec3 z_B = R_WB.col(2);
  return std::atan2(z_B.cross(Vec3::UnitZ()).norm(), z_B.z());
}

// vee(R^T R_dot): the body rates of an attitude path, R_dot by a central difference.
Vec3 body_rates_fd(const Mat3& R_minus, const Mat3& R, const Mat3& R_plus, double h) {
  const Mat3 W = R.transpose() * (R_plus - R_minus) / (2.0 * h);
  return Vec3(0.5 * (W(2, 1) - W(1, 2)), 0.5 * (W(0, 2) - W(2, 0)), 0.5 * (W(1, 0) - W(0, 1)));
}

// ---------------------------------------------------------------------------------------------
// 1. Closed forms.

TEST(FlatState, HoverIsPureYawAtWeightWithHoverRotorSpeeds) {
  const auto model = qdrone2();
  const double m = model->mass_kg();
  for (const double psi : {0.0, 0.7, -2.5, 3.0}) {
    SCOPED_TRACE(psi);
    const FlatState s = flat_state(at_rest(Vec3(1, -2, 3), psi), *model);
    const Vec4 q_expected(std::cos(psi / 2), 0.0, 0.0, std::sin(psi / 2));
    EXPECT_LT((s.q_WB - q_expected).norm(), 1e-14);
    EXPECT_LT((s.R_WB - math::rotation_matrix<double>(q_expected)).norm(), 1e-14);
    EXPECT_NEAR(s.thrust_N, m * kG, 1e-12);
    EXPECT_NEAR(s.thrust_per_mass_m_s2, kG, 1e-14);
    EXPECT_EQ(s.thrust_rate_N_s, 0.0);
    EXPECT_LT(s.angular_velocity_B_rad_s.norm(), 1e-15);
    EXPECT_LT(s.angular_acceleration_B_rad_s2.norm(), 1e-15);
    EXPECT_LT(s.torque_B_Nm.norm(), 1e-15);
    EXPECT_FALSE(s.allocation_saturated);
    const RotorVector hover = model->hover_speeds_rad_s();
    ASSERT_EQ(s.rotor_speeds_rad_s.size(), hover.size());
    EXPECT_LT((s.rotor_speeds_rad_s - hover).cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(FlatState, ConstantAccelerationTiltsByAtanOfAOverG) {
  const auto model = qdrone2();
  const double m = model->mass_kg();
  // Along +x with yaw 0: a rotation about +y by theta = atan(a / g) (positive pitch puts the nose
  // down, docs/conventions.md), so q = (cos theta/2, 0, sin theta/2, 0).
  {
    const double a = 3.0, theta = std::atan(a / kG);
    FlatOutput f = at_rest(Vec3(0, 0, 1), 0.0);
    f.acceleration_m_s2 = Vec3(a, 0, 0);
    const FlatState s = flat_state(f, *model);
    EXPECT_LT((s.q_WB - Vec4(std::cos(theta / 2), 0, std::sin(theta / 2), 0)).norm(), 1e-14);
    EXPECT_NEAR(s.thrust_N, m * std::hypot(a, kG), 1e-12);
    EXPECT_LT(s.angular_velocity_B_rad_s.norm(), 1e-15);
    EXPECT_LT(s.angular_acceleration_B_rad_s2.norm(), 1e-15);
  }
  // Any horizontal direction and heading: the tilt and thrust depend on |a| only, and the thrust
  // axis points along a + g e3.
  for (const double psi : {0.3, -1.2, 2.9}) {
    for (const double dir : {0.0, 1.0, 2.5, -2.0}) {
      SCOPED_TRACE(::testing::Message() << "yaw " << psi << " direction " << dir);
      const double a = 4.5;
      FlatOutput f = at_rest(Vec3(0, 0, 1), psi);
      f.acceleration_m_s2 = a * Vec3(std::cos(dir), std::sin(dir), 0.0);
      const FlatState s = flat_state(f, *model);
      EXPECT_NEAR(tilt_of(s.R_WB), std::atan(a / kG), 1e-14);
      EXPECT_NEAR(s.thrust_N, m * std::sqrt(a * a + kG * kG), 1e-12);
      const Vec3 thrust_W = s.R_WB * Vec3(0, 0, s.thrust_N);
      EXPECT_LT((thrust_W / m - (f.acceleration_m_s2 + Vec3(0, 0, kG))).norm(), 1e-13);
      // Heading: body y is orthogonal to [cos psi, sin psi, 0] (the SE(3) controller's b1d).
      EXPECT_NEAR(s.R_WB.col(1).dot(Vec3(std::cos(psi), std::sin(psi), 0)), 0.0, 1e-15);
      EXPECT_GT(s.R_WB.col(0).dot(Vec3(std::cos(psi), std::sin(psi), 0)), 0.0);
      EXPECT_LT(s.angular_velocity_B_rad_s.norm(), 1e-15);
    }
  }
  // Straight up: no tilt, thrust m (g + a).
  FlatOutput up = at_rest(Vec3(0, 0, 1), 0.4);
  up.acceleration_m_s2 = Vec3(0, 0, 2.0);
  const FlatState s = flat_state(up, *model);
  EXPECT_LT((s.q_WB - Vec4(std::cos(0.2), 0, 0, std::sin(0.2))).norm(), 1e-14);
  EXPECT_NEAR(s.thrust_N, m * (kG + 2.0), 1e-12);
}

// ---------------------------------------------------------------------------------------------
// 2. Derivatives against finite differences of the attitude and thrust.

TEST(FlatState, RatesAndAccelerationsMatchFiniteDifferencesOfTheAttitude) {
  const auto model = qdrone2();
  // Central differences: truncation h^2/6 |d^3 R / dt^3| (about 1e-8 here, the path's derivatives
  // are below 10 in magnitude); rounding eps/h ~ 2e-12 for rates, eps/h^2 ~ 2e-8 for accelerations.
  const double h = 1e-4;
  for (double t = 0.0; t < 8.0; t += 0.37) {
    SCOPED_TRACE(t);
    const auto R = [&](double time) { return flat_state(sine_flat(time), *model).R_WB; };
    const auto rates_fd = [&](double time) {
      return body_rates_fd(R(time - h), R(time), R(time + h), h);
    };
    const FlatState s = flat_state(sine_flat(t), *model);
    // The matrix is the quaternion's, in the project's convention (math::rotation_matrix).
    EXPECT_LT((s.R_WB - math::rotation_matrix<double>(s.q_WB)).norm(), 1e-14);
    EXPECT_NEAR(s.q_WB.norm(), 1.0, 1e-15);
    const Vec3 w_fd = rates_fd(t);
    EXPECT_LT((s.angular_velocity_B_rad_s - w_fd).norm(), 1e-7) << s.angular_velocity_B_rad_s;
    const Vec3 dw_fd = (rates_fd(t + h) - rates_fd(t - h)) / (2.0 * h);
    EXPECT_LT((s.angular_acceleration_B_rad_s2 - dw_fd).norm(), 1e-5)
        << s.angular_acceleration_B_rad_s2;
    const double thrust_rate_fd = (flat_state(sine_flat(t + h), *model).thrust_N -
                                   flat_state(sine_flat(t - h), *model).thrust_N) /
                                  (2.0 * h);
    EXPECT_NEAR(s.thrust_rate_N_s, thrust_rate_fd, 1e-7);
    // The path is not trivial: rates of order 1 rad/s.
    EXPECT_GT(s.angular_velocity_B_rad_s.norm(), 0.05);
    // Allocation: the rotor thrusts give [T, tau] through the allocation matrix; unsaturated, the
    // rotor speeds give those thrusts through the thrust polynomial.
    EXPECT_LT((model->allocation_matrix() * s.rotor_thrusts_N - s.generalized_force).norm(), 1e-12);
    ASSERT_FALSE(s.allocation_saturated);
    for (int i = 0; i < model->num_rotors(); ++i)
      EXPECT_NEAR(model->rotor(i).thrust(s.rotor_speeds_rad_s[i]), s.rotor_thrusts_N[i], 1e-11);
  }
}

// ---------------------------------------------------------------------------------------------
// 3. Round trip through the simulator.

Trajectory gentle_trajectory() {
  std::vector<Waypoint> w(3);
  w[0].position_m = Vec3(0, 0, 1.0);
  w[1].position_m = Vec3(0.8, 0.4, 1.2);
  w[1].yaw_rad = 0.3;
  w[2].position_m = Vec3(1.2, 1.2, 1.1);
  w[2].yaw_rad = 0.6;
  return plan_min_snap(w, {1.0, 1.0});
}

struct RoundTrip {
  double max_position_error_m = 0.0;
  double max_attitude_error_rad = 0.0;
};

// Flies `traj` open loop in a simulator whose physics is the flatness model: drag, ground
// effect, drag and rolling moments and the gyroscopic moment off, no motor lag (the speed jumps
// to its reference), no noise or wind. A step holds the rotor speeds it starts with; a reference
// set before step k is reached at its end and held over step k + 1. The speeds are the flat ones
// at the middle of the step they are held over (the mid-point rule, error O(dt^2)).
// With `simulated`, the simulator has those drag terms too, and `flat` says which the flat
// state accounts for.
RoundTrip fly_open_loop(const Trajectory& traj, double dt_s, FlatDragTerms simulated = {},
                        FlatDragTerms flat = {}) {
  const auto model = qdrone2();
  SimConfig cfg;
  cfg.dt_s = dt_s;
  cfg.disturbances = DisturbanceSwitches::none();
  cfg.disturbances.body_drag = simulated.body_drag;
  cfg.disturbances.rotor_drag = simulated.rotor_drag;
  cfg.motor_dynamics = false;
  Simulator sim(model, cfg);
  const auto speeds_at = [&](double t) {
    const FlatState s = flat_state(traj.at(t), *model, kG, flat);
    EXPECT_FALSE(s.allocation_saturated) << "t = " << t;
    return s.rotor_speeds_rad_s;
  };
  const FlatState s0 = flat_state(traj.at(0.0), *model, kG, flat);
  StateVector x0;
  x0 << traj.at(0.0).position_m, traj.at(0.0).velocity_m_s, s0.q_WB, s0.angular_velocity_B_rad_s;
  sim.reset(x0, speeds_at(0.5 * dt_s));
  RoundTrip r;
  const auto steps = static_cast<int>(std::llround(traj.duration_s() / dt_s));
  for (int k = 0; k < steps; ++k) {
    sim.set_rotor_speed_reference(speeds_at((k + 1.5) * dt_s));
    EXPECT_TRUE(sim.step().ok());
    const double t = (k + 1) * dt_s;
    const StateVector& x = sim.state();
    r.max_position_error_m =
        std::max(r.max_position_error_m, (x.segment<3>(0) - traj.at(t).position_m).norm());
    const Mat3 R_err = flat_state(traj.at(t), *model, kG, flat).R_WB.transpose() *
                       math::rotation_matrix<double>(x.segment<4>(6));
    r.max_attitude_error_rad = std::max(
        r.max_attitude_error_rad, std::acos(std::clamp(0.5 * (R_err.trace() - 1.0), -1.0, 1.0)));
  }
  return r;
}

TEST(FlatState, SimulatorFlownOnFlatRotorSpeedsFollowsTheTrajectory) {
  const auto model = qdrone2();
  const Trajectory traj = gentle_trajectory();
  const double dt = 1e-3, T = traj.duration_s();
  // Tolerance from the integration error. Each step holds the mid-step rotor speeds, so the body
  // thrust and torques it applies differ from their mean over the step by dt^2/24 times their
  // second time derivative (mid-point rule); RK4's own error (dt^4) is negligible beside it. A
  // thrust error dT moves the position by dT/m t^2/2; a torque error dtau turns the attitude by
  // |J^-1| dtau t^2/2, which tilts the thrust and moves the position by c |J^-1| dtau t^4/24.
  // Bound both with the maxima along the path (second derivatives by central differences).
  double T2_max = 0.0, tau2_max = 0.0, c_max = 0.0;
  const double h = 1e-3;
  for (double t = h; t < T - h; t += 0.01) {
    const FlatState a = flat_state(traj.at(t - h), *model), b = flat_state(traj.at(t), *model),
                    c = flat_state(traj.at(t + h), *model);
    T2_max = std::max(T2_max, std::abs(a.thrust_N - 2 * b.thrust_N + c.thrust_N) / (h * h));
    tau2_max =
        std::max(tau2_max, (a.torque_B_Nm - 2 * b.torque_B_Nm + c.torque_B_Nm).norm() / (h * h));
    c_max = std::max(c_max, b.thrust_per_mass_m_s2);
  }
  const double J_inv = model->inertia_inverse().norm();  // Frobenius >= spectral norm
  const double m = model->mass_kg();
  const double bound =
      dt * dt / 24.0 *
      (T2_max / m * T * T / 2.0 + c_max * J_inv * tau2_max * std::pow(T, 4) / 24.0);
  const double attitude_bound = dt * dt / 24.0 * J_inv * tau2_max * T * T / 2.0;
  const RoundTrip r = fly_open_loop(traj, dt);
  std::cout << "dt " << dt << ": max position error " << r.max_position_error_m << " m (bound "
            << bound << "), attitude " << r.max_attitude_error_rad << " rad (bound "
            << attitude_bound << ")\n";
  EXPECT_LT(r.max_position_error_m, bound);
  EXPECT_LT(r.max_attitude_error_rad, attitude_bound);
  // The remaining error is discretisation error, not a model mismatch: it falls as dt^2.
  const RoundTrip coarse = fly_open_loop(traj, 2 * dt);
  std::cout << "dt " << 2 * dt << ": max position error " << coarse.max_position_error_m
            << " m, attitude " << coarse.max_attitude_error_rad << " rad\n";
  const double ratio = coarse.max_position_error_m / r.max_position_error_m;
  EXPECT_GT(ratio, 3.0);
  EXPECT_LT(ratio, 5.0);
}

// ---------------------------------------------------------------------------------------------
// 3b. Drag (the header's (5)).

// sine_flat's position at lambda t (its path flown lambda times faster) at a constant yaw (the
// QDrone2's yaw authority is small).
FlatOutput sine_flat_faster(double t, double lambda) {
  FlatOutput f = sine_flat(lambda * t);
  f.velocity_m_s *= lambda;
  f.acceleration_m_s2 *= lambda * lambda;
  f.jerk_m_s3 *= std::pow(lambda, 3);
  f.snap_m_s4 *= std::pow(lambda, 4);
  f.yaw_rad = 0.5;
  f.yaw_rate_rad_s = 0.0;
  f.yaw_acceleration_rad_s2 = 0.0;
  return f;
}

TEST(FlatDrag, ZeroDragGivesTheDragFreeAttitudeBitwise) {
  for (double t = 0.0; t < 8.0; t += 0.37) {
    FlatAttitude plain, zero;
    ASSERT_EQ(flat_attitude(sine_flat(t), kG, plain), FlatSingularity::kNone);
    ASSERT_EQ(flat_attitude(sine_flat(t), kG, FlatDrag{}, zero), FlatSingularity::kNone);
    EXPECT_EQ(plain.R_WB, zero.R_WB);
    EXPECT_EQ(plain.angular_velocity_B_rad_s, zero.angular_velocity_B_rad_s);
    EXPECT_EQ(plain.angular_acceleration_B_rad_s2, zero.angular_acceleration_B_rad_s2);
    EXPECT_EQ(plain.thrust_per_mass_m_s2, zero.thrust_per_mass_m_s2);
    EXPECT_EQ(plain.thrust_per_mass_rate_m_s3, zero.thrust_per_mass_rate_m_s3);
  }
}

// At every instant the flat state with drag balances the simulator's own forces: put the vehicle
// in the flat state with the flat rotor speeds, and the force kernel's state derivative is the
// path's acceleration and the flat angular acceleration, to round-off. Independent of the flat
// model's derivation: the kernel computes the drag from its own maps.
TEST(FlatDrag, FlatStateBalancesTheSimulatorsForcesAtEveryInstant) {
  const auto model = qdrone2();
  for (const FlatDragTerms terms :
       {FlatDragTerms{true, false}, FlatDragTerms{false, true}, FlatDragTerms{true, true}}) {
    DisturbanceSwitches sw = DisturbanceSwitches::none();
    sw.body_drag = terms.body_drag;
    sw.rotor_drag = terms.rotor_drag;
    double largest_drag_m_s2 = 0.0;
    for (double t = 0.0; t < 4.0; t += 0.13) {
      SCOPED_TRACE(t);
      const FlatOutput f = sine_flat_faster(t, 2.0);  // up to ~2.1 m/s and ~5.4 m/s^2
      const FlatState s = flat_state(f, *model, kG, terms);
      ASSERT_FALSE(s.allocation_saturated) << s.rotor_thrusts_N.head(4).transpose();
      StateVector x;
      x << f.position_m, f.velocity_m_s, s.q_WB, s.angular_velocity_B_rad_s;
      const StateVector xdot = state_derivative(*model, sw, Environment{}, x, s.rotor_speeds_rad_s);
      EXPECT_LT((xdot.segment<3>(state_index::kVelocity) - f.acceleration_m_s2).norm(), 1e-11);
      EXPECT_LT(
          (xdot.segment<3>(state_index::kAngularVelocity) - s.angular_acceleration_B_rad_s2).norm(),
          1e-9);
      // The drag-free flat state does not balance them (the case is not trivial).
      const FlatState plain = flat_state(f, *model, kG);
      StateVector x_plain;
      x_plain << f.position_m, f.velocity_m_s, plain.q_WB, plain.angular_velocity_B_rad_s;
      const StateVector xdot_plain =
          state_derivative(*model, sw, Environment{}, x_plain, plain.rotor_speeds_rad_s);
      largest_drag_m_s2 =
          std::max(largest_drag_m_s2,
                   (xdot_plain.segment<3>(state_index::kVelocity) - f.acceleration_m_s2).norm());
    }
    std::cout << "body drag " << terms.body_drag << ", rotor drag " << terms.rotor_drag
              << ": the drag-free flat state is off by up to " << largest_drag_m_s2 << " m/s^2\n";
    EXPECT_GT(largest_drag_m_s2, 0.3);
  }
}

// With frame drag alone the linear form is the model's (A diagonal, A_xx = A_yy), so the rates,
// angular accelerations and thrust rate are exact: central differences as in the drag-free test,
// whose tolerances scale with the third derivatives (2^3 on a path flown twice as fast) and the
// fourth (2^4).
TEST(FlatDrag, FrameDragRatesMatchFiniteDifferencesOfTheAttitude) {
  const auto model = qdrone2();
  const FlatDragTerms frame{true, false};
  const double h = 1e-4;
  const auto state = [&](double time) {
    return flat_state(sine_flat_faster(time, 2.0), *model, kG, frame);
  };
  for (double t = 0.0; t < 4.0; t += 0.19) {
    SCOPED_TRACE(t);
    const auto rates_fd = [&](double time) {
      return body_rates_fd(state(time - h).R_WB, state(time).R_WB, state(time + h).R_WB, h);
    };
    const FlatState s = state(t);
    EXPECT_LT((s.angular_velocity_B_rad_s - rates_fd(t)).norm(), 8e-7);
    const Vec3 dw_fd = (rates_fd(t + h) - rates_fd(t - h)) / (2.0 * h);
    EXPECT_LT((s.angular_acceleration_B_rad_s2 - dw_fd).norm(), 16e-5);
    // A tenth of the step for the thrust: its third derivative is large, its rounding small.
    const double h_T = h / 10.0;
    EXPECT_NEAR(s.thrust_rate_N_s,
                (state(t + h_T).thrust_N - state(t - h_T).thrust_N) / (2.0 * h_T), 1e-7);
    // Drag tilts the vehicle against the velocity: the attitude differs from the drag-free one.
    const FlatState plain = flat_state(sine_flat_faster(t, 2.0), *model, kG);
    if (sine_flat_faster(t, 2.0).velocity_m_s.norm() > 1.0) {
      EXPECT_GT((s.R_WB - plain.R_WB).norm(), 1e-3);
    }
  }
}

// Open loop through the simulator with frame drag: the drag-aware rotor speeds follow the path up
// to the mid-point rule's O(dt^2) (halving dt quarters the error: no model mismatch); the
// drag-free speeds drift by far more, and halving dt does not help. With rotor drag as well the
// flat rates leave out the rates of k and of the held force, so the drag-aware error does not
// vanish with dt, but it stays below the drag-free one.
TEST(FlatDrag, SimulatorWithDragFlownOnDragAwareRotorSpeedsFollowsTheTrajectory) {
  const Trajectory traj = gentle_trajectory();
  const double dt = 1e-3;
  const FlatDragTerms frame{true, false}, both{true, true}, none{};
  const RoundTrip fine = fly_open_loop(traj, dt, frame, frame);
  const RoundTrip coarse = fly_open_loop(traj, 2 * dt, frame, frame);
  const RoundTrip blind = fly_open_loop(traj, dt, frame, none);
  const RoundTrip blind_coarse = fly_open_loop(traj, 2 * dt, frame, none);
  std::cout << "frame drag: drag-aware " << fine.max_position_error_m << " m (dt " << dt << "), "
            << coarse.max_position_error_m << " m (dt " << 2 * dt << "); drag-free "
            << blind.max_position_error_m << " m, " << blind_coarse.max_position_error_m << " m\n";
  const double ratio = coarse.max_position_error_m / fine.max_position_error_m;
  EXPECT_GT(ratio, 3.0);
  EXPECT_LT(ratio, 5.0);
  EXPECT_GT(blind.max_position_error_m, 100.0 * fine.max_position_error_m);
  EXPECT_LT(blind_coarse.max_position_error_m / blind.max_position_error_m, 1.1);
  const RoundTrip with_rotor = fly_open_loop(traj, dt, both, both);
  const RoundTrip with_rotor_blind = fly_open_loop(traj, dt, both, none);
  std::cout << "frame and rotor drag: drag-aware " << with_rotor.max_position_error_m
            << " m, attitude " << with_rotor.max_attitude_error_rad << " rad; drag-free "
            << with_rotor_blind.max_position_error_m << " m\n";
  EXPECT_LT(with_rotor.max_position_error_m, 0.1 * with_rotor_blind.max_position_error_m);
}

TEST(FlatDrag, DragTooAnisotropicForTheFixedPointIsNamed) {
  // Frame drag 1000 N s/m along x and 10 along y: the anisotropy, held as a force, outweighs the
  // closed form it corrects, and the fixed point does not settle.
  VehicleSpec spec = load_vehicle_spec(test::source_path("models/qdrone2.yaml"));
  spec.body_drag_Ns_per_m = Vec3(1000.0, 10.0, 0.25).asDiagonal();
  const VehicleModel heavy_drag(spec);
  FlatOutput f = at_rest(Vec3(0, 0, 1), 0.0);
  f.velocity_m_s = Vec3(2.0, 2.0, 0.0);
  const std::string message = error_of([&] {
    (void)flat_state(f, heavy_drag, kG, FlatDragTerms{true, false});
  });
  expect_message(message, "flat_state: the drag fixed point did not converge in 100 iterations");
  expect_message(message, "rotor speed ");
  std::cout << message << "\n";
}

// try_flat_state, the controllers' form: the same state as flat_state to the bit where that one
// returns, and false instead of a throw where it throws (free fall; the fixed point above).
TEST(FlatDrag, TryFlatStateIsFlatStateWithoutThrowing) {
  const auto model = qdrone2();
  for (const FlatDragTerms terms : {FlatDragTerms{}, FlatDragTerms{true, true}}) {
    for (double t = 0.0; t < 4.0; t += 0.29) {
      const FlatOutput f = sine_flat_faster(t, 2.0);
      const FlatState expected = flat_state(f, *model, kG, terms);
      FlatState got;
      ASSERT_TRUE(try_flat_state(f, *model, kG, terms, got)) << t;
      EXPECT_EQ(got.R_WB, expected.R_WB) << t;
      EXPECT_EQ(got.angular_velocity_B_rad_s, expected.angular_velocity_B_rad_s) << t;
      EXPECT_EQ(got.angular_acceleration_B_rad_s2, expected.angular_acceleration_B_rad_s2) << t;
      EXPECT_EQ(got.thrust_N, expected.thrust_N) << t;
      EXPECT_EQ(got.torque_B_Nm, expected.torque_B_Nm) << t;
      EXPECT_EQ(got.rotor_speeds_rad_s, expected.rotor_speeds_rad_s) << t;
    }
  }
  FlatOutput falling = at_rest(Vec3(0, 0, 1), 0.0);
  falling.acceleration_m_s2 = Vec3(0.0, 0.0, -kG);
  FlatState out;
  EXPECT_FALSE(try_flat_state(falling, *model, kG, FlatDragTerms{}, out));
  EXPECT_NE(error_of([&] { (void)flat_state(falling, *model, kG); }), "");
  VehicleSpec spec = load_vehicle_spec(test::source_path("models/qdrone2.yaml"));
  spec.body_drag_Ns_per_m = Vec3(1000.0, 10.0, 0.25).asDiagonal();
  const VehicleModel heavy_drag(spec);
  FlatOutput sideways = at_rest(Vec3(0, 0, 1), 0.0);
  sideways.velocity_m_s = Vec3(2.0, 2.0, 0.0);
  EXPECT_FALSE(try_flat_state(sideways, heavy_drag, kG, FlatDragTerms{true, false}, out));
}

// ---------------------------------------------------------------------------------------------
// 4. Feasibility and time scaling.

// The first sample (t = 0, dt, ... and the end) at which a limit is crossed, found here by
// scanning flat_state: rotor thrusts by solving A t = u (LU, not the pseudo-inverse), compared
// with each rotor's thrust at its speed limits; tilt by atan2; body rate by its norm.
struct BruteForce {
  double time_s = -1.0;
  FeasibilityViolation violation = FeasibilityViolation::kNone;
  int rotor = -1;
  double rotor_thrust_N = 0.0;
  double value = 0.0;
};

BruteForce first_violation(const Trajectory& traj, const VehicleModel& model,
                           const FeasibilityLimits& limits, double dt) {
  std::vector<double> times;
  for (int k = 0; k * dt < traj.duration_s(); ++k) times.push_back(k * dt);
  times.push_back(traj.duration_s());
  for (const double t : times) {
    BruteForce b;
    b.time_s = t;
    FlatState s;
    try {
      s = flat_state(traj.at(t), model, limits.gravity_m_s2, limits.drag);
    } catch (const InvalidArgument&) {
      b.violation = FeasibilityViolation::kSingular;
      return b;
    }
    const Eigen::Matrix4d A = model.allocation_matrix();
    const Vec4 thrusts = A.fullPivLu().solve(s.generalized_force);
    for (int i = 0; i < 4; ++i) {
      const RotorParams& r = model.rotor(i);
      if (thrusts[i] > r.thrust(r.max_speed_rad_s) || thrusts[i] < r.thrust(r.min_speed_rad_s)) {
        b.violation = thrusts[i] > r.thrust(r.max_speed_rad_s)
                          ? FeasibilityViolation::kRotorSpeedAboveMax
                          : FeasibilityViolation::kRotorSpeedBelowMin;
        b.rotor = i;
        b.rotor_thrust_N = thrusts[i];
        return b;
      }
    }
    if (tilt_of(s.R_WB) > limits.max_tilt_rad) {
      b.violation = FeasibilityViolation::kTilt;
      b.value = tilt_of(s.R_WB);
      return b;
    }
    if (s.angular_velocity_B_rad_s.norm() > limits.max_body_rate_rad_s) {
      b.violation = FeasibilityViolation::kBodyRate;
      b.value = s.angular_velocity_B_rad_s.norm();
      return b;
    }
  }
  return {};
}

void expect_same_first_violation(const Trajectory& traj, const VehicleModel& model,
                                 const FeasibilityLimits& limits, double dt) {
  const FeasibilityReport r = check_feasibility(traj, model, limits, dt);
  const BruteForce b = first_violation(traj, model, limits, dt);
  ASSERT_NE(b.violation, FeasibilityViolation::kNone) << "the case must be infeasible";
  EXPECT_FALSE(r.feasible);
  EXPECT_EQ(r.time_s, b.time_s);
  EXPECT_EQ(violation_name(r.violation), violation_name(b.violation));
  EXPECT_EQ(r.rotor, b.rotor);
  if (b.rotor >= 0) {
    // The reported speed is the one the thrust polynomial needs for that thrust.
    EXPECT_NEAR(model.rotor(b.rotor).thrust(r.value), b.rotor_thrust_N, 1e-9);
  } else if (b.violation != FeasibilityViolation::kSingular) {
    EXPECT_NEAR(r.value, b.value, 1e-12);
  }
  expect_message(r.message, "t = ");
  expect_message(r.message, b.rotor >= 0 ? "rotor " + std::to_string(b.rotor) + " speed"
                                         : std::string(violation_name(b.violation)).substr(0, 4));
  std::cout << "first infeasible: " << r.message << " (" << r.samples << " samples)\n";
}

Trajectory aggressive_trajectory() {
  std::vector<Waypoint> w(4);
  w[0].position_m = Vec3(0, 0, 1.0);
  w[1].position_m = Vec3(2.0, 0.5, 1.5);
  w[1].yaw_rad = 0.5;
  w[2].position_m = Vec3(2.5, 2.5, 1.0);
  w[2].yaw_rad = 1.5;
  w[3].position_m = Vec3(0.5, 3.0, 1.2);
  w[3].yaw_rad = 1.0;
  return plan_min_snap(w, {0.8, 0.8, 0.8});
}

TEST(Feasibility, FirstInfeasibleInstantMatchesABruteForceScan) {
  const auto model = qdrone2();
  const Trajectory traj = aggressive_trajectory();
  FeasibilityLimits limits;
  limits.max_tilt_rad = 0.6;
  limits.max_body_rate_rad_s = 4.0;
  expect_same_first_violation(traj, *model, limits, 0.01);
  // With a generous tilt limit the body rate is reached first, later or at the same sample.
  limits.max_tilt_rad = 1.5;
  expect_same_first_violation(traj, *model, limits, 0.01);
  // A rotor limit: a fast climb needs more than the rotors' maximum thrust.
  std::vector<Waypoint> climb(2);
  climb[0].position_m = Vec3(0, 0, 1);
  climb[1].position_m = Vec3(0.3, 0, 9);
  const Trajectory up = plan_min_snap(climb, {1.0});
  limits.max_tilt_rad = 3.0;
  limits.max_body_rate_rad_s = 1e3;
  expect_same_first_violation(up, *model, limits, 0.005);
  const FeasibilityReport r = check_feasibility(up, *model, limits, 0.005);
  EXPECT_EQ(r.violation, FeasibilityViolation::kRotorSpeedAboveMax);
  EXPECT_GT(r.value, model->rotor(r.rotor).max_speed_rad_s);
  EXPECT_EQ(r.limit, model->rotor(r.rotor).max_speed_rad_s);
  // With the model's drag the climb needs more thrust, so the first violation comes no later.
  FeasibilityLimits with_drag = limits;
  with_drag.drag = {true, true};
  expect_same_first_violation(up, *model, with_drag, 0.005);
  EXPECT_LE(check_feasibility(up, *model, with_drag, 0.005).time_s, r.time_s);
  // The gentle trajectory passes, every sample checked (0, 0.01, ..., 2 s).
  const FeasibilityReport ok = check_feasibility(gentle_trajectory(), *model, {}, 0.01);
  EXPECT_TRUE(ok.feasible) << ok.message;
  EXPECT_EQ(ok.samples, 201);
}

TEST(Feasibility, FreeFallIsReportedAsSingular) {
  // One segment of exact free fall, z = 2 - g t^2 / 2: a + g e3 = 0 at every instant.
  PolynomialSegment s;
  s.duration_s = 0.5;
  s.coefficients(0, 2) = 2.0;
  s.coefficients(2, 2) = -kG / 2;
  const Trajectory fall({s});
  const FeasibilityReport r = check_feasibility(fall, *qdrone2(), {}, 0.1);
  EXPECT_FALSE(r.feasible);
  EXPECT_EQ(r.violation, FeasibilityViolation::kSingular);
  EXPECT_EQ(r.time_s, 0.0);
  expect_message(r.message, "t = 0 s: zero thrust (free fall)");
  expect_message(error_of([&] { flat_state(fall.at(0.2), *qdrone2()); }),
                 "flat_state: zero thrust (free fall): |a + g e3| = 0 m/s^2");
}

TEST(TimeScaling, ScaledTrajectoryIsTheSamePathSlower) {
  const Trajectory traj = aggressive_trajectory();
  for (const double factor : {1.7, 0.6}) {
    const Trajectory slow = time_scaled(traj, factor);
    EXPECT_NEAR(slow.duration_s(), factor * traj.duration_s(), 1e-12);
    for (double t = 0.0; t <= traj.duration_s(); t += 0.13) {
      const FlatOutput a = traj.at(t), b = slow.at(factor * t);
      const double f = factor;
      EXPECT_LT((b.position_m - a.position_m).norm(), 1e-12);
      EXPECT_LT((b.velocity_m_s - a.velocity_m_s / f).norm(), 1e-11);
      EXPECT_LT((b.acceleration_m_s2 - a.acceleration_m_s2 / (f * f)).norm(), 1e-10);
      EXPECT_LT((b.jerk_m_s3 - a.jerk_m_s3 / std::pow(f, 3)).norm(), 1e-9);
      EXPECT_LT((b.snap_m_s4 - a.snap_m_s4 / std::pow(f, 4)).norm(), 1e-8);
      EXPECT_NEAR(b.yaw_rad, a.yaw_rad, 1e-12);
      EXPECT_NEAR(b.yaw_rate_rad_s, a.yaw_rate_rad_s / f, 1e-11);
      EXPECT_NEAR(b.yaw_acceleration_rad_s2, a.yaw_acceleration_rad_s2 / (f * f), 1e-10);
    }
  }
}

TEST(TimeScaling, FeasibleTimeScaleIsTheSmallestPassingFactor) {
  const auto model = qdrone2();
  const Trajectory traj = aggressive_trajectory();
  FeasibilityLimits limits;
  limits.max_tilt_rad = 0.6;
  limits.max_body_rate_rad_s = 4.0;
  const double dt = 0.01, tol = 1e-3;
  ASSERT_FALSE(check_feasibility(traj, *model, limits, dt).feasible);
  const double factor = feasible_time_scale(traj, *model, limits, dt, tol);
  std::cout << "feasible time scale " << factor << "\n";
  EXPECT_GT(factor, 1.0);
  const FeasibilityReport pass = check_feasibility(time_scaled(traj, factor), *model, limits, dt);
  EXPECT_TRUE(pass.feasible) << pass.message;
  // The bisection's lower end lo is infeasible and hi - lo <= tol lo, so factor (1 - tol) < lo.
  const FeasibilityReport fail =
      check_feasibility(time_scaled(traj, factor * (1 - tol)), *model, limits, dt);
  EXPECT_FALSE(fail.feasible);
  std::cout << "at " << factor * (1 - tol) << ": " << fail.message << "\n";
  // Already feasible: 1.
  EXPECT_EQ(feasible_time_scale(gentle_trajectory(), *model, {}, dt), 1.0);
  // A tilt limit that no motion meets, however slow: an error naming the last check.
  limits.max_tilt_rad = 1e-9;
  expect_message(error_of([&] { feasible_time_scale(traj, *model, limits, dt, tol, 8.0); }),
                 "feasible_time_scale: even 8 times slower the trajectory is infeasible: t = ");
}

// ---------------------------------------------------------------------------------------------
// 5. Errors.

TEST(FlatnessErrors, EachBadInputIsNamed) {
  const auto model = qdrone2();
  const Trajectory traj = gentle_trajectory();
  for (const double factor : {0.0, -2.0, std::nan("")}) {
    expect_message(error_of([&] { time_scaled(traj, factor); }),
                   "time_scaled: factor: expected a positive finite number, got ");
  }
  for (const double dt : {0.0, -0.01, std::nan(""), std::numeric_limits<double>::infinity()}) {
    expect_message(error_of([&] { check_feasibility(traj, *model, {}, dt); }),
                   "check_feasibility: sample_dt_s: expected a positive finite time step, got ");
    expect_message(error_of([&] { feasible_time_scale(traj, *model, {}, dt); }),
                   "feasible_time_scale: sample_dt_s: expected a positive finite time step");
  }
  // A step that would take forever: refused before the first sample, with the count named.
  expect_message(error_of([&] { check_feasibility(traj, *model, {}, 1e-12); }),
                 "s trajectory gives 2000000000001 samples, expected at most 10000000");
  FeasibilityLimits bad;
  bad.max_tilt_rad = 0.0;
  expect_message(error_of([&] { check_feasibility(traj, *model, bad, 0.01); }),
                 "limits.max_tilt_rad: expected a positive finite angle, got 0");
  bad = {};
  bad.max_body_rate_rad_s = -1.0;
  expect_message(error_of([&] { check_feasibility(traj, *model, bad, 0.01); }),
                 "limits.max_body_rate_rad_s: expected a positive finite rate, got -1");
  expect_message(error_of([&] { feasible_time_scale(traj, *model, {}, 0.01, 0.0); }),
                 "relative_tolerance: expected a number in (0, 1), got 0");
  expect_message(error_of([&] { feasible_time_scale(traj, *model, {}, 0.01, 1e-3, 1.0); }),
                 "max_factor: expected a finite number > 1, got 1");

  // Free fall, thrust along the heading, non-finite outputs, bad gravity.
  FlatOutput f = at_rest(Vec3(0, 0, 1), 0.0);
  f.acceleration_m_s2 = Vec3(0, 0, -kG);
  expect_message(error_of([&] { flat_state(f, *model); }),
                 "flat_state: zero thrust (free fall): |a + g e3| = 0 m/s^2");
  f.acceleration_m_s2 = Vec3(-3.0, 0, -kG);  // thrust along -x, heading yaw = pi along -x
  f.yaw_rad = std::numbers::pi;
  expect_message(
      error_of([&] { flat_state(f, *model); }),
      "flat_state: thrust direction z_B = [-1, 0, 0] parallel to the heading x_C = [-1, ");
  f = at_rest(Vec3(0, 0, 1), 0.0);
  f.snap_m_s4.y() = std::nan("");
  expect_message(error_of([&] { flat_state(f, *model); }),
                 "flat_state: the flat output has a non-finite number (position [0, 0, 1], "
                 "velocity [0, 0, 0], acceleration [0, 0, 0], jerk [0, 0, 0], snap [0, nan, 0]");
  expect_message(error_of([&] { flat_state(at_rest(Vec3(0, 0, 1), 0.0), *model, -9.81); }),
                 "flat_state: gravity_m_s2: expected a finite value >= 0, got -9.81");
}

}  // namespace
}  // namespace dronetwin::planning
