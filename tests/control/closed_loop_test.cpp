// Closed-loop flights of the shipped controllers on the QDrone2 (physics 1 kHz, every disturbance
// term on): sign conventions, upset and offset recovery at 1 kHz and 100 Hz control, the PID pulse
// of thesis Eq. 3.14 and the SE(3) circle of Eq. 3.28 against the thesis RMSE tables, the
// controllers as printed failing the way docs/controllers.md says, and ClosedLoop's rate check.
//
// RMSE here: every physics step from `rmse_from_s` on, true (not measured) state against the
// reference at the same instant, yaw error wrapped into [-pi, pi].
#include "dronetwin/control/closed_loop.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <tuple>

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/config/controller_config.hpp"
#include "dronetwin/control/se3.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/ground.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

struct Flight {
  std::string config;  ///< stem of a file in config/controllers, or empty with `controller`
  ControllerBase* controller = nullptr;
  const Reference* reference = nullptr;
  StateVector initial_state = Simulator::hover_state(Vec3(0, 0, 1));
  bool rotors_at_hover = true;  ///< initial rotor speeds: hover, or stopped (on the ground)
  double duration_s = 10.0;
  double rate_hz = 1000.0;
  bool noise = false;
  double rmse_from_s = 0.0;
};

struct FlightResult {
  StepStatus status = StepStatus::kOk;
  bool crashed = false;
  double end_s = 0.0;
  Vec4 rmse = Vec4::Zero();  ///< [x, y, z, psi], m and rad
  /// Last time the vehicle was more than 5 cm from the reference or tilted more than 2 deg.
  double last_outside_band_s = 0.0;
  /// First time the tilt exceeded 45 deg (-1: never).
  double first_upset_s = -1.0;
  StateVector final_state = StateVector::Zero();
  std::int64_t control_updates = 0;
  bool failed() const { return status != StepStatus::kOk || crashed; }
};

FlightResult fly(const Flight& f) {
  const auto model = test::load_model("qdrone2");
  SimConfig cfg;  // 1 ms physics step, RK4, every disturbance term, ground contact
  cfg.noise.enabled = f.noise;
  cfg.seed = 3;
  Simulator sim(model, cfg);
  sim.reset(f.initial_state,
            f.rotors_at_hover ? model->hover_speeds_rad_s() : RotorVector::Zero(4));
  std::unique_ptr<ControllerBase> owned;
  ControllerBase* controller = f.controller;
  if (controller == nullptr) {
    owned = load_controller(test::source_path("config/controllers/" + f.config + ".yaml"), model,
                            f.rate_hz);
    controller = owned.get();
  }
  controller->reset();
  ClosedLoop loop(sim, *controller, *f.reference, f.rate_hz);

  FlightResult r;
  Vec4 sum_sq = Vec4::Zero();
  std::int64_t samples = 0;
  const auto steps = static_cast<std::int64_t>(std::llround(f.duration_s / cfg.dt_s));
  for (std::int64_t k = 0; k < steps; ++k) {
    r.status = loop.step().status;
    if (r.status != StepStatus::kOk) break;
    const double t = sim.time_s();
    const StateVector& x = sim.state();
    const ReferencePoint ref = f.reference->at(t);
    Vec4 e;
    e.head<3>() = ref.position_m - x.head<3>();
    e[3] = std::remainder(ref.yaw_rad - math::to_euler(x.segment<4>(6))[2], 2.0 * std::numbers::pi);
    if (t >= f.rmse_from_s - 1e-12) {
      sum_sq += e.cwiseAbs2();
      ++samples;
    }
    const double tilt = tilt_angle_rad(x);
    if (e.head<3>().norm() > 0.05 || tilt > 2.0 * kDeg) r.last_outside_band_s = t;
    if (r.first_upset_s < 0.0 && tilt > 45.0 * kDeg) r.first_upset_s = t;
    if (sim.contact().crashed) {
      r.crashed = true;
      break;
    }
  }
  r.end_s = sim.time_s();
  r.rmse = (sum_sq / static_cast<double>(std::max<std::int64_t>(samples, 1))).cwiseSqrt();
  r.final_state = sim.state();
  r.control_updates = loop.control_updates();
  return r;
}

// ---- signs ------------------------------------------------------------------------------------

class FlyingController : public ::testing::TestWithParam<std::string> {};

