// The batched cascaded PID against CascadedPid flown by ClosedLoop at the physics rate: in double
// every lane is the same flight, for the controller as printed (Eq. 3.21 gains, no options), for
// the pole-placed configuration of config/controllers/pid_tuned.yaml (every option on) and for
// that one with the acceleration, angular and drag feed-forward, with per-lane masses and
// references (moving ones: acceleration, jerk, snap and yaw acceleration); a lane's integral is its
// own.

#include "dronetwin/batch/batch_pid.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/noise/random.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using state_index::kPosition;

/// config/controllers/pid_tuned.yaml.
std::pair<PidGains, PidOptions> tuned() {
  PidGains g;
  g.outer_p << 1.631, 1.631, 157.6, 0.487;
  g.outer_d << 0.571, 0.571, 24.52, 0.002;
  g.outer_i << 0.010, 0.010, 45.1, 0.0;
  g.inner_p << 15.95, 17.92, 1.0;
  g.inner_d1 << 0.744, 0.836, 0.195;
  g.inner_d2 << 0.003, 0.003, 0.001;
  PidOptions o;
  o.max_tilt_rad = 0.6;
  o.integral_limit << 0.5, 0.5, 0.044, 1.0;
  o.conditional_integration = true;
  o.yaw_error_wrap = true;
  o.velocity_feedforward = true;
  o.yaw_frame_mapping = true;
  return {g, o};
}

TEST(BatchPid, EveryLaneEqualsCascadedPidInAClosedLoop) {
  const auto model = test::load_model("qdrone2");
  SimConfig cfg;
  auto feed_forward = tuned();
  feed_forward.second.acceleration_feed_forward = true;
  feed_forward.second.angular_feed_forward = true;
  feed_forward.second.drag_feed_forward = true;
  const std::vector<std::pair<PidGains, PidOptions>> configs = {
      {PidGains::thesis_simulation(), PidOptions{}}, tuned(), feed_forward};
  for (std::size_t c = 0; c < configs.size(); ++c) {
    const auto& [gains, options] = configs[c];
    constexpr int N = 9, kSteps = 3000;
    BatchSimulator<double> batch(model, cfg, N, 2);
    BatchCascadedPid<double> pid(model, gains, options, cfg.dt_s, N);
    Random rng(30 + c);
    std::vector<StateVector> starts;
    std::vector<ReferencePoint> refs;
    std::vector<double> masses;
    for (int l = 0; l < N; ++l) {
      StateVector x = Simulator::hover_state(Vec3(0.3 * rng.normal(), 0.3 * rng.normal(), 1.0),
                                             0.5 * rng.normal());
      x.segment<3>(state_index::kVelocity) = 0.2 * Vec3(rng.normal(), rng.normal(), rng.normal());
      starts.push_back(x);
      ReferencePoint r;
      r.position_m = Vec3(rng.normal(), rng.normal(), 1.0 + 0.5 * rng.uniform());
      r.velocity_m_s = 0.1 * Vec3(rng.normal(), rng.normal(), 0.0);
      r.yaw_rad = 3.0 * rng.normal();  // beyond +-pi: the wrap option matters
      r.yaw_rate_rad_s = 0.05 * rng.normal();
      r.acceleration_m_s2 = 0.3 * Vec3(rng.normal(), rng.normal(), rng.normal());
      r.jerk_m_s3 = 0.5 * Vec3(rng.normal(), rng.normal(), rng.normal());
      r.snap_m_s4 = Vec3(rng.normal(), rng.normal(), rng.normal());
      r.yaw_acceleration_rad_s2 = 0.1 * rng.normal();
      refs.push_back(r);
      masses.push_back(model->mass_kg() * (0.95 + 0.1 * rng.uniform()));
      batch.set_parameter(ModelParameter::kMass, l, masses.back());
      batch.reset(l, x, model->hover_speeds_rad_s());
      pid.set_reference(l, r);
    }
    ASSERT_EQ(batch.step(kSteps, pid), 0) << "config " << c;
    double worst = 0.0, integral_gap = 0.0;
    for (int l = 0; l < N; ++l) {
      VehicleSpec spec = model->spec();
      set_parameter_value(spec, ModelParameter::kMass, masses[static_cast<std::size_t>(l)]);
      Simulator sim(std::make_shared<const VehicleModel>(spec), cfg);
      sim.reset(starts[static_cast<std::size_t>(l)], model->hover_speeds_rad_s());
      CascadedPid scalar(model, gains, options, cfg.dt_s);
      const test::FixedPoint reference(refs[static_cast<std::size_t>(l)]);
      ClosedLoop loop(sim, scalar, reference, 1.0 / cfg.dt_s);
      // ClosedLoop::run updates once more after the last step; fly the same count of updates.
      for (int k = 0; k < kSteps; ++k) ASSERT_TRUE(loop.step().ok());
      const StateVector a = batch.state(l), b = sim.state();
      for (int i = 0; i < kStateSize; ++i)
        worst = std::max(worst, std::abs(a[i] - b[i]) / (1.0 + std::abs(b[i])));
      for (int k = 0; k < 4; ++k)
        integral_gap = std::max(integral_gap, std::abs(pid.integral_data()[k * pid.stride() + l] -
                                                       scalar.integral()[k]));
    }
    std::printf(
        "[ batch    ] PID config %zu vs ClosedLoop, 9 lanes x 3 s: worst gap %.3g, "
        "integral gap %.3g\n",
        c, worst, integral_gap);
    EXPECT_LE(worst, 1e-12) << "config " << c;
    EXPECT_LE(integral_gap, 1e-12) << "config " << c;
  }
}

