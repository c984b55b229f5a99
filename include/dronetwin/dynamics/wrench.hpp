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

/// Which force terms the kernel (force_kernel.hpp) adds up: every term but gravity, by name. A
/// simulator uses of(switches) (thrust and yaw reaction are always on); the per-term breakdown
/// evaluates the same kernel with only(term), one term at a time.
struct ForceTerms {
  bool thrust = true;
  bool yaw_reaction = true;
  bool rotor_drag = true;
  bool rolling_moment = true;
  bool drag_moment = true;
  bool ground_effect = true;
  bool gyroscopic = true;
  bool body_drag = true;

  static constexpr ForceTerms of(const DisturbanceSwitches& sw) {
    return {true,           true,
            sw.rotor_drag,  sw.rolling_moment,
            sw.drag_moment, sw.ground_effect,
            sw.gyroscopic,  sw.body_drag};
  }
  /// True when term `t` is on (gravity, not a kernel term, never is).
  constexpr bool includes(Term t) const {
    switch (t) {
      case Term::kThrust:
        return thrust;
      case Term::kYawReaction:
        return yaw_reaction;
      case Term::kRotorDrag:
        return rotor_drag;
      case Term::kRollingMoment:
        return rolling_moment;
      case Term::kDragMoment:
        return drag_moment;
      case Term::kGroundEffect:
        return ground_effect;
      case Term::kGyroscopic:
        return gyroscopic;
      case Term::kBodyDrag:
        return body_drag;
      case Term::kGravity:
        return false;
    }
    return false;
  }
  /// Only `t` (gravity, which is not a kernel term, gives none).
  static constexpr ForceTerms only(Term t) {
    return {t == Term::kThrust,        t == Term::kYawReaction, t == Term::kRotorDrag,
            t == Term::kRollingMoment, t == Term::kDragMoment,  t == Term::kGroundEffect,
            t == Term::kGyroscopic,    t == Term::kBodyDrag};
  }
};

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
