#pragma once
// Downwash: the mean wake below a multirotor and what it does to a vehicle flying in it
// (docs/downwash.md).
//
// The wake. Bauersfeld et al. (RA-L 2025, arXiv 2403.13321) measured the flow below hovering
// quadrotors of several sizes and found it a round turbulent jet from about 2.5 vehicle sizes
// down. A round jet is self-similar (Pope, Turbulent Flows, Sec. 5.1): along the axis, at distance
// s from its virtual origin, the half-width grows linearly, r_1/2 = S s (S = 0.094, Pope's value
// for the round jet), and the mean velocity has the Gaussian profile
//
//   U(s, r) = U_c(s) exp(-ln 2 (r / r_1/2)^2).
//
// Its momentum flux is the thrust that drives it, T = rho int U^2 2 pi r dr = rho U_c^2 pi
// r_1/2^2 / (2 ln 2), so
//
//   U_c(s) = sqrt(2 ln 2 T / (pi rho)) / (S s).
//
// (Pope's measured decay constant B = 5.8 corresponds to sqrt(2 ln 2)/(2 S) = 6.26 here: the
// Gaussian and the mean-flow momentum flux leave out the turbulent stresses' share.) The
// virtual origin sits r0 / S above the rotor plane, r0 the half-width of the rotor layout (the
// farthest hub plus a propeller radius), so that the jet is as wide as the vehicle where it
// leaves it. The wake points along -b3 of the vehicle making it and exists only below its rotor
// plane.
//
// The effect. A rotor of the vehicle below sits in an axial inflow w (the wake's velocity along
// -a_i, its own thrust axis): its blades meet the air at a smaller angle, and at constant rotor
// speed the thrust drops. Linearising blade-element momentum theory about hover (Leishman,
// Principles of Helicopter Aerodynamics, Ch. 3) gives
//
//   dT / T = -kappa w / v_h,   v_h = sqrt(T / (2 rho A))  (the rotor's own induced velocity),
//
// with kappa = 1 / (1 + 4 lambda_h / (sigma a / 4)) between 0.3 and 0.6 for small propellers
// (inflow ratio lambda_h 0.05-0.08, sigma a / 4 0.1-0.15); `thrust_lapse` is kappa. The change is
// limited to |dT| <= T (a wake cannot reverse a rotor). The wake's velocity at the centre of mass
// is also added to the air the vehicle flies in, so the frame and rotor drag see it.
//
//   WakeSource s = wake_source(settings, upper_model, upper_state, upper_speeds);
//   DownwashEffect e = downwash_effect(settings, lower_model, lower_state, lower_speeds, &s, 1);
//   sim.set_interaction(e.flow_W_m_s, e.wrench_B);   // held over the next step
//
// Trap: a mean-flow model. The wake's turbulence, its swirl, the near field above 2.5 vehicle
// sizes (where the four rotor jets have not merged) and a wake bent by the source's own motion
// are not modelled; a moving source's wake is taken as the one it would leave in hover.

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dronetwin/core/types.hpp"
#include "dronetwin/dynamics/rotor.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

struct DownwashSettings {
  bool enabled = true;
  /// Spreading rate S of the round jet, d r_1/2 / d s (Pope, Turbulent Flows, Sec. 5.1).
  double spreading_rate = 0.094;
  /// Radius of the propellers, m: it sets the disc area A of v_h and the wake's starting width.
  /// 0.1 m is our choice for the QDrone2 (the thesis gives no size), as in
  /// VehicleModel::collision_shape().
  double propeller_radius_m = 0.1;
  /// kappa of dT / T = -kappa w / v_h (blade-element momentum theory, see above).
  double thrust_lapse = 0.5;
  double air_density_kg_m3 = 1.225;
};

/// A vehicle as a source of wake: where it is, which way its thrust points, how much thrust.
struct WakeSource {
  Vec3 position_W_m = Vec3::Zero();
  /// Unit thrust direction b3 in the world frame; the wake flows along -b3.
  Vec3 thrust_axis_W = Vec3::UnitZ();
  double thrust_N = 0.0;
  /// Half-width of the rotor layout r0 (farthest hub from the axis plus a propeller radius), m.
  double half_width_m = 0.0;
};

/// The wake's effect on one vehicle, held over a step: the air velocity it adds at the centre of
/// mass (world frame) and the rotors' thrust change as a body wrench [F_B; M_B] about the centre
/// of mass.
struct DownwashEffect {
  Vec3 flow_W_m_s = Vec3::Zero();
  Vector6<double> wrench_B = Vector6<double>::Zero();
};

