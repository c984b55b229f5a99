#pragma once
// PolicyController: a trained policy (a .dtpolicy file) flown as a ControllerBase, with the
// conventions of the RL environment it was trained in (docs/rl.md, "Flying a policy").
//
// Every call is one physics step. At the env's control rate (the env's control_rate_hz) the
// controller builds the observation the env would have built (rl/observation.hpp, from the
// measured state, the previous action and the task's target), evaluates the network
// (policy/mlp.hpp, no allocation) and turns the action into its inner loop's input exactly as the
// env does (clipped to the same box, rl/action_space.hpp); between policy steps the inner loop
// runs on its own:
//   relative_position  SE(3) to p + a (p measured at the policy step), yaw held at the start yaw
//   global_position    SE(3) to [x, y, z, yaw]
//   ctbr               body-rate controller with [T, w]
//   generalized_force  [T, tau] as is (allocated by ControllerBase)
//   rotor_speeds       the speeds as rotor references (ControlLevel::kRotorSpeed)
// The task's target: hover and trajectory, the reference the controller is given (position and
// velocity); racing, the next gate of the env's track, counted by the controller as the measured
// position passes through each gate (gates_passed, laps in the diagnostics).
//
//   PolicyFile policy = read_policy("models/policies/hover_ctbr.dtpolicy");  // config/policy_io
//   EnvFile env = load_env_config("config/rl/hover.yaml", overrides);         // config/
//   PolicyController c(model, std::make_shared<const PolicyFile>(policy), env.config);
//
// Trap: it must be called at the physics rate (an experiment's control_rate_hz = 1 / dt_s), as the
// env's inner loop is; it refuses a policy whose observation or action convention is not the
// env's, and a policy that observes rotor speeds (a controller does not see them).

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "dronetwin/control/body_rate.hpp"
#include "dronetwin/control/controller_base.hpp"
#include "dronetwin/control/se3.hpp"
#include "dronetwin/policy/mlp.hpp"
#include "dronetwin/policy/policy.hpp"
#include "dronetwin/rl/env_config.hpp"
#include "dronetwin/rl/observation.hpp"

namespace dronetwin {

class PolicyController final : public ControllerBase {
 public:
  /// InvalidArgument when the env config is invalid (rl::validate), when the policy does not
  /// match the env (require_env_match), or when it observes rotor speeds.
  PolicyController(std::shared_ptr<const VehicleModel> model,
                   std::shared_ptr<const PolicyFile> policy, rl::EnvConfig env);
  PolicyController(const PolicyController& other);
  PolicyController& operator=(const PolicyController&) = delete;

  std::string_view name() const override { return "policy"; }
  ControlLevel level() const override;
  std::unique_ptr<ControllerBase> clone() const override;
  /// A new episode: the start yaw, the previous action (zeros) and the gate count start over.
  void reset() override;
  bool uses_state_derivative() const override;
  /// gates_passed, laps, then the physical action a_0 ... a_{n-1} of the latest policy step.
  std::vector<std::string> diagnostic_names() const override;
  void diagnostics(double* out) const override;

  const PolicyFile& policy() const { return *policy_; }
  const rl::EnvConfig& env() const { return env_; }
  /// The latest action (physical units, clipped to the box) and observation.
  const std::vector<double>& action() const { return action_; }
  const std::vector<double>& observation() const { return observation_; }
  int gates_passed() const { return gates_passed_; }
  int laps() const { return laps_; }
  /// Policy evaluations so far.
  long long policy_steps() const { return policy_steps_; }

 protected:
  GeneralizedForce do_calculate_u(const ControlInput& in) override;
  RotorVector do_calculate_actuator_cmd(const ControlInput& in) override;

 private:
  void advance(const ControlInput& in);  // gates, then a policy step when one is due
  void policy_step(const ControlInput& in);

  std::shared_ptr<const PolicyFile> policy_;
  rl::EnvConfig env_;
  MlpEvaluator network_;
  std::vector<rl::PieceSlice> layout_;
  std::vector<double> low_, high_;  // the action box
  double period_s_ = 0.01;          // 1 / control_rate_hz
  std::unique_ptr<Se3Controller> se3_;
  std::unique_ptr<BodyRateController> rates_;
  // Episode state.
  bool started_ = false;
  double next_policy_time_s_ = 0.0;
  double start_yaw_rad_ = 0.0;
  Vec3 last_position_m_ = Vec3::Zero();
  int next_gate_ = 0, gates_passed_ = 0, laps_ = 0;
  long long policy_steps_ = 0;
  std::vector<double> raw_action_, action_, previous_given_, observation_;
  ReferencePoint se3_reference_{};
  GeneralizedForce force_ = GeneralizedForce::Zero();
  RotorVector speeds_;
};

}  // namespace dronetwin
