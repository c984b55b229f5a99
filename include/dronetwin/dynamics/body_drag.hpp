#pragma once
// Aerodynamic drag of the frame (thesis Eq. 2.32): F_A = -A v_air, applied at the centre of mass.
// A is a body-fixed matrix (it describes the airframe), so it acts on the body-frame air velocity;
// the thesis applies it in the world frame, which agrees at level attitude (docs/conventions.md).

#include "dronetwin/core/types.hpp"

namespace dronetwin {

template <class T>
Vector3<T> body_drag_force(const Mat3& drag_Ns_per_m, const Vector3<T>& v_air_B) {
  return -(drag_Ns_per_m.cast<T>() * v_air_B);
}

}  // namespace dronetwin