/// Total thrust of a vehicle at these rotor speeds, N (sum of the rotors' thrust polynomials).
inline double total_thrust_N(const VehicleModel& model, const RotorVector& speeds_rad_s) {
  double t = 0.0;
  for (int i = 0; i < model.num_rotors(); ++i) t += model.rotor(i).thrust(speeds_rad_s[i]);
  return t;
}

/// r0: the largest distance of a hub from the body z axis plus a propeller radius, m.
inline double rotor_layout_half_width_m(const VehicleModel& model, double propeller_radius_m) {
  double r = 0.0;
  for (int i = 0; i < model.num_rotors(); ++i)
    r = std::max(r, model.rotor(i).position_m.head<2>().norm());
  return r + propeller_radius_m;
}

inline WakeSource wake_source(const DownwashSettings& s, const VehicleModel& model,
                              const StateVector& x, const RotorVector& speeds_rad_s) {
  WakeSource w;
  w.position_W_m = x.segment<3>(state_index::kPosition);
  w.thrust_axis_W =
      math::rotation_matrix<double>(Vec4(x.segment<4>(state_index::kQuaternion))).col(2);
  w.thrust_N = total_thrust_N(model, speeds_rad_s);
  w.half_width_m = rotor_layout_half_width_m(model, s.propeller_radius_m);
  return w;
}

/// Mean wake velocity of `source` at `point_W`, world frame, m/s (zero above its rotor plane or
/// without thrust).
inline Vec3 wake_velocity_W_m_s(const DownwashSettings& s, const WakeSource& source,
                                const Vec3& point_W) {
  if (!(source.thrust_N > 0.0)) return Vec3::Zero();
  const Vec3 e = -source.thrust_axis_W;  // the wake's direction
  const Vec3 d = point_W - source.position_W_m;
  const double along_m = e.dot(d);
  if (!(along_m > 0.0)) return Vec3::Zero();
  const double s_m = along_m + source.half_width_m / s.spreading_rate;  // from the virtual origin
  const double half_width_m = s.spreading_rate * s_m;
  const double r2 = (d - along_m * e).squaredNorm();
  const double centre_m_s = std::sqrt(2.0 * std::numbers::ln2 * source.thrust_N /
                                      (std::numbers::pi * s.air_density_kg_m3)) /
                            half_width_m;
  return centre_m_s * std::exp(-std::numbers::ln2 * r2 / (half_width_m * half_width_m)) * e;
}

/// What the wakes of `sources[0..n)` do to a vehicle of `model` at state x with these rotor
/// speeds (its own wake is not among the sources).
inline DownwashEffect downwash_effect(const DownwashSettings& s, const VehicleModel& model,
                                      const StateVector& x, const RotorVector& speeds_rad_s,
                                      const WakeSource* sources, int n) {
  DownwashEffect effect;
  if (!s.enabled || n == 0) return effect;
  const Vec3 p = x.segment<3>(state_index::kPosition);
  const Mat3 R = math::rotation_matrix<double>(Vec4(x.segment<4>(state_index::kQuaternion)));
  for (int k = 0; k < n; ++k) effect.flow_W_m_s += wake_velocity_W_m_s(s, sources[k], p);
  const double disc_area_m2 = std::numbers::pi * s.propeller_radius_m * s.propeller_radius_m;
  for (int i = 0; i < model.num_rotors(); ++i) {
    const auto& rotor = model.rotor(i);
    const double thrust_N = rotor.thrust(speeds_rad_s[i]);
    if (!(thrust_N > 0.0)) continue;
    const Vec3 hub_W = p + R * rotor.position_m;
    Vec3 u = Vec3::Zero();
    for (int k = 0; k < n; ++k) u += wake_velocity_W_m_s(s, sources[k], hub_W);
    const double inflow_m_s = -(R * rotor.axis).dot(u);  // along -a_i: against the thrust
    const double induced_m_s = std::sqrt(thrust_N / (2.0 * s.air_density_kg_m3 * disc_area_m2));
    const double change_N =
        std::clamp(-s.thrust_lapse * thrust_N * inflow_m_s / induced_m_s, -thrust_N, thrust_N);
    effect.wrench_B.head<3>() += change_N * rotor.axis;
    effect.wrench_B.tail<3>() += change_N * rotor.position_m.cross(rotor.axis);
  }
  return effect;
}

}  // namespace dronetwin
