#pragma once
// Newton-Euler equations of a rigid body with the state layout of thesis Eq. 2.20:
//   p_dot = v_W
//   v_dot = (R F_B) / m + g_W                    (Eq. 2.38 / 2.41)
//   q_dot = 1/2 q (x) [0, w_B]                   (Eq. 2.13)
//   w_dot = J^-1 (M_B - w_B x J w_B)             (Eq. 2.39 / 2.42), full 3x3 J allowed
// F_B and M_B are the total non-gravitational force and the total moment in the body frame.
//
// Templated on two scalars: the state's X and the forces' and parameters' S. They are equal for
// the simulator (double), a batch (a pack) and a prediction under automatic differentiation; a
// fit evaluates a logged (double) state with parameters that carry derivatives (S = Jet), so the
// state-only parts stay cheap doubles. The result is in S.

#include <type_traits>

#include "dronetwin/core/scalar.hpp"
#include "dronetwin/core/types.hpp"
#include "dronetwin/math/ordered_product.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

template <class T>
using StateVectorT = Eigen::Matrix<T, kStateSize, 1>;

namespace detail {
/// Writes the state-only blocks of x_dot (p_dot = v, q_dot = 1/2 q (x) [0, w]) into d. Without a
/// cast when state and result share the scalar: Eigen's same-type cast still builds an
/// expression, and the compiler then assembles q_dot through the stack.
template <class S, class X>
DRONETWIN_HOT_INLINE void kinematics(const StateVectorT<X>& x, const Vector3<X>& w_B,
                                     StateVectorT<S>& d) {
  using namespace state_index;
  if constexpr (std::is_same_v<S, X>) {
    d.template segment<3>(kPosition) = x.template segment<3>(kVelocity);
    d.template segment<4>(kQuaternion) =
        math::derivative<X>(x.template segment<4>(kQuaternion), w_B);
  } else {
    d.template segment<3>(kPosition) = x.template segment<3>(kVelocity).template cast<S>();
    d.template segment<4>(kQuaternion) =
        math::derivative<X>(x.template segment<4>(kQuaternion), w_B).template cast<S>();
  }
}
}  // namespace detail

/// Eq. 2.39 / 2.42: w_dot = J^-1 (M - w x J w).
template <class S, class X, class J>
DRONETWIN_HOT_INLINE Vector3<S> angular_acceleration(const Matrix3<J>& inertia,
                                                     const Matrix3<J>& inertia_inv,
                                                     const Vector3<X>& w_B, const Vector3<S>& M_B) {
  const Vector3<S> Jw = math::ordered_product(inertia, w_B);
  const Vector3<S> net = M_B - w_B.cross(Jw);
  return math::ordered_product(inertia_inv, net);
}

/// angular_acceleration() for a diagonal inertia J = diag(j), J^-1 = diag(j_inv): the same
/// equations without the products by zero off-diagonal terms.
template <class S, class X, class J>
DRONETWIN_HOT_INLINE Vector3<S> angular_acceleration_diagonal(const Vector3<J>& j,
                                                              const Vector3<J>& j_inv,
                                                              const Vector3<X>& w_B,
                                                              const Vector3<S>& M_B) {
  const Vector3<S> Jw = j.cwiseProduct(w_B);
  return j_inv.cwiseProduct(M_B - w_B.cross(Jw));
}

/// x_dot of the full state for body-frame force F_B and moment M_B, rotation R = R(q).
template <class S, class X, class G>
DRONETWIN_HOT_INLINE StateVectorT<S> newton_euler(const StateVectorT<X>& x, const Matrix3<X>& R,
                                                  const Vector3<S>& F_B, const Vector3<S>& M_B,
                                                  const S& mass_kg, const Matrix3<S>& inertia,
                                                  const Matrix3<S>& inertia_inv,
                                                  const Vector3<G>& gravity_W) {
  using namespace state_index;
  const Vector3<X> w = x.template segment<3>(kAngularVelocity);
  StateVectorT<S> d;
  detail::kinematics(x, w, d);
  d.template segment<3>(kVelocity) = math::ordered_product(R, F_B) / mass_kg + gravity_W;
  d.template segment<3>(kAngularVelocity) = angular_acceleration(inertia, inertia_inv, w, M_B);
  return d;
}

/// newton_euler() for a diagonal inertia (the model's inertia_is_diagonal()).
template <class S, class X, class G>
DRONETWIN_HOT_INLINE StateVectorT<S> newton_euler_diagonal_inertia(
    const StateVectorT<X>& x, const Matrix3<X>& R, const Vector3<S>& F_B, const Vector3<S>& M_B,
    const S& mass_kg, const Vector3<S>& j, const Vector3<S>& j_inv, const Vector3<G>& gravity_W) {
  using namespace state_index;
  const Vector3<X> w = x.template segment<3>(kAngularVelocity);
  StateVectorT<S> d;
  detail::kinematics(x, w, d);
  d.template segment<3>(kVelocity) = math::ordered_product(R, F_B) / mass_kg + gravity_W;
  d.template segment<3>(kAngularVelocity) = angular_acceleration_diagonal(j, j_inv, w, M_B);
  return d;
}

/// Projects the quaternion block back onto the unit sphere (drift from integration). As Eigen's
/// normalize(): divided by its norm when that is positive; a zero quaternion stays zero (the
/// simulator refuses it). Written out so a double and a SIMD pack sum the squares in one order.
template <class X>
DRONETWIN_HOT_INLINE void normalize_quaternion(StateVectorT<X>& x) {
  using namespace state_index;
  using V = scalar::value_type_t<X>;
  const X q0 = x[kQuaternion], q1 = x[kQuaternion + 1], q2 = x[kQuaternion + 2],
          q3 = x[kQuaternion + 3];
  const X n2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3;
  const auto positive = V(0) < n2;
  const X norm = scalar::select(positive, scalar::sqrt(n2), X(V(1)));
  for (int k = 0; k < 4; ++k) x[kQuaternion + k] = x[kQuaternion + k] / norm;
}

/// Rotational kinetic energy 1/2 w^T J w (for tests).
inline double rotational_energy(const StateVector& x, const Mat3& inertia) {
  const Vec3 w = x.segment<3>(state_index::kAngularVelocity);
  return 0.5 * w.dot(inertia * w);
}

}  // namespace dronetwin
