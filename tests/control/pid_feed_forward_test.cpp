// The cascaded PID's feed-forward (control/pid.hpp, PidOptions::acceleration_feed_forward and
// angular_feed_forward): what it must do by the physics of the loop, and what it gains on the
// aggressive minimum-snap lap the SE(3) feed-forward is measured on.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "control/aggressive_lap.hpp"
#include "dronetwin/config/controller_config.hpp"
#include "dronetwin/control/pid.hpp"

namespace dronetwin {
namespace {

using test::qdrone2;
using test::Tracking;

/// config/controllers/pid_tuned.yaml, with the model's own mass in the gravity term.
PidSettings tuned() {
  PidSettings s = std::get<PidSettings>(
      load_controller_config(test::source_path("config/controllers/pid_tuned.yaml")).settings);
  s.gains.mass_kg = qdrone2()->mass_kg();
  return s;
}

CascadedPid controller(PidSettings s, bool acceleration, bool angular, bool drag = false) {
  s.options.acceleration_feed_forward = acceleration;
  s.options.angular_feed_forward = angular;
  s.options.drag_feed_forward = drag;
  return CascadedPid(qdrone2(), s.gains, s.options, 1e-3);
}

SimConfig flatness_model() {
  SimConfig cfg;
  cfg.disturbances = DisturbanceSwitches::none();
  cfg.motor_dynamics = false;
  return cfg;
}

// Level and at rest on a reference at the vehicle with acceleration a: the small-angle mapping of
// Eq. 3.18 with a_x = g theta and a_y = -g phi asks theta_des = a_x / g and phi_des = -a_y / g,
// and the thrust m (g + a_z); the inner P gains turn the tilt errors into moments.
TEST(PidFeedForward, TheAccelerationAsksForItsTiltAndThrust) {
  PidSettings s = tuned();
  CascadedPid pid = controller(s, true, false);
  ControlInput in;
  in.state = Simulator::hover_state(Vec3(0, 0, 1));
  in.reference.position_m = Vec3(0, 0, 1);
  in.reference.acceleration_m_s2 = Vec3(1.0, -2.0, 0.5);
  const GeneralizedForce u = pid.calculate_u(in);
  const double g = s.gains.gravity_m_s2, m = s.gains.mass_kg;
  EXPECT_NEAR(u[0], m * (g + 0.5), 1e-12);
  EXPECT_NEAR(u[1], s.gains.inner_p[0] * (2.0 / g), 1e-12);  // phi_des = -a_y / g
  EXPECT_NEAR(u[2], s.gains.inner_p[1] * (1.0 / g), 1e-12);
  EXPECT_NEAR(u[3], 0.0, 1e-15);
}

// A reference in free fall has no flat attitude (no thrust direction): the flat terms (rates,
// drag) are zero for that step, and the acceleration is still fed forward, so the drag option
// changes nothing there. Here the thrust feed-forward m a_z = -m g cancels the weight term.
TEST(PidFeedForward, AFreeFallingReferenceKeepsItsAccelerationFeedForward) {
  PidSettings s = tuned();
  CascadedPid acceleration = controller(s, true, false);
  CascadedPid all = controller(s, true, true, true);
  ControlInput in;
  in.state = Simulator::hover_state(Vec3(0, 0, 1));
  in.reference.position_m = Vec3(0, 0, 1);
  in.reference.velocity_m_s = Vec3(1.0, 0, 0);  // moving: the drag would not be zero
  in.state.segment<3>(state_index::kVelocity) = Vec3(1.0, 0, 0);
  in.reference.acceleration_m_s2 = Vec3(0, 0, -s.gains.gravity_m_s2);
  in.reference.jerk_m_s3 = Vec3(0.3, 0, 0);
  const GeneralizedForce u = acceleration.calculate_u(in);
  EXPECT_EQ(all.calculate_u(in), u);
  EXPECT_NEAR(u[0], 0.0, 1e-12);
}

// A climb at constant acceleration a from hover: z_ref = z0 + a t^2 / 2. Without the integral
// the z loop m e'' + K_D e' + K_P e = m a (T = u_z + m g, no drag) settles at e = m a / K_P;
// the thrust feed-forward m a_ref cancels its source, and the error goes to round-off.
class Climb final : public Reference {
 public:
  explicit Climb(double a) : a_(a) {}
  ReferencePoint at(double t_s) const override {
    ReferencePoint p;
    p.position_m = Vec3(0, 0, 1.0 + 0.5 * a_ * t_s * t_s);
    p.velocity_m_s = Vec3(0, 0, a_ * t_s);
    p.acceleration_m_s2 = Vec3(0, 0, a_);
    return p;
  }
  std::unique_ptr<Reference> clone() const override { return std::make_unique<Climb>(a_); }
  std::string describe() const override { return "constant-acceleration climb"; }

