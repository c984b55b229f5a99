#pragma once
// Unit-quaternion kinematics, scalar first [w, x, y, z] (thesis Sec. 2.2.2.3).
//
// Templated on the scalar so the same code runs with double in the integrator and with
// ceres::Jet inside automatic differentiation.
//
// Convention: q = q_WB rotates body vectors into the world, v_W = R(q) v_B (thesis Eq. 2.7 as it
// is used in Eq. 2.41; see docs/conventions.md, item "rotation naming").

#include <cmath>

#include "dronetwin/core/scalar.hpp"
#include "dronetwin/core/types.hpp"

namespace dronetwin::math {

/// Rotation matrix R(q) for a unit quaternion q = [w, x, y, z]: v_W = R v_B.
template <class T, class Q>
DRONETWIN_HOT_INLINE Matrix3<T> rotation_matrix(const Q& q) {
  const T w = q[0], x = q[1], y = q[2], z = q[3];
  const T xx = x * x, yy = y * y, zz = z * z;
  const T xy = x * y, xz = x * z, yz = y * z;
  const T wx = w * x, wy = w * y, wz = w * z;
  Matrix3<T> r;
  r << T(1) - T(2) * (yy + zz), T(2) * (xy - wz), T(2) * (xz + wy),  //
      T(2) * (xy + wz), T(1) - T(2) * (xx + zz), T(2) * (yz - wx),   //
      T(2) * (xz - wy), T(2) * (yz + wx), T(1) - T(2) * (xx + yy);
  return r;
}

/// Hamilton product a (x) b (the standard product; thesis Eq. 2.9 as printed has a sign slip).
template <class T>
Vector4<T> multiply(const Vector4<T>& a, const Vector4<T>& b) {
  Vector4<T> c;
  c[0] = a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3];
  c[1] = a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2];
  c[2] = a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1];
  c[3] = a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0];
  return c;
}

/// q_dot = 1/2 q (x) [0, w_B] (thesis Eq. 2.13; Eq. 2.14 as printed drops the 1/2).
template <class T, class Q, class W>
DRONETWIN_HOT_INLINE Vector4<T> derivative(const Q& q, const W& w_B) {
  Vector4<T> d;
  // One half in T's own machine number: a float pack cannot be built from a double.
  const T half = scalar::from_value<T>(0.5);
  d[0] = half * (-q[1] * w_B[0] - q[2] * w_B[1] - q[3] * w_B[2]);
  d[1] = half * (q[0] * w_B[0] + q[2] * w_B[2] - q[3] * w_B[1]);
  d[2] = half * (q[0] * w_B[1] - q[1] * w_B[2] + q[3] * w_B[0]);
  d[3] = half * (q[0] * w_B[2] + q[1] * w_B[1] - q[2] * w_B[0]);
  return d;
}

/// Quaternion from ZYX Euler angles (roll phi, pitch theta, yaw psi), R = Rz(psi) Ry(theta) Rx(phi)
/// as in thesis Eq. 2.7.
inline Vec4 from_euler(double roll, double pitch, double yaw) {
  const double cr = std::cos(roll / 2), sr = std::sin(roll / 2);
  const double cp = std::cos(pitch / 2), sp = std::sin(pitch / 2);
  const double cy = std::cos(yaw / 2), sy = std::sin(yaw / 2);
  return Vec4(cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
              cr * cp * sy - sr * sp * cy);
}

/// ZYX Euler angles [roll, pitch, yaw] of a unit quaternion (inverse of from_euler, atan2-based).
inline Vec3 to_euler(const Vec4& q) {
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double roll = std::atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
  double s = 2 * (w * y - z * x);
  s = s > 1 ? 1 : (s < -1 ? -1 : s);
  const double pitch = std::asin(s);
  const double yaw = std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
  return Vec3(roll, pitch, yaw);
}

}  // namespace dronetwin::math
