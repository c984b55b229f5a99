#pragma once
// When a sensor samples and which random stream it draws from: shared by the SensorSuite and
// the depth cameras of a run, so that every sensor follows one rule.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string_view>

#include "dronetwin/noise/random.hpp"

namespace dronetwin {

/// The physics step of sample n of a sensor at `rate_hz`: the first step k with k dt >= n / f,
/// with a tolerance for rates that divide the physics rate (1 kHz / 100 Hz is 10 steps exactly,
/// not 10.000000000000002). No drift over long runs: each sample is placed from n, not from the
/// previous one.
inline std::int64_t step_of_sample(std::int64_t n, double rate_hz, double dt_s) {
  const double k = static_cast<double>(n) / (rate_hz * dt_s);
  return static_cast<std::int64_t>(std::ceil(k - 1e-9 * std::max(1.0, k)));
}

/// The seed of a sensor's own stream: from the run's seed and the sensor's name (FNV-1a), so that
/// adding or reordering sensors changes no other sensor's noise.
inline std::uint64_t sensor_stream_seed(std::uint64_t seed, std::string_view name) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (const char c : name) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;
  }
  return Random::mix64(seed ^ h);
}

}  // namespace dronetwin
