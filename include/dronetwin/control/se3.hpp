#pragma once
// Se3Controller: geometric tracking control on SE(3) (thesis Sec. 3.6.3.1, Eq. 3.26-3.29, after
// Lee, Leok and McClamroch), with the modifications it needs to fly as switchable options
// (all off = the controller as printed).
//
// Position (world frame):
//   e_p = p_des - p,  e_v = v_des - v
//   F = K_p e_p + K_d e_v + m a_des [+ m g e3]      (m g e3 is missing in Eq. 3.27-3.28, notes #35;
//                                                    added when gravity_compensation is on)
//   f = F . R e3                                     (collective thrust, Eq. 3.27)
// Desired attitude (Eq. 3.28):
//   b3d = F / |F|,  b1d = [cos psi_ref, sin psi_ref, 0],  b2d = b3d x b1d / |b3d x b1d|
//   R_des = [b2d x b3d, b2d, b3d]
// Attitude (body frame, w_des = 0 and w_dot_des = 0 as in Eq. 3.28):
//   e_R = 1/2 vee(R_des^T R - R^T R_des),  e_w = w - R^T R_des w_des = w
//   M = -K_R e_R - K_w e_w + w x J w
// R comes from the normalised measured quaternion (notes #30); J is the vehicle model's inertia.
//
// Feed-forward (Se3Options::angular_feed_forward; not in the thesis, whose Eq. 3.28 sets
// w_des = w_dot_des = 0): w_des and w_dot_des are the body rates and angular accelerations of the
// reference's flat attitude (planning/flatness.hpp, from the reference's jerk, snap, yaw rate and
// yaw acceleration), and the attitude law becomes Lee et al.'s full one,
//   e_w = w - R^T R_des w_des,  M = -K_R e_R - K_w e_w + w x J w - J (w x R^T R_des w_des
//                                                                   - R^T R_des w_dot_des).
// Without it the attitude loop lags every turn of the reference: it damps the rates the
// trajectory needs. Where the flat attitude is singular (reference in free fall, thrust along the
// heading) the feed-forward is 0 for that step. docs/controllers.md, "Feed-forward", measures it.
//
// Drag feed-forward (Se3Options::drag_feed_forward; not in the thesis): F gains -F_drag, the
// frame and rotor drag (Eq. 2.32) of the controller's model on the reference's flat state flown
// through that drag, in still air (planning/flatness.hpp (5), control/feed_forward.hpp): its
// thrust and attitude balance the drag exactly, and with angular_feed_forward w_des and
// w_dot_des are that attitude's. The rates of the rotor drag's coefficient (the model with rotor
// drag is not flat) and the wind are not compensated.
//
//   Se3Options options;                          // as printed
//   options.gravity_compensation = true;         // notes #35
//   options.max_tilt_rad = 0.6;
//   Se3Controller se3(model, Se3Gains::thesis(), options);
//   const CircleReference circle;                // Eq. 3.28; must outlive the loop
//   ClosedLoop loop(sim, se3, circle, 1000.0);
//
// With Se3Options::payload_mass_kg it carries a slung payload's weight: the load's mass joins the
// vehicle's in the feedforward m a_des + m g e3. With shape_reference_for_payload it also shapes
// the horizontal reference so that its own moves leave the payload swinging far less
// (docs/payload.md).
//
// Trap: without gravity_compensation (as printed) the vehicle hovers where K_p e_p,z = m g, i.e.
// m g / K_p,z = 0.45 m below the reference. |F| -> 0 (for instance commanding free fall) leaves
// b3d undefined; the controller then keeps b3d = e3 instead of producing NaN.

#include <limits>
#include <memory>
#include <string_view>

#include "dronetwin/control/controller_base.hpp"
#include "dronetwin/control/input_shaper.hpp"
#include "dronetwin/control/se3_law.hpp"

namespace dronetwin {

struct Se3Gains {
  Vec3 position_p = Vec3::Zero();  ///< K_P,outer, N/m
  Vec3 position_d = Vec3::Zero();  ///< K_D,outer, N s/m
  Vec3 attitude_p = Vec3::Zero();  ///< K_R = K_P,inner, N m (per unit of e_R)
  Vec3 attitude_d = Vec3::Zero();  ///< K_w = K_D,inner, N m s/rad
  double mass_kg = 1.504;          ///< m in m a_des and m g e3
  double gravity_m_s2 = 9.81;      ///< g in m g e3

