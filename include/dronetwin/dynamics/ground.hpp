#pragma once
// Contact with a flat ground at z = 0 (the thesis PID experiment starts on the ground; Gazebo's
// collision geometry is not described, notes #26).
//
// Model: the body origin cannot go below z = 0. After each step, a state below the ground is put
// back on it and its downward velocity removed (perfectly inelastic: no bouncing). While resting
// on it (in contact and not climbing) the landing gear touches the ground with Coulomb friction:
//
//   the step's horizontal acceleration a_h and the normal specific force n (the downward
//   acceleration the ground cancels) come from the free step x_prev -> x_next;
//   |a_h| <= mu n   static friction holds: position, attitude and rates stay as they were
//                   (the vehicle does not creep), velocity zero;
//   |a_h| >  mu n   it slides: kinetic friction mu n opposes the motion (or the push, from rest),
//                   the horizontal velocity is what remains, the position advances by the
//                   trapezoid of the old and new velocities (so the logged velocity says how it
//                   moved), attitude held upright by the gear, rates zero.
//   tilt > crash_tilt_rad   lying on its side or back (a wreck): the gear does not carry it and
//                   the friction model above does not apply; it is held where it lies. A wreck
//                   pushed sideways by its own rotors would otherwise skid off at tens of m/s
//                   (thrust against the weight alone), which is no better a model of arms and
//                   propellers digging into the floor than holding it.
//
// A touchdown faster than `crash_speed_m_s`, or contact with a tilt beyond `crash_tilt_rad`, sets
// the crash flag, which stays set until reset. Tipping over on the gear is not modelled.
//
//   ContactState c;
//   resolve_ground_contact(config, x_prev, dt_s, x_next, c);   // after integrating x_prev
//
// Trap: the friction is applied after the step from the step's own accelerations (an explicit,
// first-order treatment): exact for holding still, first order in dt for sliding.

#include <cmath>

#include "dronetwin/core/types.hpp"

