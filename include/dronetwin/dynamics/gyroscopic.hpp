#pragma once
// Gyroscopic moment of the spinning rotors on a rotating body (thesis Eq. 2.35, with the minus
// sign of Eq. 2.37): M_G = -w_B x h_rotors, h_rotors = sum_i eps_i J_r,i w_i a_i.
//
//   Vector3<double> h = speed_0 * rotor_momentum_per_speed(model.rotor(0)) + ...;
//   Vector3<double> M = gyroscopic_moment(w_B, h);

#include "dronetwin/core/types.hpp"
#include "dronetwin/model/rotor_params.hpp"

namespace dronetwin {

/// Angular momentum of rotor i per unit rotor speed, eps_i J_r,i a_i (kg m^2: times rad/s gives
/// kg m^2/s).
template <class S>
Vector3<S> rotor_momentum_per_speed(const RotorParamsTpl<S>& r) {
  using V = typename RotorParamsTpl<S>::Value;
  const S per_speed = V(r.spin) * r.inertia_kgm2;
  return Vector3<S>(per_speed * r.axis[0], per_speed * r.axis[1], per_speed * r.axis[2]);
}

/// M_G = -w_B x h (Eq. 2.35, 2.37): the body rate w_B may be plain while h carries derivatives.
template <class S, class RateVector>
DRONETWIN_HOT_INLINE Vector3<S> gyroscopic_moment(const Eigen::MatrixBase<RateVector>& w_B,
                                                  const Vector3<S>& rotor_momentum_B) {
  return -(w_B.template cast<S>().cross(rotor_momentum_B));
}

}  // namespace dronetwin
