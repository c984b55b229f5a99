#pragma once
// The force kernel: the complete multirotor force model of thesis Sec. 2.3 (Eq. 2.22-2.42), the
// one implementation the simulator, the batch, the NMPC and the fits all evaluate. It adds up the
// terms of rotor.hpp, gyroscopic.hpp and body_drag.hpp in three stages, because over a physics
// step the rotor speeds are held (zero-order hold, thesis Alg. 1-2):
//
//   1. ForceKernel(model, terms)  once per model and term set: every coefficient folded into
//      per-rotor constants (thrust wrench per unit thrust, drag map per unit |w|, momentum per
//      unit speed) shared by every vehicle that flies this model.
//   2. prepare(speeds, held)      once per step: the rotor-speed dependent parts,
//        constant wrench   sum_i T_i [a_i; r_i x a_i + eps_i (1/K_tau - C_MD) a_i]
//        velocity map      -A + sum_i |w_i| (C_D D_i + C_R L_i)        (a 6x6 linear map)
//        rotor momentum    sum_i eps_i J_r w_i a_i,   ground gains C_G T_i.
//      This is the small per-vehicle scratch (HeldRotorTerms).
//   3. wrench(held, x, R, wind) / derivative(...)  at each RK4 stage:
//        [F; M] = constant + map [v_air_B; w_B] - w_B x h + sum_i C_G T_i / h_i^2 [a_i; r_i x a_i].
//
// This is an exact rearrangement of the term-by-term sum, not an approximation; the per-term
// breakdown (vehicle_dynamics.hpp) evaluates the same kernel with one term on at a time, and the
// tests check each term against a hand calculation.
//
//   ForceKernel<double> kernel(*model, ForceTerms::of(switches));
//   HeldRotorTerms<double> held;
//   kernel.prepare(rotor_speeds, held);
//   StateVector x_dot = kernel.derivative(held, x, env.wind_W_m_s, env.gravity_W_m_s2);
//
// Scalars: S for the parameters and the result; X for the state (X = S, or X = double with
// S = ceres::Jet when a fit differentiates a logged state's prediction with respect to the
// parameters). Instantiated with double, float, ceres::Jet and SIMD packs (core/simd.hpp).
//
// held_rotor_step() below is one physics step with it (held speeds, the integrator, the quaternion
// projected back): the Simulator takes it with S = double, a BatchSimulator (batch/) with S = a
// SIMD pack, W vehicles per instruction, each lane with its own parameters (docs/batch.md).
//
// Trap: the kernel copies the model's parameters; build a new one when the model or the term set
// changes.

#include <array>

#include "dronetwin/core/scalar.hpp"
#include "dronetwin/core/types.hpp"
#include "dronetwin/dynamics/body_drag.hpp"
#include "dronetwin/dynamics/environment.hpp"
#include "dronetwin/dynamics/gyroscopic.hpp"
#include "dronetwin/dynamics/rigid_body.hpp"
#include "dronetwin/dynamics/rotor.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/integrators/integrator.hpp"
#include "dronetwin/math/ordered_product.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

/// The rotor-speed dependent part of the force model for one vehicle and one step (stage 2).
template <class S>
struct HeldRotorTerms {
  /// Thrust, yaw reaction and drag moment: constant while the speeds are held.
  Vector6<S> constant = Vector6<S>::Zero();
  /// Rotor drag, rolling moment and frame drag as a linear map of [v_air_B; w_B].
  Matrix6<S> velocity_map = Matrix6<S>::Zero();
  /// Total angular momentum of the rotors, body frame (gyroscopic moment).
  Vector3<S> rotor_momentum_B = Vector3<S>::Zero();
  /// C_G T_i per rotor (ground effect).
  std::array<S, kMaxRotors> ground_gain{};
};

template <class S>
class ForceKernel {
 public:
  using Value = scalar::value_type_t<S>;