namespace dronetwin {

struct GroundConfig {
  bool enabled = true;
  /// Vertical touchdown speed above which a landing counts as a crash, m/s.
  double crash_speed_m_s = 1.5;
  /// Tilt (angle between body z and world z) in contact above which it counts as a crash, rad.
  double crash_tilt_rad = 1.0;
  /// Coulomb friction coefficient of the landing gear on the ground (static = kinetic): 0.6,
  /// plastic or rubber feet on a hard floor (engineering tables give 0.5-0.8).
  double friction_coefficient = 0.6;
};

struct ContactState {
  bool in_contact = false;
  bool crashed = false;
  int touchdowns = 0;
  /// Vertical speed at the most recent touchdown (positive, m/s); 0 before any touchdown.
  double last_touchdown_speed_m_s = 0.0;
  /// Largest touchdown speed seen since reset, m/s.
  double max_touchdown_speed_m_s = 0.0;
  /// True while resting contact slides (friction could not hold the vehicle).
  bool sliding = false;
};

/// Tilt angle between body z and world z, rad, from the quaternion block of the state.
inline double tilt_angle_rad(const StateVector& x) {
  const double qx = x[state_index::kQuaternion + 1], qy = x[state_index::kQuaternion + 2];
  const double n2 = x.segment<4>(state_index::kQuaternion).squaredNorm();
  // R(2,2) = 1 - 2 (qx^2 + qy^2) for a unit quaternion.
  const double c = 1.0 - 2.0 * (qx * qx + qy * qy) / n2;
  return std::acos(c > 1.0 ? 1.0 : (c < -1.0 ? -1.0 : c));
}

namespace detail {
/// The contact rule once the vehicle touches the ground (see resolve_ground_contact). Kept out of
/// line: in flight the step pays only the height test, and this body does not weigh on the
/// compiler's inlining of the step's hot arithmetic.
[[gnu::noinline]] inline bool resolve_touching(const GroundConfig& cfg, const StateVector& x_prev,
                                               double dt_s, StateVector& x, ContactState& c) {
  using namespace state_index;
  const double vz = x[kVelocity + 2];
  const bool was_resting = c.in_contact;
  if (!c.in_contact) {
    const double speed = vz < 0.0 ? -vz : 0.0;
    ++c.touchdowns;
    c.last_touchdown_speed_m_s = speed;
    if (speed > c.max_touchdown_speed_m_s) c.max_touchdown_speed_m_s = speed;
    if (speed > cfg.crash_speed_m_s) c.crashed = true;
  }
  c.in_contact = true;
  x[kPosition + 2] = 0.0;
  if (vz < 0.0) x[kVelocity + 2] = 0.0;
  if (x[kVelocity + 2] > 0.0) {  // lifting off: the ground only stops the fall
    c.sliding = false;
    if (tilt_angle_rad(x) > cfg.crash_tilt_rad) c.crashed = true;
    return true;
  }
  // Resting on the landing gear. The free step's accelerations: horizontal push and the
  // downward acceleration the ground takes up (the normal force per unit mass).
  const Eigen::Vector2d v0 = x_prev.segment<2>(kVelocity);
  const Eigen::Vector2d a_h = (x.segment<2>(kVelocity) - v0) / dt_s;
  const double normal = std::max(0.0, -(vz - x_prev[kVelocity + 2]) / dt_s);
  const double friction = cfg.friction_coefficient * normal;
  const double v0_norm = v0.norm();
  const bool wreck = tilt_angle_rad(x) > cfg.crash_tilt_rad;
  if (wreck || (v0_norm == 0.0 && a_h.norm() <= friction)) {
    // Held: nothing moves (a touchdown step keeps the attitude it landed with).
    x.segment<2>(kPosition) = x_prev.segment<2>(kPosition);
    if (was_resting) x.segment<4>(kQuaternion) = x_prev.segment<4>(kQuaternion);
    x.segment<2>(kVelocity).setZero();
    x.segment<3>(kAngularVelocity).setZero();
    c.sliding = false;
    if (tilt_angle_rad(x) > cfg.crash_tilt_rad) c.crashed = true;
    return true;
  }
  // Sliding: kinetic friction against the motion (against the push when starting from rest),
  // never reversing it within the step.
  const Eigen::Vector2d dir =
      v0_norm > 0.0 ? Eigen::Vector2d(v0 / v0_norm) : Eigen::Vector2d(a_h / a_h.norm());
  Eigen::Vector2d v1 = v0 + (a_h - friction * dir) * dt_s;
  if (v0_norm > 0.0 && v1.dot(dir) <= 0.0) v1.setZero();  // friction stopped it in this step
  x.segment<2>(kPosition) = x_prev.segment<2>(kPosition) + 0.5 * (v0 + v1) * dt_s;
  x.segment<2>(kVelocity) = v1;
  if (was_resting) x.segment<4>(kQuaternion) = x_prev.segment<4>(kQuaternion);
  x.segment<3>(kAngularVelocity).setZero();
  c.sliding = v1.squaredNorm() > 0.0;
  if (tilt_angle_rad(x) > cfg.crash_tilt_rad) c.crashed = true;
  return true;
}
}  // namespace detail

/// Applies the contact rule to `x`, freshly integrated over `dt_s` from `x_prev`. Returns true
/// when the state changed.
inline bool resolve_ground_contact(const GroundConfig& cfg, const StateVector& x_prev, double dt_s,
                                   StateVector& x, ContactState& c) {
  using namespace state_index;
  if (!cfg.enabled) return false;
  const double z = x[kPosition + 2], vz = x[kVelocity + 2];
  const bool touching = z < 0.0 || (z == 0.0 && vz <= 0.0);
  if (!touching) {
    c.in_contact = false;
    c.sliding = false;
    return false;
  }
  return detail::resolve_touching(cfg, x_prev, dt_s, x, c);
}

}  // namespace dronetwin
