// The error-state EKF: exact behaviour on noiseless data (a static vehicle keeps its estimate; a
// position fix pulls the estimate by the Kalman gain), Jacobians of every update against central
// differences, and consistency: over Monte-Carlo runs of the QDrone2 flying the SE(3) circle with
// the default IMU at 1 kHz and motion capture at 100 Hz, the run-averaged normalised estimation
// error squared (NEES, 15 states) stays inside its two-sided 95 % chi-square interval at >= 90 %
// of the instants (Bar-Shalom, Li & Kirubarajan 2001, Sec. 5.4), and it is not trivially small.

#include "dronetwin/estimation/error_state_ekf.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "circle_flight.hpp"
#include "dronetwin/control/reference.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

/// Wilson-Hilferty: the p-quantile of chi-square with k degrees of freedom (relative error below
/// 1e-3 for k >= 100).
double chi2_quantile(double z_p, double k) {
  const double c = 2.0 / (9.0 * k);
  return k * std::pow(1.0 - c + z_p * std::sqrt(c), 3);
}

TEST(ErrorStateEkf, AStaticNoiselessImuKeepsTheEstimate) {
  EkfParameters p;
  ErrorStateEkf ekf(p);
  const StateVector x0 = Simulator::hover_state(Vec3(1, 2, 3), 0.4);
  ekf.reset(x0, 0.0);
  const Mat3 R = math::rotation_matrix<double>(Vec4(x0.segment<4>(6)));
  const Vec3 f_B = R.transpose() * Vec3(0, 0, 9.81);
  for (int k = 0; k < 1000; ++k) ekf.propagate(f_B, Vec3::Zero(), 1e-3);
  EXPECT_LT((ekf.state() - x0).norm(), 1e-12);
  EXPECT_NEAR(ekf.time_s(), 1.0, 1e-12);
  // Uncertainty grows: velocity by the accel density over 1 s, at least.
  EXPECT_GT(ekf.covariance()(3, 3), p.velocity_sigma_m_s * p.velocity_sigma_m_s);
}

TEST(ErrorStateEkf, APositionFixMovesTheEstimateByTheKalmanGain) {
  // Right after reset, P is diagonal: a fix with variance r moves p by P / (P + r) of the
  // innovation, and the NIS is y^2 / (P + r) per axis.
  EkfParameters p;
  p.position_sigma_m = 0.3;
  ErrorStateEkf ekf(p);
  ekf.reset(Simulator::hover_state(Vec3::Zero()), 0.0);
  const double nis = ekf.update_position(Vec3(0.1, -0.2, 0.05), 0.1);
  const double g = 0.09 / (0.09 + 0.01);
  EXPECT_NEAR(ekf.position()[0], 0.1 * g, 1e-15);
  EXPECT_NEAR(ekf.position()[1], -0.2 * g, 1e-15);
  EXPECT_NEAR(nis, (0.01 + 0.04 + 0.0025) / 0.1, 1e-12);
  EXPECT_NEAR(ekf.covariance()(0, 0), 0.09 * 0.01 / 0.1, 1e-15);
}