  /// Stage 1: folds the model's coefficients and the term switches into per-rotor constants.
  ForceKernel(const VehicleModelTpl<S>& model, ForceTerms terms)
      : num_rotors_(model.num_rotors()),
        terms_(terms),
        mass_kg_(model.mass_kg()),
        inertia_(model.inertia_kgm2()),
        inertia_inverse_(model.inertia_inverse()),
        inertia_diagonal_(model.inertia_kgm2().diagonal()),
        inertia_inverse_diagonal_(model.inertia_inverse().diagonal()),
        inertia_is_diagonal_(model.inertia_is_diagonal()),
        ground_min_height_m_(model.ground_effect_min_height_m()) {
    per_speed_maps_.setZero();
    thrust_wrench_.setZero();
    momentum_per_speed_.setZero();
    rotor_position_.setZero();
    ground_direction_.setZero();
    for (int i = 0; i < num_rotors_; ++i) {
      const RotorParamsTpl<S>& r = model.rotor(i);
      thrust_polynomial_[static_cast<std::size_t>(i)] = r.thrust_coefficients;
      ground_coefficient_[static_cast<std::size_t>(i)] = r.ground_effect_coefficient;
      // Rotor drag and rolling moment per unit |w_i| (Eq. 2.32), stacked column-major so that one
      // axpy per rotor and step builds the whole 6x6 velocity map.
      Matrix6<S> m = Matrix6<S>::Zero();
      if (terms.rotor_drag) m += r.rotor_drag_coefficient * rotor_drag_map(r.position_m, r.axis);
      if (terms.rolling_moment) {
        m += r.rolling_moment_coefficient * rolling_moment_map(r.position_m, r.axis);
      }
      per_speed_maps_.col(i) = Eigen::Map<const Eigen::Matrix<S, 36, 1>>(m.data());
      // Thrust (Eq. 2.22) at the hub, and the moments about the axis that are proportional to
      // the thrust: yaw reaction (Eq. 2.24) and drag moment (Eq. 2.32).
      const Vector6<Value> unit_force = axial_force_wrench(r.position_m, r.axis);
      S axial_per_thrust = S(Value(0));
      if (terms.yaw_reaction) axial_per_thrust = yaw_reaction_per_thrust(r);
      if (terms.drag_moment) axial_per_thrust += drag_moment_per_thrust(r);
      Vector6<S> per_thrust = Vector6<S>::Zero();
      if (terms.thrust) per_thrust = unit_force.template cast<S>();
      per_thrust.template tail<3>() += axial_per_thrust * r.axis;
      thrust_wrench_.col(i) = per_thrust;
      if (terms.gyroscopic) momentum_per_speed_.col(i) = rotor_momentum_per_speed(r);
      rotor_position_.col(i) = r.position_m;
      ground_direction_.col(i) = unit_force;
    }
    body_drag_map_ = terms.body_drag ? body_drag_map(model.body_drag_Ns_per_m())
                                     : Matrix6<S>(Matrix6<S>::Zero());
  }

  const ForceTerms& terms() const { return terms_; }
  int num_rotors() const { return num_rotors_; }

  /// Stage 2: the parts that depend on the held rotor speeds (magnitudes, rad/s). `speeds[i]` may
  /// be plain doubles (a logged flight) or of the kernel's scalar.
  template <class Speeds>
  DRONETWIN_HOT_INLINE void prepare(const Speeds& speeds_rad_s, HeldRotorTerms<S>& held) const {
    held.constant.setZero();
    held.rotor_momentum_B.setZero();
    for (int i = 0; i < num_rotors_; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const auto& w = speeds_rad_s[i];
      const S thrust_N = thrust_polynomial(thrust_polynomial_[k], w);  // Eq. 2.22
      held.constant += thrust_N * thrust_wrench_.col(i);
      held.rotor_momentum_B += w * momentum_per_speed_.col(i);
      held.ground_gain[k] = ground_coefficient_[k] * thrust_N;
    }
    // Fixed-size axpy per rotor: cheaper than a dynamic-size matrix-vector product here.
    Eigen::Map<Eigen::Matrix<S, 36, 1>> map(held.velocity_map.data());
    map = Eigen::Map<const Eigen::Matrix<S, 36, 1>>(body_drag_map_.data());
    for (int i = 0; i < num_rotors_; ++i)
      map += scalar::abs(speeds_rad_s[i]) * per_speed_maps_.col(i);
  }

