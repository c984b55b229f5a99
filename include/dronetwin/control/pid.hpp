#pragma once
// CascadedPid: the thesis's cascaded PID tracking controller (Sec. 3.6.1.1, Eq. 3.15-3.20), with
// the modifications it needs to fly as switchable options (all off = the controller as printed).
//
// Outer loop (position and yaw, world frame, Eq. 3.15):
//   e_p = [x_ref - x, y_ref - y, z_ref - z, psi_ref - psi]
//   e_v = -[v_x, v_y, v_z, psi_dot]          (as printed; v_ref - v when velocity_feedforward)
//   I_k = I_{k-1} + e_p(t_k) dt               (the sum includes the current sample, notes #33)
//   u_outer = K_P e_p + K_D e_v + K_I I_k     (dt = controller period = 1 / f_control)
// Mapping (Eq. 3.18):
//   T = u_z + m g,  phi_des = -u_y,  theta_des = u_x,  psi_des = u_psi
// Inner loop (attitude, body rates, Eq. 3.19-3.20):
//   e_att = [phi_des - phi, theta_des - theta, psi_des - 0]     (yaw "error" as printed, notes #32)
//   tau = K_P,in e_att - K_D1 w_B - K_D2 w_dot_B,  u = [T, tau]
// Euler angles come from the normalised measured quaternion through atan2 (notes #23); psi_dot
// from the body rates through Eq. 2.8; w_dot_B is the measured state derivative.
//
// Feed-forward (not in the thesis; both off as printed), from the reference's derivatives:
//   acceleration_feed_forward: u_outer += [a_x / g, a_y / g, m a_z, 0]: the tilt the reference's
//     acceleration needs in the small-angle mapping of Eq. 3.18 (a_x = g theta, a_y = -g phi),
//     and its vertical thrust;
//   angular_feed_forward: with w_ref, w_dot_ref the body rates and angular accelerations of the
//     reference's flat attitude (planning/flatness.hpp, from its jerk, snap and yaw motion),
//     tau = K_P,in e_att - K_D1 (w_B - w_ref) - K_D2 (w_dot_B - w_dot_ref)
//           + J w_dot_ref + w_ref x J w_ref         (J: the controller model's inertia).
//   drag_feed_forward: the acceleration feed-forward (on with it) also cancels the model's frame
//     and rotor drag on the reference's flat state through the drag (control/feed_forward.hpp):
//     a_ff = a_ref - F_drag / m, and w_ref, w_dot_ref are that state's, as SE(3)'s;
//   Where the flat attitude is singular (free fall, thrust along the heading) w_ref = w_dot_ref
//   = 0 and F_drag = 0 for that step. docs/controllers.md, "Feed-forward", measures them.
//
// Sign check (z up, x forward, y left, R = Rz Ry Rx): R e3 = [cos phi sin theta, -sin phi,
// cos phi cos theta] at psi = 0, so a positive pitch tilts the thrust toward +x and a positive roll
// toward -y. Eq. 3.18's theta_des = +u_x and phi_des = -u_y are therefore right in our frames, as
// printed (tests/control/closed_loop_test.cpp checks that a +x error moves the vehicle to +x).
//
//   PidGains gains = PidGains::thesis_simulation();          // Eq. 3.21
//   PidOptions options;                                      // as printed
//   options.max_tilt_rad = 0.2;                              // notes #34
//   CascadedPid pid(model, gains, options, /*control_period_s=*/1e-3);
//   ClosedLoop loop(sim, pid, reference, 1000.0);
//
// Trap: the controller period is not passed by ClosedLoop; it is fixed at construction (or by
// set_control_period) and must match the control rate the loop runs at, or the integral term is
// scaled wrongly. load_controller() sets it from the rate it is given.

#include <limits>
#include <memory>
#include <string_view>

#include "dronetwin/control/controller_base.hpp"
#include "dronetwin/control/pid_law.hpp"
#include "dronetwin/control/reference.hpp"

namespace dronetwin {

/// Gains of the cascaded PID. Outer gains act on [x, y, z, psi], inner gains on [roll, pitch, yaw].
struct PidGains {
  Vec4 outer_p = Vec4::Zero();   ///< rad/m, rad/m, N/m, 1/s
  Vec4 outer_d = Vec4::Zero();   ///< rad s/m, rad s/m, N s/m, -
  Vec4 outer_i = Vec4::Zero();   ///< rad/(m s), rad/(m s), N/(m s), 1/s^2
  Vec3 inner_p = Vec3::Zero();   ///< N m/rad (yaw: N m s/rad as printed)
  Vec3 inner_d1 = Vec3::Zero();  ///< N m s/rad, on the body rates
  Vec3 inner_d2 = Vec3::Zero();  ///< N m s^2/rad, on the body angular acceleration
  double mass_kg = 1.504;        ///< gravity compensation m (Eq. 3.18)
  double gravity_m_s2 = 9.81;    ///< gravity compensation g (Eq. 3.18)

