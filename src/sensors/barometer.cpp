#include "dronetwin/sensors/barometer.hpp"

#include <cmath>

#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

namespace {
// ISA sea-level values and tropospheric lapse rate (ISO 2533:1975).
constexpr double kP0_Pa = 101325.0;
constexpr double kT0_K = 288.15;
constexpr double kLapse_K_m = 0.0065;
constexpr double kG0 = 9.80665;
constexpr double kMolarMass = 0.0289644;  // kg/mol, dry air
constexpr double kGasConstant = 8.31432;  // J/(mol K), the value the standard tables use
constexpr double kExponent = kG0 * kMolarMass / (kGasConstant * kLapse_K_m);  // 5.2559
}  // namespace

double isa_pressure_Pa(double altitude_m) {
  return kP0_Pa * std::pow(1.0 - kLapse_K_m * altitude_m / kT0_K, kExponent);
}

double isa_altitude_m(double pressure_Pa) {
  return kT0_K / kLapse_K_m * (1.0 - std::pow(pressure_Pa / kP0_Pa, 1.0 / kExponent));
}

void reset_barometer(BarometerState& s) { s.drift_Pa = 0.0; }

void measure_barometer(const BarometerParameters& p, BarometerState& s, const Mounting& m,
                       const SensorTruth& t, double dt_s, Random& rng, double* out) {
  using namespace state_index;
  const Mat3 R_WB = math::rotation_matrix<double>(t.state.segment<4>(kQuaternion));
  const double z = t.state[kPosition + 2] + (R_WB * m.position_B_m)[2];
  if (p.drift_Pa_per_sqrt_s > 0.0)
    s.drift_Pa += p.drift_Pa_per_sqrt_s * std::sqrt(dt_s) * rng.normal();
  const double noise = p.noise_Pa > 0.0 ? p.noise_Pa * rng.normal() : 0.0;
  out[0] = isa_pressure_Pa(p.origin_altitude_m + z) + p.offset_Pa + s.drift_Pa + noise;
}

}  // namespace dronetwin
