#pragma once
// The complete multirotor force model (thesis Sec. 2.3, Eq. 2.36-2.42) assembled from the
// per-term components in this folder, and the resulting state derivative.
//
//   StateVector xdot = state_derivative(model, switches, env, x, rotor_speeds);
//   WrenchBreakdown b = wrench_breakdown(model, switches, env, x, rotor_speeds);
//
// One templated routine (accumulate_wrench) feeds both: the integrator sums the terms, the
// breakdown records them one by one, so the two can never disagree. Rotor speeds are magnitudes
// in rad/s, held constant over a physics step.

#include <cmath>

#include "dronetwin/core/types.hpp"
#include "dronetwin/dynamics/body_drag.hpp"
#include "dronetwin/dynamics/environment.hpp"
#include "dronetwin/dynamics/gyroscopic.hpp"
#include "dronetwin/dynamics/rigid_body.hpp"
#include "dronetwin/dynamics/rotor.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

/// Visits every enabled term. `sink.force(term, F_B, r_B)` receives a force acting at point r_B
/// (its moment about the centre of mass is r_B x F_B); `sink.moment(term, M_B)` a pure moment.
template <class T, class Sink>
void accumulate_wrench(const VehicleModel& model, const DisturbanceSwitches& sw,
                       const Environment& env, const StateVectorT<T>& x, const Matrix3<T>& R,
                       const RotorVector& speeds_rad_s, Sink& sink) {
  using namespace state_index;
  const Vector3<T> p_W = x.template segment<3>(kPosition);
  const Vector3<T> w_B = x.template segment<3>(kAngularVelocity);
  const Vector3<T> v_air_B =
      R.transpose() * (x.template segment<3>(kVelocity) - env.wind_W_m_s.cast<T>());
  const bool need_plane_velocity = sw.rotor_drag || sw.rolling_moment;
  Vec3 rotor_momentum_B = Vec3::Zero();

  for (int i = 0; i < model.num_rotors(); ++i) {
    const RotorParams& r = model.rotor(i);
    const double w = speeds_rad_s[i];
    const double thrust_N = r.thrust(w);
    sink.force(Term::kThrust, thrust_force<T>(r, w), r.position_m);
    sink.moment(Term::kYawReaction, yaw_reaction_moment<T>(r, thrust_N));
    if (need_plane_velocity) {
      const Vector3<T> v_perp =
          in_plane<T>(hub_air_velocity<T>(v_air_B, w_B, r.position_m), r.axis);
      if (sw.rotor_drag)
        sink.force(Term::kRotorDrag, rotor_drag_force<T>(r, w, v_perp), r.position_m);
      if (sw.rolling_moment) sink.moment(Term::kRollingMoment, rolling_moment<T>(r, w, v_perp));
    }
    if (sw.drag_moment) sink.moment(Term::kDragMoment, drag_moment<T>(r, thrust_N));
    if (sw.ground_effect) {
      const T hub_height = p_W.z() + R.row(2).dot(r.position_m.cast<T>());
      sink.force(
          Term::kGroundEffect,
          ground_effect_force<T>(r, thrust_N, hub_height, model.ground_effect_min_height_m()),
          r.position_m);
    }
    if (sw.gyroscopic) rotor_momentum_B += (r.spin * r.inertia_kgm2 * w) * r.axis;
  }
  if (sw.gyroscopic) sink.moment(Term::kGyroscopic, gyroscopic_moment<T>(w_B, rotor_momentum_B));
  if (sw.body_drag) {
    sink.force(Term::kBodyDrag, body_drag_force<T>(model.body_drag_Ns_per_m(), v_air_B),
               Vec3::Zero());
  }
}

namespace detail {
template <class T>
struct SumSink {
  Vector3<T> force_B = Vector3<T>::Zero();
  Vector3<T> moment_B = Vector3<T>::Zero();
  void force(Term, const Vector3<T>& f, const Vec3& r) {
    force_B += f;
    moment_B += r.cast<T>().cross(f);
  }
  void moment(Term, const Vector3<T>& m) { moment_B += m; }
};

struct BreakdownSink {
  WrenchBreakdown* out;
  void force(Term t, const Vec3& f, const Vec3& r) {
    (*out)[t].force_B += f;
    (*out)[t].moment_B += r.cross(f);
  }
  void moment(Term t, const Vec3& m) { (*out)[t].moment_B += m; }
};
}  // namespace detail

/// Total non-gravitational body-frame wrench about the centre of mass.
template <class T>
Wrench<T> total_wrench(const VehicleModel& model, const DisturbanceSwitches& sw,
                       const Environment& env, const StateVectorT<T>& x, const Matrix3<T>& R,
                       const RotorVector& speeds_rad_s) {
  detail::SumSink<T> sink;
  accumulate_wrench<T>(model, sw, env, x, R, speeds_rad_s, sink);
  return {sink.force_B, sink.moment_B};
}

/// x_dot = f(x, w) for the full model (thesis Eq. 2.41-2.42 with the resolutions of
/// docs/conventions.md). The quaternion in x need not be exactly unit (RK4 stages are not).
template <class T>
StateVectorT<T> state_derivative(const VehicleModel& model, const DisturbanceSwitches& sw,
                                 const Environment& env, const StateVectorT<T>& x,
                                 const RotorVector& speeds_rad_s) {
  const Matrix3<T> R = math::rotation_matrix<T>(x.template segment<4>(state_index::kQuaternion));
  const Wrench<T> wr = total_wrench<T>(model, sw, env, x, R, speeds_rad_s);
  return newton_euler<T>(x, R, wr.force_B, wr.moment_B, model.mass_kg(), model.inertia_kgm2(),
                         model.inertia_inverse(), env.gravity_W_m_s2);
}

/// Every term's force and moment at one state, gravity included (expressed in the body frame).
inline WrenchBreakdown wrench_breakdown(const VehicleModel& model, const DisturbanceSwitches& sw,
                                        const Environment& env, const StateVector& x,
                                        const RotorVector& speeds_rad_s) {
  WrenchBreakdown out;
  const Mat3 R = math::rotation_matrix<double>(x.segment<4>(state_index::kQuaternion));
  detail::BreakdownSink sink{&out};
  accumulate_wrench<double>(model, sw, env, x, R, speeds_rad_s, sink);
  out[Term::kGravity].force_B = R.transpose() * (model.mass_kg() * env.gravity_W_m_s2);
  return out;
}

}  // namespace dronetwin
