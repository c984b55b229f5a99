// Controller objects from controller files (controller_registry.hpp).
#include "dronetwin/app/controller_registry.hpp"

#include <cmath>
#include <utility>
#include <variant>

#include "dronetwin/control/pid.hpp"
#include "dronetwin/control/se3.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/nmpc/nmpc.hpp"
#include "dronetwin/policy/policy_controller.hpp"

namespace dronetwin {
namespace {
template <class... Fs>
struct Overloaded : Fs... {
  using Fs::operator()...;
};
template <class... Fs>
Overloaded(Fs...) -> Overloaded<Fs...>;
}  // namespace

std::unique_ptr<ControllerBase> make_controller(const ControllerConfig& config,
                                                std::shared_ptr<const VehicleModel> model,
                                                double control_rate_hz) {
  require(model != nullptr, config.source, ": controller: model is null");
  require(std::isfinite(control_rate_hz) && control_rate_hz > 0.0, config.source,
          ": control_rate_hz: expected > 0, got ", control_rate_hz);
  const double mass = config.mass_kg.value_or(model->mass_kg());
  // One lambda per controller type: a type added to ControllerSettings without one does not
  // compile.
  return std::visit(
      Overloaded{
          [&](const PidSettings& pid) -> std::unique_ptr<ControllerBase> {
            PidGains g = pid.gains;
            g.mass_kg = mass;
            g.gravity_m_s2 = config.gravity_m_s2;
            return std::make_unique<CascadedPid>(model, g, pid.options, 1.0 / control_rate_hz,
                                                 config.allocation);
          },
          [&](const Se3Settings& se3) -> std::unique_ptr<ControllerBase> {
            Se3Gains g = se3.gains;
            g.mass_kg = mass;
            g.gravity_m_s2 = config.gravity_m_s2;
            return std::make_unique<Se3Controller>(model, g, se3.options, config.allocation);
          },
          [&](const PolicySettings& policy) -> std::unique_ptr<ControllerBase> {
            // The env's inner loop runs at every physics step and the policy at the env's rate:
            // the controller is called at a whole multiple of the latter (the physics rate).
            const double ratio = control_rate_hz / policy.env.control_rate_hz;
            require(ratio >= 1.0 - 1e-9 && std::abs(ratio - std::round(ratio)) < 1e-9 * ratio,
                    config.source, ": control_rate_hz: a policy trained at ",
                    policy.env.control_rate_hz,
                    " Hz flies with its inner loop at the physics rate; expected a whole multiple "
                    "of it (the physics rate, 1 / physics_dt_s), got ",
                    control_rate_hz);
            try {
              return std::make_unique<PolicyController>(model, policy.policy, policy.env);
            } catch (const InvalidArgument& err) {
              throw InvalidArgument(config.source + ": " + err.what());
            }
          },
          [&](const NmpcSettings& nmpc) -> std::unique_ptr<ControllerBase> {
            NmpcOptions o = nmpc.options;
            o.se3.mass_kg = mass;
            o.se3.gravity_m_s2 = config.gravity_m_s2;
            try {
              return std::make_unique<NmpcController>(model, o, control_rate_hz, config.allocation);
            } catch (const InvalidArgument& err) {
              throw InvalidArgument(config.source + ": " + err.what());
            }
          },
      },
      config.settings);
}

std::unique_ptr<ControllerBase> make_controller_from_yaml(const std::string& yaml_text,
                                                          const std::string& source_name,
                                                          std::shared_ptr<const VehicleModel> model,
                                                          double control_rate_hz) {
  return make_controller(parse_controller_config(yaml_text, source_name), std::move(model),
                         control_rate_hz);
}

std::unique_ptr<ControllerBase> load_controller(const std::string& path,
                                                std::shared_ptr<const VehicleModel> model,
                                                double control_rate_hz) {
  return make_controller(load_controller_config(path), std::move(model), control_rate_hz);
}

}  // namespace dronetwin
