#pragma once
// An experiment's open-loop input (constant or piecewise rotor speeds, a constant generalized
// force, hover; config/experiment.hpp) as a controller, so that every experiment flies through
// the one run loop, ClosedLoop::run(), at the physics rate.
//
//   OpenLoopInput input(experiment, model);
//   SetpointReference none(Vec3::Zero());
//   ClosedLoop loop(sim, input, none, 1.0 / experiment.sim.dt_s);
//
// The command at step k (t = k dt) is the last schedule entry whose start step is <= k
// (segment_start_step(); of segments that land on one step the last one wins), or the
// generalized force allocated with the input's allocation method. It ignores the reference and
// the state derivative.

#include <cstdint>
#include <memory>
#include <string_view>
#include <vector>

#include "dronetwin/config/experiment.hpp"
#include "dronetwin/control/controller_base.hpp"

namespace dronetwin {

class OpenLoopInput final : public ControllerBase {
 public:
  /// `experiment.input` must be an open-loop input (InvalidArgument for a controller input) and
  /// match `model` (check_against_model()).
  OpenLoopInput(const Experiment& experiment, std::shared_ptr<const VehicleModel> model);

  std::string_view name() const override { return "open_loop"; }
  ControlLevel level() const override {
    return use_force_ ? ControlLevel::kGeneralizedForce : ControlLevel::kRotorSpeed;
  }
  std::unique_ptr<ControllerBase> clone() const override {
    return std::make_unique<OpenLoopInput>(*this);
  }
  bool uses_state_derivative() const override { return false; }

 protected:
  GeneralizedForce do_calculate_u(const ControlInput& in) override;
  RotorVector do_calculate_actuator_cmd(const ControlInput& in) override;

 private:
  struct Entry {
    std::int64_t start_step;
    RotorVector reference_rad_s;
  };
  double dt_s_;
  std::vector<Entry> schedule_;
  GeneralizedForce force_ = GeneralizedForce::Zero();
  bool use_force_ = false;
};

}  // namespace dronetwin
