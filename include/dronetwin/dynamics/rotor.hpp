#pragma once
// Forces and moments of one rotor (thesis Sec. 2.3.1-2.3.2, Eq. 2.22-2.37).
//
// Inputs are the rotor's parameters, its speed magnitude w (rad/s, held over a physics step),
// the air velocity at the hub projected into the rotor plane, and the hub height. Outputs are
// body-frame vectors. Each function is one physical term so tests can check it by hand:
//
//   RotorParams r = model.rotor(0);
//   Vec3 F = rotor_drag_force<double>(r, 1200.0, v_perp_B);   // -|w| C_D v_perp
//
// Templated on the scalar for automatic differentiation. Trap: `w` is a magnitude; the turning
// direction is r.spin (thesis Eq. 2.24 sign convention, see docs/conventions.md).

#include <algorithm>

#include "dronetwin/core/types.hpp"
#include "dronetwin/model/rotor_params.hpp"

namespace dronetwin {

/// Air velocity of the hub in the rotor plane: v_perp = v - (a.v) a (Eq. 2.33 for a unit axis a).
template <class T>
Vector3<T> in_plane(const Vector3<T>& v_hub_B, const Vec3& axis_B) {
  const Vector3<T> a = axis_B.cast<T>();
  return v_hub_B - a * a.dot(v_hub_B);
}

/// Hub air velocity in the body frame: v_air_B + w_B x r_i (rigid-body velocity of the hub).
template <class T>
Vector3<T> hub_air_velocity(const Vector3<T>& v_air_B, const Vector3<T>& w_B, const Vec3& r_B) {
  return v_air_B + w_B.cross(r_B.cast<T>());
}

/// Thrust force T(w) a (Eq. 2.22). May be slightly negative at low speed ('K3 < 0), as printed.
template <class T>
Vector3<T> thrust_force(const RotorParams& r, double w) {
  return T(r.thrust(w)) * r.axis.cast<T>();
}

/// Reaction (yaw) moment +eps T / K_tau about the axis (Eq. 2.24).
template <class T>
Vector3<T> yaw_reaction_moment(const RotorParams& r, double thrust_N) {
  return T(r.spin * r.yaw_moment_per_thrust_m * thrust_N) * r.axis.cast<T>();
}

/// Rotor (blade-flapping) drag F_D = -|w| C_D v_perp (Eq. 2.32), acting at the hub.
template <class T>
Vector3<T> rotor_drag_force(const RotorParams& r, double w, const Vector3<T>& v_perp_B) {
  return T(-std::abs(w) * r.rotor_drag_coefficient) * v_perp_B;
}

/// Rolling moment M_R = |w| C_R v_perp (Eq. 2.32).
template <class T>
Vector3<T> rolling_moment(const RotorParams& r, double w, const Vector3<T>& v_perp_B) {
  return T(std::abs(w) * r.rolling_moment_coefficient) * v_perp_B;
}

/// Drag moment M_D = -eps C_MD T a (Eq. 2.32).
template <class T>
Vector3<T> drag_moment(const RotorParams& r, double thrust_N) {
  return T(-r.spin * r.drag_moment_coefficient * thrust_N) * r.axis.cast<T>();
}

/// Ground effect F_G = C_G T / h^2 along the axis, h = hub height above ground floored at
/// `min_height_m` (thesis appendix C.2; Eq. 2.34 has no height and is unusable, notes #10).
template <class T>
Vector3<T> ground_effect_force(const RotorParams& r, double thrust_N, const T& hub_height_m,
                               double min_height_m) {
  using std::max;
  const T h = max(hub_height_m, T(min_height_m));
  return (T(r.ground_effect_coefficient * thrust_N) / (h * h)) * r.axis.cast<T>();
}

}  // namespace dronetwin
