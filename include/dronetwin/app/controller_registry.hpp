#pragma once
// The controller registry: a controller object from a parsed controller file
// (config/controller_config.hpp), for a vehicle model and a control rate. Used by the experiment
// runner, the CLI and Python.
//
//   auto model = std::make_shared<const VehicleModel>(load_vehicle_model("models/qdrone2.yaml"));
//   auto controller = load_controller("config/controllers/pid.yaml", model, 1000.0);
//   ClosedLoop loop(sim, *controller, reference, 1000.0);   // the rate given to the loader
//
// type nmpc builds an NmpcController (docs/controllers.md section 8): the control rate is the rate
// it is called at (its inner loop); horizon.step_s must be a whole number of those periods.
//
// Trap: the control rate is part of the PID (its integral is a sum times the period); build the
// controller with the rate the ClosedLoop will run at.

#include <memory>
#include <string>

#include "dronetwin/config/controller_config.hpp"
#include "dronetwin/control/controller_base.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

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
