#pragma once
// Magnetometer: the world's magnetic field seen in the sensor frame, with a hard-iron offset
// (a field fixed to the vehicle: magnets of the motors, currents) and white noise.
//
//   m_S = R_BS^T R_WB^T B_W + b_hard + n
//
// Defaults: a mid-latitude field of 48 uT pointing 66 deg below the horizon with the world's x
// axis toward magnetic north (world z is up), ST LIS3MDL class noise (0.3 uT), docs/sensors.md.

#include "dronetwin/core/types.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/sensors/mounting.hpp"
#include "dronetwin/sensors/sensor_truth.hpp"

namespace dronetwin {

struct MagnetometerParameters {
  Vec3 field_W_uT{19.5, 0.0, -43.9};
  double noise_uT = 0.3;
  Vec3 hard_iron_uT = Vec3::Zero();  ///< sensor frame
};

/// out[0..2] = field in the sensor frame, uT.
void measure_magnetometer(const MagnetometerParameters& p, const Mounting& m, const SensorTruth& t,
                          Random& rng, double* out);

}  // namespace dronetwin
