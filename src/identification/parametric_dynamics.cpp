// ParametricModel construction (parametric_dynamics.hpp): the model's own coefficients become the
// units of theta, so theta = 1 is the model.
#include "dronetwin/identification/parametric_dynamics.hpp"

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

double ParametricModel::unit(const VehicleSpec& spec, ModelParameter p, double own_value) {
  const auto k = static_cast<std::size_t>(p);
  const double mean = parameter_value(spec, p);
  if (mean != 0.0) {
    initial_theta_[k] = 1.0;
    mean_unit_[k] = mean;
    return own_value;
  }
  initial_theta_[k] = 0.0;
  mean_unit_[k] = typical_magnitude(p);
  return typical_magnitude(p);
}

ParametricModel::ParametricModel(const VehicleModel& model, const DisturbanceSwitches& switches,
                                 const Environment& environment)
    : num_rotors_(model.num_rotors()),
      ground_effect_min_height_m_(model.ground_effect_min_height_m()),
      switches_(switches),
      environment_(environment) {
  using P = ModelParameter;
  const VehicleSpec& spec = model.spec();
  for (int i = 0; i < num_rotors_; ++i) {
    const RotorParams& src = model.rotor(i);
    Rotor& r = rotors_[static_cast<std::size_t>(i)];
    r.position_m = src.position_m;
    r.axis = src.axis;
    r.spin = src.spin;
    r.inertia_kgm2 = src.inertia_kgm2;
    r.k1 = unit(spec, P::kThrustK1, src.thrust_coefficients[0]);
    r.k2 = unit(spec, P::kThrustK2, src.thrust_coefficients[1]);
    r.k3 = unit(spec, P::kThrustK3, src.thrust_coefficients[2]);
    r.yaw = unit(spec, P::kYawMomentPerThrust, src.yaw_moment_per_thrust_m);
    r.drag_moment = unit(spec, P::kDragMoment, src.drag_moment_coefficient);
    r.rotor_drag = unit(spec, P::kRotorDrag, src.rotor_drag_coefficient);
    r.rolling = unit(spec, P::kRollingMoment, src.rolling_moment_coefficient);
    r.ground = unit(spec, P::kGroundEffect, src.ground_effect_coefficient);
    (void)unit(spec, P::kTauRise, src.time_constant_rise_s);
    (void)unit(spec, P::kTauFall, src.time_constant_fall_s);
  }
  mass_unit_ = unit(spec, P::kMass, spec.mass_kg);
  const Mat3& J = spec.inertia_kgm2;
  inertia_diag_unit_ = Vec3(unit(spec, P::kInertiaXX, J(0, 0)), unit(spec, P::kInertiaYY, J(1, 1)),
                            unit(spec, P::kInertiaZZ, J(2, 2)));
  inertia_off_diagonal_ = J;
  inertia_off_diagonal_.diagonal().setZero();
  const Mat3& A = spec.body_drag_Ns_per_m;
  body_drag_diag_unit_ =
      Vec3(unit(spec, P::kBodyDragX, A(0, 0)), unit(spec, P::kBodyDragY, A(1, 1)),
           unit(spec, P::kBodyDragZ, A(2, 2)));
  body_drag_off_diagonal_ = A;
  body_drag_off_diagonal_.diagonal().setZero();
}

}  // namespace dronetwin
