#pragma once
// Parameters of one rotor (propeller + motor), as written in a vehicle model file.
// All quantities SI; the thesis symbols are given for the QDrone2 (thesis Table 2.1).
//
// Templated on the scalar S of the coefficients a fit estimates or a batch varies per vehicle
// (thrust curve, moment and drag coefficients, rotor inertia, motor time constants), so the same
// rotor can carry ceres::Jet coefficients in a fit or one value per lane in a SIMD pack. The
// geometry (hub position, axis, spin) and the speed limits are what the airframe is: plain
// numbers of S's value type (double for double, Jet and double packs), shared by every cast.
//
//   RotorParams r = model.rotor(0);                  // RotorParamsTpl<double>
//   double T = r.thrust(1200.0);                     // Eq. 2.22
//   RotorParamsTpl<ceres::Jet<double, 4>> j = r.cast<ceres::Jet<double, 4>>();

#include <array>

#include "dronetwin/core/scalar.hpp"
#include "dronetwin/core/types.hpp"

namespace dronetwin {

/// The thrust polynomial of thesis Eq. 2.22, T(w) = c[0] w^2 + c[1] w + c[2], in Horner form.
/// `w` may be plain (a logged speed) while the coefficients carry derivatives, or both packs.
template <class S, class W>
S thrust_polynomial(const std::array<S, 3>& c, const W& w) {
  return (c[0] * w + c[1]) * w + c[2];
}

/// The speed in [min_speed, max_speed] at which T(w) = thrust_N for the thrust polynomial c, for
/// any lane scalar (a pack inverts W rotors' thrusts at once, each lane as the double would).
template <class S>
S inverse_thrust_polynomial(const std::array<double, 3>& c, double min_speed_rad_s,
                            double max_speed_rad_s, const S& thrust_N) {
  using V = scalar::value_type_t<S>;
  const V a = static_cast<V>(c[0]), b = static_cast<V>(c[1]), k = static_cast<V>(c[2]);
  S w;
  if (c[0] > 0.0) {
    // Positive root of a w^2 + b w + (k - T) = 0, written to avoid cancellation when b > 0.
    const S disc = S(b * b) - S(V(4) * a) * (S(k) - thrust_N);
    const S s = scalar::sqrt(scalar::max(disc, S(V(0))));
    const S root =
        c[1] >= 0.0 ? (S(V(2)) * (thrust_N - S(k))) / (S(b) + s) : (S(-b) + s) / S(V(2) * a);
    w = scalar::select(disc <= S(V(0)), S(-b / (V(2) * a)), root);
  } else {
    w = (thrust_N - S(k)) / S(b);  // linear curve; validation guarantees b > 0 when a == 0
  }
  const S lo(static_cast<V>(min_speed_rad_s)), hi(static_cast<V>(max_speed_rad_s));
  w = scalar::select(!(w >= lo), lo, w);  // also maps NaN to the limit
  return scalar::select(w > hi, hi, w);
}

/// The speed in [min_speed_rad_s, max_speed_rad_s] at which T(w) = thrust_N for the thrust
/// polynomial c (RotorParamsTpl<double>::speed_for_thrust).
double rotor_speed_for_thrust(const std::array<double, 3>& c, double min_speed_rad_s,
                              double max_speed_rad_s, double thrust_N);

template <class S>
struct RotorParamsTpl {
  using Scalar = S;
  using Value = scalar::value_type_t<S>;

