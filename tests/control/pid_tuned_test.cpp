// config/controllers/pid_tuned.yaml: the cascaded PID with pole-placed gains and a 0.6 rad tilt
// limit (the file explains every number). It flies the pulse of thesis Eq. 3.14 from the ground
// (physics and control 1 kHz, every disturbance term, OU noise off and on) against Table 3.1, and
// keeps its margins: tilt limit, rotor saturation, a well-damped attitude loop, recovery from a
// 30 deg upset and a steady hover.
//
// RMSE here, as in closed_loop_test.cpp: every physics step of the run, true (not measured) state
// against the reference at the same instant, yaw error wrapped into [-pi, pi].
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <numbers>
#include <string>

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/config/controller_config.hpp"
#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/control/reference.hpp"
#include "dronetwin/dynamics/ground.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kG = 9.81;
const char* const kConfig = "config/controllers/pid_tuned.yaml";

// Thesis Table 3.1, PID in simulation: x, y, z in m, psi in rad.
constexpr double kThesisRmseX = 0.1213;
constexpr double kThesisRmseY = 0.0385;
constexpr double kThesisRmseZ = 0.0377;
constexpr double kThesisRmsePsi = 0.1179;

struct TunedRun {
  StepStatus status = StepStatus::kOk;
  bool crashed = false;
  double end_s = 0.0;
  Vec4 rmse = Vec4::Zero();
  double max_tilt_rad = 0.0;
  /// Last time the vehicle was more than 5 cm from the reference or tilted more than 2 deg.
  double last_outside_band_s = 0.0;
  std::int64_t control_updates = 0;
  std::int64_t saturated_updates = 0;
  StateVector final_state = StateVector::Zero();
  bool failed() const { return status != StepStatus::kOk || crashed; }
  double saturated_fraction() const {
    return static_cast<double>(saturated_updates) /
           static_cast<double>(std::max<std::int64_t>(control_updates, 1));
  }
};

TunedRun fly(const Reference& reference, const StateVector& start, bool rotors_at_hover,
             double duration_s, bool noise) {
  const auto model = test::load_model("qdrone2");
  SimConfig cfg;              // 1 ms physics step, RK4, every disturbance term, ground contact
  cfg.noise.enabled = noise;  // thesis OU parameters (Eq. 3.8-3.9)
  cfg.seed = 1;
  Simulator sim(model, cfg);
  sim.reset(start, rotors_at_hover ? model->hover_speeds_rad_s() : RotorVector::Zero(4));
  const double rate_hz = 1000.0;
  auto pid = load_controller(test::source_path(kConfig), model, rate_hz);
  ClosedLoop loop(sim, *pid, reference, rate_hz);

  TunedRun r;
  Vec4 sum_sq = Vec4::Zero();
  std::int64_t samples = 0;
  const auto steps = static_cast<std::int64_t>(std::llround(duration_s / cfg.dt_s));
  for (std::int64_t k = 0; k < steps; ++k) {
    r.status = loop.step().status;
    if (r.status != StepStatus::kOk) break;
    const double t = sim.time_s();
    const StateVector& x = sim.state();
    const ReferencePoint ref = reference.at(t);
    Vec4 e;
    e.head<3>() = ref.position_m - x.head<3>();
    e[3] = std::remainder(ref.yaw_rad - math::to_euler(x.segment<4>(6))[2], 2.0 * std::numbers::pi);
    sum_sq += e.cwiseAbs2();
    ++samples;
    const double tilt = tilt_angle_rad(x);
    r.max_tilt_rad = std::max(r.max_tilt_rad, tilt);
    if (e.head<3>().norm() > 0.05 || tilt > 2.0 * kDeg) r.last_outside_band_s = t;
    if (sim.contact().crashed) {
      r.crashed = true;
      break;
    }
  }
  r.end_s = sim.time_s();
  r.rmse = (sum_sq / static_cast<double>(std::max<std::int64_t>(samples, 1))).cwiseSqrt();
  r.control_updates = loop.control_updates();
  r.saturated_updates = loop.saturated_updates();
  r.final_state = sim.state();
  return r;
}

/// Lower bound on the x RMSE of the pulse for any controller whose horizontal acceleration is at
/// most g tan(tilt): from rest, the error of a step A cannot fall faster than A - a t^2 / 2, so
/// int e^2 dt >= (8/15) A^2 sqrt(2 A / a). Steps of Eq. 3.14: 0.75, 1.5, 1.5, 0.75 m in 60 s.
double pulse_x_rmse_floor(double tilt_rad) {
  const double a = kG * std::tan(tilt_rad);
  double ise = 0.0;
  for (double step : {0.75, 1.5, 1.5, 0.75})
    ise += 8.0 / 15.0 * step * step * std::sqrt(2.0 * step / a);
  return std::sqrt(ise / 60.0);
}

