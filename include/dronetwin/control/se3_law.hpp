#pragma once
// The SE(3) law of Se3Controller (thesis Eq. 3.26-3.29; control/se3.hpp says what each line means)
// written once for any lane scalar: double for Se3Controller, a pack of W vehicles for the batched
// controller (batch/batch_se3.hpp). Every sum is spelled out in a fixed order and every branch is
// a per-lane select, so each lane of a pack equals the double controller bit for bit.
//
//   const Se3LawConstants k = se3_law_constants(gains, options, model->inertia_kgm2());
//   Se3LawInput<double> in{p, v, q, w, p_ref, v_ref, a_ref, std::cos(yaw), std::sin(yaw)};
//   GeneralizedForceT<double> u = se3_law(k, in);       // [f, M_x, M_y, M_z]
//
// Trap: with a pack, the branches not taken are still computed (and may hold inf or NaN in the
// lanes that did not take them); only selected values reach the result.

#include <cmath>

#include "dronetwin/core/scalar.hpp"
#include "dronetwin/core/types.hpp"
#include "dronetwin/math/ordered_product.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

/// The law's constants (gains, mass, options), shared by every lane.
struct Se3LawConstants {
  Vec3 position_p = Vec3::Zero(), position_d = Vec3::Zero();
  Vec3 attitude_p = Vec3::Zero(), attitude_d = Vec3::Zero();
  double mass_kg = 1.0;
  double gravity_m_s2 = 9.81;
  bool gravity_compensation = false;
  /// Tilt cone: off when the limit is infinite; cos, sin, tan of its half-angle.
  bool limit_tilt = false;
  double cos_tilt = 0.0, sin_tilt = 1.0, tan_tilt = 0.0;
  bool nonnegative_thrust = false;
  double min_thrust_N = 0.0;  ///< 0: no floor
  Mat3 inertia_kgm2 = Mat3::Identity();
  /// Read Se3LawInput's desired body rates and angular accelerations (control/se3.hpp).
  bool angular_feed_forward = false;
  /// Add Se3LawInput's drag compensation to the desired force (control/se3.hpp).
  bool drag_feed_forward = false;
};

/// What the reference asks for beyond position, velocity and acceleration (control/se3.hpp):
/// the body rates and angular accelerations of its flat attitude (planning/flatness.hpp), in the
/// desired body frame, and the force that cancels the model's drag along it, world frame.
template <class S>
struct Se3FeedForward {
  Vector3<S> angular_velocity_B, angular_acceleration_B;
  Vector3<S> drag_compensation_W;
};

/// What the law reads for one vehicle (or one pack of vehicles).
template <class S>
struct Se3LawInput {
  Vector3<S> position_m, velocity_m_s;
  Vector4<S> quaternion;  ///< measured, not necessarily unit
  Vector3<S> angular_velocity_B;
  Vector3<S> position_ref_m, velocity_ref_m_s, acceleration_ref_m_s2;
  S cos_yaw, sin_yaw;  ///< of the yaw reference
  /// Read only with Se3LawConstants::angular_feed_forward or drag_feed_forward.
  Se3FeedForward<S> feed_forward;
};

namespace se3_law_detail {

template <class S>
S dot(const Vector3<S>& a, const Vector3<S>& b) {
  return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2];
}

template <class M, class S>
Vector3<S> select(const M& mask, const Vector3<S>& a, const Vector3<S>& b) {
  return Vector3<S>(scalar::select(mask, a[0], b[0]), scalar::select(mask, a[1], b[1]),
                    scalar::select(mask, a[2], b[2]));
}

/// v / |v| where |v| > tiny, else `otherwise`.
template <class S>
Vector3<S> unit_or(const Vector3<S>& v, const S& tiny, const Vector3<S>& otherwise) {
  const S n = scalar::sqrt(dot(v, v));
  return select(n > tiny, Vector3<S>(v[0] / n, v[1] / n, v[2] / n), otherwise);
}

}  // namespace se3_law_detail

