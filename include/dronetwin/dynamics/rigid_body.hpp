#pragma once
// Newton-Euler equations of a rigid body with the state layout of thesis Eq. 2.20:
//   p_dot = v_W
//   v_dot = (R F_B) / m + g_W                    (Eq. 2.38 / 2.41)
//   q_dot = 1/2 q (x) [0, w_B]                   (Eq. 2.13)
//   w_dot = J^-1 (M_B - w_B x J w_B)             (Eq. 2.39 / 2.42), full 3x3 J allowed
// F_B and M_B are the total non-gravitational force and the total moment in the body frame.

#include "dronetwin/core/types.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

template <class T>
using StateVectorT = Eigen::Matrix<T, kStateSize, 1>;

template <class T>
DRONETWIN_HOT_INLINE StateVectorT<T> newton_euler(const StateVectorT<T>& x, const Matrix3<T>& R,
                                                  const Vector3<T>& F_B, const Vector3<T>& M_B,
                                                  double mass_kg, const Mat3& inertia,
                                                  const Mat3& inertia_inv, const Vec3& gravity_W) {
  using namespace state_index;
  const Vector3<T> w = x.template segment<3>(kAngularVelocity);
  StateVectorT<T> d;
  d.template segment<3>(kPosition) = x.template segment<3>(kVelocity);
  d.template segment<3>(kVelocity) = R * F_B / T(mass_kg) + gravity_W.cast<T>();
  d.template segment<4>(kQuaternion) = math::derivative<T>(x.template segment<4>(kQuaternion), w);
  const Vector3<T> Jw = inertia.cast<T>() * w;
  d.template segment<3>(kAngularVelocity) = inertia_inv.cast<T>() * (M_B - w.cross(Jw));
  return d;
}

/// newton_euler() for a diagonal inertia J = diag(j) with J^-1 = diag(j_inv) (the diagonals of
/// the model's matrices): the same equations, without the products by zero off-diagonal terms.
template <class T>
DRONETWIN_HOT_INLINE StateVectorT<T> newton_euler_diagonal_inertia(
    const StateVectorT<T>& x, const Matrix3<T>& R, const Vector3<T>& F_B, const Vector3<T>& M_B,
    double mass_kg, const Vec3& j, const Vec3& j_inv, const Vec3& gravity_W) {
  using namespace state_index;
  const Vector3<T> w = x.template segment<3>(kAngularVelocity);
  StateVectorT<T> d;
  d.template segment<3>(kPosition) = x.template segment<3>(kVelocity);
  d.template segment<3>(kVelocity) = R * F_B / T(mass_kg) + gravity_W.cast<T>();
  d.template segment<4>(kQuaternion) = math::derivative<T>(x.template segment<4>(kQuaternion), w);
  const Vector3<T> Jw = j.cast<T>().cwiseProduct(w);
  d.template segment<3>(kAngularVelocity) = j_inv.cast<T>().cwiseProduct(M_B - w.cross(Jw));
  return d;
}

/// Projects the quaternion block back onto the unit sphere (drift from integration).
inline void normalize_quaternion(StateVector& x) {
  x.segment<4>(state_index::kQuaternion).normalize();
}

/// Rotational kinetic energy 1/2 w^T J w and world-frame angular momentum R J w (for tests).
inline double rotational_energy(const StateVector& x, const Mat3& inertia) {
  const Vec3 w = x.segment<3>(state_index::kAngularVelocity);
  return 0.5 * w.dot(inertia * w);
}

}  // namespace dronetwin
