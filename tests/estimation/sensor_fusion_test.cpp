// SensorFusion: the filter fed by a SensorSuite. Without any position fix, an indoor flight stack's
// sensors (IMU, downward optical flow and range finder, barometer, magnetometer) keep the velocity
// and height estimates of a QDrone2 flying the SE(3) circle (on its true state) within what the
// flow's noise allows; a gyro bias step is learnt and a motion-capture dropout coasted through;
// bad settings are named.

#include "dronetwin/estimation/sensor_fusion.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "circle_flight.hpp"
#include "dronetwin/control/reference.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

TEST(SensorFusion, FlowRangeBaroAndMagKeepVelocityAndHeight) {
  const std::vector<SensorSpec> specs = {SensorSpec::imu(), SensorSpec::optical_flow(),
                                         SensorSpec::range_finder(), SensorSpec::barometer(),
                                         SensorSpec::magnetometer()};
  // 0.8 m/s at 1 m.
  test::CircleFlight flight(CircleReference(Vec3(0, 0, 1), 1.0, 8.0), specs, 5);
  SensorFusion fusion(specs, {"imu", {"flow", "range", "baro", "mag"}}, flight.initial_state());
  const Simulator& sim = flight.sim();
  double v2 = 0.0, z2 = 0.0;
  int n = 0;
  const int steps = test::kSanitized ? 4000 : 16000;
  for (int k = 0; k <= steps; ++k) {
    flight.advance();
    fusion.process(flight.sensors());
    if (k >= 1000) {  // after a second of convergence
      const StateVector& e = fusion.estimate();
      v2 += (e.segment<3>(3) - sim.state().segment<3>(3)).squaredNorm();
      z2 += std::pow(e[2] - sim.state()[2], 2);
      ++n;
    }
  }
  // One flow sample at 1 m carries 0.05 rad/s x 1 m = 5 cm/s of noise per axis; 100 of them a
  // second, blended with the IMU, leave a centimetre or two. The height: the range finder's 1.5 cm.
  const double v_rmse = std::sqrt(v2 / n), z_rmse = std::sqrt(z2 / n);
  RecordProperty("velocity_rmse_m_s", std::to_string(v_rmse));
  RecordProperty("height_rmse_m", std::to_string(z_rmse));
  EXPECT_LT(v_rmse, 0.05);
  EXPECT_LT(z_rmse, 0.015);
  EXPECT_GT(fusion.updates(), 0);
}

// Sensor faults seen through the filter (faults/sensor_fault.hpp), on the SE(3) circle flown on
// the true state: the filter is not told of them.
TEST(SensorFusion, FollowsAGyroBiasStepAndCoastsThroughAMotionCaptureDropout) {
  constexpr double kStep_rad_s = 0.02, kStepAt_s = 4.0, kGapFrom_s = 2.0, kGapTo_s = 3.0;
  SensorSpec imu = SensorSpec::imu();
  imu.faults.push_back(SensorFault::bias_step(kStepAt_s, "wz", kStep_rad_s));
  SensorSpec mocap = SensorSpec::motion_capture();
  mocap.faults.push_back(SensorFault::dropout(kGapFrom_s, kGapTo_s));
  const std::vector<SensorSpec> specs = {imu, mocap};
  test::CircleFlight flight(CircleReference(Vec3(0, 0, 1), 1.0, 6.0), specs, 3);
  SensorFusion fusion(specs, {"imu", {"mocap"}}, flight.initial_state());
  const ErrorStateEkf& ekf = fusion.filter();
  const auto sigma = [&](int i) { return std::sqrt(ekf.covariance()(i, i)); };
  const auto at = [](int k) { return static_cast<double>(k) * 1e-3; };
  std::int64_t updates_at_gap = -1;
  double sigma_before_gap = 0.0, sigma_end_of_gap = 0.0;
  const int steps = test::kSanitized ? 7000 : 12000;
  for (int k = 0; k <= steps; ++k) {
    flight.advance();
    fusion.process(flight.sensors());
    const double t = at(k);
    const double true_bias_z = flight.sensors().imu_bias(0).first[2];
    const double bias_error = ekf.gyro_bias()[2] - true_bias_z;
    if (k == static_cast<int>(kGapFrom_s * 1000) - 1) {
      updates_at_gap = fusion.updates();
      sigma_before_gap = sigma(ekf_index::kPosition);
      // Before the step the filter holds the sensor's own (random) bias within its 3 sigma.
      EXPECT_LT(std::abs(bias_error), 3.0 * sigma(ekf_index::kGyroBias + 2)) << t;
    }
    if (t > kGapFrom_s && t < kGapTo_s + 0.004) {
      // The last pre-gap reading (1.99 s) arrived at 1.995 s; nothing until the gap ends.
      EXPECT_EQ(fusion.updates(), updates_at_gap) << t;
      EXPECT_GE(sigma(ekf_index::kPosition), sigma_end_of_gap) << "P shrank in the gap at " << t;
      sigma_end_of_gap = sigma(ekf_index::kPosition);
    }
    if (k == steps) {
      // The step, unannounced, moves the bias estimate towards it by far more than the filter's
      // own uncertainty (it learns it slowly: its bias random walk is made for drift, not steps;
      // docs/faults.md).
      EXPECT_GT(bias_error, 10.0 * sigma(ekf_index::kGyroBias + 2));
      EXPECT_LT(bias_error, kStep_rad_s + 3.0 * sigma(ekf_index::kGyroBias + 2));
      // Fixes again: the position uncertainty back to what it was before the gap.
      EXPECT_LT(sigma(ekf_index::kPosition), 1.5 * sigma_before_gap);
    }
  }
  // Dead reckoning on the IMU alone for a second lets the uncertainty grow severalfold.
  EXPECT_GT(sigma_end_of_gap, 3.0 * sigma_before_gap);
}

TEST(SensorFusion, BadSettingsAreNamed) {
  const std::vector<SensorSpec> specs = {SensorSpec::imu(), SensorSpec::rotor_speed()};
  const StateVector x = Simulator::hover_state(Vec3::Zero());
  EXPECT_EQ(test::error_of([&] {
              SensorFusion f(specs, {"gyro", {}}, x);
            }),
            "imu: no sensor named 'gyro' (sensors: imu, rpm)");
  EXPECT_EQ(test::error_of([&] {
              SensorFusion f(specs, {"rpm", {}}, x);
            }),
            "imu: sensor 'rpm' is a rotor_speed, not an imu");
  EXPECT_NE(test::error_of([&] {
              SensorFusion f(specs, {"imu", {"rpm"}}, x);
            }).find("updates[0]: the filter cannot use a rotor_speed"),
            std::string::npos);
}

}  // namespace
}  // namespace dronetwin
