#pragma once
// The box of every action mode (docs/rl.md, "Action modes"): per action element, the physical
// lower and upper bound. VecEnv clips actions to it (and maps normalised ones onto it); a
// deployed policy (policy/policy_controller.hpp) does the same with the same box.
#include <vector>

#include "dronetwin/model/vehicle_model.hpp"
#include "dronetwin/rl/env_config.hpp"

namespace dronetwin::rl {

struct ActionBox {
  std::vector<double> low, high;  ///< physical units, one entry per action element
};

/// The box of `config.action` for vehicle `m` (thrust from its rotors' full speed, or
/// max_thrust_to_weight; rotor speed limits; relative_scale_m; the arena for global positions).
ActionBox action_box(const VehicleModel& m, const EnvConfig& config);

}  // namespace dronetwin::rl
