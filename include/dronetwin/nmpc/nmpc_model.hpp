#pragma once
// The NMPC prediction model: the simplified rigid body of thesis Eq. 3.23, its RK4 discretisation,
// and the map from the optimiser's bounded parameters to the model input. Templated on the scalar
// so the same code runs with double (prediction) and ceres::Jet (the NMPC's Jacobians, and the
// central-difference test in tests/control/nmpc_test.cpp).
//
// State x (13, the simulator's layout, Eq. 2.20): [p_W, v_W, q_WB (w, x, y, z), w_B]. The
// attitude and rotational equations are the simulator's own (math::derivative, rigid_body.hpp's
// angular_acceleration); only the force model is Eq. 3.23's, not the full one of Sec. 2.3.
// Input u (6): [F_W (3), M_B (3)] = Eq. 3.23's [u1 u2 u3 u4 u5 u6]:
//   p_dot = v
//   v_dot = T / m (+ d),   T = R [0, 0, (R e3) . F]^T - m g e3 = ((R e3) . F) R e3 - m g e3
//   q_dot = 1/2 q (x) [0, w]                                   (Eq. 2.13, math::derivative)
//   w_dot = J^-1 (M - w x J w)
// d is an optional constant disturbance acceleration (NmpcModel::disturbance_m_s2, default 0).
// F is a desired world-frame force (gravity included): the thrust is its projection on the body
// z axis, applied along that axis — exactly the collective thrust f = F . R e3 of the SE(3)
// controller (Eq. 3.27), whose attitude law then turns R e3 toward F. docs/controllers.md
// ("NMPC") says why this is our reading of Eq. 3.23.
//
//   NmpcModel<double> m{mass, g, J, J_inv};
//   Eigen::Matrix<double, 13, 1> x_next;
//   nmpc_rk4_step(m, x.data(), u.data(), 0.01, x_next.data());
//
// Optimiser parameters z (6) = [f_z, t_x, t_y, M (3)] give F = f_z [t_x, t_y, 1]: box bounds on
// f_z and t_x, t_y then bound the thrust |F| = f_z sqrt(1 + t_x^2 + t_y^2) and the tilt
// atan(sqrt(t_x^2 + t_y^2)) of F, which Ceres (box bounds only) cannot state directly.
//
// Trap: the quaternion is not renormalised inside the prediction (that would make the map
// non-smooth for no gain over 1 s); the caller passes a unit quaternion in the hemisphere of the
// reference attitude.

#include <Eigen/Core>

#include "dronetwin/core/types.hpp"
#include "dronetwin/dynamics/rigid_body.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

inline constexpr int kNmpcStateSize = 13;
inline constexpr int kNmpcInputSize = 6;

/// Constants of Eq. 3.23 (plain doubles; only the state and input are differentiated).
struct NmpcModel {
  double mass_kg = 1.504;
  double gravity_m_s2 = 9.81;
  Mat3 inertia_kgm2 = Mat3::Identity();
  Mat3 inertia_inverse = Mat3::Identity();
  /// Constant world-frame acceleration added to v_dot (an estimate of what Eq. 3.23 leaves out:
  /// drag, ground effect). Zero = Eq. 3.23 as printed.
  Vec3 disturbance_m_s2 = Vec3::Zero();
};

/// x_dot = f(x, u), Eq. 3.23. x, u, x_dot point at 13, 6, 13 scalars.
template <class T>
void nmpc_derivative(const NmpcModel& m, const T* x, const T* u, T* x_dot) {
  const Eigen::Map<const Vector4<T>> q(x + 6);
  const Eigen::Map<const Vector3<T>> w(x + 10);
  const Eigen::Map<const Vector3<T>> F(u);
  const Eigen::Map<const Vector3<T>> M(u + 3);
  // b3 = R(q) e3, the third column of math::rotation_matrix written out: only this column is
  // needed, and under autodiff every product counts.
  const T two_x = x[7] + x[7], two_y = x[8] + x[8];
  const Vector3<T> b3(two_x * x[9] + two_y * x[6], two_y * x[9] - two_x * x[6],
                      T(1.0) - two_x * x[7] - two_y * x[8]);
  // T = R [0, 0, (R e3) . F] - m g e3: the part of F along the body z axis.
  const T f = b3.dot(F);
  const T f_over_m = f * (1.0 / m.mass_kg);
  for (int i = 0; i < 3; ++i) {
    x_dot[i] = x[3 + i];
    x_dot[3 + i] = f_over_m * b3[i];
  }
  x_dot[5] -= m.gravity_m_s2;
  for (int i = 0; i < 3; ++i) x_dot[3 + i] += m.disturbance_m_s2[i];
  const Vector4<T> q_dot = math::derivative<T>(q, w);
  for (int i = 0; i < 4; ++i) x_dot[6 + i] = q_dot[i];
  // The rigid body's rotational equation, shared with the simulator (Eq. 2.39 / 2.42). J and
  // J^-1 stay double: a Jet times a double is cheap, a Jet times a Jet made from a double is not.
  const Vector3<T> w_dot =
      angular_acceleration(m.inertia_kgm2, m.inertia_inverse, Vector3<T>(w), Vector3<T>(M));
  for (int i = 0; i < 3; ++i) x_dot[10 + i] = w_dot[i];
}

/// One classical RK4 step of Eq. 3.23 with u held (zero-order hold over dt_s).
template <class T>
void nmpc_rk4_step(const NmpcModel& m, const T* x, const T* u, double dt_s, T* x_next) {
  T k1[kNmpcStateSize], k2[kNmpcStateSize], k3[kNmpcStateSize], k4[kNmpcStateSize];
  T tmp[kNmpcStateSize];
  const double h = dt_s, h2 = 0.5 * dt_s;
  nmpc_derivative<T>(m, x, u, k1);
  for (int i = 0; i < kNmpcStateSize; ++i) tmp[i] = x[i] + h2 * k1[i];
  nmpc_derivative<T>(m, tmp, u, k2);
  for (int i = 0; i < kNmpcStateSize; ++i) tmp[i] = x[i] + h2 * k2[i];
  nmpc_derivative<T>(m, tmp, u, k3);
  for (int i = 0; i < kNmpcStateSize; ++i) tmp[i] = x[i] + h * k3[i];
  nmpc_derivative<T>(m, tmp, u, k4);
  const double sixth = dt_s / 6.0;
  for (int i = 0; i < kNmpcStateSize; ++i)
    x_next[i] = x[i] + sixth * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
}

/// Input u = [F, M] from optimiser parameters z = [f_z, t_x, t_y, M]: F = f_z [t_x, t_y, 1].
template <class T>
void nmpc_input_from_parameters(const T* z, T* u) {
  u[0] = z[0] * z[1];
  u[1] = z[0] * z[2];
  u[2] = z[0];
  u[3] = z[3];
  u[4] = z[4];
  u[5] = z[5];
}

}  // namespace dronetwin
