#include "dronetwin/sensors/gps.hpp"

#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/sensors/bias_process.hpp"

namespace dronetwin {

void reset_gps(const GpsParameters& /*p*/, GpsState& s, Random& rng) {
  // Stationary start: the fix is already off by its usual error when the run begins.
  s.wander_unit = Vec3(rng.normal(), rng.normal(), rng.normal());
}

void measure_gps(const GpsParameters& p, GpsState& s, const Mounting& m, const SensorTruth& t,
                 double dt_s, Random& rng, double* out) {
  using namespace state_index;
  const Mat3 R_WB = math::rotation_matrix<double>(t.state.segment<4>(kQuaternion));
  const Vec3 w = t.state.segment<3>(kAngularVelocity);
  const Vec3 position = t.state.segment<3>(kPosition) + R_WB * m.position_B_m;
  const Vec3 velocity = t.state.segment<3>(kVelocity) + R_WB * w.cross(m.position_B_m);
  gauss_markov_step(s.wander_unit, 1.0, p.position_error_time_s, dt_s, rng);
  for (int i = 0; i < 3; ++i) {
    out[i] = position[i] + p.position_error_m[i] * s.wander_unit[i] +
             p.position_noise_m[i] * rng.normal();
  }
  for (int i = 0; i < 3; ++i) out[3 + i] = velocity[i] + p.velocity_noise_m_s[i] * rng.normal();
}

}  // namespace dronetwin
