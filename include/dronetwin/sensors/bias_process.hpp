#pragma once
// The slowly wandering errors of a sensor, sampled at its own instants (not the physics step):
//   random walk     b += q sqrt(dt) n                       (q: units/sqrt(s), a "rate random
//                                                            walk" or "bias random walk")
//   Gauss-Markov    b = phi b + sigma sqrt(1 - phi^2) n,    phi = exp(-dt / T)
// both exact discretisations of their continuous processes for any dt, so a sensor sampled at
// an irregular rate keeps the configured statistics. n ~ N(0, 1) from the sensor's own stream.

#include <cmath>

#include "dronetwin/core/types.hpp"
#include "dronetwin/noise/random.hpp"

namespace dronetwin {

/// One random-walk step of each component.
inline void random_walk_step(Vec3& b, double q_per_sqrt_s, double dt_s, Random& rng) {
  if (q_per_sqrt_s == 0.0) return;
  const double s = q_per_sqrt_s * std::sqrt(dt_s);
  for (int i = 0; i < 3; ++i) b[i] += s * rng.normal();
}

/// One Gauss-Markov step of each component; stationary standard deviation sigma, correlation
/// time T.
inline void gauss_markov_step(Vec3& b, double sigma, double correlation_time_s, double dt_s,
                              Random& rng) {
  if (sigma == 0.0) return;
  const double phi = std::exp(-dt_s / correlation_time_s);
  const double s = sigma * std::sqrt(1.0 - phi * phi);
  for (int i = 0; i < 3; ++i) b[i] = phi * b[i] + s * rng.normal();
}

/// Allan variance of a first-order Gauss-Markov process divided by its variance, at averaging
/// time tau = x T: (2x - 3 + 4 e^-x - e^-2x) / x^2 (from its autocovariance sigma^2 e^(-|u|/T):
/// Var of a tau-average minus the covariance of two adjacent ones; docs/sensors.md).
inline double gauss_markov_allan_variance_ratio(double x) {
  if (x < 1e-3) return x * (2.0 / 3.0 - 0.5 * x);  // series: the closed form cancels there
  return (2.0 * x - 3.0 + 4.0 * std::exp(-x) - std::exp(-2.0 * x)) / (x * x);
}

/// The largest Allan deviation of a Gauss-Markov process over all tau, as a multiple of sigma
/// (about 0.62, at tau of about 1.9 T), found by golden-section search on the ratio above.
double gauss_markov_allan_peak_ratio();

/// The Gauss-Markov sigma that models a datasheet "bias instability" B: the process's Allan
/// deviation peaks at the flicker floor 0.664 B (IEEE Std 952: sigma_floor = B sqrt(2 ln 2 / pi)).
/// The IMU calls it at every sample: the factor is computed once.
double gauss_markov_sigma_for_bias_instability(double bias_instability);

}  // namespace dronetwin
