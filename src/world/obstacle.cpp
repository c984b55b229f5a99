#include "dronetwin/world/obstacle.hpp"

#include <algorithm>
#include <cmath>

#include "dronetwin/math/segment_distance.hpp"

namespace dronetwin {

namespace {

// The part [t0, t1] of the segment from + t (to - from), t in [0, 1], inside the slab
// |x_k - c_k| <= h_k of axis k; false when it misses the slab.
bool clip_to_slab(double from, double to, double c, double h, double& t0, double& t1) {
  const double d = to - from;
  const double lo = c - h - from, hi = c + h - from;
  if (d == 0.0) return lo <= 0.0 && 0.0 <= hi;
  double a = lo / d, b = hi / d;
  if (a > b) std::swap(a, b);
  t0 = std::max(t0, a);
  t1 = std::min(t1, b);
  return t0 <= t1;
}

}  // namespace

bool touches_obstacle(const Obstacle& o, const Vec3& from, const Vec3& to, double radius_m) {
  double t0 = 0.0, t1 = 1.0;
  if (o.shape == Obstacle::Shape::kSphere)
    return math::point_segment_distance(o.center_m, from, to) < o.half_size_m[0] + radius_m;
  if (o.shape == Obstacle::Shape::kBox) {
    for (int k = 0; k < 3; ++k)
      if (!clip_to_slab(from[k], to[k], o.center_m[k], o.half_size_m[k] + radius_m, t0, t1))
        return false;
    return true;
  }
  // Cylinder: the part of the segment within the grown height, then its horizontal distance
  // to the axis.
  if (!clip_to_slab(from[2], to[2], o.center_m[2], o.half_size_m[2] + radius_m, t0, t1))
    return false;
  const Eigen::Vector2d a = (from + t0 * (to - from)).head<2>() - o.center_m.head<2>();
  const Eigen::Vector2d b = (from + t1 * (to - from)).head<2>() - o.center_m.head<2>();
  const Eigen::Vector2d d = b - a;
  const double dd = d.squaredNorm();
  const double t = dd > 0.0 ? std::clamp(-a.dot(d) / dd, 0.0, 1.0) : 0.0;
  return (a + t * d).norm() < o.half_size_m[0] + radius_m;
}

}  // namespace dronetwin