TEST_P(FlyingController, PositiveErrorsMoveTowardTheReference) {
  // Eq. 3.18 as printed maps u_x to +theta and u_y to -phi. In our frames (z up, y left,
  // R = Rz Ry Rx) a positive pitch tilts the thrust toward +x and a negative roll toward +y, so a
  // +x error must pitch the nose down (theta > 0) and move the vehicle to +x, a +y error must
  // roll negative and move it to +y.
  const SetpointReference ahead(Vec3(0.5, 0, 1)), left(Vec3(0, 0.5, 1));
  Flight f;
  f.config = GetParam();
  f.duration_s = 0.3;
  f.reference = &ahead;
  FlightResult r = fly(f);
  Vec3 euler = math::to_euler(r.final_state.segment<4>(6));
  EXPECT_GT(euler[1], 1.0 * kDeg);    // pitched toward +x
  EXPECT_GT(r.final_state[3], 0.05);  // v_x > 0
  EXPECT_GT(r.final_state[0], 0.0);
  EXPECT_NEAR(r.final_state[1], 0.0, 1e-3);
  f.duration_s = 1.0;
  r = fly(f);
  EXPECT_GT(r.final_state[0], 0.1);

  f.reference = &left;
  f.duration_s = 0.3;
  r = fly(f);
  euler = math::to_euler(r.final_state.segment<4>(6));
  EXPECT_LT(euler[0], -1.0 * kDeg);   // rolled toward +y
  EXPECT_GT(r.final_state[4], 0.05);  // v_y > 0
  EXPECT_NEAR(r.final_state[0], 0.0, 1e-3);
  f.duration_s = 1.0;
  r = fly(f);
  EXPECT_GT(r.final_state[1], 0.1);
}

TEST_P(FlyingController, ReachesASetpointAtAnotherHeading) {
  // Heading 2 rad (held by the reference): the horizontal commands must be taken in the heading
  // frame (pid.yaml's yaw_frame_mapping; SE(3) does it through b1d), or the vehicle spirals.
  const SetpointReference target(Vec3(0.5, -0.3, 1), 2.0);
  Flight f;
  f.config = GetParam();
  f.reference = &target;
  f.initial_state = Simulator::hover_state(Vec3(0, 0, 1), 2.0);
  f.duration_s = 8.0;
  const FlightResult r = fly(f);
  ASSERT_FALSE(r.failed());
  EXPECT_LT(r.last_outside_band_s, 4.0);
  // 0.05 rad: pid.yaml keeps the printed yaw loop (notes #32), a stiffness of 0.0015 N m/rad
  // against ~0.03 N m s/rad of rotor-drag yaw damping, i.e. a ~20 s time constant; the manoeuvre
  // leaves it ~0.025 rad off at 8 s. SE(3) ends within 1e-4 rad.
  EXPECT_NEAR(math::to_euler(r.final_state.segment<4>(6))[2], 2.0, 0.05);
}

INSTANTIATE_TEST_SUITE_P(Configs, FlyingController, ::testing::Values("pid", "se3"));

// ---- upsets and offsets -----------------------------------------------------------------------

using RecoveryCase = std::tuple<std::string, int /*0 roll, 1 pitch*/, double /*rate*/>;
class TiltRecovery : public ::testing::TestWithParam<RecoveryCase> {};

TEST_P(TiltRecovery, BackWithin5cmAnd2DegreesWithin3Seconds) {
  // Hover at 1 m, released with a 30 deg roll or pitch and zero rates. Settling time 3 s: the
  // attitude loops remove the upset in a few tenths of a second (measured 0.5-1.0 s to the band,
  // PID and SE(3), both rates); what remains is the drift it caused, removed by the slowest loop,
  // the PID's position loop (omega = sqrt(g K_P,x) = 2.15 rad/s, zeta = 0.95, 2 % settling time
  // 4 / (zeta omega) = 2.0 s). The run goes on to 8 s, so the vehicle must also stay in the band.
  const auto& [config, axis, rate] = GetParam();
  const SetpointReference hover(Vec3(0, 0, 1));
  Flight f;
  f.config = config;
  f.reference = &hover;
  f.rate_hz = rate;
  f.duration_s = 8.0;
  f.initial_state.segment<4>(6) =
      axis == 0 ? math::from_euler(30 * kDeg, 0, 0) : math::from_euler(0, 30 * kDeg, 0);
  const FlightResult r = fly(f);
  ASSERT_FALSE(r.failed()) << status_name(r.status);
  EXPECT_LT(r.last_outside_band_s, 3.0);
  EXPECT_LT((r.final_state.head<3>() - Vec3(0, 0, 1)).norm(), 0.01);
  // Zero-order hold: one controller update per 1000 / rate physics steps.
  EXPECT_EQ(r.control_updates, static_cast<std::int64_t>(std::llround(8.0 * rate)));
}