TEST(ErrorStateEkf, UpdatesReproduceAPreciseMeasurementOfANearbyState) {
  // A filter with a wide prior and a near-exact sensor (sigma 1e-9) must move its estimate until
  // the measurement function of the estimate equals the measurement. With K = P H^T (H P H^T +
  // R)^-1 the filter's own H always gives H K = I, so the residual h(x_hat+) - z, computed here
  // with the true measurement function, is second order in the offset only if the filter's H is
  // the true Jacobian; a wrong H leaves a first-order residual (offsets here ~2e-5).
  EkfParameters p;
  p.position_sigma_m = p.velocity_sigma_m_s = p.attitude_sigma_rad = 1.0;
  const StateVector x0 = [] {
    StateVector x = Simulator::hover_state(Vec3(0.3, -0.2, 1.7));
    x.segment<3>(3) = Vec3(0.8, -0.5, 0.2);
    x.segment<4>(6) = math::from_euler(0.2, -0.15, 0.8);
    x.segment<3>(10) = Vec3(0.3, -0.2, 0.4);
    return x;
  }();
  const Mounting m{Vec3(0.05, 0.02, -0.04), math::from_euler(M_PI + 0.1, 0.05, -0.2)};
  const Vec3 field(19.5, 0.0, -43.9);
  // Position with a lever arm, magnetometer, range, optical flow.
  for (int which = 0; which < 4; ++which) {
    ErrorStateEkf ekf(p);
    ekf.reset(x0, 0.0);
    auto h = [&](const StateVector& x) -> Eigen::VectorXd {
      const Mat3 R = math::rotation_matrix<double>(Vec4(x.segment<4>(6)));
      if (which == 0) {
        const Vec3 lever(0.1, -0.05, 0.02);
        return x.segment<3>(0) + R * lever;
      }
      if (which == 1) return m.rotation_BS().transpose() * (R.transpose() * field);
      const Vec3 o = x.segment<3>(0) + R * m.position_B_m;
      const Vec3 a = R * m.rotation_BS().col(2);
      Eigen::VectorXd d(1);
      d << -o[2] / a[2];
      if (which == 2) return d;
      // The flow of sensors/optical_flow.hpp, independently: the sensor's velocity and rates in
      // its frame over the distance along its axis.
      const Mat3 R_SB = m.rotation_BS().transpose();
      const Vec3 w = x.segment<3>(10);
      const Vec3 v_S = R_SB * (R.transpose() * Vec3(x.segment<3>(3)) + w.cross(m.position_B_m));
      const Vec3 w_S = R_SB * w;
      Eigen::VectorXd f(2);
      f << -v_S[0] / d[0] - w_S[1], -v_S[1] / d[0] + w_S[0];
      return f;
    };
    Eigen::Matrix<double, 9, 1> delta;
    delta << 1e-5, -2e-5, 1.5e-5, 3e-5, -1e-5, 2e-5, 2e-5, -1e-5, 1.2e-5;
    StateVector xt = x0;
    xt.head<6>() += delta.head<6>();
    xt.segment<4>(6) = math::multiply<double>(Vec4(x0.segment<4>(6)),
                                              math::from_euler(delta[6], delta[7], delta[8]));
    const Eigen::VectorXd z = h(xt);
    if (which == 0) ekf.update_position(z, 1e-9, Vec3(0.1, -0.05, 0.02));
    // The field constrains two of the three attitude angles: S = H P H^T + R has one eigenvalue
    // of R alone, so R stays above round-off (1e-4 uT against offsets of 1e-3 uT).
    if (which == 1) ekf.update_magnetometer(z, field, 1e-4, m);
    if (which == 2) ekf.update_range(z[0], 1e-9, m);
    if (which == 3) ekf.update_optical_flow(Eigen::Vector2d(z[0], z[1]), 1e-9, m);
    const Eigen::VectorXd before = h(x0);
    const Eigen::VectorXd after = h(ekf.state());
    ASSERT_GT((z - before).norm(), 1e-6) << "update " << which << ": the offset must show";
    EXPECT_LT((after - z).norm(), 1e-3 * (z - before).norm()) << "update " << which;
  }
}

TEST(ErrorStateEkf, BadSettingsAndInputsAreNamed) {
  EkfParameters p;
  p.gyro_noise_density = -1.0;
  EXPECT_EQ(test::error_of([&] { ErrorStateEkf e(p); }),
            "ekf: gyro_noise_density: expected a finite number >= 0, got -1");
  p = {};
  p.attitude_sigma_rad = 0.0;
  EXPECT_EQ(test::error_of([&] { ErrorStateEkf e(p); }),
            "ekf: attitude_sigma_rad: expected a finite number > 0, got 0");
  ErrorStateEkf ekf{EkfParameters{}};
  EXPECT_EQ(test::error_of([&] { ekf.propagate(Vec3(0, 0, 9.81), Vec3::Zero(), 0.0); }),
            "ekf propagate: dt_s: expected 0 < dt < 1 s, got 0");
  EXPECT_EQ(test::error_of([&] { ekf.update_position(Vec3(NAN, 0, 0), 0.01); }),
            "ekf update: the innovation is not finite (a NaN measurement?)");
  StateVector bad = Simulator::hover_state(Vec3::Zero());
  bad[0] = NAN;
  EXPECT_EQ(test::error_of([&] { ekf.reset(bad, 0.0); }),
            "ekf reset: the initial guess is not finite");
  // A range finder looking sideways gives no update and leaves the estimate alone.
  const StateVector before = ekf.state();
  EXPECT_TRUE(std::isnan(ekf.update_range(1.0, 0.01, Mounting::at(Vec3::Zero(), 0, M_PI / 2))));
  EXPECT_EQ(ekf.state(), before);
}

