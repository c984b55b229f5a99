#pragma once
// Gyroscopic moment of the spinning rotors on a rotating body (thesis Eq. 2.35, with the minus
// sign of Eq. 2.37): M_G = -w_B x h_rotors, h_rotors = sum_i eps_i J_r,i w_i a_i.

#include "dronetwin/core/types.hpp"

namespace dronetwin {

template <class T>
Vector3<T> gyroscopic_moment(const Vector3<T>& w_B, const Vec3& rotor_momentum_B) {
  return -w_B.cross(rotor_momentum_B.cast<T>());
}

}  // namespace dronetwin