/// The attitude half (Eq. 3.27-3.28 with w_des = 0): R_des = [b2d x b3d, b2d, b3d] from the unit
/// thrust direction b3d and b1d = [cos yaw, sin yaw, 0] (when b3d is parallel to b1d, b2d falls
/// back on b3d x R e1, then b3d x e3), e_R = 1/2 vee(R_des^T R - R^T R_des) and
/// M = -K_R e_R - K_w w_B + w_B x J w_B.
/// With `feed_forward` (w_d, w_d' in the desired frame), the full law of Lee, Leok and
/// McClamroch (CDC 2010, Eq. 11 and 16): e_w = w_B - R^T R_des w_d and
/// M = -K_R e_R - K_w e_w + w_B x J w_B - J (w_B x R^T R_des w_d - R^T R_des w_d').
template <class S>
Vector3<S> se3_attitude_law(const Matrix3<S>& R, const Vector3<S>& w_B, const Vector3<S>& b3d,
                            const S& cos_yaw, const S& sin_yaw, const Vec3& attitude_p,
                            const Vec3& attitude_d, const Mat3& J,
                            const Se3FeedForward<S>* feed_forward = nullptr) {
  using namespace se3_law_detail;
  const auto c = [](double v) { return scalar::from_value<S>(v); };
  const S zero(0), one = c(1.0), small = c(1e-6);
  const Vector3<S> e2(zero, one, zero), e3(zero, zero, one);
  const Vector3<S> b1d(cos_yaw, sin_yaw, zero);
  const Vector3<S> Re1(R(0, 0), R(1, 0), R(2, 0));
  // First usable of b3d x b1d, b3d x R e1, b3d x e3 (else e2).
  const Vector3<S> third = unit_or(Vector3<S>(b3d.cross(e3)), zero, e2);
  const Vector3<S> second = unit_or(Vector3<S>(b3d.cross(Re1)), small, third);
  const Vector3<S> b2d = unit_or(Vector3<S>(b3d.cross(b1d)), small, second);
  const Vector3<S> b1 = b2d.cross(b3d);
  // M1 = R_des^T R; e_R = 1/2 vee(M1 - M1^T) needs its off-diagonal entries only.
  const auto m = [&](const Vector3<S>& des, int j) {
    return (des[0] * R(0, j) + des[1] * R(1, j)) + des[2] * R(2, j);
  };
  const S half = c(0.5);
  const Vector3<S> e_R(half * (m(b3d, 1) - m(b2d, 2)), half * (m(b1, 2) - m(b3d, 0)),
                       half * (m(b2d, 0) - m(b1, 1)));
  using V = scalar::value_type_t<S>;
  const Vector3<S> gyro = w_B.cross(math::ordered_product(J.cast<V>(), w_B));
  Vector3<S> e_w = w_B;
  Vector3<S> rel_w, rel_dw;  // R^T R_des w_d and R^T R_des w_d'
  if (feed_forward != nullptr) {
    const auto to_body = [&](const Vector3<S>& v_des) {
      Vector3<S> world, body;
      for (int k = 0; k < 3; ++k)
        world[k] = (b1[k] * v_des[0] + b2d[k] * v_des[1]) + b3d[k] * v_des[2];
      for (int i = 0; i < 3; ++i)
        body[i] = (R(0, i) * world[0] + R(1, i) * world[1]) + R(2, i) * world[2];
      return body;
    };
    rel_w = to_body(feed_forward->angular_velocity_B);
    rel_dw = to_body(feed_forward->angular_acceleration_B);
    for (int i = 0; i < 3; ++i) e_w[i] = w_B[i] - rel_w[i];
  }
  Vector3<S> M;
  for (int i = 0; i < 3; ++i)
    M[i] = (-c(attitude_p[i]) * e_R[i] - c(attitude_d[i]) * e_w[i]) + gyro[i];
  if (feed_forward != nullptr) {
    const Vector3<S> w_x_rel = w_B.cross(rel_w);
    Vector3<S> d;
    for (int i = 0; i < 3; ++i) d[i] = rel_dw[i] - w_x_rel[i];
    const Vector3<S> Jd = math::ordered_product(J.cast<V>(), d);
    for (int i = 0; i < 3; ++i) M[i] = M[i] + Jd[i];
  }
  return M;
}