TEST(PidTuned, FliesTheThesisPulseFromTheGround) {
  // Bounds: y, z and psi are thesis Table 3.1. x is NOT: Table 3.1's 0.1213 m is out of reach
  // for any controller with a tilt limit of 0.6 rad (the floor above gives 0.177 m; 0.1213 m
  // needs a >= 30.7 m/s^2, a 72 deg tilt). The x bound is instead that floor at pid.yaml's
  // 0.2 rad limit (0.240 m): the tuned file must do better than any controller limited to 0.2 rad
  // could. Besides: no crash, the whole 60 s flown, rotor saturation in at most 5 % of the control
  // updates, the tilt never far past the 0.6 rad command limit, and the vehicle at the final
  // setpoint.
  EXPECT_GT(pulse_x_rmse_floor(0.6), kThesisRmseX);  // Table 3.1's x: unreachable at 0.6 rad
  const double x_bound = pulse_x_rmse_floor(0.2);
  EXPECT_NEAR(x_bound, 0.240, 0.001);
  const PiecewiseConstantReference pulse = PiecewiseConstantReference::thesis_pulse();
  for (bool noise : {false, true}) {
    SCOPED_TRACE(noise ? "OU noise on, seed 1" : "noise off");
    const TunedRun r =
        fly(pulse, Simulator::hover_state(Vec3::Zero()), /*rotors_at_hover=*/false, 60.0, noise);
    ASSERT_FALSE(r.failed()) << status_name(r.status) << ", crashed " << r.crashed
                             << " at t = " << r.end_s;
    EXPECT_DOUBLE_EQ(r.end_s, 60.0);
    EXPECT_LE(r.rmse[0], x_bound);
    EXPECT_LE(r.rmse[1], kThesisRmseY);
    EXPECT_LE(r.rmse[2], kThesisRmseZ);
    EXPECT_LE(r.rmse[3], kThesisRmsePsi);
    EXPECT_LE(r.saturated_fraction(), 0.05)
        << r.saturated_updates << " of " << r.control_updates << " updates saturated";
    EXPECT_LT(r.max_tilt_rad, 0.6 + 5.0 * kDeg);
    EXPECT_LT((r.final_state.head<3>() - Vec3(0, 0, 0.75)).norm(), 0.05);
    ::testing::Test::RecordProperty(noise ? "rmse_noise_on" : "rmse_noise_off",
                                    ::testing::PrintToString(r.rmse.transpose()));
  }
}

TEST(PidTuned, AttitudeLoopIsFastAndWellDamped) {
  // Margins the file promises, from the gains and the model's inertia: tilt limit <= 0.6 rad;
  // roll and pitch loops (J + K_D2) s^2 + K_D1 s + K_P damped at zeta >= 0.6 and at least 5 times
  // faster than the horizontal position loop s^2 + g K_D s + g K_P.
  const auto model = test::load_model("qdrone2");
  const ControllerConfig cfg = load_controller_config(test::source_path(kConfig));
  ASSERT_EQ(cfg.type(), ControllerType::kPid);
  EXPECT_LE(std::get<PidSettings>(cfg.settings).options.max_tilt_rad, 0.6);
  const PidGains& g = std::get<PidSettings>(cfg.settings).gains;
  for (int axis = 0; axis < 2; ++axis) {
    SCOPED_TRACE(axis == 0 ? "roll / y" : "pitch / x");
    const double j = model->inertia_kgm2()(axis, axis) + g.inner_d2[axis];
    const double omega_in = std::sqrt(g.inner_p[axis] / j);
    const double zeta_in = g.inner_d1[axis] / (2.0 * std::sqrt(g.inner_p[axis] * j));
    const int outer = axis == 0 ? 1 : 0;
    const double omega_out = std::sqrt(kG * g.outer_p[outer]);
    EXPECT_GE(zeta_in, 0.6);
    EXPECT_LE(zeta_in, 1.0);
    EXPECT_GE(omega_in, 5.0 * omega_out);
  }
}

TEST(PidTuned, RecoversFromA30DegreeUpsetAndHoldsHover) {
  // Hover at 1 m, released with a 30 deg roll or pitch (zero rates), noise on: back within 5 cm and
  // 2 deg within 3 s, and never out again for the rest of 8 s. Then a plain 10 s hover with noise
  // never leaves the 5 cm / 2 deg band.
  const SetpointReference hover(Vec3(0, 0, 1));
  for (int axis : {0, 1}) {
    SCOPED_TRACE(axis == 0 ? "roll" : "pitch");
    StateVector start = Simulator::hover_state(Vec3(0, 0, 1));
    start.segment<4>(6) =
        axis == 0 ? math::from_euler(30 * kDeg, 0, 0) : math::from_euler(0, 30 * kDeg, 0);
    const TunedRun r = fly(hover, start, /*rotors_at_hover=*/true, 8.0, /*noise=*/true);
    ASSERT_FALSE(r.failed()) << status_name(r.status);
    EXPECT_LT(r.last_outside_band_s, 3.0);
    EXPECT_LT((r.final_state.head<3>() - Vec3(0, 0, 1)).norm(), 0.05);
  }
  const TunedRun r = fly(hover, Simulator::hover_state(Vec3(0, 0, 1)), true, 10.0, /*noise=*/true);
  ASSERT_FALSE(r.failed()) << status_name(r.status);
  EXPECT_EQ(r.last_outside_band_s, 0.0);
}

}  // namespace
}  // namespace dronetwin