  /// Thesis Eq. 3.29, m = 1.504 kg.
  static Se3Gains thesis();
};

/// The modifications that make the printed controller fly. Default-constructed = as printed.
struct Se3Options {
  /// Add m g e3 to the desired force (notes #35). As printed: off.
  bool gravity_compensation = false;
  /// Largest angle between the desired thrust direction b3d and +z, rad. The horizontal part of
  /// F is shortened (its vertical part kept) to stay inside the cone. Infinity: no limit.
  double max_tilt_rad = std::numeric_limits<double>::infinity();
  /// Clamp the collective thrust f = F . R e3 at >= 0 (as printed it may go negative when the
  /// body points away from F; rotors cannot push).
  bool nonnegative_thrust = false;
  /// Floor of the collective thrust f, N (0: none; not in the thesis). A large descent request
  /// makes F point downwards and f about 0, which leaves the thrust-first allocation no room for
  /// moments: the attitude is then uncontrolled and the vehicle can tumble. A floor keeps
  /// authority (config/controllers/se3_racing.yaml, docs/controllers.md).
  double min_thrust_N = 0.0;
  /// Payload awareness (docs/payload.md; not in the thesis, whose SE(3) flies the payload with
  /// the gains of the flight without it). The mass of a slung payload, kg, added to the mass in
  /// m a_des and m g e3: the controller carries the load's weight instead of sagging under it.
  double payload_mass_kg = 0.0;
  /// Input shaping against the payload's swing (control/input_shaper.hpp): the horizontal
  /// reference is convolved with the ZV shapers of the swing modes of this controller's own
  /// position loop with a payload of payload_mass_kg on a tether of payload_tether_length_m
  /// (both > 0 then). Needs the reference ahead of time (set_reference_preview, which
  /// ClosedLoop calls); without it the reference is flown as given.
  bool shape_reference_for_payload = false;
  double payload_tether_length_m = 0.0;
  /// Body-rate and angular-acceleration feed-forward from the reference's jerk and snap (see
  /// above). As printed: off.
  bool angular_feed_forward = false;
  /// Drag force feed-forward at the reference velocity (see above). As printed: off.
  bool drag_feed_forward = false;
};

/// The constants of the law (control/se3_law.hpp) for these gains, options and inertia.
Se3LawConstants se3_law_constants(const Se3Gains& gains, const Se3Options& options, const Mat3& J);

/// The feed-forward of the SE(3) law `k` for reference `ref` and the controller's `model` (see
/// above): the body rates and angular accelerations of the reference's flat attitude (with
/// k.angular_feed_forward) and the drag compensation (with k.drag_feed_forward); zero where not
/// asked for or where the flat attitude is singular. Shared with the batched controller, which
/// computes it per lane when the reference is set.
Se3FeedForward<double> se3_feed_forward(const ReferencePoint& ref, const VehicleModel& model,
                                        const Se3LawConstants& k);

/// The attitude half of the SE(3) law (Eq. 3.27-3.28 with w_des = 0), shared with the NMPC's
/// inner loop: R_des = [b2d x b3d, b2d, b3d] from the desired thrust direction `b3d` (unit) and
/// b1d = [cos yaw, sin yaw, 0], e_R = 1/2 vee(R_des^T R - R^T R_des), and
/// M = -K_R e_R - K_w w_B + w_B x J w_B. When b3d is parallel to b1d, b2d falls back on
/// b3d x R e1, then b3d x e3.
Vec3 se3_attitude_moment(const Mat3& R, const Vec3& w_B, const Vec3& b3d, double yaw_rad,
                         const Vec3& attitude_p, const Vec3& attitude_d, const Mat3& J);

class Se3Controller final : public ControllerBase {
 public:
  /// Throws InvalidArgument for negative or non-finite gains, non-positive mass or gravity, or a
  /// tilt limit outside (0, pi/2) (infinity allowed: no limit).
  Se3Controller(std::shared_ptr<const VehicleModel> model, const Se3Gains& gains,
                const Se3Options& options, AllocationMethod allocation = AllocationMethod::kExact);

  std::string_view name() const override { return "se3_geometric"; }
  std::unique_ptr<ControllerBase> clone() const override;

  const Se3Gains& gains() const { return gains_; }
  const Se3Options& options() const { return options_; }
  const Se3LawConstants& law() const { return law_; }
  /// The shapers of the x and y references (one impulse of 1 when shaping is off).
  const std::array<InputShaper, 2>& shapers() const { return shapers_; }

  /// Keeps the reference (shared, immutable) for input shaping; ignored when shaping is off.
  void set_reference_preview(const Reference& reference) override;

 protected:
  GeneralizedForce do_calculate_u(const ControlInput& in) override;

 private:
  Se3Gains gains_;
  Se3Options options_;
  Se3LawConstants law_;
  std::array<InputShaper, 2> shapers_{};
  std::shared_ptr<const Reference> preview_;
};

}  // namespace dronetwin