INSTANTIATE_TEST_SUITE_P(Configs, TiltRecovery,
                         ::testing::Combine(::testing::Values("pid", "se3"),
                                            ::testing::Values(0, 1),
                                            ::testing::Values(1000.0, 100.0)),
                         [](const ::testing::TestParamInfo<RecoveryCase>& p) {
                           return std::get<0>(p.param) +
                                  (std::get<1>(p.param) == 0 ? "_roll_" : "_pitch_") +
                                  std::to_string(static_cast<int>(std::get<2>(p.param))) + "Hz";
                         });

using OffsetCase = std::tuple<std::string, double /*rate*/>;
class OffsetRecovery : public ::testing::TestWithParam<OffsetCase> {};

TEST_P(OffsetRecovery, OneMetreHorizontalOffsetSettlesWithin4Seconds) {
  // Hover at rest 1 m from the setpoint along x, then along y. 4 s: the PID's tilt limit
  // (0.2 rad) caps the acceleration at g tan 0.2 = 2 m/s^2, and its position loop then settles in
  // ~2 s (see above); measured 2.7 s (PID) and 1.9 s (SE(3)) at both rates.
  const auto& [config, rate] = GetParam();
  const SetpointReference hover(Vec3(0, 0, 1));
  for (const Vec3& start : {Vec3(1, 0, 1), Vec3(0, -1, 1)}) {
    Flight f;
    f.config = config;
    f.reference = &hover;
    f.rate_hz = rate;
    f.duration_s = 8.0;
    f.initial_state = Simulator::hover_state(start);
    const FlightResult r = fly(f);
    ASSERT_FALSE(r.failed()) << status_name(r.status);
    EXPECT_LT(r.last_outside_band_s, 4.0) << "start " << start.transpose();
    // The PID ends ~9 mm past the setpoint: the integral charged during the approach unwinds
    // with the slow ratio K_I / K_P = 0.021 1/s (Eq. 3.21), so 2 cm here, 5 cm in the band.
    EXPECT_LT((r.final_state.head<3>() - Vec3(0, 0, 1)).norm(), 0.02);
  }
}

INSTANTIATE_TEST_SUITE_P(Configs, OffsetRecovery,
                         ::testing::Combine(::testing::Values("pid", "se3"),
                                            ::testing::Values(1000.0, 100.0)),
                         [](const ::testing::TestParamInfo<OffsetCase>& p) {
                           return std::get<0>(p.param) + "_" +
                                  std::to_string(static_cast<int>(std::get<1>(p.param))) + "Hz";
                         });

// ---- the thesis experiments -------------------------------------------------------------------

class PulseFlight : public ::testing::TestWithParam<bool /*noise*/> {};

TEST_P(PulseFlight, PidFliesThePulseFromTheGround) {
  // Thesis Sec. 3.6.1.2: pulse of Eq. 3.14 for 60 s from rest on the ground, 1 kHz control.
  // Bounds, against Table 3.1 (x 0.1213 m, y 0.0385 m, z 0.0377 m, psi 0.1179 rad):
  //  - y and psi: the thesis values. We measure ~0 (nothing excites y or yaw without wind).
  //  - x and z: NOT the thesis values, which these outer-loop gains (Eq. 3.21, unchanged in
  //    pid.yaml) cannot reach under any reading. Even an ideal loop (instant attitude, no tilt
  //    limit) e'' = -g K_P,x e - g K_D,x e' gives a step error integral A^2 (1 + 4 zeta^2) /
  //    (4 zeta omega) = 0.566 A^2 (omega = 2.15 rad/s, zeta = 0.95); the pulse's steps (0.75,
  //    1.5, 1.5, 0.75 m) then give RMSE_x = 0.230 m over 60 s. Likewise z (omega = 4.58 rad/s,
  //    zeta = 1.36, one 0.75 m step) gives 0.056 m. We measure x 0.282 m (the 0.2 rad tilt limit
  //    slows the 1.5 m steps) and z 0.059 m, with and without noise, and bound them at 0.30 m and
  //    0.065 m. This shortfall is reported in docs/controllers.md.
  const PiecewiseConstantReference pulse = PiecewiseConstantReference::thesis_pulse();
  Flight f;
  f.config = "pid";
  f.reference = &pulse;
  f.initial_state = Simulator::hover_state(Vec3::Zero());
  f.rotors_at_hover = false;
  f.duration_s = 60.0;
  f.noise = GetParam();
  const FlightResult r = fly(f);
  ASSERT_FALSE(r.failed()) << status_name(r.status) << " at t = " << r.end_s;
  EXPECT_DOUBLE_EQ(r.end_s, 60.0);
  EXPECT_LT(r.rmse[0], 0.30);
  EXPECT_LT(r.rmse[1], 0.0385);
  EXPECT_LT(r.rmse[2], 0.065);
  EXPECT_LT(r.rmse[3], 0.1179);
  EXPECT_LT((r.final_state.head<3>() - Vec3(0, 0, 0.75)).norm(), 0.05);
  ::testing::Test::RecordProperty("rmse", ::testing::PrintToString(r.rmse.transpose()));
}

