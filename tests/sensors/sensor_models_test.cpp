// The sensor models against closed forms and independent computations: what an IMU feels at rest,
// in free fall and off-centre on a spinning body; ISA pressures against the standard's table; the
// magnetometer's field under yaw; the range finder's slant distances and obstacles; the optical
// flow against a numerical derivative of a ground point's image coordinates; noise statistics
// against their configuration.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/sensors/barometer.hpp"
#include "dronetwin/sensors/gps.hpp"
#include "dronetwin/sensors/imu.hpp"
#include "dronetwin/sensors/magnetometer.hpp"
#include "dronetwin/sensors/motion_capture.hpp"
#include "dronetwin/sensors/optical_flow.hpp"
#include "dronetwin/sensors/range_finder.hpp"
#include "dronetwin/world/ray_cast.hpp"

namespace dronetwin {
namespace {

SensorTruth at(const Vec3& p, const Vec4& q = Vec4(1, 0, 0, 0), const Vec3& v = Vec3::Zero(),
               const Vec3& w = Vec3::Zero()) {
  SensorTruth t;
  t.state << p, v, q, w;
  return t;
}

double mean(const std::vector<double>& x) {
  double s = 0.0;
  for (double v : x) s += v;
  return s / static_cast<double>(x.size());
}
double stddev(const std::vector<double>& x) {
  const double m = mean(x);
  double s = 0.0;
  for (double v : x) s += (v - m) * (v - m);
  return std::sqrt(s / static_cast<double>(x.size() - 1));
}

// ---- IMU ----------------------------------------------------------------------------------------

TEST(ImuModel, RestReadsMinusGravityAndFreeFallReadsNothing) {
  SensorTruth t = at(Vec3(0, 0, 1));
  Vec3 f, w;
  ideal_imu(Mounting{}, t, f, w);
  EXPECT_TRUE(f.isApprox(Vec3(0, 0, 9.81), 1e-15));
  t.acceleration_W_m_s2 = t.gravity_W_m_s2;
  ideal_imu(Mounting{}, t, f, w);
  EXPECT_LT(f.norm(), 1e-15);
  // Rolled 90 deg about x at rest: gravity's reaction lies along body +y... R^T (0, 0, g).
  t = at(Vec3::Zero(), math::from_euler(M_PI / 2, 0, 0));
  ideal_imu(Mounting{}, t, f, w);
  EXPECT_NEAR(f[1], 9.81, 1e-12);
  EXPECT_NEAR(f[2], 0.0, 1e-12);
}

TEST(ImuModel, OffCentreSensorFeelsTheCentripetalAcceleration) {
  // Spinning at w about z in free fall (a = g): a sensor at r = (0.1, 0, 0) accelerates toward the
  // axis at w^2 r, so it reads -w^2 r along x; a yawed mounting (90 deg) turns that onto -y_S.
  const double w = 5.0;
  SensorTruth t = at(Vec3::Zero(), Vec4(1, 0, 0, 0), Vec3::Zero(), Vec3(0, 0, w));
  t.acceleration_W_m_s2 = t.gravity_W_m_s2;
  Vec3 f, rate;
  ideal_imu(Mounting::at(Vec3(0.1, 0, 0)), t, f, rate);
  EXPECT_TRUE(f.isApprox(Vec3(-w * w * 0.1, 0, 0), 1e-14));
  EXPECT_TRUE(rate.isApprox(Vec3(0, 0, w), 1e-15));
  ideal_imu(Mounting::at(Vec3(0.1, 0, 0), 0, 0, M_PI / 2), t, f, rate);
  EXPECT_NEAR(f[1], w * w * 0.1, 1e-12);  // body -x is sensor +y after a 90 deg yaw
  EXPECT_NEAR(f[0], 0.0, 1e-12);
  // An angular acceleration adds dw x r: about z at r = (0.1, 0, 0) that is +y.
  t.state.segment<3>(10).setZero();
  t.angular_acceleration_B_rad_s2 = Vec3(0, 0, 2.0);
  ideal_imu(Mounting::at(Vec3(0.1, 0, 0)), t, f, rate);
  EXPECT_TRUE(f.isApprox(Vec3(0, 0.2, 0), 1e-14));
}

TEST(ImuModel, ReadingsClipAtTheRange) {
  ImuParameters p;
  p.gyro = TriadNoise{0, 0, 0, 100, 0, 1.0};
  p.accel = TriadNoise{0, 0, 0, 100, 0, 5.0};
  ImuState s;
  Random rng(1);
  reset_imu(p, s, rng);
  const SensorTruth t = at(Vec3::Zero(), Vec4(1, 0, 0, 0), Vec3::Zero(), Vec3(3, -3, 0.5));
  double out[6];
  measure_imu(p, s, Mounting{}, t, 0.001, 1000, rng, out);
  EXPECT_EQ(out[2], 5.0);  // 9.81 clipped
  EXPECT_EQ(out[3], 1.0);
  EXPECT_EQ(out[4], -1.0);
  EXPECT_EQ(out[5], 0.5);
}

// ---- barometer ----------------------------------------------------------------------------------

TEST(Barometer, IsaPressureMatchesTheStandardTable) {
  // ISO 2533 / U.S. Standard Atmosphere 1976, geopotential altitude.
  EXPECT_NEAR(isa_pressure_Pa(0.0), 101325.0, 1e-9);
  EXPECT_NEAR(isa_pressure_Pa(1000.0), 89874.6, 0.5);
  EXPECT_NEAR(isa_pressure_Pa(5000.0), 54019.9, 0.5);
  EXPECT_NEAR(isa_pressure_Pa(11000.0), 22632.1, 0.5);
  EXPECT_NEAR(isa_altitude_m(isa_pressure_Pa(1234.5)), 1234.5, 1e-8);
  // Near the ground 1 m of climb is about 12 Pa (rho g).
  EXPECT_NEAR(isa_pressure_Pa(0.0) - isa_pressure_Pa(1.0), 1.225 * 9.80665, 0.02);
}

TEST(Barometer, NoiseAndDriftHaveTheConfiguredStatistics) {
  BarometerParameters p;
  p.noise_Pa = 1.5;
  p.drift_Pa_per_sqrt_s = 0.0;
  p.origin_altitude_m = 500.0;
  BarometerState s;
  Random rng(7);
  const SensorTruth t = at(Vec3(0, 0, 10));
  std::vector<double> y;
  for (int k = 0; k < 200000; ++k) {
    double out;
    measure_barometer(p, s, Mounting{}, t, 0.02, rng, &out);
    y.push_back(out);
  }
  EXPECT_NEAR(stddev(y) / p.noise_Pa, 1.0, 0.01);  // 200 000 samples: 0.16 % standard error
  EXPECT_NEAR(mean(y), isa_pressure_Pa(510.0), 5 * p.noise_Pa / std::sqrt(200000.0));
  // Drift alone: increments over dt have the deviation q sqrt(dt).
  p.noise_Pa = 0.0;
  p.drift_Pa_per_sqrt_s = 0.2;
  reset_barometer(s);
  std::vector<double> d;
  double last;
  measure_barometer(p, s, Mounting{}, t, 0.02, rng, &last);
  for (int k = 0; k < 100000; ++k) {
    double out;
    measure_barometer(p, s, Mounting{}, t, 0.02, rng, &out);
    d.push_back(out - last);
    last = out;
  }
  EXPECT_NEAR(stddev(d) / (0.2 * std::sqrt(0.02)), 1.0, 0.02);
}

// ---- magnetometer -------------------------------------------------------------------------------

TEST(Magnetometer, FieldTurnsWithTheVehicleAndKeepsItsStrength) {
  MagnetometerParameters p;
  p.noise_uT = 0.0;
  Random rng(1);
  double out[3];
  // Yawed by 90 deg (nose to world +y): north (world +x) appears on the body's -y axis.
  measure_magnetometer(p, Mounting{}, at(Vec3::Zero(), math::from_euler(0, 0, M_PI / 2)), rng, out);
  EXPECT_NEAR(out[0], 0.0, 1e-12);
  EXPECT_NEAR(out[1], -p.field_W_uT[0], 1e-12);
  EXPECT_NEAR(out[2], p.field_W_uT[2], 1e-12);
  const Vec4 q = math::from_euler(0.3, -0.7, 2.0);
  measure_magnetometer(p, Mounting{}, at(Vec3::Zero(), q), rng, out);
  EXPECT_NEAR(Vec3(out[0], out[1], out[2]).norm(), p.field_W_uT.norm(), 1e-12);
  p.hard_iron_uT = Vec3(5, -2, 1);
  double with[3];
  measure_magnetometer(p, Mounting{}, at(Vec3::Zero(), q), rng, with);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(with[i] - out[i], p.hard_iron_uT[i], 1e-12);
}

// ---- GPS and motion capture ---------------------------------------------------------------------

TEST(Gps, WanderingErrorHasItsSigmaAndCorrelationTime) {
  GpsParameters p;
  p.position_noise_m.setZero();
  p.position_error_m = Vec3(1.5, 1.5, 3.0);
  p.position_error_time_s = 20.0;
  GpsState s;
  Random rng(11);
  reset_gps(p, s, rng);
  const SensorTruth t = at(Vec3(1, 2, 3));
  std::vector<double> ex, ez;
  for (int k = 0; k < 400000; ++k) {  // 40 000 s at 10 Hz: 2000 correlation times
    double out[6];
    measure_gps(p, s, Mounting{}, t, 0.1, rng, out);
    ex.push_back(out[0] - 1.0);
    ez.push_back(out[2] - 3.0);
  }
  EXPECT_NEAR(stddev(ex) / 1.5, 1.0, 0.05);
  EXPECT_NEAR(stddev(ez) / 3.0, 1.0, 0.05);
  // Autocorrelation at a lag of one correlation time (200 samples): e^-1.
  double c = 0.0, v = 0.0;
  const double m = mean(ex);
  for (std::size_t k = 0; k + 200 < ex.size(); ++k) c += (ex[k] - m) * (ex[k + 200] - m);
  for (double e : ex) v += (e - m) * (e - m);
  EXPECT_NEAR(c / v, std::exp(-1.0), 0.05);
}

TEST(Gps, WhiteNoiseAndAntennaOffset) {
  GpsParameters p;
  p.position_error_m.setZero();
  p.position_noise_m = Vec3(0.3, 0.3, 0.6);
  p.velocity_noise_m_s = Vec3(0.05, 0.05, 0.08);
  GpsState s;
  Random rng(3);
  reset_gps(p, s, rng);
  // Yawing at 1 rad/s with the antenna 0.2 m ahead: it moves at 0.2 m/s along world +y.
  const SensorTruth t = at(Vec3::Zero(), Vec4(1, 0, 0, 0), Vec3::Zero(), Vec3(0, 0, 1));
  std::vector<double> x, z, vy;
  for (int k = 0; k < 100000; ++k) {
    double out[6];
    measure_gps(p, s, Mounting::at(Vec3(0.2, 0, 0)), t, 0.1, rng, out);
    x.push_back(out[0]);
    z.push_back(out[2]);
    vy.push_back(out[4]);
  }
  EXPECT_NEAR(mean(x), 0.2, 5 * 0.3 / std::sqrt(1e5));
  EXPECT_NEAR(mean(vy), 0.2, 5 * 0.05 / std::sqrt(1e5));
  EXPECT_NEAR(stddev(x) / 0.3, 1.0, 0.02);
  EXPECT_NEAR(stddev(z) / 0.6, 1.0, 0.02);
  EXPECT_NEAR(stddev(vy) / 0.05, 1.0, 0.02);
}

TEST(MotionCapture, PoseErrorsHaveTheConfiguredSize) {
  MotionCaptureParameters p;
  p.position_noise_m = 0.001;
  p.attitude_noise_rad = 0.01;
  Random rng(5);
  const Vec4 q = math::from_euler(0.2, 0.1, -1.0);
  const SensorTruth t = at(Vec3(1, 1, 1), q);
  std::vector<double> x;
  double angle2 = 0.0;
  const int n = 50000;
  for (int k = 0; k < n; ++k) {
    double out[7];
    measure_motion_capture(p, Mounting{}, t, rng, out);
    x.push_back(out[0]);
    const Vec4 qm(out[3], out[4], out[5], out[6]);
    EXPECT_NEAR(qm.norm(), 1.0, 1e-12);
    const double c = std::min(1.0, std::abs(qm.dot(q)));
    angle2 += std::pow(2.0 * std::acos(c), 2);
  }
  EXPECT_NEAR(stddev(x) / 0.001, 1.0, 0.02);
  // The rotation angle of a 3-D isotropic error: E[theta^2] = 3 sigma^2.
  EXPECT_NEAR(std::sqrt(angle2 / n) / (std::sqrt(3.0) * 0.01), 1.0, 0.02);
}

// ---- range finder and optical flow --------------------------------------------------------------

TEST(RangeFinder, SlantDistanceObstaclesAndLimits) {
  const Mounting down = Mounting::looking_down();
  EXPECT_NEAR(true_range_m(down, at(Vec3(0, 0, 2)), 4.0), 2.0, 1e-15);
  // Rolled by 0.3 rad: the beam meets the ground at h / cos(0.3).
  EXPECT_NEAR(true_range_m(down, at(Vec3(0, 0, 2), math::from_euler(0.3, 0, 0)), 4.0),
              2.0 / std::cos(0.3), 1e-12);
  // Over a box 1 m tall: the top face.
  Track scene;
  Obstacle box;
  box.shape = Obstacle::Shape::kBox;
  box.center_m = Vec3(0, 0, 0.5);
  box.half_size_m = Vec3(1, 1, 0.5);
  scene.obstacles.push_back(box);
  SensorTruth t = at(Vec3(0.5, 0, 3));
  t.scene = &scene;
  EXPECT_NEAR(true_range_m(down, t, 4.0), 2.0, 1e-12);
  // Beyond the range: no return.
  EXPECT_EQ(true_range_m(down, at(Vec3(0, 0, 5)), 4.0), kNoHit);
  RangeFinderParameters p;
  p.dropout_probability = 0.0;
  Random rng(1);
  double out;
  measure_range_finder(p, down, at(Vec3(0, 0, 5)), rng, &out);
  EXPECT_TRUE(std::isnan(out));
  // Dropouts happen at their probability (binomial, n = 100 000: sd 0.03 %).
  p.dropout_probability = 0.05;
  int dropped = 0;
  std::vector<double> d;
  for (int k = 0; k < 100000; ++k) {
    measure_range_finder(p, down, at(Vec3(0, 0, 2)), rng, &out);
    if (std::isnan(out))
      ++dropped;
    else
      d.push_back(out);
  }
  EXPECT_NEAR(dropped / 1e5, 0.05, 0.0035);
  EXPECT_NEAR(stddev(d) / (p.noise_m + p.noise_fraction * 2.0), 1.0, 0.02);
}

/// Image coordinates (x/z, y/z) of world point P in the sensor frame of state x.
Eigen::Vector2d image_of(const Vec3& P_W, const StateVector& x, const Mounting& m) {
  const Mat3 R_WB = math::rotation_matrix<double>(Vec4(x.segment<4>(6)));
  const Vec3 o = x.segment<3>(0) + R_WB * m.position_B_m;
  const Vec3 P_S = m.rotation_BS().transpose() * (R_WB.transpose() * (P_W - o));
  return Eigen::Vector2d(P_S[0] / P_S[2], P_S[1] / P_S[2]);
}

TEST(OpticalFlow, EqualsTheRateOfAGroundPointsImageCoordinates) {
  // Independent computation: the ground point on the optical axis now, projected at t - h and
  // t + h with the state moved on by its velocity and body rates, differenced (central, h = 1e-6).
  const Mounting m{Vec3(0.05, -0.02, -0.03), math::from_euler(M_PI + 0.1, -0.05, 0.3)};
  OpticalFlowParameters p;
  Random rng(2);
  for (int trial = 0; trial < 50; ++trial) {
    const Vec4 q = math::from_euler(0.3 * (rng.uniform() - 0.5), 0.3 * (rng.uniform() - 0.5),
                                    6.0 * rng.uniform());
    const Vec3 v(2 * rng.normal(), 2 * rng.normal(), 0.5 * rng.normal());
    const Vec3 w(rng.normal(), rng.normal(), rng.normal());
    const SensorTruth t = at(Vec3(0, 0, 0.5 + 2.0 * rng.uniform()), q, v, w);
    double flow[2];
    ASSERT_TRUE(ideal_optical_flow(p, m, t, flow));
    const Mat3 R_WB = math::rotation_matrix<double>(q);
    const Vec3 o = t.state.segment<3>(0) + R_WB * m.position_B_m;
    const Vec3 axis = R_WB * m.rotation_BS().col(2);
    const Vec3 P = o + axis * ray_ground_m(o, axis);
    const double h = 1e-6;
    auto moved = [&](double dt) {
      StateVector x = t.state;
      x.segment<3>(0) += v * dt;
      const double a = w.norm() * dt;
      const Vec3 u = w.normalized();
      const Vec4 dq(std::cos(a / 2), std::sin(a / 2) * u[0], std::sin(a / 2) * u[1],
                    std::sin(a / 2) * u[2]);
      x.segment<4>(6) = math::multiply<double>(q, dq);
      return x;
    };
    const Eigen::Vector2d rate = (image_of(P, moved(h), m) - image_of(P, moved(-h), m)) / (2 * h);
    EXPECT_NEAR(flow[0], rate[0], 1e-6) << "trial " << trial;
    EXPECT_NEAR(flow[1], rate[1], 1e-6) << "trial " << trial;
  }
  // Level, 2 m up, moving forward at 1 m/s: the ground streams backward at v/h.
  double f[2];
  ASSERT_TRUE(ideal_optical_flow(p, Mounting::looking_down(),
                                 at(Vec3(0, 0, 2), Vec4(1, 0, 0, 0), Vec3(1, 0, 0)), f));
  EXPECT_NEAR(f[0], -0.5, 1e-15);
  EXPECT_NEAR(f[1], 0.0, 1e-15);
  // Too close: no reading.
  EXPECT_FALSE(ideal_optical_flow(p, Mounting::looking_down(), at(Vec3(0, 0, 0.05)), f));
  EXPECT_TRUE(std::isnan(f[0]));
}

}  // namespace
}  // namespace dronetwin
