#pragma once
// Optical-flow sensor (a downward camera that reports how fast the texture below moves across
// its image, PixArt PMW3901 class): the angular rate of the image at the principal point.
// A static point at distance d along the optical axis z_S moves in the sensor frame with
// dP/dt = -v_S - w_S x P, so its normalised image coordinates change at
//
//   flow_x = -v_x / d - w_y,    flow_y = -v_y / d + w_x        (rad/s, sensor frame)
//
// with v_S the sensor's velocity and w_S the body rates in the sensor frame. The sensor does not
// remove the rotation (a flight stack subtracts the gyro). No reading (NaN) outside the sensor's
// working distances. Defaults: PMW3901 (0.08 m to 4 m here; 42 deg field of view), noise
// 0.05 rad/s, docs/sensors.md. A PMW3901 count is flow * dt * 35 px / 0.733 rad.

#include "dronetwin/core/types.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/sensors/mounting.hpp"
#include "dronetwin/sensors/sensor_truth.hpp"

namespace dronetwin {

struct OpticalFlowParameters {
  double noise_rad_s = 0.05;
  double min_distance_m = 0.08;
  double max_distance_m = 4.0;
};

/// The noiseless flow [flow_x, flow_y] (rad/s); false (and NaN) when the distance is out of range.
bool ideal_optical_flow(const OpticalFlowParameters& p, const Mounting& m, const SensorTruth& t,
                        double* flow);
/// out[0..1] = [flow_x, flow_y] rad/s, NaN when there is no reading.
void measure_optical_flow(const OpticalFlowParameters& p, const Mounting& m, const SensorTruth& t,
                          Random& rng, double* out);

}  // namespace dronetwin