 private:
  double a_;
};

double climb_error_after(double duration_s, bool feed_forward, const PidSettings& s) {
  Simulator sim(qdrone2(), flatness_model());
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1.0)), qdrone2()->hover_speeds_rad_s());
  CascadedPid pid = controller(s, feed_forward, false);
  const Climb climb(1.5);
  ClosedLoop loop(sim, pid, climb, 1000.0);
  EXPECT_TRUE(loop.run(duration_s).ok());
  return climb.at(sim.time_s()).position_m.z() - sim.state()[state_index::kPosition + 2];
}

TEST(PidFeedForward, TheThrustFeedForwardRemovesTheSteadyLagOfAClimb) {
  PidSettings s = tuned();
  s.gains.outer_i.setZero();  // the analytic steady state of a PD loop
  const double a = 1.5, expected = s.gains.mass_kg * a / s.gains.outer_p[2];
  const double plain = climb_error_after(3.0, false, s);
  const double ff = climb_error_after(3.0, true, s);
  std::printf(
      "[ pid ff   ] climb at %.1f m/s^2: lag %.4g m without (m a / K_P = %.4g m), %.3g m "
      "with\n",
      a, plain, expected, ff);
  EXPECT_NEAR(plain, expected, 0.02 * expected);
  EXPECT_LT(std::abs(ff), 1e-3 * expected);
}

// A reference without acceleration, jerk, snap or yaw motion (a setpoint) leaves the law as it
// was: the same command bit for bit.
TEST(PidFeedForward, ASetpointGetsTheSameCommandAsWithout) {
  CascadedPid with = controller(tuned(), true, true), without = controller(tuned(), false, false);
  ControlInput in;
  in.state = Simulator::hover_state(Vec3(0.3, -0.2, 1.1), 0.4);
  in.state.segment<3>(state_index::kAngularVelocity) = Vec3(0.2, -0.1, 0.3);
  in.state_derivative.setZero();
  in.state_derivative.segment<3>(state_index::kAngularVelocity) = Vec3(1.0, -0.5, 0.2);
  in.reference.position_m = Vec3(1, 0, 1.5);
  in.reference.yaw_rad = 0.7;
  EXPECT_EQ(with.calculate_u(in), without.calculate_u(in));
}

// The aggressive lap on the QDrone2 model with every term but drag (motor lag, rotor moments,
// ground effect): the acceleration feed-forward removes the lag the PD loop needs to build the
// tilt, and the angular one the damping of the body rates the turns need. The numbers go to
// docs/controllers.md.
TEST(PidFeedForward, LowersTheTrackingErrorOnAnAggressiveLap) {
  const planning::Trajectory lap = test::aggressive_lap();
  SimConfig no_drag;
  no_drag.disturbances.rotor_drag = false;
  no_drag.disturbances.body_drag = false;
  CascadedPid plain = controller(tuned(), false, false);
  CascadedPid acceleration = controller(tuned(), true, false);
  CascadedPid both = controller(tuned(), true, true);
  const Tracking p = test::fly_lap(lap, plain, no_drag);
  const Tracking a = test::fly_lap(lap, acceleration, no_drag);
  const Tracking b = test::fly_lap(lap, both, no_drag);
  std::printf(
      "[ pid ff   ] all but drag, RMSE (max): plain %.4f (%.4f) m, acceleration %.4f (%.4f) m, "
      "acceleration and angular %.4f (%.4f) m\n",
      p.rms_m, p.max_m, a.rms_m, a.max_m, b.rms_m, b.max_m);
  EXPECT_LT(a.rms_m, p.rms_m);
  EXPECT_LT(b.rms_m, a.rms_m);
}

// With drag on, the drag the reference's speed meets is what remains; the drag feed-forward
// cancels it, and with every feed-forward the error falls below each partial one.
TEST(PidFeedForward, WithDragOnTheDragFeedForwardRemovesMostOfTheRest) {
  const planning::Trajectory lap = test::aggressive_lap();
  CascadedPid plain = controller(tuned(), false, false);
  CascadedPid acceleration = controller(tuned(), true, false);
  CascadedPid drag = controller(tuned(), true, false, true);
  CascadedPid all = controller(tuned(), true, true, true);
  const Tracking p = test::fly_lap(lap, plain, SimConfig{});
  const Tracking a = test::fly_lap(lap, acceleration, SimConfig{});
  const Tracking d = test::fly_lap(lap, drag, SimConfig{});
  const Tracking e = test::fly_lap(lap, all, SimConfig{});
  std::printf(
      "[ pid ff   ] full model with drag, RMSE (max): plain %.4f (%.4f) m, acceleration %.4f "
      "(%.4f) m, acceleration and drag %.4f (%.4f) m, all %.4f (%.4f) m\n",
      p.rms_m, p.max_m, a.rms_m, a.max_m, d.rms_m, d.max_m, e.rms_m, e.max_m);
  EXPECT_LT(a.rms_m, p.rms_m);
  EXPECT_LT(d.rms_m, a.rms_m);
  EXPECT_LT(e.rms_m, d.rms_m);
}

}  // namespace
}  // namespace dronetwin
