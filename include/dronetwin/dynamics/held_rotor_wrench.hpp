#pragma once
// The full force model of vehicle_dynamics.hpp, factored for a physics step in which the rotor
// speeds are held constant. This is an exact rearrangement, not an approximation:
//
//   thrust, yaw reaction, drag moment           -> constant over the step
//   rotor drag, rolling moment, body drag       -> linear in [v_air_B; w_B] (a 6x6 map)
//   gyroscopic moment                           -> -w_B x h, h constant over the step
//   ground effect                               -> sum_i (C_G T_i / h_i^2) [a_i; r_i x a_i]
//
// configure() does the work that depends only on the model and the switches; prepare() the
// rotor-speed-dependent work once per step; evaluate() is what the four RK4 stages pay.
// tests/dynamics/held_rotor_wrench_test.cpp checks it against accumulate_wrench() term by term at
// random states, so the two cannot drift apart.

#include <algorithm>
#include <array>
#include <cmath>

#include "dronetwin/core/types.hpp"
#include "dronetwin/dynamics/environment.hpp"
#include "dronetwin/dynamics/rigid_body.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

class HeldRotorWrench {
 public:
  /// Speed-independent constants for a model and a set of switches. Call again whenever the
  /// switches change.
  void configure(const VehicleModel& model, const DisturbanceSwitches& sw) {
    num_rotors_ = model.num_rotors();
    switches_ = sw;
    // Column i holds rotor i's rotor-drag and rolling-moment map per unit |w_i|, stacked
    // column-major, so one matrix-vector product per step builds the whole 6x6 velocity map.
    per_speed_maps_.setZero();
    for (int i = 0; i < num_rotors_; ++i) {
      const RotorParams& r = model.rotor(i);
      const RotorGeometry& g = model.rotor_geometry(i);
      Matrix6 m = Matrix6::Zero();
      if (sw.rotor_drag) m += r.rotor_drag_coefficient * g.drag_map;
      if (sw.rolling_moment) m += r.rolling_moment_coefficient * g.rolling_map;
      per_speed_maps_.col(i) = Eigen::Map<const Eigen::Matrix<double, 36, 1>>(m.data());
    }
    body_drag_map_.setZero();
    if (sw.body_drag) body_drag_map_.topLeftCorner<3, 3>() = -model.body_drag_Ns_per_m();
    // Copies of the per-rotor vectors the ground-effect loop reads four times per step, packed
    // contiguously here instead of chased through the model's rotor and geometry arrays.
    for (int i = 0; i < num_rotors_; ++i) {
      rotor_position_.col(i) = model.rotor(i).position_m;
      ground_direction_.col(i) << model.rotor(i).axis, model.rotor_geometry(i).arm_cross_axis;
    }
    // Speed-independent parts of the constant wrench and of the rotor angular momentum:
    // thrust along the axis, its moment r x a, the yaw reaction (Eq. 2.24) and the drag moment
    // are all T_i times a fixed vector; the rotor momentum is w_i times a fixed vector.
    for (int i = 0; i < num_rotors_; ++i) {
      const RotorParams& r = model.rotor(i);
      double axial_per_thrust = r.spin * r.yaw_moment_per_thrust_m;  // Eq. 2.24
      if (sw.drag_moment) axial_per_thrust -= r.spin * r.drag_moment_coefficient;
      thrust_wrench_.col(i) << r.axis,
          model.rotor_geometry(i).arm_cross_axis + axial_per_thrust * r.axis;
      momentum_per_speed_.col(i) =
          sw.gyroscopic ? Vec3(r.spin * r.inertia_kgm2 * r.axis) : Vec3::Zero();
    }
    // Most airframes have a principal-axis (diagonal) inertia. Then J w and J^-1 y are three
    // products each instead of nine multiply-adds; the off-diagonal terms are exact zeros, so
    // skipping them gives the same numbers.
    const Mat3& J = model.inertia_kgm2();
    const Mat3& J_inv = model.inertia_inverse();
    diagonal_inertia_ = J.isDiagonal(0.0) && J_inv.isDiagonal(0.0);
    inertia_diagonal_ = J.diagonal();
    inertia_inverse_diagonal_ = J_inv.diagonal();
  }

  const DisturbanceSwitches& switches() const { return switches_; }