TEST(BatchPid, TheTunedPidSettlesInFloatAndResetsPerLane) {
  const auto model = test::load_model("qdrone2");
  const auto [gains, options] = tuned();
  constexpr int N = 20;
  SimConfig cfg;
  BatchSimulator<float> batch(model, cfg, N);
  BatchCascadedPid<float> pid(model, gains, options, cfg.dt_s, N);
  for (int l = 0; l < N; ++l) {
    batch.reset(l, Simulator::hover_state(Vec3(0, 0, 1.0)), model->hover_speeds_rad_s());
    ReferencePoint r;
    r.position_m = Vec3(0.05 * l, -0.5, 1.5);
    r.yaw_rad = 0.1 * l;
    pid.set_reference(l, r);
  }
  ASSERT_EQ(batch.step(8000, pid), 0);
  double worst = 0.0;
  for (int l = 0; l < N; ++l)
    worst =
        std::max(worst, (batch.state(l).segment<3>(kPosition) - Vec3(0.05 * l, -0.5, 1.5)).norm());
  std::printf("[ batch    ] tuned PID, float, after 8 s: worst position error %.3g m\n", worst);
  EXPECT_LT(worst, 0.01);
  EXPECT_NE(pid.integral_data()[2 * pid.stride() + 3], 0.0f);
  pid.reset_integral(3);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(pid.integral_data()[k * pid.stride() + 3], 0.0f);
  EXPECT_NE(pid.integral_data()[2 * pid.stride() + 4], 0.0f) << "lane 4 keeps its memory";
  EXPECT_NE(test::error_of([&] {
              BatchCascadedPid<float> bad(model, gains, options, 0.0, 3);
            }).find("control period"),
            std::string::npos);
}

TEST(BatchPid, BadReferencesLanesAndSizesAreNamed) {
  const auto model = test::load_model("qdrone2");
  BatchCascadedPid<double> pid(model, PidGains::thesis_simulation(), PidOptions{}, 1e-3, 4);
  ReferencePoint bad;
  bad.yaw_rate_rad_s = std::nan("");
  const std::string e = test::error_of([&] { pid.set_reference(1, bad); });
  EXPECT_NE(e.find("lane 1"), std::string::npos) << e;
  EXPECT_NE(e.find("yaw rate"), std::string::npos) << e;
  EXPECT_NE(test::error_of([&] { pid.set_reference(4, ReferencePoint{}); }).find("lane 4 is out"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] { pid.reset_integral(-1); }).find("lane -1 is out"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] {
              BatchCascadedPid<double> none(model, PidGains::thesis_simulation(), PidOptions{},
                                            1e-3, 0);
            }).find("BatchCascadedPid: num_vehicles: expected 1 to 16777216, got 0"),
            std::string::npos);
  // A controller built for another airframe is refused by the batch, naming both rotor counts.
  const auto hexa = test::load_model("hexarotor");
  BatchCascadedPid<double> six(hexa, PidGains::thesis_simulation(), PidOptions{}, 1e-3, 4);
  BatchSimulator<double> batch(model, SimConfig{}, 4);
  const std::string r = test::error_of([&] { batch.step(1, six); });
  EXPECT_NE(r.find("inner loop is for 6 rotors, the batch's model has 4"), std::string::npos) << r;
  EXPECT_NE(test::error_of([&] { batch.set_generalized_forces(nullptr); }).find("u is null"),
            std::string::npos);
}

}  // namespace
}  // namespace dronetwin
