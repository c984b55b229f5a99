// The SE(3) controller's body-rate and angular-acceleration feed-forward (control/se3.hpp,
// Se3Options::angular_feed_forward) on an aggressive minimum-snap trajectory.
//
// The physics the tests rest on: in a simulator whose model is the flatness model (no drag or
// rotor moments besides the allocation's, no motor lag; planning/flatness.hpp), the reference's
// flat state is an exact solution of the closed loop with the full law of Lee et al. (every error
// term is zero on it, and the feed-forward supplies exactly the flat torques). What remains is
// the discretisation: the controller's command is held over a step (and a step later without
// motor lag), an O(dt) perturbation, so the tracking error must fall in proportion to the step.
// Without the feed-forward the law damps the very body rates the trajectory needs: a structural
// error that does not shrink with the step. Drag is the one term neither law knows: with it on,
// the remaining error is the drag's (docs/controllers.md, "Feed-forward").

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "control/aggressive_lap.hpp"
#include "dronetwin/control/se3.hpp"
#include "dronetwin/planning/flatness.hpp"

namespace dronetwin {
namespace {

using planning::Trajectory;
using test::aggressive_lap;
using test::qdrone2;
using test::Tracking;

// The flying configuration of config/controllers/se3.yaml (Eq. 3.29 with more roll and pitch
// damping, the gravity term), with the model's own mass so that the feed-forward is exact.
Se3Controller controller(bool feed_forward, bool drag_feed_forward = false) {
  Se3Gains gains = Se3Gains::thesis();
  gains.attitude_d = Vec3(0.8, 0.8, 0.05);
  gains.mass_kg = qdrone2()->mass_kg();
  Se3Options options;
  options.gravity_compensation = true;
  options.angular_feed_forward = feed_forward;
  options.drag_feed_forward = drag_feed_forward;
  return Se3Controller(qdrone2(), gains, options);
}

Tracking fly(const Trajectory& lap, bool feed_forward, SimConfig cfg,
             bool drag_feed_forward = false) {
  Se3Controller se3 = controller(feed_forward, drag_feed_forward);
  return test::fly_lap(lap, se3, cfg);
}

SimConfig flatness_model(double dt_s) {
  SimConfig cfg;
  cfg.dt_s = dt_s;
  cfg.disturbances = DisturbanceSwitches::none();
  cfg.motor_dynamics = false;
  return cfg;
}

TEST(Se3FeedForward, TheLapIsFeasibleForTheRotors) {
  planning::FeasibilityLimits limits;
  limits.max_tilt_rad = 0.5;
  const planning::FeasibilityReport r =
      planning::check_feasibility(aggressive_lap(), *qdrone2(), limits, 0.005);
  EXPECT_TRUE(r.feasible) << r.message;
}

// On the flatness model the error with feed-forward is discretisation error (first order in the
// step); without it the error is the law's and stays.
TEST(Se3FeedForward, OnTheFlatnessModelOnlyDiscretisationErrorRemains) {
  const Trajectory lap = aggressive_lap();
  const Tracking ff = fly(lap, true, flatness_model(1e-3));
  const Tracking ff_fine = fly(lap, true, flatness_model(5e-4));
  const Tracking plain = fly(lap, false, flatness_model(1e-3));
  const Tracking plain_fine = fly(lap, false, flatness_model(5e-4));
  std::printf(
      "[ se3 ff   ] flatness model, max error: with feed-forward %.3g m (dt 1 ms), "
      "%.3g m (0.5 ms); without %.3g m, %.3g m\n",
      ff.max_m, ff_fine.max_m, plain.max_m, plain_fine.max_m);
  const double ff_ratio = ff.max_m / ff_fine.max_m;
  EXPECT_GT(ff_ratio, 1.7) << "first order in the step";
  EXPECT_LT(ff_ratio, 2.3) << "first order in the step";
  const double plain_ratio = plain.max_m / plain_fine.max_m;
  EXPECT_GT(plain_ratio, 0.8) << "without feed-forward the error does not shrink with the step";
  EXPECT_LT(plain_ratio, 1.25) << "without feed-forward the error does not shrink with the step";
  EXPECT_LT(ff.max_m, plain.max_m);
}

// The QDrone2 model with every term the feed-forward does not know except drag: the motor lag,
// the rotors' drag and rolling moments, their gyroscopic moment, ground effect. The feed-forward
// still removes most of the error. With drag on as well, neither law compensates it and the
// error is the drag's; both numbers are printed for docs/controllers.md.
TEST(Se3FeedForward, LowersTheTrackingErrorWithEveryTermButDrag) {
  const Trajectory lap = aggressive_lap();
  SimConfig no_drag;
  no_drag.disturbances.rotor_drag = false;
  no_drag.disturbances.body_drag = false;
  const Tracking ff = fly(lap, true, no_drag);
  const Tracking plain = fly(lap, false, no_drag);
  std::printf(
      "[ se3 ff   ] all but drag, 1 kHz: RMSE %.4f m with feed-forward, %.4f m without "
      "(max %.4f m, %.4f m)\n",
      ff.rms_m, plain.rms_m, ff.max_m, plain.max_m);
  EXPECT_LT(ff.rms_m, plain.rms_m);
  EXPECT_LT(ff.max_m, plain.max_m);
}

// With drag on, neither the rate feed-forward nor the plain law compensates the drag force; the
// drag feed-forward (the model's drag on the reference's flat state through the drag) does, and
// with both the error falls well below the plain law's. The numbers go to docs/controllers.md.
TEST(Se3FeedForward, WithDragOnTheDragFeedForwardRemovesMostOfTheError) {
  const Trajectory lap = aggressive_lap();
  const Tracking plain = fly(lap, false, SimConfig{});
  const Tracking rates = fly(lap, true, SimConfig{});
  const Tracking drag = fly(lap, false, SimConfig{}, true);
  const Tracking both = fly(lap, true, SimConfig{}, true);
  std::printf(
      "[ se3 ff   ] full model with drag, RMSE (max): plain %.4f (%.4f) m, rates %.4f "
      "(%.4f) m, drag %.4f (%.4f) m, both %.4f (%.4f) m\n",
      plain.rms_m, plain.max_m, rates.rms_m, rates.max_m, drag.rms_m, drag.max_m, both.rms_m,
      both.max_m);
  EXPECT_LT(both.rms_m, plain.rms_m);
  EXPECT_LT(both.rms_m, drag.rms_m);
  EXPECT_LT(drag.rms_m, plain.rms_m);
}

// A reference without jerk, snap or yaw motion (a setpoint) leaves the law as printed: the same
// command bit for bit.
TEST(Se3FeedForward, ASetpointGetsTheSameCommandAsWithout) {
  Se3Controller with = controller(true), without = controller(false);
  ControlInput in;
  in.state = Simulator::hover_state(Vec3(0.3, -0.2, 1.1), 0.4);
  in.state.segment<3>(state_index::kAngularVelocity) = Vec3(0.2, -0.1, 0.3);
  in.reference.position_m = Vec3(1, 0, 1.5);
  in.reference.yaw_rad = 0.7;
  EXPECT_EQ(with.calculate_u(in), without.calculate_u(in));
}

}  // namespace
}  // namespace dronetwin