  /// Rotor-speed-dependent constants for one step (configure() must have been called).
  void prepare(const VehicleModel& model, const RotorVector& speeds_rad_s) {
    // Per rotor only the thrust polynomial is evaluated here; everything else is a 6-vector
    // (or 3-vector) per unit thrust or speed, folded together in configure().
    constant_.setZero();
    rotor_momentum_B_.setZero();
    for (int i = 0; i < num_rotors_; ++i) {
      const RotorParams& r = model.rotor(i);
      const double w = speeds_rad_s[i];
      const double thrust_N = r.thrust(w);
      constant_ += thrust_N * thrust_wrench_.col(i);
      rotor_momentum_B_ += w * momentum_per_speed_.col(i);
      abs_speed_[i] = std::abs(w);
      ground_gain_[static_cast<std::size_t>(i)] = r.ground_effect_coefficient * thrust_N;
    }
    // Fixed-size axpy per rotor: cheaper than a dynamic-size matrix-vector product here.
    Eigen::Map<Eigen::Matrix<double, 36, 1>> map(velocity_map_.data());
    map = Eigen::Map<const Eigen::Matrix<double, 36, 1>>(body_drag_map_.data());
    for (int i = 0; i < num_rotors_; ++i) map += abs_speed_[i] * per_speed_maps_.col(i);
  }

  /// Total non-gravitational [F_B; M_B] at state x with rotation R = R(q).
  DRONETWIN_HOT_INLINE Eigen::Matrix<double, 6, 1> evaluate(const VehicleModel& model,
                                                            const Environment& env,
                                                            const StateVector& x,
                                                            const Mat3& R) const {
    using namespace state_index;
    Eigen::Matrix<double, 6, 1> air_and_rate;
    air_and_rate.head<3>() = R.transpose() * (x.segment<3>(kVelocity) - env.wind_W_m_s);
    air_and_rate.tail<3>() = x.segment<3>(kAngularVelocity);
    Eigen::Matrix<double, 6, 1> wrench = constant_ + velocity_map_ * air_and_rate;
    if (switches_.gyroscopic) wrench.tail<3>() -= air_and_rate.tail<3>().cross(rotor_momentum_B_);
    if (switches_.ground_effect) {
      const double z = x[kPosition + 2];
      const double h_min = model.ground_effect_min_height_m();
      for (int i = 0; i < num_rotors_; ++i) {
        const double h = std::max(z + R.row(2).dot(rotor_position_.col(i)), h_min);
        const double s = ground_gain_[static_cast<std::size_t>(i)] / (h * h);
        wrench += s * ground_direction_.col(i);  // [a_i; r_i x a_i]
      }
    }
    return wrench;
  }

  /// x_dot for the held rotor speeds (same equations as state_derivative()).
  DRONETWIN_HOT_INLINE StateVector derivative(const VehicleModel& model, const Environment& env,
                                              const StateVector& x) const {
    const Mat3 R = math::rotation_matrix<double>(x.segment<4>(state_index::kQuaternion));
    const Eigen::Matrix<double, 6, 1> w = evaluate(model, env, x, R);
    if (diagonal_inertia_) {
      return newton_euler_diagonal_inertia<double>(x, R, w.head<3>(), w.tail<3>(), model.mass_kg(),
                                                   inertia_diagonal_, inertia_inverse_diagonal_,
                                                   env.gravity_W_m_s2);
    }
    return newton_euler<double>(x, R, w.head<3>(), w.tail<3>(), model.mass_kg(),
                                model.inertia_kgm2(), model.inertia_inverse(), env.gravity_W_m_s2);
  }

 private:
  int num_rotors_ = 0;
  DisturbanceSwitches switches_{};
  Eigen::Matrix<double, 36, kMaxRotors> per_speed_maps_ =
      Eigen::Matrix<double, 36, kMaxRotors>::Zero();
  Matrix6 body_drag_map_ = Matrix6::Zero();
  Eigen::Matrix<double, kMaxRotors, 1> abs_speed_ = Eigen::Matrix<double, kMaxRotors, 1>::Zero();
  Eigen::Matrix<double, 6, 1> constant_ = Eigen::Matrix<double, 6, 1>::Zero();
  Matrix6 velocity_map_ = Matrix6::Zero();
  Vec3 rotor_momentum_B_ = Vec3::Zero();
  std::array<double, kMaxRotors> ground_gain_{};
  Eigen::Matrix<double, 3, kMaxRotors> rotor_position_ =
      Eigen::Matrix<double, 3, kMaxRotors>::Zero();
  Eigen::Matrix<double, 6, kMaxRotors> ground_direction_ =
      Eigen::Matrix<double, 6, kMaxRotors>::Zero();
  Eigen::Matrix<double, 6, kMaxRotors> thrust_wrench_ =
      Eigen::Matrix<double, 6, kMaxRotors>::Zero();
  Eigen::Matrix<double, 3, kMaxRotors> momentum_per_speed_ =
      Eigen::Matrix<double, 3, kMaxRotors>::Zero();
  bool diagonal_inertia_ = false;
  Vec3 inertia_diagonal_ = Vec3::Zero();
  Vec3 inertia_inverse_diagonal_ = Vec3::Zero();
};

}  // namespace dronetwin
