#pragma once
// Motion capture: the pose of the tracked frame (the sensor frame S: the marker set's origin and
// axes) in the world, with white position noise and a white attitude error applied as a small
// rotation q_WS (x) exp(dtheta / 2).
//
// Defaults: a room-scale Vicon / OptiTrack system at 100 Hz (0.5 mm, 0.1 deg), docs/sensors.md.

#include "dronetwin/core/types.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/sensors/mounting.hpp"
#include "dronetwin/sensors/sensor_truth.hpp"

namespace dronetwin {

struct MotionCaptureParameters {
  double position_noise_m = 5.0e-4;
  double attitude_noise_rad = 1.75e-3;
};

/// out[0..6] = [x, y, z (m), q_w, q_x, q_y, q_z] of the tracked frame (unit quaternion, w >= 0).
void measure_motion_capture(const MotionCaptureParameters& p, const Mounting& m,
                            const SensorTruth& t, Random& rng, double* out);

}  // namespace dronetwin
