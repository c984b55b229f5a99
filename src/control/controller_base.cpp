#include "dronetwin/control/controller_base.hpp"

#include <cmath>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

ControllerBase::ControllerBase(std::shared_ptr<const VehicleModel> model,
                               AllocationMethod allocation)
    : model_(std::move(model)), allocation_(allocation) {
  require(model_ != nullptr, "controller: model is null");
  last_allocation_.speeds_rad_s = RotorVector::Zero(model_->num_rotors());
  last_allocation_.thrusts_N = RotorVector::Zero(model_->num_rotors());
}

void ControllerBase::check_input(const ControlInput& in) const {
  require(std::isfinite(in.time_s), "controller '", name(), "': time is not finite");
  for (int i = 0; i < kStateSize; ++i) {
    require(std::isfinite(in.state[i]), "controller '", name(), "': state[", i,
            "]: expected a finite number, got ", in.state[i]);
    require(std::isfinite(in.state_derivative[i]), "controller '", name(), "': state_derivative[",
            i, "]: expected a finite number, got ", in.state_derivative[i]);
  }
  const ReferencePoint& r = in.reference;
  require(r.position_m.allFinite() && r.velocity_m_s.allFinite() &&
              r.acceleration_m_s2.allFinite() && std::isfinite(r.yaw_rad) &&
              std::isfinite(r.yaw_rate_rad_s),
          "controller '", name(), "': reference at t = ", in.time_s, " is not finite");
}

GeneralizedForce ControllerBase::calculate_u(const ControlInput& in) {
  const SingleThreadGuard::Hold hold(guard_, "controller calculate_u");
  check_input(in);
  const GeneralizedForce u = do_calculate_u(in);
  if (!u.allFinite()) {
    throw SimulationError(detail::concat("controller '", name(),
                                         "' returned a non-finite "
                                         "generalized force [",
                                         u.transpose(), "] at t = ", in.time_s, " s"));
  }
  return u;
}

RotorVector ControllerBase::calculate_actuator_cmd(const ControlInput& in) {
  const SingleThreadGuard::Hold hold(guard_, "controller calculate_actuator_cmd");
  check_input(in);
  const RotorVector w = do_calculate_actuator_cmd(in);
  if (w.size() != model_->num_rotors() || !w.allFinite()) {
    throw SimulationError(detail::concat("controller '", name(), "' returned ", w.size(),
                                         " rotor speeds [", w.transpose(), "] at t = ", in.time_s,
                                         " s; expected ", model_->num_rotors(), " finite values"));
  }
  return w;
}

GeneralizedForce ControllerBase::do_calculate_u(const ControlInput&) {
  throw InvalidArgument(detail::concat("controller '", name(),
                                       "' implements neither calculate_u nor "
                                       "calculate_actuator_cmd"));
}

RotorVector ControllerBase::do_calculate_actuator_cmd(const ControlInput& in) {
  last_allocation_ = allocate(*model_, calculate_u(in), allocation_);
  return last_allocation_.speeds_rad_s;
}

}  // namespace dronetwin
