// SensorFusion: the filter fed by a SensorSuite. Without any position fix, an indoor flight stack's
// sensors (IMU, downward optical flow and range finder, barometer, magnetometer) keep the velocity
// and height estimates of a QDrone2 flying the SE(3) circle (on its true state) within what the
// flow's noise allows; bad settings are named.

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
