#pragma once
// Aerodynamic drag of the frame (thesis Eq. 2.32): F_A = -A v_air, applied at the centre of mass.
// A is a body-fixed matrix (it describes the airframe), so it acts on the body-frame air velocity;
// the thesis applies it in the world frame, which agrees at level attitude (docs/conventions.md).
//
//   Matrix6<double> B = body_drag_map(model.body_drag_Ns_per_m());
//   Vector6<double> wrench = B * air_and_rate;     // [v_air_B; w_B] -> [F_A; 0]

#include "dronetwin/dynamics/rotor.hpp"

namespace dronetwin {

/// The frame drag as a linear map of [v_air_B; w_B] to the wrench [F_B; M_B]: -A in the force
/// rows and air-velocity columns, zero elsewhere (no moment: it acts at the centre of mass).
template <class S>
Matrix6<S> body_drag_map(const Matrix3<S>& drag_Ns_per_m) {
  Matrix6<S> m = Matrix6<S>::Zero();
  m.template topLeftCorner<3, 3>() = -drag_Ns_per_m;
  return m;
}

}  // namespace dronetwin
