#pragma once
// The cascaded PID law of CascadedPid (thesis Eq. 3.15-3.20; control/pid.hpp says what each line
// means and which options change it) written once for any lane scalar: double for CascadedPid, a
// pack of W vehicles for the batched controller (batch/batch_pid.hpp). Sums keep the order of the
// scalar expressions, branches are per-lane selects, and the library functions (atan2, asin,
// sin, cos, remainder) run lane by lane (lanewise, core/simd.hpp), so each lane of a pack equals
// the double controller bit for bit.
//
//   PidLawConstants k = pid_law_constants(gains, options, J);
//   Vector4<double> integral = Vector4<double>::Zero();          // the controller's memory
//   Vector4<double> u = cascaded_pid_law(k, in, dt_s, integral);  // [T, tau]; integral advanced

#include <cmath>
#include <numbers>

#include "dronetwin/core/scalar.hpp"
#include "dronetwin/core/simd.hpp"
#include "dronetwin/core/types.hpp"

namespace dronetwin {

/// The law's gains and options, shared by every lane (control/pid.hpp: PidGains, PidOptions).
struct PidLawConstants {
  Vec4 outer_p = Vec4::Zero(), outer_d = Vec4::Zero(), outer_i = Vec4::Zero();
  Vec3 inner_p = Vec3::Zero(), inner_d1 = Vec3::Zero(), inner_d2 = Vec3::Zero();
  double mass_kg = 1.0, gravity_m_s2 = 9.81;
  double max_tilt_rad = 0.0;
  Vec4 integral_limit = Vec4::Zero();
  bool conditional_integration = false;
  bool yaw_error_wrap = false;
  bool velocity_feedforward = false;
  bool yaw_frame_mapping = false;
  bool yaw_rate_loop = false;              ///< PidYawLoop::kRate
  bool acceleration_feed_forward = false;  ///< on with PidOptions::drag_feed_forward too
  bool angular_feed_forward = false;
  bool drag_feed_forward = false;  ///< read by pid_feed_forward, not by the law
  /// The controller model's inertia, for the torque of the angular feed-forward.
  Mat3 inertia_kgm2 = Mat3::Zero();
};

/// What the law reads for one vehicle (or one pack).
template <class S>
struct PidLawInput {
  Vector3<S> position_m, velocity_m_s;
  Vector4<S> quaternion;  ///< measured, not necessarily unit
  Vector3<S> angular_velocity_B;
  Vector3<S> angular_acceleration_B;  ///< from the measured state derivative
  Vector3<S> position_ref_m, velocity_ref_m_s;
  S yaw_ref_rad, yaw_rate_ref_rad_s;
  /// Read only with PidLawConstants::acceleration_feed_forward.
  Vector3<S> acceleration_ref_m_s2;
  /// The reference's flat body rates and angular accelerations (planning/flatness.hpp); read
  /// only with PidLawConstants::angular_feed_forward.
  Vector3<S> angular_velocity_ref_B, angular_acceleration_ref_B;
};

/// u = [T, tau] of Eq. 3.15-3.20 at one control update of period dt_s; `integral` (per axis
/// [x, y, z, psi]) is the controller's memory and is advanced.
template <class S>
Vector4<S> cascaded_pid_law(const PidLawConstants& k, const PidLawInput<S>& in, double dt_s,
                            Vector4<S>& integral) {
  using V = scalar::value_type_t<S>;
  const auto c = [](double v) { return scalar::from_value<S>(v); };
  const S zero = c(0.0), one = c(1.0), two = c(2.0);

  // Attitude from the measured quaternion, normalised (notes #30); a zero one is read as level.
  const Vector4<S>& q = in.quaternion;
  const S qn = scalar::sqrt(((q[0] * q[0] + q[1] * q[1]) + q[2] * q[2]) + q[3] * q[3]);
  const auto q_ok = qn > c(1e-12);
  const S w = scalar::select(q_ok, q[0] / qn, one), x = scalar::select(q_ok, q[1] / qn, zero);
  const S y = scalar::select(q_ok, q[2] / qn, zero), z = scalar::select(q_ok, q[3] / qn, zero);
  // ZYX Euler angles through atan2 (math::to_euler, Eq. 3.16, notes #23).
  const auto atan2 = [](V a, V b) { return std::atan2(a, b); };
  const S phi = lanewise(atan2, S(two * (w * x + y * z)), S(one - two * (x * x + y * y)));
  const S s_pitch = scalar::clamp(S(two * (w * y - z * x)), S(-one), one);
  const S theta = lanewise([](V a) { return std::asin(a); }, s_pitch);
  const S psi = lanewise(atan2, S(two * (w * z + x * y)), S(one - two * (y * y + z * z)));
  const Vector3<S>& w_B = in.angular_velocity_B;

  // psi_dot from the body rates (last row of Eq. 2.8), cos(theta) floored at 1e-6 in magnitude.
  const auto sin_l = [](V a) { return std::sin(a); };
  const auto cos_l = [](V a) { return std::cos(a); };
  S cos_theta = lanewise(cos_l, theta);
  cos_theta =
      scalar::select(scalar::abs(cos_theta) < c(1e-6),
                     lanewise([](V a) { return std::copysign(V(1e-6), a); }, cos_theta), cos_theta);
  const S psi_dot = (lanewise(sin_l, phi) * w_B[1] + lanewise(cos_l, phi) * w_B[2]) / cos_theta;

  // Outer loop, Eq. 3.15.
  Vector4<S> e_p, e_v;
  for (int i = 0; i < 3; ++i) e_p[i] = in.position_ref_m[i] - in.position_m[i];
  e_p[3] = in.yaw_ref_rad - psi;
  if (k.yaw_error_wrap)
    e_p[3] = lanewise([](V a) { return std::remainder(a, V(2) * std::numbers::pi_v<V>); }, e_p[3]);
  for (int i = 0; i < 3; ++i) e_v[i] = -in.velocity_m_s[i];
  e_v[3] = -psi_dot;
  if (k.velocity_feedforward) {
    for (int i = 0; i < 3; ++i) e_v[i] = e_v[i] + in.velocity_ref_m_s[i];
    e_v[3] = e_v[3] + in.yaw_rate_ref_rad_s;
  }

  // Integral including the current sample (notes #33), clamped per axis.
  const Vector4<S> previous = integral;
  const S dt = c(dt_s);
  for (int i = 0; i < 4; ++i)
    integral[i] = scalar::min(scalar::max(S(integral[i] + e_p[i] * dt), S(-c(k.integral_limit[i]))),
                              c(k.integral_limit[i]));
  // Acceleration feed-forward: the tilt the reference's horizontal acceleration needs in the
  // small-angle mapping of Eq. 3.18 (a_x = g theta, a_y = -g phi at hover), and the thrust of its
  // vertical one.
  Vector4<S> u_ff = Vector4<S>::Constant(zero);
  if (k.acceleration_feed_forward) {
    const S inv_g = c(1.0 / k.gravity_m_s2);
    u_ff[0] = in.acceleration_ref_m_s2[0] * inv_g;
    u_ff[1] = in.acceleration_ref_m_s2[1] * inv_g;
    u_ff[2] = c(k.mass_kg) * in.acceleration_ref_m_s2[2];
  }
  const auto outer = [&](const Vector4<S>& I) {
    Vector4<S> u;
    for (int i = 0; i < 4; ++i)
      u[i] = (c(k.outer_p[i]) * e_p[i] + c(k.outer_d[i]) * e_v[i]) + c(k.outer_i[i]) * I[i];
    if (k.acceleration_feed_forward)
      for (int i = 0; i < 3; ++i) u[i] = u[i] + u_ff[i];
    return u;
  };
  Vector4<S> u_outer = outer(integral);

  // Mapping, Eq. 3.18: [phi_des, theta_des] = [-u_y, u_x], optionally in the yaw-aligned frame.
  const S cos_psi = k.yaw_frame_mapping ? lanewise(cos_l, psi) : one;
  const S sin_psi = k.yaw_frame_mapping ? lanewise(sin_l, psi) : zero;
  const auto tilt_of = [&](const Vector4<S>& u, S& phi_des, S& theta_des) {
    S ux = u[0], uy = u[1];
    if (k.yaw_frame_mapping) {
      const S bx = cos_psi * ux + sin_psi * uy, by = -sin_psi * ux + cos_psi * uy;
      ux = bx;
      uy = by;
    }
    phi_des = -uy;
    theta_des = ux;
  };
  S phi_des, theta_des;
  tilt_of(u_outer, phi_des, theta_des);
  const S limit = c(k.max_tilt_rad);
  if (k.conditional_integration) {
    // Undo this sample's integration on a horizontal axis whose error pushes its command further
    // into the tilt limit, then recompute the command (the lanes where that happened).
    const auto clipped = scalar::abs(phi_des) > limit || scalar::abs(theta_des) > limit;
    auto changed = clipped && !clipped;  // all false, of the mask type
    for (int i = 0; i < 2; ++i) {
      const auto undo = clipped && e_p[i] * u_outer[i] > zero && integral[i] != previous[i];
      integral[i] = scalar::select(undo, previous[i], integral[i]);
      changed = changed || undo;
    }
    const Vector4<S> again = outer(integral);
    S phi_again, theta_again;
    tilt_of(again, phi_again, theta_again);
    for (int i = 0; i < 4; ++i) u_outer[i] = scalar::select(changed, again[i], u_outer[i]);
    phi_des = scalar::select(changed, phi_again, phi_des);
    theta_des = scalar::select(changed, theta_again, theta_des);
  }
  phi_des = scalar::min(scalar::max(phi_des, S(-limit)), limit);
  theta_des = scalar::min(scalar::max(theta_des, S(-limit)), limit);
  const S thrust = u_outer[2] + c(k.mass_kg * k.gravity_m_s2);
  const S psi_des = u_outer[3];

  // Inner loop, Eq. 3.19-3.20 (yaw: psi_des - 0 as printed, or a rate loop psi_des - w_z).
  Vector3<S> e_att(phi_des - phi, theta_des - theta,
                   k.yaw_rate_loop ? S(psi_des - w_B[2]) : psi_des);
  Vector4<S> u;
  u[0] = thrust;
  if (!k.angular_feed_forward) {
    for (int i = 0; i < 3; ++i)
      u[1 + i] = (c(k.inner_p[i]) * e_att[i] - c(k.inner_d1[i]) * w_B[i]) -
                 c(k.inner_d2[i]) * in.angular_acceleration_B[i];
    return u;
  }
  // Angular feed-forward: the damping acts on the rate errors to the reference's flat body rates
  // and angular accelerations, and the torque J w_dot_ref + w_ref x J w_ref they need is added.
  const Vector3<S>& w_ref = in.angular_velocity_ref_B;
  const Vector3<S>& dw_ref = in.angular_acceleration_ref_B;
  Vector3<S> Jw, Jdw;
  for (int i = 0; i < 3; ++i) {
    Jw[i] = (c(k.inertia_kgm2(i, 0)) * w_ref[0] + c(k.inertia_kgm2(i, 1)) * w_ref[1]) +
            c(k.inertia_kgm2(i, 2)) * w_ref[2];
    Jdw[i] = (c(k.inertia_kgm2(i, 0)) * dw_ref[0] + c(k.inertia_kgm2(i, 1)) * dw_ref[1]) +
             c(k.inertia_kgm2(i, 2)) * dw_ref[2];
  }
  const Vector3<S> gyro(w_ref[1] * Jw[2] - w_ref[2] * Jw[1], w_ref[2] * Jw[0] - w_ref[0] * Jw[2],
                        w_ref[0] * Jw[1] - w_ref[1] * Jw[0]);
  for (int i = 0; i < 3; ++i)
    u[1 + i] = ((c(k.inner_p[i]) * e_att[i] - c(k.inner_d1[i]) * (w_B[i] - w_ref[i])) -
                c(k.inner_d2[i]) * (in.angular_acceleration_B[i] - dw_ref[i])) +
               (Jdw[i] + gyro[i]);
  return u;
}

}  // namespace dronetwin
