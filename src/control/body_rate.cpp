#include "dronetwin/control/body_rate.hpp"

#include <cmath>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

BodyRateController::BodyRateController(std::shared_ptr<const VehicleModel> model,
                                       const BodyRateGains& gains, AllocationMethod allocation)
    : ControllerBase(std::move(model), allocation), gains_(gains) {
  for (int i = 0; i < 3; ++i)
    require(std::isfinite(gains_.rate_p[i]) && gains_.rate_p[i] >= 0.0, "body_rate: rate_p[", i,
            "]: expected a finite gain >= 0, got ", gains_.rate_p[i]);
}

std::unique_ptr<ControllerBase> BodyRateController::clone() const {
  return std::make_unique<BodyRateController>(*this);
}

void BodyRateController::reset() {
  thrust_N_ = 0.0;
  rates_rad_s_.setZero();
}

void BodyRateController::set_command(double thrust_N, const Vec3& rates_rad_s) {
  require(std::isfinite(thrust_N) && thrust_N >= 0.0,
          "body_rate: thrust command: expected a finite value >= 0 N, got ", thrust_N);
  for (int i = 0; i < 3; ++i)
    require(std::isfinite(rates_rad_s[i]), "body_rate: rate command[", i,
            "]: expected a finite rate in rad/s, got ", rates_rad_s[i]);
  thrust_N_ = thrust_N;
  rates_rad_s_ = rates_rad_s;
}

GeneralizedForce BodyRateController::do_calculate_u(const ControlInput& in) {
  const Vec3 w_B = in.state.segment<3>(state_index::kAngularVelocity);
  const Vec3 tau = body_rate_law<double>(gains_.rate_p, model().inertia_kgm2(), w_B, rates_rad_s_);
  return GeneralizedForce(thrust_N_, tau[0], tau[1], tau[2]);
}

}  // namespace dronetwin
