#include "dronetwin/sensors/motion_capture.hpp"

#include <cmath>

#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/math/rotation_vector.hpp"

namespace dronetwin {

void measure_motion_capture(const MotionCaptureParameters& p, const Mounting& m,
                            const SensorTruth& t, Random& rng, double* out) {
  using namespace state_index;
  const Vec4 q_WB = t.state.segment<4>(kQuaternion);
  const Vec3 position =
      t.state.segment<3>(kPosition) + math::rotation_matrix<double>(q_WB) * m.position_B_m;
  Vec4 q = math::multiply<double>(q_WB, m.rotation_BS_wxyz);
  // Attitude error: a rotation by the small vector dtheta (in the tracked frame), exact exp map.
  const Vec3 dtheta(p.attitude_noise_rad * rng.normal(), p.attitude_noise_rad * rng.normal(),
                    p.attitude_noise_rad * rng.normal());
  q = math::multiply<double>(q, math::rotation_exp(dtheta));
  q.normalize();
  if (q[0] < 0.0) q = -q;  // one of the two signs, so logged components do not jump
  for (int i = 0; i < 3; ++i) out[i] = position[i] + p.position_noise_m * rng.normal();
  for (int i = 0; i < 4; ++i) out[3 + i] = q[i];
}

}  // namespace dronetwin
