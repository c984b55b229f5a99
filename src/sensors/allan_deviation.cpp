#include "dronetwin/sensors/allan_deviation.hpp"

#include <cmath>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

std::vector<AllanPoint> allan_deviation(std::span<const double> samples, double dt_s,
                                        std::span<const std::int64_t> cluster_sizes) {
  require(std::isfinite(dt_s) && dt_s > 0.0, "allan_deviation: dt_s: expected a number > 0, got ",
          dt_s);
  const auto n = static_cast<std::int64_t>(samples.size());
  require(n >= 2, "allan_deviation: expected at least 2 samples, got ", n);
  // Prefix sums in long double around the mean: a bias of the signal would otherwise grow the
  // sums until the second differences lose their digits.
  long double mean = 0.0L;
  for (std::int64_t k = 0; k < n; ++k) {
    const double y = samples[static_cast<std::size_t>(k)];
    require(std::isfinite(y), "allan_deviation: sample ", k, " is not finite (", y, ")");
    mean += y;
  }
  mean /= static_cast<long double>(n);
  std::vector<long double> theta(static_cast<std::size_t>(n) + 1, 0.0L);
  for (std::int64_t k = 0; k < n; ++k)
    theta[static_cast<std::size_t>(k) + 1] =
        theta[static_cast<std::size_t>(k)] + (samples[static_cast<std::size_t>(k)] - mean);
  std::vector<AllanPoint> out;
  out.reserve(cluster_sizes.size());
  for (std::size_t c = 0; c < cluster_sizes.size(); ++c) {
    const std::int64_t m = cluster_sizes[c];
    require(m >= 1 && 2 * m <= n, "allan_deviation: cluster_sizes[", c, "]: expected 1 .. ", n / 2,
            " (half the ", n, " samples), got ", m);
    long double sum = 0.0L;
    const std::int64_t terms = n - 2 * m + 1;
    for (std::int64_t k = 0; k < terms; ++k) {
      const auto i = static_cast<std::size_t>(k);
      const auto mm = static_cast<std::size_t>(m);
      const long double d = theta[i + 2 * mm] - 2.0L * theta[i + mm] + theta[i];
      sum += d * d;
    }
    // theta carries no dt: sigma^2 = sum (dt d)^2 / (2 (m dt)^2 terms) = sum d^2 / (2 m^2 terms).
    const long double var = sum / (2.0L * static_cast<long double>(m) *
                                   static_cast<long double>(m) * static_cast<long double>(terms));
    out.push_back({static_cast<double>(m) * dt_s, std::sqrt(static_cast<double>(var)), n / m});
  }
  return out;
}

std::vector<std::int64_t> log_spaced_cluster_sizes(std::int64_t num_samples, int per_decade) {
  require(per_decade >= 1, "log_spaced_cluster_sizes: per_decade: expected >= 1, got ", per_decade);
  std::vector<std::int64_t> out;
  const std::int64_t max_m = num_samples / 2;
  for (int i = 0;; ++i) {
    const auto m = static_cast<std::int64_t>(
        std::llround(std::pow(10.0, static_cast<double>(i) / per_decade)));
    if (m > max_m) break;
    if (out.empty() || m > out.back()) out.push_back(m);
  }
  return out;
}

}  // namespace dronetwin
