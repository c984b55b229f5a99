#include "dronetwin/sensors/optical_flow.hpp"

#include <limits>

#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/sensors/range_finder.hpp"

namespace dronetwin {

bool ideal_optical_flow(const OpticalFlowParameters& p, const Mounting& m, const SensorTruth& t,
                        double* flow) {
  using namespace state_index;
  const double d = true_range_m(m, t, p.max_distance_m);
  if (!(d >= p.min_distance_m && d <= p.max_distance_m)) {
    flow[0] = flow[1] = std::numeric_limits<double>::quiet_NaN();
    return false;
  }
  const Mat3 R_WB = math::rotation_matrix<double>(t.state.segment<4>(kQuaternion));
  const Mat3 R_BS = m.rotation_BS();
  const Vec3 w_B = t.state.segment<3>(kAngularVelocity);
  const Vec3 v_B = R_WB.transpose() * t.state.segment<3>(kVelocity) + w_B.cross(m.position_B_m);
  const Vec3 v_S = R_BS.transpose() * v_B;
  const Vec3 w_S = R_BS.transpose() * w_B;
  flow[0] = -v_S[0] / d - w_S[1];
  flow[1] = -v_S[1] / d + w_S[0];
  return true;
}

void measure_optical_flow(const OpticalFlowParameters& p, const Mounting& m, const SensorTruth& t,
                          Random& rng, double* out) {
  const double n0 = rng.normal(), n1 = rng.normal();
  if (!ideal_optical_flow(p, m, t, out)) return;
  out[0] += p.noise_rad_s * n0;
  out[1] += p.noise_rad_s * n1;
}

}  // namespace dronetwin
