#include "dronetwin/sensors/imu.hpp"

#include <algorithm>
#include <cmath>

#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/sensors/bias_process.hpp"

namespace dronetwin {

namespace {

Vec3 normal3(Random& rng, double sigma) {
  if (sigma == 0.0) return Vec3::Zero();
  return Vec3(rng.normal(), rng.normal(), rng.normal()) * sigma;
}

void reset_triad(const TriadNoise& n, Vec3& turn_on, Vec3& walk, Vec3& markov, Random& rng) {
  turn_on = normal3(rng, n.turn_on_bias);
  walk.setZero();
  // Started from its stationary distribution, so the statistics hold from the first sample.
  markov = normal3(rng, gauss_markov_sigma_for_bias_instability(n.bias_instability));
}

Vec3 sample_triad(const TriadNoise& n, const Vec3& truth, const Vec3& turn_on, Vec3& walk,
                  Vec3& markov, double dt_s, double rate_hz, Random& rng) {
  random_walk_step(walk, n.bias_random_walk, dt_s, rng);
  gauss_markov_step(markov, gauss_markov_sigma_for_bias_instability(n.bias_instability),
                    n.bias_correlation_time_s, dt_s, rng);
  Vec3 y = truth + turn_on + walk + markov + normal3(rng, n.noise_density * std::sqrt(rate_hz));
  if (n.range > 0.0)
    for (int i = 0; i < 3; ++i) y[i] = std::clamp(y[i], -n.range, n.range);
  return y;
}

}  // namespace

void reset_imu(const ImuParameters& p, ImuState& s, Random& rng) {
  reset_triad(p.gyro, s.gyro_turn_on, s.gyro_walk, s.gyro_markov, rng);
  reset_triad(p.accel, s.accel_turn_on, s.accel_walk, s.accel_markov, rng);
}

void ideal_imu(const Mounting& m, const SensorTruth& t, Vec3& specific_force_S, Vec3& rate_S) {
  using namespace state_index;
  const Mat3 R_WB = math::rotation_matrix<double>(t.state.segment<4>(kQuaternion));
  const Vec3 w = t.state.segment<3>(kAngularVelocity);
  const Vec3& r = m.position_B_m;
  // Acceleration of a point fixed to the body at r: a + dw x r + w x (w x r) (rigid body).
  const Vec3 f_B = R_WB.transpose() * (t.acceleration_W_m_s2 - t.gravity_W_m_s2) +
                   t.angular_acceleration_B_rad_s2.cross(r) + w.cross(w.cross(r));
  const Mat3 R_BS = m.rotation_BS();
  specific_force_S = R_BS.transpose() * f_B;
  rate_S = R_BS.transpose() * w;
}

void measure_imu(const ImuParameters& p, ImuState& s, const Mounting& m, const SensorTruth& t,
                 double dt_s, double rate_hz, Random& rng, double* out) {
  Vec3 f, w;
  ideal_imu(m, t, f, w);
  const Vec3 fa =
      sample_triad(p.accel, f, s.accel_turn_on, s.accel_walk, s.accel_markov, dt_s, rate_hz, rng);
  const Vec3 wg =
      sample_triad(p.gyro, w, s.gyro_turn_on, s.gyro_walk, s.gyro_markov, dt_s, rate_hz, rng);
  for (int i = 0; i < 3; ++i) {
    out[i] = fa[i];
    out[3 + i] = wg[i];
  }
}

}  // namespace dronetwin
