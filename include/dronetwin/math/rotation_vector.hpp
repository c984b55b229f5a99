#pragma once
// Rotation vectors and unit quaternions (w, x, y, z): exp(theta) is the rotation by |theta| about
// theta / |theta|, log its inverse (the shorter of the two quaternions' rotations). The error-state
// filter's attitude error and the motion capture's attitude noise are rotation vectors.

#include <cmath>

#include "dronetwin/core/types.hpp"

namespace dronetwin::math {

/// The unit quaternion of rotation vector `theta` (rad).
inline Vec4 rotation_exp(const Vec3& theta) {
  const double a = theta.norm();
  // Below 1e-12 rad the first-order form is exact to round-off (sin(a/2)/a = 1/2 - a^2/48).
  if (a < 1e-12) return Vec4(1.0, 0.5 * theta[0], 0.5 * theta[1], 0.5 * theta[2]).normalized();
  const Vec3 v = std::sin(0.5 * a) / a * theta;
  return Vec4(std::cos(0.5 * a), v[0], v[1], v[2]);
}

/// The rotation vector of unit quaternion `q`, angle in [0, pi].
inline Vec3 rotation_log(Vec4 q) {
  if (q[0] < 0.0) q = -q;
  const Vec3 v = q.tail<3>();
  const double n = v.norm();
  if (n < 1e-12) return 2.0 * v;
  return 2.0 * std::atan2(n, q[0]) / n * v;
}

/// The conjugate (for a unit quaternion, the inverse rotation).
inline Vec4 conjugate(const Vec4& q) { return Vec4(q[0], -q[1], -q[2], -q[3]); }

}  // namespace dronetwin::math
