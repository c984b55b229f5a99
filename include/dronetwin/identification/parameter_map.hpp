#pragma once
// The fit's unknowns: the 17 identifiable coefficients (model_parameters.hpp) as multipliers
// theta_j of unit values, and the vehicle model they describe, in any scalar. A fit differentiates
// the force kernel's predictions (dynamics/force_kernel.hpp) with respect to theta by building the
// model at a theta of ceres::Jet: there is no second copy of the force model here.
//
//   ParameterMap map(model);
//   std::array<double, kNumModelParameters> theta = map.initial_theta();   // = the model itself
//   VehicleModelTpl<Jet> m = map.model_at(theta_as_jets);                   // same airframe
//   ForceKernel<Jet> kernel(m, ForceTerms::of(switches));                   // d/dtheta for free
//
// theta_j multiplies the model's own value (theta = 1 reproduces the model); a coefficient the
// model has at 0 is fitted as theta_j * typical_j instead (theta = 0 reproduces the model), so a
// zero never pins a parameter. Per-rotor coefficients share one theta_j (each rotor keeps its
// ratio to the others). Only the diagonal of the inertia and of the body-drag matrix are
// parameters; their off-diagonal terms are kept as they are.

#include <array>

#include "dronetwin/core/types.hpp"
#include "dronetwin/model/model_parameters.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

class ParameterMap {
 public:
  using Theta = std::array<double, kNumModelParameters>;

  explicit ParameterMap(const VehicleModel& model);

  const VehicleModel& model() const { return *model_; }
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

  /// The model at `theta` (kNumModelParameters values of scalar T: double, or Jet to
  /// differentiate): every identifiable coefficient = theta_j * its unit, the rest as in the model.
  template <class T>
  VehicleModelTpl<T> model_at(const T* theta) const {
    using P = ModelParameter;
    const auto th = [theta](P p) -> const T& { return theta[static_cast<int>(p)]; };
    return model_->template cast<T>().edited([&](VehicleParametersTpl<T>& q) {
      q.mass_kg = th(P::kMass) * unit_.mass;
      for (int a = 0; a < 3; ++a) {
        q.inertia_kgm2(a, a) =
            th(static_cast<P>(static_cast<int>(P::kInertiaXX) + a)) * unit_.inertia_diagonal[a];
        q.body_drag_Ns_per_m(a, a) =
            th(static_cast<P>(static_cast<int>(P::kBodyDragX) + a)) * unit_.body_drag_diagonal[a];
      }
      for (int i = 0; i < q.num_rotors; ++i) {
        const RotorUnits& u = unit_.rotors[static_cast<std::size_t>(i)];
        RotorParamsTpl<T>& r = q.rotors[static_cast<std::size_t>(i)];
        r.thrust_coefficients[0] = th(P::kThrustK1) * u.k1;
        r.thrust_coefficients[1] = th(P::kThrustK2) * u.k2;
        r.thrust_coefficients[2] = th(P::kThrustK3) * u.k3;
        r.yaw_moment_per_thrust_m = th(P::kYawMomentPerThrust) * u.yaw;
        r.drag_moment_coefficient = th(P::kDragMoment) * u.drag_moment;
        r.rotor_drag_coefficient = th(P::kRotorDrag) * u.rotor_drag;
        r.rolling_moment_coefficient = th(P::kRollingMoment) * u.rolling;
        r.ground_effect_coefficient = th(P::kGroundEffect) * u.ground;
        r.time_constant_rise_s = th(P::kTauRise) * u.tau_rise;
        r.time_constant_fall_s = th(P::kTauFall) * u.tau_fall;
      }
    });
  }

 private:
  // Coefficient = theta * unit.
  struct RotorUnits {
    double k1 = 0, k2 = 0, k3 = 0, yaw = 0, drag_moment = 0, rotor_drag = 0, rolling = 0,
           ground = 0, tau_rise = 0, tau_fall = 0;
  };
  struct Units {
    double mass = 1.0;
    Vec3 inertia_diagonal = Vec3::Ones();
    Vec3 body_drag_diagonal = Vec3::Zero();
    std::array<RotorUnits, kMaxRotors> rotors{};
  };
  double unit(ModelParameter p, double own_value);

  const VehicleModel* model_;
  Units unit_;
  Theta initial_theta_{};
  Theta mean_unit_{};
};

}  // namespace dronetwin
