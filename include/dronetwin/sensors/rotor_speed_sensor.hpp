#pragma once
// Rotor-speed sensor (ESC telemetry or an optical tachometer): each rotor's speed with white
// noise. Default 2 rad/s (about 20 rpm), docs/sensors.md.

#include "dronetwin/noise/random.hpp"
#include "dronetwin/sensors/sensor_truth.hpp"

namespace dronetwin {

struct RotorSpeedSensorParameters {
  double noise_rad_s = 2.0;
};

/// out[0..n-1] = rotor speeds, rad/s.
void measure_rotor_speeds(const RotorSpeedSensorParameters& p, const SensorTruth& t, Random& rng,
                          double* out);

}  // namespace dronetwin
