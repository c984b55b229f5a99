#include "dronetwin/sensors/magnetometer.hpp"

#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

void measure_magnetometer(const MagnetometerParameters& p, const Mounting& m, const SensorTruth& t,
                          Random& rng, double* out) {
  const Mat3 R_WB = math::rotation_matrix<double>(t.state.segment<4>(state_index::kQuaternion));
  const Vec3 b = m.rotation_BS().transpose() * (R_WB.transpose() * p.field_W_uT) + p.hard_iron_uT;
  for (int i = 0; i < 3; ++i) out[i] = b[i] + (p.noise_uT > 0.0 ? p.noise_uT * rng.normal() : 0.0);
}

}  // namespace dronetwin
