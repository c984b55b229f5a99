// ParameterMap construction (parameter_map.hpp): the model's own coefficients become the units of
// theta, so theta = 1 is the model.
#include "dronetwin/identification/parameter_map.hpp"

namespace dronetwin {
namespace {

// Scale of a parameter whose model value is 0 (theta then starts at 0 and value = theta * this):
// an order of magnitude typical of a 0.03-3 kg multirotor, only so the solver sees theta ~ 1.
double typical_magnitude(ModelParameter p) {
  using P = ModelParameter;
  switch (p) {
    case P::kMass:
      return 1.0;
    case P::kInertiaXX:
    case P::kInertiaYY:
    case P::kInertiaZZ:
      return 1e-2;
    case P::kThrustK1:
      return 1e-6;
    case P::kThrustK2:
      return 1e-4;
    case P::kThrustK3:
      return 1e-2;
    case P::kYawMomentPerThrust:
      return 1e-2;
    case P::kDragMoment:
      return 1e-3;
    case P::kRotorDrag:
      return 1e-4;
    case P::kRollingMoment:
      return 1e-6;
    case P::kBodyDragX:
    case P::kBodyDragY:
    case P::kBodyDragZ:
      return 0.1;
    case P::kGroundEffect:
      return 1e-3;
    case P::kTauRise:
    case P::kTauFall:
      return 1e-2;
  }
  return 1.0;
}

}  // namespace

double ParameterMap::unit(ModelParameter p, double own_value) {
  const auto k = static_cast<std::size_t>(p);
  const double mean = parameter_value(model_->spec(), p);
  if (mean != 0.0) {
    initial_theta_[k] = 1.0;
    mean_unit_[k] = mean;
    return own_value;
  }
  initial_theta_[k] = 0.0;
  mean_unit_[k] = typical_magnitude(p);
  return typical_magnitude(p);
}

ParameterMap::ParameterMap(const VehicleModel& model) : model_(&model) {
  using P = ModelParameter;
  for (int i = 0; i < model.num_rotors(); ++i) {
    const RotorParams& src = model.rotor(i);
    RotorUnits& r = unit_.rotors[static_cast<std::size_t>(i)];
    r.k1 = unit(P::kThrustK1, src.thrust_coefficients[0]);
    r.k2 = unit(P::kThrustK2, src.thrust_coefficients[1]);
    r.k3 = unit(P::kThrustK3, src.thrust_coefficients[2]);
    r.yaw = unit(P::kYawMomentPerThrust, src.yaw_moment_per_thrust_m);
    r.drag_moment = unit(P::kDragMoment, src.drag_moment_coefficient);
    r.rotor_drag = unit(P::kRotorDrag, src.rotor_drag_coefficient);
    r.rolling = unit(P::kRollingMoment, src.rolling_moment_coefficient);
    r.ground = unit(P::kGroundEffect, src.ground_effect_coefficient);
    r.tau_rise = unit(P::kTauRise, src.time_constant_rise_s);
    r.tau_fall = unit(P::kTauFall, src.time_constant_fall_s);
  }
  unit_.mass = unit(P::kMass, model.mass_kg());
  const Mat3& J = model.inertia_kgm2();
  unit_.inertia_diagonal = Vec3(unit(P::kInertiaXX, J(0, 0)), unit(P::kInertiaYY, J(1, 1)),
                                unit(P::kInertiaZZ, J(2, 2)));
  const Mat3& A = model.body_drag_Ns_per_m();
  unit_.body_drag_diagonal = Vec3(unit(P::kBodyDragX, A(0, 0)), unit(P::kBodyDragY, A(1, 1)),
                                  unit(P::kBodyDragZ, A(2, 2)));
}

}  // namespace dronetwin
