#pragma once
// The force kernel: the complete multirotor force model of thesis Sec. 2.3 (Eq. 2.22-2.42), the
// one implementation the simulator, the batch and the fits all evaluate (the NMPC plans on its own
// reduced model, nmpc/nmpc_model.hpp, Eq. 3.23). It adds up the
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
/// Scratch: prepare() writes every member it later reads, so nothing is zeroed up front (for a
/// pack of vehicles that would be a kilobyte of stores per step).
template <class S>
struct HeldRotorTerms {
  /// Thrust, yaw reaction and drag moment: constant while the speeds are held.
  Vector6<S> constant;
  /// Rotor drag, rolling moment and frame drag as a linear map of [v_air_B; w_B].
  Matrix6<S> velocity_map;
  /// Total angular momentum of the rotors, body frame (gyroscopic moment).
  Vector3<S> rotor_momentum_B;
  /// C_G T_i per rotor (ground effect); the first num_rotors() entries.
  std::array<S, kMaxRotors> ground_gain;
};

template <class S>
class ForceKernel {
 public:
  using Value = scalar::value_type_t<S>;

  /// Stage 1: folds the model's coefficients and the term switches into per-rotor constants.
  /// What is geometry (hub positions and axes: the airframe's, shared by every lane of a batch) is
  /// kept in the value type apart from the coefficients that a fit or a batch lane varies (S), so
  /// a pack of vehicles carries one number per coefficient, not one per matrix entry.
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
    drag_maps_.setZero();
    rolling_maps_.setZero();
    axis_.setZero();
    rotor_position_.setZero();
    ground_direction_.setZero();
    for (int i = 0; i < num_rotors_; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const RotorParamsTpl<S>& r = model.rotor(i);
      thrust_polynomial_[k] = r.thrust_coefficients;
      ground_coefficient_[k] = r.ground_effect_coefficient;
      // Rotor drag and rolling moment per unit C |w_i| (Eq. 2.32), stacked column-major so that
      // one axpy per rotor and step builds the 6x6 velocity map; the rolling moment acts on the
      // moment rows only (rows 3-5, 18 entries).
      const Matrix6<Value> drag = rotor_drag_map(r.position_m, r.axis);
      const Matrix6<Value> rolling = rolling_moment_map(r.position_m, r.axis);
      drag_maps_.col(i) = Eigen::Map<const Eigen::Matrix<Value, 36, 1>>(drag.data());
      for (int c = 0; c < 6; ++c)
        for (int row = 0; row < 3; ++row) rolling_maps_(3 * c + row, i) = rolling(3 + row, c);
      drag_coefficient_[k] = terms.rotor_drag ? r.rotor_drag_coefficient : S(Value(0));
      rolling_coefficient_[k] = terms.rolling_moment ? r.rolling_moment_coefficient : S(Value(0));
      // The moments about the axis that are proportional to the thrust (Eq. 2.22): yaw reaction
      // (Eq. 2.24) and drag moment (Eq. 2.32).
      S axial_per_thrust = S(Value(0));
      if (terms.yaw_reaction) axial_per_thrust = yaw_reaction_per_thrust(r);
      if (terms.drag_moment) axial_per_thrust += drag_moment_per_thrust(r);
      axial_per_thrust_[k] = axial_per_thrust;
      // Rotor angular momentum per unit speed, eps_i J_r,i along the axis (Eq. 2.35).
      momentum_per_speed_[k] = terms.gyroscopic ? S(Value(r.spin) * r.inertia_kgm2) : S(Value(0));
      axis_.col(i) = r.axis;
      rotor_position_.col(i) = r.position_m;
      ground_direction_.col(i) = axial_force_wrench(r.position_m, r.axis);  // [a_i; r_i x a_i]
    }
    body_drag_ = terms.body_drag ? model.body_drag_Ns_per_m() : Matrix3<S>(Matrix3<S>::Zero());
  }

  const ForceTerms& terms() const { return terms_; }
  int num_rotors() const { return num_rotors_; }

  /// Stage 2: the parts that depend on the held rotor speeds (magnitudes, rad/s). `speeds[i]` may
  /// be plain doubles (a logged flight) or of the kernel's scalar.
  template <class Speeds>
  DRONETWIN_HOT_INLINE void prepare(const Speeds& speeds_rad_s, HeldRotorTerms<S>& held) const {
    const S zero = S(Value(0));
    held.constant.setConstant(zero);
    held.rotor_momentum_B.setConstant(zero);
    for (int i = 0; i < num_rotors_; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const auto& w = speeds_rad_s[i];
      const S thrust_N = thrust_polynomial(thrust_polynomial_[k], w);  // Eq. 2.22
      // Thrust along the axis at the hub [a_i; r_i x a_i] T_i, and the axial moments.
      if (terms_.thrust) {
        for (int row = 0; row < 6; ++row)
          held.constant[row] = held.constant[row] + thrust_N * ground_direction_(row, i);
      }
      const S axial_moment = thrust_N * axial_per_thrust_[k];
      const S momentum = w * momentum_per_speed_[k];
      for (int row = 0; row < 3; ++row) {
        held.constant[3 + row] = held.constant[3 + row] + axial_moment * axis_(row, i);
        held.rotor_momentum_B[row] = held.rotor_momentum_B[row] + momentum * axis_(row, i);
      }
      held.ground_gain[k] = ground_coefficient_[k] * thrust_N;
    }
    // The 6x6 velocity map: frame drag -A in the force rows and air-velocity columns, then one
    // axpy per rotor and term, written as plain loops so that they inline for packs too.
    S* map = held.velocity_map.data();
    for (int e = 0; e < 36; ++e) map[e] = zero;
    for (int c = 0; c < 3; ++c)
      for (int row = 0; row < 3; ++row) map[6 * c + row] = -body_drag_(row, c);
    for (int i = 0; i < num_rotors_; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const auto speed = scalar::abs(speeds_rad_s[i]);
      if (terms_.rotor_drag) {
        const S c_drag = speed * drag_coefficient_[k];
        for (int e = 0; e < 36; ++e) map[e] = map[e] + c_drag * drag_maps_(e, i);
      }
      if (terms_.rolling_moment) {
        const S c_rolling = speed * rolling_coefficient_[k];
        for (int c = 0; c < 6; ++c)
          for (int row = 0; row < 3; ++row)
            map[6 * c + 3 + row] = map[6 * c + 3 + row] + c_rolling * rolling_maps_(3 * c + row, i);
      }
    }
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
  // Per-rotor coefficients (one per lane in a pack) ...
  std::array<S, kMaxRotors> drag_coefficient_{}, rolling_coefficient_{}, axial_per_thrust_{},
      momentum_per_speed_{};
  Matrix3<S> body_drag_;
  // ... and the airframe's geometry they multiply (shared by every lane).
  Eigen::Matrix<Value, 36, kMaxRotors> drag_maps_;
  Eigen::Matrix<Value, 18, kMaxRotors> rolling_maps_;
  Eigen::Matrix<Value, 3, kMaxRotors> axis_;
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