  /// Stage 3: total non-gravitational [F_B; M_B] about the centre of mass at state x, rotation
  /// R = R(q), in air moving at wind_W.
  template <class X, class V>
  DRONETWIN_HOT_INLINE Vector6<S> wrench(const HeldRotorTerms<S>& held, const StateVectorT<X>& x,
                                         const Matrix3<X>& R, const Vector3<V>& wind_W) const {
    using namespace state_index;
    Vector6<X> air_and_rate;
    const Vector3<X> air_W = x.template segment<3>(kVelocity) - wind_W;
    air_and_rate.template head<3>() = math::ordered_product(R.transpose(), air_W);
    air_and_rate.template tail<3>() = x.template segment<3>(kAngularVelocity);
    Vector6<S> w = held.constant + math::ordered_product(held.velocity_map, air_and_rate);
    if (terms_.gyroscopic) {
      w.template tail<3>() +=
          gyroscopic_moment(air_and_rate.template tail<3>(), held.rotor_momentum_B);
    }
    if (terms_.ground_effect) {
      const X z = x[kPosition + 2];
      for (int i = 0; i < num_rotors_; ++i) {
        const X hub_height =
            z + ((R(2, 0) * rotor_position_(0, i) + R(2, 1) * rotor_position_(1, i)) +
                 R(2, 2) * rotor_position_(2, i));
        const S f = ground_effect_force(held.ground_gain[static_cast<std::size_t>(i)], hub_height,
                                        ground_min_height_m_);
        w += f * ground_direction_.col(i);  // along [a_i; r_i x a_i]
      }
    }
    return w;
  }

  /// x_dot = f(x) for the held rotor speeds (Newton-Euler, rigid_body.hpp).
  template <class X, class V, class G>
  DRONETWIN_HOT_INLINE StateVectorT<S> derivative(const HeldRotorTerms<S>& held,
                                                  const StateVectorT<X>& x,
                                                  const Vector3<V>& wind_W,
                                                  const Vector3<G>& gravity_W) const {
    const Matrix3<X> R = math::rotation_matrix<X>(x.template segment<4>(state_index::kQuaternion));
    const Vector6<S> w = wrench(held, x, R, wind_W);
    if (inertia_is_diagonal_) {
      return newton_euler_diagonal_inertia<S, X>(x, R, w.template head<3>(), w.template tail<3>(),
                                                 mass_kg_, inertia_diagonal_,
                                                 inertia_inverse_diagonal_, gravity_W);
    }
    return newton_euler<S, X>(x, R, w.template head<3>(), w.template tail<3>(), mass_kg_, inertia_,
                              inertia_inverse_, gravity_W);
  }

  /// derivative() in an Environment (double wind and gravity).
  template <class X>
  DRONETWIN_HOT_INLINE StateVectorT<S> derivative(const HeldRotorTerms<S>& held,
                                                  const StateVectorT<X>& x,
                                                  const Environment& env) const {
    return derivative(held, x, env.wind_W_m_s, env.gravity_W_m_s2);
  }

 private:
  int num_rotors_ = 0;
  ForceTerms terms_{};
  S mass_kg_;
  Matrix3<S> inertia_, inertia_inverse_;
  Vector3<S> inertia_diagonal_, inertia_inverse_diagonal_;
  bool inertia_is_diagonal_ = false;
  Value ground_min_height_m_ = Value(0);
  std::array<std::array<S, 3>, kMaxRotors> thrust_polynomial_{};
  std::array<S, kMaxRotors> ground_coefficient_{};
  Eigen::Matrix<S, 36, kMaxRotors> per_speed_maps_;
  Matrix6<S> body_drag_map_;
  Eigen::Matrix<S, 6, kMaxRotors> thrust_wrench_;
  Eigen::Matrix<S, 3, kMaxRotors> momentum_per_speed_;
  Eigen::Matrix<Value, 3, kMaxRotors> rotor_position_;
  Eigen::Matrix<Value, 6, kMaxRotors> ground_direction_;
};

/// One physics step with the rotor speeds held (thesis Alg. 1-2): the held-rotor terms once, the
/// integrator's stages through the kernel, and the quaternion projected back onto the unit sphere.
/// Ground contact, motors and the validity checks are the caller's (the simulators).
template <class S, class Speeds>
DRONETWIN_HOT_INLINE StateVectorT<S> held_rotor_step(
    const ForceKernel<S>& kernel, Integrator method, const StateVectorT<S>& x,
    const Speeds& rotor_speeds_rad_s, const Vector3<S>& wind_W_m_s,
    const Vector3<scalar::value_type_t<S>>& gravity_W_m_s2, double dt_s) {
  HeldRotorTerms<S> held;
  kernel.prepare(rotor_speeds_rad_s, held);
  const auto f = [&](const StateVectorT<S>& y) {
    return kernel.derivative(held, y, wind_W_m_s, gravity_W_m_s2);
  };
  StateVectorT<S> next = integrate_step(method, x, dt_s, f);
  normalize_quaternion(next);
  return next;
}

}  // namespace dronetwin