  /// Hub position relative to the centre of mass, body frame, m (thesis Eq. 2.25, z from SDF).
  Vector3<Value> position_m = Vector3<Value>::Zero();
  /// Thrust direction in the body frame; normalised when the model is loaded. Tilted rotors
  /// allowed.
  Vector3<Value> axis = Vector3<Value>::UnitZ();
  /// Turning direction epsilon_i in {+1, -1}. Sign convention of thesis Eq. 2.24: the reaction
  /// (yaw) moment of this rotor is +epsilon_i * T_i / K_tau about its axis.
  int spin = 1;
  /// Thrust polynomial T(w) = c[0] w^2 + c[1] w + c[2]  ('K1 [N s^2/rad^2], 'K2 [N s/rad], 'K3
  /// [N]), thesis Eq. 2.22.
  std::array<S, 3> thrust_coefficients{S(0), S(0), S(0)};
  /// Reaction moment per unit thrust, 1/K_tau, m (thesis Eq. 2.23).
  S yaw_moment_per_thrust_m = S(0);
  /// Rotor (blade-flapping) drag C_D: F_D = -|w| C_D v_perp, N s^2/(rad m) (thesis Eq. 2.32).
  S rotor_drag_coefficient = S(0);
  /// Rolling moment C_R: M_R = |w| C_R v_perp, N s^2/rad (thesis Eq. 2.32).
  S rolling_moment_coefficient = S(0);
  /// Drag moment C_MD: M_D = -epsilon C_MD T axis, m (thesis Eq. 2.32).
  S drag_moment_coefficient = S(0);
  /// Ground effect C_G: F_G = C_G T / h^2 along the axis, m^2 (thesis appendix C.2 form).
  S ground_effect_coefficient = S(0);
  /// Spinning-part inertia about the axis, kg m^2 (gyroscopic moment, thesis Eq. 2.35).
  S inertia_kgm2 = S(0);
  /// Motor first-order lag constants, s (thesis Eq. 2.43-2.45).
  S time_constant_rise_s = S(0);
  S time_constant_fall_s = S(0);
  /// Rotor speed limits, rad/s (speeds are magnitudes; the spin sign is `spin`).
  Value min_speed_rad_s = Value(0);
  Value max_speed_rad_s = Value(0);

  /// Thrust T(w) in N for speed w in rad/s (thesis Eq. 2.22).
  template <class W>
  S thrust(const W& w) const {
    return thrust_polynomial(thrust_coefficients, w);
  }

  /// Inverse of the thrust polynomial on [min_speed, max_speed]: the speed that gives
  /// `thrust_N`, clamped to the speed limits. Closed form (positive root of the quadratic).
  /// Only for plain double rotors (the allocation and the hover trim use it).
  double speed_for_thrust(double thrust_N) const requires std::is_same_v<S, double> {
    // Defined through a free function: clang 16 rejects an explicit specialization of a
    // constrained member.
    return rotor_speed_for_thrust(thrust_coefficients, min_speed_rad_s, max_speed_rad_s, thrust_N);
  }

  /// The same rotor with coefficients of scalar S2 (geometry and limits unchanged). From double
  /// only: a Jet's derivatives or a pack's lanes have no single value to carry over.
  template <class S2>
  RotorParamsTpl<S2> cast() const requires std::is_arithmetic_v<S> {
    using V2 = typename RotorParamsTpl<S2>::Value;
    RotorParamsTpl<S2> r;
    r.position_m = position_m.template cast<V2>();
    r.axis = axis.template cast<V2>();
    r.spin = spin;
    for (std::size_t k = 0; k < 3; ++k)
      r.thrust_coefficients[k] = scalar::from_value<S2>(thrust_coefficients[k]);
    r.yaw_moment_per_thrust_m = scalar::from_value<S2>(yaw_moment_per_thrust_m);
    r.rotor_drag_coefficient = scalar::from_value<S2>(rotor_drag_coefficient);
    r.rolling_moment_coefficient = scalar::from_value<S2>(rolling_moment_coefficient);
    r.drag_moment_coefficient = scalar::from_value<S2>(drag_moment_coefficient);
    r.ground_effect_coefficient = scalar::from_value<S2>(ground_effect_coefficient);
    r.inertia_kgm2 = scalar::from_value<S2>(inertia_kgm2);
    r.time_constant_rise_s = scalar::from_value<S2>(time_constant_rise_s);
    r.time_constant_fall_s = scalar::from_value<S2>(time_constant_fall_s);
    r.min_speed_rad_s = static_cast<V2>(min_speed_rad_s);
    r.max_speed_rad_s = static_cast<V2>(max_speed_rad_s);
    return r;
  }
};

/// A rotor with plain double coefficients: what a model file holds.
using RotorParams = RotorParamsTpl<double>;

}  // namespace dronetwin
