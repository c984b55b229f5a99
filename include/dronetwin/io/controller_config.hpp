#pragma once
// Controller files (YAML): which controller, its gains, limits and options. Format:
// docs/controllers.md. Parsing is strict: an unknown key, a missing gain, a wrong vector length, a
// non-number, a non-finite or negative gain is an InvalidArgument that starts with the file and
// names the field ("pid.yaml: gains.outer_p: expected 4 numbers [x, y, z, psi], got 3 (line 4)").
//
//   auto model = std::make_shared<const VehicleModel>(load_vehicle_model("models/qdrone2.yaml"));
//   auto controller = load_controller("config/controllers/pid.yaml", model, 1000.0);
//   ClosedLoop loop(sim, *controller, reference, 1000.0);   // the rate given to the loader
//
// Omitted `limits` and `options` mean the controller as printed in the thesis (every
// modification off); the gains section is required in full. The mass used by the controllers is
// the model's unless the file sets mass_kg.
//
// type nmpc builds an NmpcController (docs/controllers.md section 8): the control rate is the rate
// it is called at (its inner loop); horizon.step_s must be a whole number of those periods.
//
// Trap: the control rate is part of the PID (its integral is a sum times the period); build the
// controller with the rate the ClosedLoop will run at.

#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "dronetwin/control/controller_base.hpp"
#include "dronetwin/control/nmpc.hpp"
#include "dronetwin/control/pid.hpp"
#include "dronetwin/control/se3.hpp"
#include "dronetwin/model/allocation.hpp"

namespace dronetwin {

enum class ControllerType { kPid, kSe3, kNmpc };

constexpr std::string_view controller_type_name(ControllerType t) {
  return t == ControllerType::kPid ? "pid" : (t == ControllerType::kSe3 ? "se3" : "nmpc");
}

/// A parsed controller file. Only the members of `type` are meaningful.
struct ControllerConfig {
  std::string source;       ///< the file (or the source name given to the parser)
  std::string description;  ///< optional free text
  ControllerType type = ControllerType::kPid;
  AllocationMethod allocation = AllocationMethod::kExact;
  /// Mass for gravity compensation and m a_des; empty: the vehicle model's mass.
  std::optional<double> mass_kg;
  double gravity_m_s2 = 9.81;
  PidGains pid_gains;
  PidOptions pid_options;
  Se3Gains se3_gains;
  Se3Options se3_options;
  /// type nmpc: everything but the mass (nmpc_options.se3.mass_kg is set by make_controller).
  NmpcOptions nmpc_options;
};

/// Reads and checks a controller file. Throws InvalidArgument "<path>: <field>: <what>".
ControllerConfig load_controller_config(const std::string& path);
/// Same, from YAML text; `source_name` stands for the file in messages.
ControllerConfig parse_controller_config(const std::string& yaml_text,
                                         const std::string& source_name);

/// Builds the controller a config describes for `model` at `control_rate_hz` (the PID's period is
/// 1 / control_rate_hz). Throws InvalidArgument for a null model or a non-positive rate.
std::unique_ptr<ControllerBase> make_controller(const ControllerConfig& config,
                                                std::shared_ptr<const VehicleModel> model,
                                                double control_rate_hz);

/// parse_controller_config + make_controller.
std::unique_ptr<ControllerBase> make_controller_from_yaml(const std::string& yaml_text,
                                                          const std::string& source_name,
                                                          std::shared_ptr<const VehicleModel> model,
                                                          double control_rate_hz);

/// load_controller_config + make_controller.
std::unique_ptr<ControllerBase> load_controller(const std::string& path,
                                                std::shared_ptr<const VehicleModel> model,
                                                double control_rate_hz);

}  // namespace dronetwin
