#pragma once
// Controller files (YAML): which controller, its gains, limits and options. Format:
// docs/controllers.md. Parsing is strict: an unknown key, a missing gain, a wrong vector length, a
// non-number, a non-finite or negative gain is an InvalidArgument that starts with the file and
// names the field ("pid.yaml: gains.outer_p: expected 4 numbers [x, y, z, psi], got 3 (line 4)").
//
//   ControllerConfig c = load_controller_config("config/controllers/pid.yaml");
//   const PidSettings& pid = std::get<PidSettings>(c.settings);     // gains and options
//   auto controller = make_controller(c, model, 1000.0);            // app/controller_registry.hpp
//
// Omitted `limits` and `options` mean the controller as printed in the thesis (every
// modification off); the gains section is required in full. The mass used by the controllers is
// the model's unless the file sets mass_kg.
//
// The settings of each controller type are one alternative of a variant (like ExperimentInput);
// building the controller object from them is app/controller_registry.hpp.

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>

#include "dronetwin/control/pid.hpp"
#include "dronetwin/control/se3.hpp"
#include "dronetwin/model/allocation.hpp"
#include "dronetwin/nmpc/nmpc.hpp"
#include "dronetwin/policy/policy.hpp"
#include "dronetwin/rl/env_config.hpp"

namespace dronetwin {

enum class ControllerType { kPid, kSe3, kNmpc };

constexpr std::string_view controller_type_name(ControllerType t) {
  return t == ControllerType::kPid ? "pid" : (t == ControllerType::kSe3 ? "se3" : "nmpc");
}

/// `type: pid`: cascaded PID (docs/controllers.md). mass_kg and gravity_m_s2 of the gains are set
/// from the file's top level (or the model) when the controller is built.
struct PidSettings {
  PidGains gains;
  PidOptions options;
};
/// `type: se3`: geometric SE(3) controller.
struct Se3Settings {
  Se3Gains gains;
  Se3Options options;
};
/// `type: nmpc`: everything but the mass (options.se3.mass_kg is set when it is built).
struct NmpcSettings {
  NmpcOptions options;
};
/// `type: policy`: a trained policy (.dtpolicy, docs/policy-format.md) flown with the conventions
/// of the RL environment it was trained in (policy/policy_controller.hpp). Both files are read
/// and checked against each other when the controller file is read.
struct PolicySettings {
  std::string policy_path;  ///< the .dtpolicy file, resolved
  std::string env_path;     ///< the environment file, resolved
  std::shared_ptr<const PolicyFile> policy;
  rl::EnvConfig env;  ///< the environment file with the controller file's env_overrides
};
/// One alternative per controller type, in ControllerType order.
using ControllerSettings = std::variant<PidSettings, Se3Settings, NmpcSettings, PolicySettings>;

/// A parsed controller file.
struct ControllerConfig {
  std::string source;       ///< the file (or the source name given to the parser)
  std::string description;  ///< optional free text
  AllocationMethod allocation = AllocationMethod::kExact;
  /// Mass for gravity compensation and m a_des; empty: the vehicle model's mass.
  std::optional<double> mass_kg;
  double gravity_m_s2 = 9.81;
  ControllerSettings settings = PidSettings{};

  ControllerType type() const { return static_cast<ControllerType>(settings.index()); }
};

/// Reads and checks a controller file. Throws InvalidArgument "<path>: <field>: <what>".
ControllerConfig load_controller_config(const std::string& path);
/// Same, from YAML text; `source_name` stands for the file in messages.
ControllerConfig parse_controller_config(const std::string& yaml_text,
                                         const std::string& source_name);

}  // namespace dronetwin
