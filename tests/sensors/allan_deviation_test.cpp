// The IMU's noise model against its configuration through the Allan deviation (IEEE Std 952):
// white noise of density N gives N / sqrt(tau); a bias random walk K gives K sqrt(tau / 3); a
// Gauss-Markov bias set from a bias instability B peaks at the flicker floor 0.664 B; all three
// together give the sum of their Allan variances. The simulated static IMU must match within 10 %
// (issue 15). Tolerances: the overlapping estimator's relative error at tau is about
// 1 / sqrt(windows); each check uses taus with hundreds of windows or more.

#include "dronetwin/sensors/allan_deviation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/sensors/bias_process.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"

namespace dronetwin {
namespace {

/// A static, level IMU sampled `seconds` long at `rate_hz`: gyro x and accel z channels.
struct StaticLog {
  std::vector<double> gyro_x, accel_z;
  double dt_s = 0.0;
};

StaticLog record(const ImuParameters& imu, double rate_hz, double seconds, std::uint64_t seed) {
  SensorSpec spec = SensorSpec::imu("imu");
  spec.rate_hz = rate_hz;
  spec.parameters = imu;
  // Physics step = the IMU period: one sample per update.
  SensorSuite suite({spec}, 1.0 / rate_hz, 4, seed);
  SensorTruth truth;  // at rest: a = 0, so the accelerometer reads +g on z
  truth.state[6] = 1.0;
  const auto n = static_cast<std::int64_t>(seconds * rate_hz);
  StaticLog log;
  log.dt_s = 1.0 / rate_hz;
  log.gyro_x.reserve(static_cast<std::size_t>(n));
  log.accel_z.reserve(static_cast<std::size_t>(n));
  for (std::int64_t k = 0; k < n; ++k) {
    truth.time_s = static_cast<double>(k) / rate_hz;
    suite.update(k, truth);
    log.gyro_x.push_back(suite.latest(0).values[3]);
    log.accel_z.push_back(suite.latest(0).values[2]);
  }
  return log;
}

TriadNoise only(double n, double k, double b, double t) {
  TriadNoise x;
  x.noise_density = n;
  x.bias_random_walk = k;
  x.bias_instability = b;
  x.bias_correlation_time_s = t;
  x.turn_on_bias = 0.0;
  x.range = 0.0;
  return x;
}

/// The Allan deviation the configuration predicts: the components' variances add.
double expected(const TriadNoise& n, double tau) {
  const double sigma_gm = gauss_markov_sigma_for_bias_instability(n.bias_instability);
  const double v =
      n.noise_density * n.noise_density / tau +
      n.bias_random_walk * n.bias_random_walk * tau / 3.0 +
      sigma_gm * sigma_gm * gauss_markov_allan_variance_ratio(tau / n.bias_correlation_time_s);
  return std::sqrt(v);
}

TEST(AllanDeviation, WhiteNoiseFollowsTheDensity) {
  ImuParameters p;
  p.gyro = only(2.44e-4, 0, 0, 100);   // BMI088: 0.014 deg/s/sqrt(Hz)
  p.accel = only(1.72e-3, 0, 0, 100);  // BMI088: 175 ug/sqrt(Hz)
  const StaticLog log = record(p, 200.0, 600.0, 1);
  const std::vector<std::int64_t> m = {1, 10, 100, 1000};  // tau 5 ms .. 5 s
  double worst = 0.0;
  for (const auto& [signal, density] :
       {std::pair{&log.gyro_x, p.gyro.noise_density}, {&log.accel_z, p.accel.noise_density}}) {
    for (const AllanPoint& a : allan_deviation(*signal, log.dt_s, m)) {
      const double want = density / std::sqrt(a.tau_s);
      EXPECT_NEAR(a.deviation / want, 1.0, 0.10) << "tau " << a.tau_s << " s";
      worst = std::max(worst, std::abs(a.deviation / want - 1.0));
    }
  }
  RecordProperty("worst_relative_error", std::to_string(worst));
}

TEST(AllanDeviation, BiasRandomWalkRisesAsTheSquareRootOfTau) {
  ImuParameters p;
  p.gyro = only(0, 2.0e-5, 0, 100);
  const StaticLog log = record(p, 100.0, 7200.0, 2);
  const std::vector<std::int64_t> m = {100, 1000, 10000};  // 1 s .. 100 s: 72 .. 7200 windows
  for (const AllanPoint& a : allan_deviation(log.gyro_x, log.dt_s, m)) {
    const double want = p.gyro.bias_random_walk * std::sqrt(a.tau_s / 3.0);
    EXPECT_NEAR(a.deviation / want, 1.0, 0.10) << "tau " << a.tau_s << " s";
  }
}

TEST(AllanDeviation, GaussMarkovBiasPeaksAtTheBiasInstabilityFloor) {
  // The peak ratio: golden-section result against a dense scan.
  double best = 0.0;
  for (double x = 0.01; x < 50.0; x *= 1.0001)
    best = std::max(best, std::sqrt(gauss_markov_allan_variance_ratio(x)));
  EXPECT_NEAR(gauss_markov_allan_peak_ratio(), best, 1e-8);
  // A short correlation time (2 s) so that the peak (near 3.8 s) has ~2000 windows in 2 h.
  ImuParameters p;
  const double B = 9.7e-6;  // 2 deg/h
  p.gyro = only(0, 0, B, 2.0);
  const StaticLog log = record(p, 100.0, 7200.0, 3);
  // From 10 samples per window on: the formula is for a continuous process, and point samples
  // differ from it by O(1 / m^2) (at m = 1 the Allan variance of a sampled random walk is 3/2 of
  // the continuous one). Up to 24 s (6 T): 300 windows or more.
  std::vector<std::int64_t> m;
  for (const std::int64_t k :
       log_spaced_cluster_sizes(static_cast<std::int64_t>(log.gyro_x.size()), 20))
    if (k >= 10 && k <= 2400) m.push_back(k);
  const auto points = allan_deviation(log.gyro_x, log.dt_s, m);
  double peak = 0.0;
  for (const AllanPoint& a : points) {
    peak = std::max(peak, a.deviation);
    EXPECT_NEAR(a.deviation / expected(p.gyro, a.tau_s), 1.0, 0.10) << "tau " << a.tau_s << " s";
  }
  EXPECT_NEAR(peak / (0.664 * B), 1.0, 0.10);
  RecordProperty("peak_over_floor", std::to_string(peak / (0.664 * B)));
}

TEST(AllanDeviation, DatasheetImuMatchesItsConfiguration) {
  // The default (BMI088-class) IMU, all terms on, over taus from 10 ms to 30 s.
  ImuParameters p;
  p.gyro.turn_on_bias = p.accel.turn_on_bias = 0.0;  // a constant: no Allan deviation anyway
  p.gyro.range = p.accel.range = 0.0;
  const StaticLog log = record(p, 100.0, 7200.0, 4);
  const std::vector<std::int64_t> m = {1, 10, 100, 1000, 3000};
  double worst = 0.0;
  for (const auto& [signal, triad] :
       {std::pair{&log.gyro_x, p.gyro}, std::pair{&log.accel_z, p.accel}}) {
    for (const AllanPoint& a : allan_deviation(*signal, log.dt_s, m)) {
      EXPECT_NEAR(a.deviation / expected(triad, a.tau_s), 1.0, 0.10) << "tau " << a.tau_s << " s";
      worst = std::max(worst, std::abs(a.deviation / expected(triad, a.tau_s) - 1.0));
    }
  }
  RecordProperty("worst_relative_error", std::to_string(worst));
}

TEST(AllanDeviation, BadInputIsNamed) {
  const std::vector<double> y = {1.0, 2.0, 3.0, 4.0};
  const std::vector<std::int64_t> too_big = {3};
  EXPECT_THROW(allan_deviation(y, 0.0, too_big), InvalidArgument);
  try {
    allan_deviation(y, 0.1, too_big);
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("cluster_sizes[0]: expected 1 .. 2"), std::string::npos)
        << e.what();
  }
  const std::vector<double> bad = {1.0, NAN, 3.0};
  const std::vector<std::int64_t> one = {1};
  EXPECT_THROW(allan_deviation(bad, 0.1, one), InvalidArgument);
}

}  // namespace
}  // namespace dronetwin
