#pragma once
// Range finder (time-of-flight or lidar): the distance along the sensor's z axis to the first
// thing the ray hits (the ground or the scene, world/ray_cast.hpp), with noise that grows with
// the distance, and no return (NaN) beyond the range, below the minimum, or at a dropout.
//
// Defaults: ST VL53L1X class (0.04-4 m, about 1 cm + 0.5 % noise, 1 % dropouts), looking down,
// docs/sensors.md.

#include "dronetwin/core/types.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/sensors/mounting.hpp"
#include "dronetwin/sensors/sensor_truth.hpp"

namespace dronetwin {

struct RangeFinderParameters {
  double min_range_m = 0.04;
  double max_range_m = 4.0;
  double noise_m = 0.01;              ///< sigma at zero distance
  double noise_fraction = 0.005;      ///< plus this share of the distance
  double dropout_probability = 0.01;  ///< chance a sample has no return
};

/// Distance from the sensor along its z axis to the ground or the scene, or kNoHit.
double true_range_m(const Mounting& m, const SensorTruth& t, double max_range_m);

/// out[0] = distance (m) or NaN when there is no return.
void measure_range_finder(const RangeFinderParameters& p, const Mounting& m, const SensorTruth& t,
                          Random& rng, double* out);

}  // namespace dronetwin