TEST(ErrorStateEkf, NeesStaysInsideItsChiSquareBoundsOverMonteCarloRuns) {
  const int runs = test::full_or_sanitized(30, 6);
  const double duration_s = test::kSanitized ? 2.0 : 6.0;
  const CircleReference circle(Vec3(0, 0, 1), 1.0, 6.0);
  ImuParameters imu;  // BMI088-class defaults
  SensorSpec imu_spec = SensorSpec::imu("imu");
  SensorSpec mocap = SensorSpec::motion_capture("mocap");
  mocap.latency_s = 0.0;  // the filter applies fixes on arrival
  const auto& mp = std::get<MotionCaptureParameters>(mocap.parameters);
  const int checks = static_cast<int>(duration_s * 100.0);
  std::vector<double> nees_sum(static_cast<std::size_t>(checks), 0.0);
  for (int r = 0; r < runs; ++r) {
    test::CircleFlight flight(circle, {imu_spec, mocap}, 1000 + static_cast<std::uint64_t>(r));
    const StateVector& x0 = flight.initial_state();
    const SensorSuite& sensors = flight.sensors();
    EkfParameters ep = EkfParameters::from_imu(imu);
    ErrorStateEkf ekf(ep);
    // Initial error drawn from the filter's own initial covariance.
    Random rng(77 + static_cast<std::uint64_t>(r));
    StateVector guess = x0;
    for (int i = 0; i < 3; ++i) {
      guess[i] += ep.position_sigma_m * rng.normal();
      guess[3 + i] += ep.velocity_sigma_m_s * rng.normal();
    }
    const Vec3 dth(ep.attitude_sigma_rad * rng.normal(), ep.attitude_sigma_rad * rng.normal(),
                   ep.attitude_sigma_rad * rng.normal());
    guess.segment<4>(6) =
        math::multiply<double>(Vec4(x0.segment<4>(6)), math::from_euler(dth[0], dth[1], dth[2]));
    ekf.reset(guess, 0.0);
    double last_imu_s = 0.0;
    int check = 0;
    for (std::int64_t k = 0; check < checks; ++k) {
      flight.advance();
      if (sensors.fresh(0) && k > 0) {
        const SensorReading& s = sensors.latest(0);
        ekf.propagate(Vec3(s.values[0], s.values[1], s.values[2]),
                      Vec3(s.values[3], s.values[4], s.values[5]), s.stamp_s - last_imu_s);
        last_imu_s = s.stamp_s;
      }
      if (sensors.fresh(1)) {
        const SensorReading& s = sensors.latest(1);
        ekf.update_position(Vec3(s.values[0], s.values[1], s.values[2]), mp.position_noise_m);
        ekf.update_attitude(Vec4(s.values[3], s.values[4], s.values[5], s.values[6]),
                            mp.attitude_noise_rad);
        const auto [bg, ba] = sensors.imu_bias(0);
        nees_sum[static_cast<std::size_t>(check++)] += ekf.nees(flight.sim().state(), bg, ba);
      }
    }
  }
  // Two-sided 95 % interval of the run average of a chi-square(15) NEES.
  const double k = 15.0 * runs;
  const double lo = chi2_quantile(-1.959964, k) / runs, hi = chi2_quantile(1.959964, k) / runs;
  int inside = 0;
  double mean = 0.0;
  for (const double s : nees_sum) {
    const double avg = s / runs;
    inside += (avg >= lo && avg <= hi) ? 1 : 0;
    mean += avg / checks;
  }
  RecordProperty("mean_nees", std::to_string(mean));
  RecordProperty("inside_fraction", std::to_string(static_cast<double>(inside) / checks));
  EXPECT_GE(inside, static_cast<int>(0.9 * checks))
      << "average NEES " << mean << ", bounds [" << lo << ", " << hi << "]";
  EXPECT_NEAR(mean, 15.0, 0.15 * 15.0);
}

}  // namespace
}  // namespace dronetwin
