#pragma once
// Slung payload (docs/payload.md, thesis Sec. 3.6.3.2): a point mass m_L on a massless tether of
// length l tied to the vehicle's centre of mass (as in the thesis's Eq. 3.32, whose rotational
// dynamics carry no cable moment). The tether is a cable: it pulls, never pushes, and can go slack.
//
// We integrate the payload in Cartesian coordinates (position and velocity, world frame) next to
// the vehicle's state instead of the swing angles of Eq. 3.32-3.35: no singularity at 90 degrees
// of swing, and slack and ground contact are simple. With r = x_L - x_Q, q = r / |r|:
//   vehicle   m_Q a_Q = F_Q + T q            (F_Q: thrust, drag, gravity: the force kernel)
//   payload   m_L a_L = m_L g + D_L - T q    (D_L: the payload's own quadratic drag)
// and a taut cable keeps |r| = l, so r . (a_L - a_Q) = -|r_dot|^2, which gives the tension
//   T = mu (q . (a_L,free - a_Q,free) + |r_dot|^2 / |r|),   mu = m_Q m_L / (m_Q + m_L),
// clamped at 0 (a cable that would have to push goes slack). A payload resting on the ground is
// held there (a_L = 0), so T = m_Q (|r_dot|^2 / |r| - q . a_Q,free); it lifts off once the cable's
// upward pull exceeds its weight.
//
// The mode (taut or slack, resting or free) is decided at a step's start and held over it, like
// the rotor speeds. After the step, settle_cable() puts a taut cable back at length l (RK4 keeps
// it only to O(dt^5)), and a slack cable that the step stretched past l jerks taut: an inelastic
// impulse along q removes the masses' relative speed along the cable. Both keep the centre of mass
// and the total momentum (a resting payload's share goes to the ground). A free payload that
// reaches the ground stops there (sticky ground, no bounce).
//
// Swing angles as parametrised by Eq. 3.33: r / l = (sin g1 cos g2, sin g2, -cos g1 cos g2), z up.
// (Eq. 3.36's arctan(l1 / l3), arctan(l2 / l3) do not invert that parametrisation; docs/payload.md
// says why we invert Eq. 3.33 exactly instead.)

#include <algorithm>
#include <cmath>

#include "dronetwin/core/types.hpp"