INSTANTIATE_TEST_SUITE_P(Noise, PulseFlight, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& p) {
                           return p.param ? std::string("noise_on") : std::string("noise_off");
                         });

class AsPrintedPid : public ::testing::TestWithParam<std::string> {};

TEST_P(AsPrintedPid, LosesAttitudeAtTheFirstXStepOfThePulse) {
  // This test records a failure on purpose. The PID as printed (pid_thesis.yaml: Eq. 3.21 gains
  // and Eq. 2.31 allocation; pid_hardware.yaml: Eq. 3.22 gains) takes off and hovers, then loses
  // attitude right after the first 0.75 m x step at t = 30 s and crashes (notes #34: t ~ 30.6 s).
  // docs/controllers.md and the config files say so; if this starts passing, update them.
  const PiecewiseConstantReference pulse = PiecewiseConstantReference::thesis_pulse();
  Flight f;
  f.config = GetParam();
  f.reference = &pulse;
  f.initial_state = Simulator::hover_state(Vec3::Zero());
  f.rotors_at_hover = false;
  f.duration_s = 60.0;
  for (bool noise : {false, true}) {
    f.noise = noise;
    const FlightResult r = fly(f);
    EXPECT_TRUE(r.failed()) << "noise " << noise << ": finished the pulse";
    EXPECT_GT(r.first_upset_s, 30.0) << "noise " << noise;
    EXPECT_LT(r.first_upset_s, 31.0) << "noise " << noise;
  }
}

INSTANTIATE_TEST_SUITE_P(Configs, AsPrintedPid, ::testing::Values("pid_thesis", "pid_hardware"));

class CircleFlight : public ::testing::TestWithParam<bool /*noise*/> {};

TEST_P(CircleFlight, Se3TracksTheCircleFromTheReference) {
  // Thesis Sec. 3.6.3.1: circle of Eq. 3.28 (r = 2 m, T = 7 s, z = 1 m), 35 s (5 laps), started
  // on the reference (p_des(0), v_des(0); notes #37). Bounds: Table 3.8 as printed (x 0.1594 m,
  // y 0.14099 m, z 0.0835 m, psi 0.0347 rad). Measured ~[0.047, 0.047, 0.0084, 0.019].
  const CircleReference circle;
  const ReferencePoint start = circle.at(0.0);
  Flight f;
  f.config = "se3";
  f.reference = &circle;
  f.initial_state = Simulator::hover_state(start.position_m);
  f.initial_state.segment<3>(3) = start.velocity_m_s;
  f.duration_s = 35.0;
  f.noise = GetParam();
  const FlightResult r = fly(f);
  ASSERT_FALSE(r.failed()) << status_name(r.status) << " at t = " << r.end_s;
  EXPECT_LT(r.rmse[0], 0.1594);
  EXPECT_LT(r.rmse[1], 0.14099);
  EXPECT_LT(r.rmse[2], 0.0835);
  EXPECT_LT(r.rmse[3], 0.0347);
  ::testing::Test::RecordProperty("rmse", ::testing::PrintToString(r.rmse.transpose()));
}

INSTANTIATE_TEST_SUITE_P(Noise, CircleFlight, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& p) {
                           return p.param ? std::string("noise_on") : std::string("noise_off");
                         });

