// SensorFusion: the filter fed by a SensorSuite. Without any position fix, an indoor flight stack's
// sensors (IMU, downward optical flow and range finder, barometer, magnetometer) keep the velocity
// and height estimates of a QDrone2 flying the SE(3) circle (on its true state) within what the
// flow's noise allows; bad settings are named.

#include "dronetwin/estimation/sensor_fusion.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/control/reference.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

TEST(SensorFusion, FlowRangeBaroAndMagKeepVelocityAndHeight) {
  auto model = test::load_model("qdrone2");
  const CircleReference circle(Vec3(0, 0, 1), 1.0, 8.0);  // 0.8 m/s at 1 m
  Simulator sim(model);
  const ReferencePoint r0 = circle.at(0.0);
  StateVector x0 = Simulator::hover_state(r0.position_m);
  x0.segment<3>(3) = r0.velocity_m_s;
  sim.reset(x0, model->hover_speeds_rad_s());
  auto controller =
      load_controller(test::source_path("config/controllers/se3.yaml"), model, 1000.0);
  ClosedLoop loop(sim, *controller, circle, 1000.0);
  const std::vector<SensorSpec> specs = {SensorSpec::imu(), SensorSpec::optical_flow(),
                                         SensorSpec::range_finder(), SensorSpec::barometer(),
                                         SensorSpec::magnetometer()};
  SensorSuite suite(specs, 1e-3, 4, 5);
  SensorFusion fusion(specs, {"imu", {"flow", "range", "baro", "mag"}}, x0);
  StateVector previous = sim.state();
  double v2 = 0.0, z2 = 0.0;
  int n = 0;
  const int steps = test::kSanitized ? 4000 : 16000;
  for (int k = 0; k <= steps; ++k) {
    if (k > 0) {
      previous = sim.state();
      ASSERT_TRUE(loop.step().ok());
    }
    suite.update(sim.step_count(), make_sensor_truth(sim, previous));
    fusion.process(suite);
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