namespace dronetwin {

struct SlungPayload {
  /// Payload mass, kg (thesis Sec. 3.6.3.2: 0.500 kg).
  double mass_kg = 0.5;
  /// Tether length, m (the thesis does not give it; 0.5 m is our choice, docs/payload.md).
  double tether_length_m = 0.5;
  /// Drag coefficient times frontal area of the payload, m^2 (0: no drag).
  double drag_area_m2 = 0.0;
  double air_density_kg_m3 = 1.225;
};

struct PayloadSettings {
  bool enabled = false;
  SlungPayload payload{};
  /// Swing angles of Eq. 3.33 the payload starts at (at rest relative to the vehicle), rad.
  double initial_swing1_rad = 0.0;
  double initial_swing2_rad = 0.0;
};

/// The payload now. Plain data.
struct PayloadState {
  Vec3 position_W_m = Vec3::Zero();
  Vec3 velocity_W_m_s = Vec3::Zero();
  /// The cable was taut at the last step's end (|r| = l).
  bool taut = true;
  /// The payload rests on the ground (held there until the cable lifts it).
  bool on_ground = false;
};

/// Swing angles of Eq. 3.33 and their rates, rad and rad/s.
struct SwingAngles {
  double gamma1_rad = 0.0, gamma2_rad = 0.0;
  double gamma1_rate_rad_s = 0.0, gamma2_rate_rad_s = 0.0;
};

/// The cable's pull on each body and the payload's acceleration (one derivative evaluation).
struct CableCoupling {
  double tension_N = 0.0;
  /// Added to the vehicle's acceleration: T q / m_Q.
  Vec3 vehicle_acceleration_W_m_s2 = Vec3::Zero();
  Vec3 payload_acceleration_W_m_s2 = Vec3::Zero();
};

/// Puts the payload down at its (x, y) on the ground, at rest (sticky ground: no bounce, no slide).
inline void rest_on_ground(PayloadState& s) {
  s.position_W_m.z() = 0.0;
  s.velocity_W_m_s.setZero();
  s.on_ground = true;
}

/// Where Eq. 3.33 puts the payload for swing angles g1, g2: x_Q + l (sin g1 cos g2, sin g2,
/// -cos g1 cos g2).
inline Vec3 payload_position_at(const Vec3& vehicle_position_W_m, double tether_length_m,
                                double gamma1_rad, double gamma2_rad) {
  return vehicle_position_W_m +
         tether_length_m * Vec3(std::sin(gamma1_rad) * std::cos(gamma2_rad), std::sin(gamma2_rad),
                                -std::cos(gamma1_rad) * std::cos(gamma2_rad));
}

/// The payload at rest relative to the vehicle at `vehicle_position_W_m`, at the settings' initial
/// swing angles; when that is below the ground (and it is on), on the ground below the vehicle,
/// the cable slack unless the vehicle is l up.
inline PayloadState payload_start(const PayloadSettings& settings, const Vec3& vehicle_position_W_m,
                                  const Vec3& vehicle_velocity_W_m_s, bool ground_enabled) {
  const double l = settings.payload.tether_length_m;
  PayloadState s;
  s.position_W_m = payload_position_at(vehicle_position_W_m, l, settings.initial_swing1_rad,
                                       settings.initial_swing2_rad);
  s.velocity_W_m_s = vehicle_velocity_W_m_s;
  if (ground_enabled && s.position_W_m.z() <= 0.0) {
    s.position_W_m.head<2>() = vehicle_position_W_m.head<2>();
    rest_on_ground(s);
    s.taut = vehicle_position_W_m.z() >= l;
  }
  return s;
}

/// Whether the cable pulls over the next step: taut at the last step's end and, at the step's
/// start, not needing to push. `tension_N` is the tension the taut cable would carry now.
inline bool cable_pulls(const PayloadState& s, double tension_N) {
  return s.taut && tension_N > 0.0;
}

/// The cable's tension and the accelerations it causes, with the vehicle's acceleration without it
/// (`vehicle_free_W_m_s2`, from the force kernel). `pulling`: the mode held over the step.
inline CableCoupling cable_coupling(const SlungPayload& p, double vehicle_mass_kg, bool pulling,
                                    bool on_ground, const Vec3& vehicle_position_W_m,
                                    const Vec3& vehicle_velocity_W_m_s,
                                    const Vec3& vehicle_free_W_m_s2,
                                    const Vec3& payload_position_W_m,
                                    const Vec3& payload_velocity_W_m_s, const Vec3& wind_W_m_s,
                                    const Vec3& gravity_W_m_s2) {
  CableCoupling c;
  Vec3 payload_free = Vec3::Zero();
  if (!on_ground) {
    payload_free = gravity_W_m_s2;
    if (p.drag_area_m2 > 0.0) {
      const Vec3 air = payload_velocity_W_m_s - wind_W_m_s;
      payload_free -= (0.5 * p.air_density_kg_m3 * p.drag_area_m2 * air.norm() / p.mass_kg) * air;
    }
  }
  c.payload_acceleration_W_m_s2 = payload_free;
  if (!pulling) return c;
  const Vec3 r = payload_position_W_m - vehicle_position_W_m;
  const double length = r.norm();
  if (!(length > 0.0)) return c;
  const Vec3 q = r / length;
  const double rdot2 = (payload_velocity_W_m_s - vehicle_velocity_W_m_s).squaredNorm();
  double tension = 0.0;
  if (on_ground) {
    tension = vehicle_mass_kg * (rdot2 / length - q.dot(vehicle_free_W_m_s2));
  } else {
    const double mu = vehicle_mass_kg * p.mass_kg / (vehicle_mass_kg + p.mass_kg);
    tension = mu * (q.dot(payload_free - vehicle_free_W_m_s2) + rdot2 / length);
  }
  tension = std::max(tension, 0.0);
  c.tension_N = tension;
  c.vehicle_acceleration_W_m_s2 = (tension / vehicle_mass_kg) * q;
  if (!on_ground) c.payload_acceleration_W_m_s2 -= (tension / p.mass_kg) * q;
  return c;
}

/// After a step: a cable that pulled is put back at length l with no relative speed along it; a
/// slack one stretched past l jerks taut (inelastic); a free payload below the ground stops on it.
/// (A resting payload is freed at a step's start, by payload_lifts_off().)
/// Positions and velocities are moved along q in inverse proportion to the masses, so the centre
/// of mass and the momentum stay (a resting payload does not move: the ground takes its share).
inline void settle_cable(const SlungPayload& p, double vehicle_mass_kg, bool pulled,
                         bool ground_enabled, Vec3& vehicle_position_W_m,
                         Vec3& vehicle_velocity_W_m_s, PayloadState& s) {
  const Vec3 r = s.position_W_m - vehicle_position_W_m;
  const double length = r.norm();
  const double l = p.tether_length_m;
  if (length > 0.0 && (pulled || length > l)) {
    const Vec3 q = r / length;
    const double stretch_m = length - l;
    const double radial_m_s = q.dot(s.velocity_W_m_s - vehicle_velocity_W_m_s);
    // Only an outward relative speed is taken out of a cable that just went taut.
    const double removed_m_s = pulled ? radial_m_s : std::max(radial_m_s, 0.0);
    const double vehicle_share = s.on_ground ? 1.0 : p.mass_kg / (vehicle_mass_kg + p.mass_kg);
    vehicle_position_W_m += (vehicle_share * stretch_m) * q;
    vehicle_velocity_W_m_s += (vehicle_share * removed_m_s) * q;
    if (!s.on_ground) {
      s.position_W_m -= ((1.0 - vehicle_share) * stretch_m) * q;
      s.velocity_W_m_s -= ((1.0 - vehicle_share) * removed_m_s) * q;
    }
    s.taut = true;
  } else {
    s.taut = false;
  }
  if (ground_enabled && !s.on_ground && s.position_W_m.z() <= 0.0) rest_on_ground(s);
}

/// Whether a resting payload leaves the ground at this step's start: the taut cable's upward pull
/// (tension T along -q) exceeds its weight.
inline bool payload_lifts_off(const SlungPayload& p, const PayloadState& s, double tension_N,
                              const Vec3& vehicle_position_W_m, const Vec3& gravity_W_m_s2) {
  if (!s.on_ground || !s.taut) return false;
  const Vec3 r = s.position_W_m - vehicle_position_W_m;
  const double length = r.norm();
  if (!(length > 0.0)) return false;
  const Vec3 up = -gravity_W_m_s2.normalized();
  return tension_N * (-r / length).dot(up) > p.mass_kg * gravity_W_m_s2.norm();
}

/// Eq. 3.33's swing angles of the payload seen from the vehicle, and their rates (exact, from the
/// velocities, rather than Eq. 3.37's backward difference).
inline SwingAngles swing_angles(const Vec3& vehicle_position_W_m,
                                const Vec3& vehicle_velocity_W_m_s, const PayloadState& s) {
  SwingAngles a;
  const Vec3 r = s.position_W_m - vehicle_position_W_m;
  const double length = r.norm();
  if (!(length > 0.0)) return a;
  const Vec3 u = r / length;
  const Vec3 u_dot = ((s.velocity_W_m_s - vehicle_velocity_W_m_s) -
                      u * u.dot(s.velocity_W_m_s - vehicle_velocity_W_m_s)) /
                     length;
  const double xz2 = u.x() * u.x() + u.z() * u.z();
  a.gamma1_rad = std::atan2(u.x(), -u.z());
  a.gamma2_rad = std::asin(std::clamp(u.y(), -1.0, 1.0));
  if (xz2 > 0.0) {
    a.gamma1_rate_rad_s = (-u.z() * u_dot.x() + u.x() * u_dot.z()) / xz2;
    a.gamma2_rate_rad_s = u_dot.y() / std::sqrt(xz2);
  }
  return a;
}

}  // namespace dronetwin
