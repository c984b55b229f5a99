#pragma once
// The vehicle force model with its coefficients as unknowns: the same equations as
// dynamics/vehicle_dynamics.hpp (thesis Eq. 2.22-2.42), but every identifiable coefficient is
// theta_j * unit_j with theta templated on the scalar, so Ceres can differentiate the predicted
// accelerations with respect to the parameters (ceres::Jet) for the fits in fit.hpp.
//
//   ParametricModel pm(model, switches, env);
//   std::array<double, kNumModelParameters> theta = pm.initial_theta();   // = the model itself
//   StateVector xdot = pm.derivative<double, double>(theta.data(), x, rotor_speeds);
//   // equals state_derivative(model, switches, env, x, rotor_speeds) (tested to 1e-12)
//
// theta_j multiplies the model's own value (theta = 1 reproduces the model); a coefficient the
// model has at 0 is fitted as theta_j * typical_j instead (theta = 0 reproduces the model), so a
// zero never pins a parameter. Only the diagonal of the inertia and of the body-drag matrix are
// parameters; their off-diagonal terms are kept as they are.
//
// Trap: this is a second implementation of the force model, kept for differentiation in the
// parameters; tests/identification/parametric_dynamics_test.cpp checks it against the
// simulator's model for every switch combination, so a change to one that misses the other fails.

#include <array>

#include "dronetwin/core/types.hpp"
#include "dronetwin/dynamics/environment.hpp"
#include "dronetwin/dynamics/rigid_body.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/identification/model_parameters.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

class ParametricModel {
 public:
  using Theta = std::array<double, kNumModelParameters>;

  ParametricModel(const VehicleModel& model, const DisturbanceSwitches& switches,
                  const Environment& environment);

  int num_rotors() const { return num_rotors_; }
  const Environment& environment() const { return environment_; }
  /// theta that reproduces the model it was built from (1, or 0 for coefficients that are 0).
  const Theta& initial_theta() const { return initial_theta_; }
  /// Physical value (mean over rotors for per-rotor coefficients) of parameter p at theta_p.
  double value(ModelParameter p, double theta_p) const {
    return theta_p * mean_unit_[static_cast<std::size_t>(p)];
  }
  /// theta_p giving the physical value `value` (inverse of value()).
  double theta_for(ModelParameter p, double value) const {
    return value / mean_unit_[static_cast<std::size_t>(p)];
  }

  /// x_dot = f(x, w; theta): [v_W, a_W, q_dot, w_dot_B]; theta has kNumModelParameters entries.
  /// The state may be plain double (S = double) while theta carries derivatives (T = Jet).
  template <class T, class S>
  StateVectorT<T> derivative(const T* theta, const StateVectorT<S>& x,
                             const RotorVector& speeds_rad_s) const;

 private:
  struct Rotor {
    Vec3 position_m = Vec3::Zero();
    Vec3 axis = Vec3::UnitZ();
    double spin = 1.0;
    double inertia_kgm2 = 0.0;
    // unit values: coefficient = theta * unit
    double k1 = 0, k2 = 0, k3 = 0, yaw = 0, drag_moment = 0, rotor_drag = 0, rolling = 0,
           ground = 0;
  };
  double unit(const VehicleSpec& spec, ModelParameter p, double own_value);

  int num_rotors_ = 0;
  std::array<Rotor, kMaxRotors> rotors_{};
  double mass_unit_ = 1.0;
  Vec3 inertia_diag_unit_ = Vec3::Ones();
  Mat3 inertia_off_diagonal_ = Mat3::Zero();
  Vec3 body_drag_diag_unit_ = Vec3::Zero();
  Mat3 body_drag_off_diagonal_ = Mat3::Zero();
  double ground_effect_min_height_m_ = 0.0;
  DisturbanceSwitches switches_{};
  Environment environment_{};
  Theta initial_theta_{};
  Theta mean_unit_{};
};