  /// Thesis Eq. 3.21 (simulation gains), m = 1.504 kg, g = 9.81 m/s^2.
  static PidGains thesis_simulation();
  /// Thesis Eq. 3.22 (hardware gains).
  static PidGains thesis_hardware();
};

/// How the inner loop treats yaw.
enum class PidYawLoop {
  /// As printed (Eq. 3.19, notes #32): the yaw "attitude error" is psi_des - 0, where psi_des is
  /// the outer loop's PID output on the yaw error.
  kThesis,
  /// The yaw angle error is handled in the outer loop only; its output is read as a yaw-rate
  /// command (the unit N m s/rad of K_P,in,psi in Eq. 3.21 suggests it) and the inner error is
  /// psi_des - w_z, a rate loop.
  kRate,
};

constexpr std::string_view yaw_loop_name(PidYawLoop m) {
  return m == PidYawLoop::kThesis ? "thesis" : "rate";
}

/// The modifications that make the printed controller fly. Default-constructed = as printed.
struct PidOptions {
  /// Limit on |phi_des| and |theta_des|, rad (notes #34). Infinity: no limit (as printed).
  double max_tilt_rad = std::numeric_limits<double>::infinity();
  /// Clamp of the integral state |S_i dt| per axis [x, y, z, psi], m s and rad s. Infinity: none.
  Vec4 integral_limit = Vec4::Constant(std::numeric_limits<double>::infinity());
  /// Anti-windup for x and y: an axis does not integrate while the tilt command is clipped by
  /// max_tilt_rad and its error has the sign of its command (it would only wind further up).
  bool conditional_integration = false;
  /// Wrap the yaw error psi_ref - psi into [-pi, pi] (as printed: plain difference).
  bool yaw_error_wrap = false;
  /// e_v = v_ref - v (and yaw_rate_ref - psi_dot) instead of -v as printed (Eq. 3.15). Our
  /// references carry their derivatives; the printed one (a pulse) has zero velocity anyway.
  bool velocity_feedforward = false;
  /// Rotate the horizontal outer commands into the yaw-aligned frame before the mapping of
  /// Eq. 3.18 (as printed: no rotation, which is only right at psi = 0).
  bool yaw_frame_mapping = false;
  PidYawLoop yaw_loop = PidYawLoop::kThesis;
  /// Tilt and thrust feed-forward of the reference's acceleration (see the top of this file).
  bool acceleration_feed_forward = false;
  /// Body-rate, angular-acceleration and torque feed-forward of the reference's flat attitude.
  bool angular_feed_forward = false;
  /// Cancel the model's drag at the reference velocity through the acceleration feed-forward.
  bool drag_feed_forward = false;
};

/// The constants of the law (control/pid_law.hpp) for these gains and options; J is the
/// controller model's inertia (read only with angular_feed_forward).
PidLawConstants pid_law_constants(const PidGains& gains, const PidOptions& options,
                                  const Mat3& inertia_kgm2);

/// The feed-forward inputs of the law for one reference point: the acceleration to feed forward
/// (the reference's, less the drag's F_drag / m with drag_feed_forward) and, with
/// angular_feed_forward, its flat body rates and angular accelerations. Zero where the options
/// are off; the flat terms are zero where the flat attitude is singular.
void pid_feed_forward(const ReferencePoint& reference, const PidLawConstants& k,
                      const VehicleModel& model, Vec3& acceleration_m_s2, Vec3& angular_velocity_B,
                      Vec3& angular_acceleration_B);

class CascadedPid final : public ControllerBase {
 public:
  /// Throws InvalidArgument for negative or non-finite gains, non-positive mass, gravity or
  /// period, a non-positive tilt or integral limit.
  CascadedPid(std::shared_ptr<const VehicleModel> model, const PidGains& gains,
              const PidOptions& options, double control_period_s,
              AllocationMethod allocation = AllocationMethod::kExact);

  std::string_view name() const override { return "cascaded_pid"; }
  std::unique_ptr<ControllerBase> clone() const override;
  /// Clears the integral.
  void reset() override;

  const PidGains& gains() const { return gains_; }
  const PidOptions& options() const { return options_; }
  double control_period_s() const { return dt_s_; }
  void set_control_period(double dt_s);
  /// Integral state sum_i e_p(t_i) dt per axis [x, y, z, psi] (after clamping).
  const Vec4& integral() const { return integral_; }
  const PidLawConstants& law() const { return law_; }

 protected:
  GeneralizedForce do_calculate_u(const ControlInput& in) override;

 private:
  PidGains gains_;
  PidOptions options_;
  PidLawConstants law_;
  double dt_s_;
  /// sum_i e_p(t_i) dt, accumulated one sample (times the current period) per call.
  Vec4 integral_ = Vec4::Zero();
};

}  // namespace dronetwin
