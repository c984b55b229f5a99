#pragma once
// Barometer: static pressure of the International Standard Atmosphere's troposphere at the
// sensor's altitude, with white noise, a fixed offset and a drift (random walk).
//
//   p = p0 (1 - L h / T0)^(g0 M / (R L)),   h = origin_altitude_m + z of the sensor  (ISA, ISO
//   2533)
//
// Defaults: Bosch BMP388 / TE MS5611 class (about 1 Pa of noise at a high oversampling rate,
// that is 8 cm of altitude), docs/sensors.md.

#include "dronetwin/core/types.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/sensors/mounting.hpp"
#include "dronetwin/sensors/sensor_truth.hpp"

namespace dronetwin {

struct BarometerParameters {
  double noise_Pa = 1.0;              ///< standard deviation of each sample
  double drift_Pa_per_sqrt_s = 0.05;  ///< random walk of the offset
  double offset_Pa = 0.0;             ///< fixed error
  double origin_altitude_m = 0.0;     ///< altitude above mean sea level of z = 0
};

struct BarometerState {
  double drift_Pa = 0.0;
};

/// ISA pressure at `altitude_m` above mean sea level (valid -500 .. 11000 m), Pa.
double isa_pressure_Pa(double altitude_m);
/// Its inverse: the altitude at pressure `pressure_Pa`, m.
double isa_altitude_m(double pressure_Pa);

void reset_barometer(BarometerState& s);
/// out[0] = pressure, Pa.
void measure_barometer(const BarometerParameters& p, BarometerState& s, const Mounting& m,
                       const SensorTruth& t, double dt_s, Random& rng, double* out);

}  // namespace dronetwin
