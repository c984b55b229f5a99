#pragma once
// Overlapping Allan deviation of a uniformly sampled signal (IEEE Std 952 / 1554): for averaging
// time tau = m dt, with theta_k = dt (y_0 + ... + y_{k-1}),
//
//   sigma^2(tau) = sum_k (theta_{k+2m} - 2 theta_{k+m} + theta_k)^2 / (2 tau^2 (N - 2m + 1))
//
// The tool that validates the IMU model against its datasheet numbers (tests/sensors), and that
// a user applies to a logged static IMU to identify one.

#include <cstdint>
#include <span>
#include <vector>

namespace dronetwin {

struct AllanPoint {
  double tau_s = 0.0;
  double deviation = 0.0;
  /// Non-overlapping windows of length tau in the record (N / m): the estimate's relative
  /// uncertainty is about 1 / sqrt(2 (windows - 1)), less thanks to the overlap.
  std::int64_t windows = 0;
};

/// The Allan deviation at each cluster size m (samples per window; 1 <= m <= N / 2), in the
/// order given. InvalidArgument for dt_s <= 0, an empty signal, non-finite samples or a cluster
/// size out of range.
std::vector<AllanPoint> allan_deviation(std::span<const double> samples, double dt_s,
                                        std::span<const std::int64_t> cluster_sizes);

/// Cluster sizes from 1 to N / 2, spaced about evenly in log(m) with `per_decade` per decade,
/// without repeats.
std::vector<std::int64_t> log_spaced_cluster_sizes(std::int64_t num_samples, int per_decade = 10);

}  // namespace dronetwin
