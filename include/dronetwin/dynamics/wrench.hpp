#pragma once
// Names of the force/moment terms of the vehicle model (thesis Sec. 2.3), the per-run switches
// that turn the disturbance terms off for ablation studies, and a breakdown of the total wrench
// by term for logs, tests and parameter identification.
//
// Every term is expressed in the body frame about the centre of mass (forces acting at a rotor
// hub contribute r_i x F_i to the moment), gravity included (as R^T m g), so the breakdown sums to
// the wrench that drives the Newton-Euler equations.

#include <array>
#include <string_view>

#include "dronetwin/core/types.hpp"

namespace dronetwin {

enum class Term : int {
  kThrust = 0,     ///< T_i along each rotor axis, Eq. 2.22 (+ its moment r_i x T_i)
  kYawReaction,    ///< +eps_i T_i / K_tau about each axis, Eq. 2.24
  kRotorDrag,      ///< -|w_i| C_D v_perp,i at each hub, Eq. 2.32
  kRollingMoment,  ///< |w_i| C_R v_perp,i, Eq. 2.32
  kDragMoment,     ///< -eps_i C_MD T_i along each axis, Eq. 2.32
  kGroundEffect,   ///< C_G T_i / h_i^2 along each axis, appendix C.2 form
  kGyroscopic,     ///< -w_B x sum_i eps_i J_r w_i a_i, Eq. 2.35
  kBodyDrag,       ///< -A v_air on the frame, Eq. 2.32
  kGravity,        ///< m g
};
inline constexpr int kNumTerms = 9;

/// Lower-case name used in logs and experiment files ("rotor_drag", ...).
constexpr std::string_view term_name(Term t) {
  constexpr std::array<std::string_view, kNumTerms> names{
      "thrust",        "yaw_reaction", "rotor_drag", "rolling_moment", "drag_moment",
      "ground_effect", "gyroscopic",   "body_drag",  "gravity"};
  return names[static_cast<std::size_t>(t)];
}

/// Which disturbance terms are applied. Thrust, yaw reaction and gravity are always on.
struct DisturbanceSwitches {
  bool rotor_drag = true;
  bool rolling_moment = true;
  bool drag_moment = true;
  bool ground_effect = true;
  bool gyroscopic = true;
  bool body_drag = true;

  static constexpr DisturbanceSwitches none() { return {false, false, false, false, false, false}; }
};

/// The switches by name, in declaration order: the names experiment files, log sidecars and
/// `dronetwin fit --disturbances` use (kDisturbanceSwitchMembers[i] is the one named [i]).
inline constexpr std::array<std::string_view, 6> kDisturbanceSwitchNames = {
    "rotor_drag", "rolling_moment", "drag_moment", "ground_effect", "gyroscopic", "body_drag"};
inline constexpr std::array<bool DisturbanceSwitches::*, 6> kDisturbanceSwitchMembers = {
    &DisturbanceSwitches::rotor_drag,  &DisturbanceSwitches::rolling_moment,
    &DisturbanceSwitches::drag_moment, &DisturbanceSwitches::ground_effect,
    &DisturbanceSwitches::gyroscopic,  &DisturbanceSwitches::body_drag};

template <class T>
struct Wrench {
  Vector3<T> force_B = Vector3<T>::Zero();
  Vector3<T> moment_B = Vector3<T>::Zero();
};

/// Force and moment of every term at one state; terms that are switched off are zero.
struct WrenchBreakdown {
  std::array<Wrench<double>, kNumTerms> terms{};

  const Wrench<double>& operator[](Term t) const { return terms[static_cast<std::size_t>(t)]; }
  Wrench<double>& operator[](Term t) { return terms[static_cast<std::size_t>(t)]; }
  /// Sum over all terms (body frame, about the centre of mass).
  Wrench<double> total() const {
    Wrench<double> w;
    for (const auto& t : terms) {
      w.force_B += t.force_B;
      w.moment_B += t.moment_B;
    }
    return w;
  }
};

}  // namespace dronetwin