/// The whole law: [f, M] for one vehicle or one pack (Eq. 3.26-3.29 with the options of
/// Se3LawConstants; control/se3.hpp).
template <class S>
Vector4<S> se3_law(const Se3LawConstants& k, const Se3LawInput<S>& in) {
  using namespace se3_law_detail;
  const auto c = [](double v) { return scalar::from_value<S>(v); };
  const S zero(0), one = c(1.0);
  const Vector3<S> e3(zero, zero, one);
  // Measured attitude, normalised (notes #30); a zero quaternion is read as level.
  const Vector4<S>& q = in.quaternion;
  const S qn = scalar::sqrt(((q[0] * q[0] + q[1] * q[1]) + q[2] * q[2]) + q[3] * q[3]);
  const auto q_ok = qn > c(1e-12);
  Vector4<S> qu;
  for (int i = 0; i < 4; ++i) qu[i] = scalar::select(q_ok, q[i] / qn, i == 0 ? one : zero);
  const Matrix3<S> R = math::rotation_matrix<S>(qu);

  // Desired force, Eq. 3.27-3.28 (+ m g e3, notes #35).
  const S m = c(k.mass_kg);
  Vector3<S> F;
  for (int i = 0; i < 3; ++i) {
    const S e_p = in.position_ref_m[i] - in.position_m[i];
    const S e_v = in.velocity_ref_m_s[i] - in.velocity_m_s[i];
    F[i] = (c(k.position_p[i]) * e_p + c(k.position_d[i]) * e_v) + m * in.acceleration_ref_m_s2[i];
  }
  if (k.gravity_compensation) F[2] = F[2] + c(k.mass_kg * k.gravity_m_s2);
  if (k.drag_feed_forward)
    for (int i = 0; i < 3; ++i) F[i] = F[i] + in.feed_forward.drag_compensation_W[i];

  // Desired thrust direction b3d; |F| below a micro-newton carries none: keep e3.
  const S tiny = c(1e-6 * k.mass_kg * k.gravity_m_s2);
  Vector3<S> b3d = unit_or(F, tiny, e3);
  if (k.limit_tilt) {
    // Cone of half-angle a around +z: inside it nothing changes; above the cone's edge the
    // horizontal part is shortened onto it (vertical part kept); level or downward F gives the
    // cone edge on F's horizontal side, with F projected on it.
    const S tan_a = c(k.tan_tilt);
    const Vector3<S> F_h(F[0], F[1], zero);
    const S h = scalar::sqrt(dot(F_h, F_h));
    const auto outside = F[2] > zero && h > F[2] * tan_a;
    const auto downward = !(F[2] > zero);
    const S shrink = F[2] * tan_a / h;
    const Vector3<S> F_cone(F[0] * shrink, F[1] * shrink, F[2]);
    const Vector3<S> dir_h = unit_or(F_h, tiny, Vector3<S>(zero, zero, zero));
    const auto has_dir = h > tiny;
    const S sin_a = c(k.sin_tilt), cos_a = c(k.cos_tilt);
    const Vector3<S> edge =
        select(has_dir, Vector3<S>(sin_a * dir_h[0], sin_a * dir_h[1], cos_a), e3);
    const S along = scalar::max(dot(F, edge), zero);
    const Vector3<S> F_edge(edge[0] * along, edge[1] * along, edge[2] * along);
    b3d = select(outside, unit_or(F_cone, tiny, e3), select(downward, edge, b3d));
    F = select(outside, F_cone, select(downward, F_edge, F));
  }

  // Collective thrust f = F . R e3 (Eq. 3.27).
  const Vector3<S> Re3(R(0, 2), R(1, 2), R(2, 2));
  S f = dot(F, Re3);
  if (k.nonnegative_thrust) f = scalar::max(f, zero);
  if (k.min_thrust_N > 0.0) f = scalar::max(f, c(k.min_thrust_N));
  const Vector3<S> M = se3_attitude_law(R, in.angular_velocity_B, b3d, in.cos_yaw, in.sin_yaw,
                                        k.attitude_p, k.attitude_d, k.inertia_kgm2,
                                        k.angular_feed_forward ? &in.feed_forward : nullptr);
  return Vector4<S>(f, M[0], M[1], M[2]);
}

}  // namespace dronetwin
