#include "dronetwin/sensors/range_finder.hpp"

#include <cmath>
#include <limits>

#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/world/ray_cast.hpp"

namespace dronetwin {

double true_range_m(const Mounting& m, const SensorTruth& t, double max_range_m) {
  using namespace state_index;
  const Mat3 R_WB = math::rotation_matrix<double>(t.state.segment<4>(kQuaternion));
  const Vec3 origin = t.state.segment<3>(kPosition) + R_WB * m.position_B_m;
  Vec3 axis = R_WB * m.rotation_BS().col(2);
  axis.normalize();
  if (t.scene != nullptr) return cast_ray(*t.scene, origin, axis, max_range_m).distance_m;
  const double d = ray_ground_m(origin, axis);
  return d <= max_range_m ? d : kNoHit;
}

void measure_range_finder(const RangeFinderParameters& p, const Mounting& m, const SensorTruth& t,
                          Random& rng, double* out) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  const double d = true_range_m(m, t, p.max_range_m);
  // Always the same two draws, so a dropout does not shift the stream of later samples.
  const double dropout_u = rng.uniform();
  const double n = rng.normal();
  if (!(d >= p.min_range_m && d <= p.max_range_m) || dropout_u < p.dropout_probability) {
    out[0] = kNaN;
    return;
  }
  out[0] = d + (p.noise_m + p.noise_fraction * d) * n;
}

}  // namespace dronetwin
