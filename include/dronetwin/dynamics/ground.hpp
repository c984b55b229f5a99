#pragma once
// Contact with a flat ground at z = 0 (the thesis PID experiment starts on the ground; Gazebo's
// collision geometry is not described, notes #26).
//
// Model: the body origin cannot go below z = 0. After each step, a state below the ground is put
// back on it and its downward velocity removed (perfectly inelastic: no bouncing). While resting
// (in contact and not climbing) the landing gear holds the vehicle: horizontal and angular
// velocity are zeroed. A touchdown faster than `crash_speed_m_s`, or contact with a tilt beyond
// `crash_tilt_rad`, sets the crash flag, which stays set until reset.

#include <cmath>

#include "dronetwin/core/types.hpp"

namespace dronetwin {

struct GroundConfig {
  bool enabled = true;
  /// Vertical touchdown speed above which a landing counts as a crash, m/s.
  double crash_speed_m_s = 1.5;
  /// Tilt (angle between body z and world z) in contact above which it counts as a crash, rad.
  double crash_tilt_rad = 1.0;
};

struct ContactState {
  bool in_contact = false;
  bool crashed = false;
  int touchdowns = 0;
  /// Vertical speed at the most recent touchdown (positive, m/s); 0 before any touchdown.
  double last_touchdown_speed_m_s = 0.0;
  /// Largest touchdown speed seen since reset, m/s.
  double max_touchdown_speed_m_s = 0.0;
};

/// Tilt angle between body z and world z, rad, from the quaternion block of the state.
inline double tilt_angle_rad(const StateVector& x) {
  const double qx = x[state_index::kQuaternion + 1], qy = x[state_index::kQuaternion + 2];
  const double n2 = x.segment<4>(state_index::kQuaternion).squaredNorm();
  // R(2,2) = 1 - 2 (qx^2 + qy^2) for a unit quaternion.
  const double c = 1.0 - 2.0 * (qx * qx + qy * qy) / n2;
  return std::acos(c > 1.0 ? 1.0 : (c < -1.0 ? -1.0 : c));
}

/// Applies the contact rule to a freshly integrated state. Returns true when the state changed.
inline bool resolve_ground_contact(const GroundConfig& cfg, StateVector& x, ContactState& c) {
  using namespace state_index;
  if (!cfg.enabled) return false;
  const double z = x[kPosition + 2], vz = x[kVelocity + 2];
  const bool touching = z < 0.0 || (z == 0.0 && vz <= 0.0);
  if (!touching) {
    c.in_contact = false;
    return false;
  }
  if (!c.in_contact) {
    const double speed = vz < 0.0 ? -vz : 0.0;
    ++c.touchdowns;
    c.last_touchdown_speed_m_s = speed;
    if (speed > c.max_touchdown_speed_m_s) c.max_touchdown_speed_m_s = speed;
    if (speed > cfg.crash_speed_m_s) c.crashed = true;
  }
  c.in_contact = true;
  if (tilt_angle_rad(x) > cfg.crash_tilt_rad) c.crashed = true;
  x[kPosition + 2] = 0.0;
  if (vz < 0.0) x[kVelocity + 2] = 0.0;
  if (x[kVelocity + 2] <= 0.0) {
    // Resting on the landing gear: friction holds it in place.
    x.segment<2>(kVelocity).setZero();
    x.segment<3>(kAngularVelocity).setZero();
  }
  return true;
}

}  // namespace dronetwin