TEST(CircleFlight, Se3JoinsTheCircleFromRest) {
  // Two starts at rest: hovering at p_des(0) (where the circle's reference velocity is 1.8 m/s),
  // and on the ground at the origin with the rotors stopped (2.2 m from the circle). The first
  // lap is the transient; from the second lap on (t >= 7 s) the Table 3.8 bounds hold.
  const CircleReference circle;
  for (bool on_ground : {false, true}) {
    Flight f;
    f.config = "se3";
    f.reference = &circle;
    f.initial_state = Simulator::hover_state(on_ground ? Vec3::Zero() : circle.at(0.0).position_m);
    f.rotors_at_hover = !on_ground;
    f.duration_s = 35.0;
    f.rmse_from_s = 7.0;
    const FlightResult r = fly(f);
    ASSERT_FALSE(r.failed()) << status_name(r.status) << " at t = " << r.end_s;
    EXPECT_LT(r.rmse[0], 0.1594) << "on ground " << on_ground;
    EXPECT_LT(r.rmse[1], 0.14099) << "on ground " << on_ground;
    EXPECT_LT(r.rmse[2], 0.0835) << "on ground " << on_ground;
    EXPECT_LT(r.rmse[3], 0.0347) << "on ground " << on_ground;
  }
}

TEST(CircleFlight, AsPrintedSe3LosesTheCircle) {
  // Records a failure on purpose (se3_thesis.yaml says so): as printed, the desired force has no
  // m g e3 (notes #35), so on the reference at t = 0 it is m a_des, horizontal, and asks for a
  // 90 deg tilt; with the Eq. 2.31 allocation the vehicle does not recover.
  const CircleReference circle;
  const ReferencePoint start = circle.at(0.0);
  Flight f;
  f.config = "se3_thesis";
  f.reference = &circle;
  f.initial_state = Simulator::hover_state(start.position_m);
  f.initial_state.segment<3>(3) = start.velocity_m_s;
  f.duration_s = 35.0;
  const FlightResult r = fly(f);
  EXPECT_TRUE(r.failed());
  EXPECT_GT(r.first_upset_s, 0.0);
  EXPECT_LT(r.first_upset_s, 2.0);  // measured 1.02 s
}

TEST(Se3AsPrinted, WithoutTheGravityTermHoversMgOverKpLow) {
  // Notes #35: with F = K_p e_p + K_d e_v + m a_des only, hover needs K_p,z e_z = m g, i.e. the
  // vehicle settles m g / K_p,z = 1.504 * 9.81 / 33 = 0.447 m below the setpoint (exact
  // allocation here, so that only the missing term shows).
  const auto model = test::load_model("qdrone2");
  Se3Controller printed(model, Se3Gains::thesis(), Se3Options{});
  const SetpointReference hover(Vec3(0, 0, 1));
  Flight f;
  f.controller = &printed;
  f.reference = &hover;
  f.duration_s = 15.0;
  const FlightResult r = fly(f);
  ASSERT_FALSE(r.failed());
  EXPECT_NEAR(r.final_state[2], 1.0 - 1.504 * 9.81 / 33.0, 0.005);
}

// ---- ClosedLoop -------------------------------------------------------------------------------

TEST(ClosedLoopRate, MustDivideThePhysicsRate) {
  const auto model = test::load_model("qdrone2");
  Simulator sim(model);  // 1 kHz
  const auto pid = load_controller(test::source_path("config/controllers/pid.yaml"), model, 100);
  const SetpointReference hover(Vec3(0, 0, 1));
  for (double bad : {300.0, 2000.0, 1500.0, 0.0, -100.0, std::numeric_limits<double>::quiet_NaN()})
    EXPECT_THROW((ClosedLoop{sim, *pid, hover, bad}), InvalidArgument) << bad;
  try {
    ClosedLoop loop(sim, *pid, hover, 300.0);
    ADD_FAILURE() << "300 Hz accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("must divide the physics rate"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ((ClosedLoop{sim, *pid, hover, 1000.0}).steps_per_control(), 1);
  EXPECT_EQ((ClosedLoop{sim, *pid, hover, 250.0}).steps_per_control(), 4);
  EXPECT_EQ((ClosedLoop{sim, *pid, hover, 100.0}).steps_per_control(), 10);
}

}  // namespace
}  // namespace dronetwin