template <class T, class S>
StateVectorT<T> ParametricModel::derivative(const T* theta, const StateVectorT<S>& x,
                                            const RotorVector& speeds_rad_s) const {
  using namespace state_index;
  using P = ModelParameter;
  const auto th = [theta](P p) -> const T& { return theta[static_cast<int>(p)]; };
  // Everything that depends only on the state stays in S (double for the equation error), so
  // only the coefficient products carry derivatives.
  const Matrix3<S> R = math::rotation_matrix<S>(x.template segment<4>(kQuaternion));
  const Vector3<S> w_B = x.template segment<3>(kAngularVelocity);
  const Vector3<S> v_air_B =
      R.transpose() * (x.template segment<3>(kVelocity) - environment_.wind_W_m_s.cast<S>());
  const S p_z = x[kPosition + 2];

  Vector3<T> F = Vector3<T>::Zero();
  Vector3<T> M = Vector3<T>::Zero();
  Vec3 rotor_momentum_B = Vec3::Zero();
  for (int i = 0; i < num_rotors_; ++i) {
    const Rotor& r = rotors_[static_cast<std::size_t>(i)];
    const double w = speeds_rad_s[i];
    // Eq. 2.22: T = 'K1 w^2 + 'K2 w + 'K3
    const T thrust =
        (th(P::kThrustK1) * (r.k1 * w) + th(P::kThrustK2) * r.k2) * w + th(P::kThrustK3) * r.k3;
    T along_axis = thrust;
    if (switches_.ground_effect) {  // appendix C.2: C_G T / h^2, h floored
      const S hub = p_z + R.row(2).dot(r.position_m.cast<S>());
      const S h = hub < S(ground_effect_min_height_m_) ? S(ground_effect_min_height_m_) : hub;
      along_axis += th(P::kGroundEffect) * r.ground * thrust / (h * h);
    }
    Vector3<T> f = along_axis * r.axis;
    if (switches_.rotor_drag || switches_.rolling_moment) {  // Eq. 2.32-2.33
      const Vector3<S> v_hub = v_air_B + w_B.cross(r.position_m.cast<S>());
      const Vector3<S> v_perp = v_hub - r.axis.cast<S>() * r.axis.cast<S>().dot(v_hub);
      const double speed = w < 0 ? -w : w;
      if (switches_.rotor_drag) f -= (th(P::kRotorDrag) * (r.rotor_drag * speed)) * v_perp;
      if (switches_.rolling_moment) M += (th(P::kRollingMoment) * (r.rolling * speed)) * v_perp;
    }
    F += f;
    M += r.position_m.cross(f);
    // Eq. 2.24 (reaction +eps T / K_tau) and Eq. 2.32 (drag moment -eps C_MD T), both along a
    T yaw = th(P::kYawMomentPerThrust) * (r.spin * r.yaw) * thrust;
    if (switches_.drag_moment) yaw -= th(P::kDragMoment) * (r.spin * r.drag_moment) * thrust;
    M += yaw * r.axis;
    if (switches_.gyroscopic) rotor_momentum_B += (r.spin * r.inertia_kgm2 * w) * r.axis;
  }
  if (switches_.gyroscopic) M -= w_B.cross(rotor_momentum_B.cast<S>());  // Eq. 2.35, 2.37
  if (switches_.body_drag) {                                             // Eq. 2.32, body frame
    const Vector3<S> off = body_drag_off_diagonal_.cast<S>() * v_air_B;
    F[0] -= th(P::kBodyDragX) * (body_drag_diag_unit_[0] * v_air_B[0]) + off[0];
    F[1] -= th(P::kBodyDragY) * (body_drag_diag_unit_[1] * v_air_B[1]) + off[1];
    F[2] -= th(P::kBodyDragZ) * (body_drag_diag_unit_[2] * v_air_B[2]) + off[2];
  }

  // Newton-Euler, Eq. 2.41-2.42, with the mass and the inertia diagonal as unknowns.
  const T mass = th(P::kMass) * mass_unit_;
  StateVectorT<T> d;
  d.template segment<3>(kPosition) = x.template segment<3>(kVelocity).template cast<T>();
  d.template segment<3>(kVelocity) = (R * F) / mass + environment_.gravity_W_m_s2;
  d.template segment<4>(kQuaternion) =
      math::derivative<S>(x.template segment<4>(kQuaternion), w_B).template cast<T>();
  Matrix3<T> J = inertia_off_diagonal_.cast<T>();
  J(0, 0) += th(P::kInertiaXX) * inertia_diag_unit_[0];
  J(1, 1) += th(P::kInertiaYY) * inertia_diag_unit_[1];
  J(2, 2) += th(P::kInertiaZZ) * inertia_diag_unit_[2];
  const Vector3<T> rhs = M - w_B.cross(J * w_B);
  if (inertia_off_diagonal_.isZero(0.0)) {
    d.template segment<3>(kAngularVelocity) =
        Vector3<T>(rhs[0] / J(0, 0), rhs[1] / J(1, 1), rhs[2] / J(2, 2));
  } else {
    d.template segment<3>(kAngularVelocity) = J.inverse() * rhs;
  }
  return d;
}

}  // namespace dronetwin
