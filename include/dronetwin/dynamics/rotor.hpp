#pragma once
// Forces and moments of one rotor (thesis Sec. 2.3.1-2.3.2, Eq. 2.22-2.34), each written once, in
// the form the force kernel (force_kernel.hpp) folds together: over a physics step the rotor speed
// w is held, so every rotor term is either
//   - a constant times the rotor's thrust T(w)  (thrust, yaw reaction, drag moment),
//   - |w| times a linear map of the body air velocity and body rate  (rotor drag, rolling moment),
//   - or the thrust scaled by a function of the hub height  (ground effect).
// Wrenches are [F_B; M_B] in the body frame about the centre of mass: a force F acting at the hub
// r contributes the moment r x F.
//
//   const RotorParams& r = model.rotor(0);
//   Vector6<double> F = r.thrust(1200.0) * axial_force_wrench(r.position_m, r.axis);  // Eq. 2.22
//   Matrix6<double> D = rotor_drag_map(r.position_m, r.axis);   // times C_D |w| [v_air_B; w_B]
//
// Templated on the scalar (double, float, ceres::Jet, SIMD packs). Trap: w is a magnitude; the
// turning direction is r.spin (thesis Eq. 2.24 sign convention, see docs/conventions.md).

#include "dronetwin/core/scalar.hpp"
#include "dronetwin/core/types.hpp"
#include "dronetwin/model/rotor_params.hpp"

namespace dronetwin {

template <class T>
using Vector6 = Eigen::Matrix<T, 6, 1>;
template <class T>
using Matrix6 = Eigen::Matrix<T, 6, 6>;

/// [a; r x a]: the wrench of a unit force along the rotor axis a acting at the hub r. The thrust
/// T(w) a (Eq. 2.22, its moment Eq. 2.27) and the ground-effect force (appendix C.2) act along it.
template <class V>
Vector6<V> axial_force_wrench(const Vector3<V>& position_m, const Vector3<V>& axis) {
  Vector6<V> w;
  w << axis, position_m.cross(axis);
  return w;
}

/// Reaction (yaw) moment about the axis per unit thrust: +eps / K_tau (Eq. 2.24).
template <class S>
S yaw_reaction_per_thrust(const RotorParamsTpl<S>& r) {
  using V = typename RotorParamsTpl<S>::Value;
  return V(r.spin) * r.yaw_moment_per_thrust_m;
}

/// Drag moment about the axis per unit thrust: -eps C_MD (Eq. 2.32, M_D = -eps C_MD T a).
template <class S>
S drag_moment_per_thrust(const RotorParamsTpl<S>& r) {
  using V = typename RotorParamsTpl<S>::Value;
  return V(-r.spin) * r.drag_moment_coefficient;
}

namespace detail {
/// [v_perp] = P [I, -[r]x] [v; w]: the hub's air velocity in the rotor plane as a linear map of
/// the body air velocity v and body rate w. v_hub = v + w x r = v - [r]x w (Eq. 2.33), and
/// P = I - a a^T removes the axial part.
template <class V>
Eigen::Matrix<V, 3, 6> in_plane_hub_velocity_map(const Vector3<V>& r, const Vector3<V>& a) {
  const Matrix3<V> plane = Matrix3<V>::Identity() - a * a.transpose();
  Matrix3<V> r_hat;
  r_hat << V(0), -r.z(), r.y(), r.z(), V(0), -r.x(), -r.y(), r.x(), V(0);
  Eigen::Matrix<V, 3, 6> map;
  map << plane, -plane * r_hat;
  return map;
}
template <class V>
Matrix3<V> cross_matrix(const Vector3<V>& r) {
  Matrix3<V> r_hat;
  r_hat << V(0), -r.z(), r.y(), r.z(), V(0), -r.x(), -r.y(), r.x(), V(0);
  return r_hat;
}
}  // namespace detail

/// Rotor (blade-flapping) drag per unit C_D |w| (Eq. 2.32): the force F = -C_D |w| v_perp acts at
/// the hub, so [F; r x F] = C_D |w| * rotor_drag_map(r, a) * [v_air_B; w_B].
template <class V>
Matrix6<V> rotor_drag_map(const Vector3<V>& position_m, const Vector3<V>& axis) {
  const Eigen::Matrix<V, 3, 6> v_perp = detail::in_plane_hub_velocity_map(position_m, axis);
  Matrix6<V> m;
  m.template topRows<3>() = -v_perp;
  m.template bottomRows<3>() = -detail::cross_matrix(position_m) * v_perp;
  return m;
}

/// Rolling moment per unit C_R |w| (Eq. 2.32): M_R = C_R |w| v_perp, a pure moment, so
/// [0; M_R] = C_R |w| * rolling_moment_map(r, a) * [v_air_B; w_B].
template <class V>
Matrix6<V> rolling_moment_map(const Vector3<V>& position_m, const Vector3<V>& axis) {
  Matrix6<V> m = Matrix6<V>::Zero();
  m.template bottomRows<3>() = detail::in_plane_hub_velocity_map(position_m, axis);
  return m;
}

/// Ground-effect force along the axis (thesis appendix C.2; Eq. 2.34 has no height and is
/// unusable, notes #10): C_G T / h^2 with `gain` = C_G T and h the hub height above the ground,
/// floored at `min_height_m` so the force stays finite when a hub touches the ground.
template <class S, class X, class V>
DRONETWIN_HOT_INLINE S ground_effect_force(const S& gain, const X& hub_height_m,
                                           const V& min_height_m) {
  const X h = scalar::max(hub_height_m, X(min_height_m));
  return gain / (h * h);
}

}  // namespace dronetwin
