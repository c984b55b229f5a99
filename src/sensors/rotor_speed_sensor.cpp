#include "dronetwin/sensors/rotor_speed_sensor.hpp"

namespace dronetwin {

void measure_rotor_speeds(const RotorSpeedSensorParameters& p, const SensorTruth& t, Random& rng,
                          double* out) {
  for (Eigen::Index i = 0; i < t.rotor_speed_rad_s.size(); ++i)
    out[i] = t.rotor_speed_rad_s[i] + p.noise_rad_s * rng.normal();
}

}  // namespace dronetwin
