#pragma once
// GNSS receiver: the antenna's position and velocity in the world frame (a local tangent frame:
// a receiver's latitude and longitude converted about the origin), each sample late by the
// sensor's latency. The position error is white noise plus a slowly wandering part (a
// Gauss-Markov process: the atmosphere and orbit errors that make a standing receiver's fix
// walk around by metres over minutes); the velocity error is white.
//
// Defaults: u-blox M8/M9 class at 10 Hz (position about 1.5 m horizontal / 3 m vertical,
// velocity 0.05 m/s), docs/sensors.md.

#include "dronetwin/core/types.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/sensors/mounting.hpp"
#include "dronetwin/sensors/sensor_truth.hpp"

namespace dronetwin {

struct GpsParameters {
  Vec3 position_noise_m{0.3, 0.3, 0.6};       ///< white, per axis
  Vec3 position_error_m{1.5, 1.5, 3.0};       ///< stationary sigma of the wandering part
  double position_error_time_s = 60.0;        ///< its correlation time
  Vec3 velocity_noise_m_s{0.05, 0.05, 0.08};  ///< white, per axis
};

struct GpsState {
  Vec3 wander_unit = Vec3::Zero();  ///< Gauss-Markov state with sigma 1 (scaled per axis)
};

void reset_gps(const GpsParameters& p, GpsState& s, Random& rng);
/// out[0..5] = [x, y, z (m), v_x, v_y, v_z (m/s)] of the antenna, world frame.
void measure_gps(const GpsParameters& p, GpsState& s, const Mounting& m, const SensorTruth& t,
                 double dt_s, Random& rng, double* out);

}  // namespace dronetwin
