// PolicyController (policy/policy_controller.hpp): the env's step, one vehicle at a time.
#include "dronetwin/policy/policy_controller.hpp"

#include <algorithm>
#include <cmath>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/rl/action_space.hpp"
#include "dronetwin/world/gate.hpp"

namespace dronetwin {

namespace {

std::shared_ptr<const Mlp> network_of(const std::shared_ptr<const PolicyFile>& policy) {
  require(policy != nullptr, "PolicyController: policy: expected a policy, got none");
  return std::shared_ptr<const Mlp>(policy, &policy->mlp);  // shares the file's lifetime
}

rl::EnvConfig checked(rl::EnvConfig env) {
  if (env.observation.empty()) env.observation = rl::default_observation(env.task);
  rl::validate(env);
  return env;
}

}  // namespace

PolicyController::PolicyController(std::shared_ptr<const VehicleModel> model,
                                   std::shared_ptr<const PolicyFile> policy, rl::EnvConfig env)
    : ControllerBase(std::move(model)),
      policy_(std::move(policy)),
      env_(checked(std::move(env))),
      network_(network_of(policy_)) {
  const VehicleModel& m = this->model();
  const rl::ActionBox box = rl::action_box(m, env_);
  low_ = box.low;
  high_ = box.high;
  const int action_size = static_cast<int>(low_.size());
  layout_ =
      rl::observation_layout(env_.observation, action_size, m.num_rotors(), env_.gate_lookahead);
  require(env_.sensors.empty() && env_.depth_cameras.empty(), policy_->source,
          ": the policy observes sensors or depth cameras (its env's `sensors:`), which a "
          "PolicyController does not simulate; evaluate it in a VecEnv instead");
  require_env_match(*policy_, layout_, env_.action, env_.normalized_actions, action_size);
  for (const rl::ObservationPiece p : env_.observation) {
    require(p != rl::ObservationPiece::kRotorSpeeds, policy_->source,
            ": the policy observes rotor_speeds, which a controller is not given (ControlInput "
            "holds the rigid-body state only); fly it in a VecEnv instead");
  }
  require(env_.task != rl::Task::kRacing || !env_.track.gates.empty(),
          "PolicyController: a racing env needs a track with gates");
  period_s_ = 1.0 / env_.control_rate_hz;
  switch (env_.action) {
    case rl::ActionMode::kRelativePosition:
    case rl::ActionMode::kGlobalPosition:
      // The env's gains, its mass included (the env file's model or controller file).
      se3_ = std::make_unique<Se3Controller>(model_ptr(), env_.se3_gains, env_.se3_options);
      break;
    case rl::ActionMode::kCtbr:
      rates_ = std::make_unique<BodyRateController>(model_ptr(), env_.rate_gains);
      break;
    case rl::ActionMode::kRotorSpeeds:
    case rl::ActionMode::kGeneralizedForce:
      break;
  }
  raw_action_.assign(low_.size(), 0.0);
  action_.assign(low_.size(), 0.0);
  previous_given_.assign(low_.size(), 0.0);
  observation_.assign(static_cast<std::size_t>(policy_->observation_size), 0.0);
  speeds_ = m.hover_speeds_rad_s();
  reset();
}

// A copy carries the episode on (clone() is a controller with the same memory).
PolicyController::PolicyController(const PolicyController& other)
    : ControllerBase(other),
      policy_(other.policy_),
      env_(other.env_),
      network_(other.network_),
      layout_(other.layout_),
      low_(other.low_),
      high_(other.high_),
      period_s_(other.period_s_),
      se3_(other.se3_ ? std::make_unique<Se3Controller>(*other.se3_) : nullptr),
      rates_(other.rates_ ? std::make_unique<BodyRateController>(*other.rates_) : nullptr),
      started_(other.started_),
      next_policy_time_s_(other.next_policy_time_s_),
      start_yaw_rad_(other.start_yaw_rad_),
      last_position_m_(other.last_position_m_),
      next_gate_(other.next_gate_),
      gates_passed_(other.gates_passed_),
      laps_(other.laps_),
      policy_steps_(other.policy_steps_),
      raw_action_(other.raw_action_),
      action_(other.action_),
      previous_given_(other.previous_given_),
      observation_(other.observation_),
      se3_reference_(other.se3_reference_),
      force_(other.force_),
      speeds_(other.speeds_) {}

std::unique_ptr<ControllerBase> PolicyController::clone() const {
  return std::make_unique<PolicyController>(*this);
}

ControlLevel PolicyController::level() const {
  return env_.action == rl::ActionMode::kRotorSpeeds ? ControlLevel::kRotorSpeed
                                                     : ControlLevel::kGeneralizedForce;
}

bool PolicyController::uses_state_derivative() const {
  return se3_ != nullptr && se3_->uses_state_derivative();
}

void PolicyController::reset() {
  started_ = false;
  next_policy_time_s_ = 0.0;
  next_gate_ = gates_passed_ = laps_ = 0;
  policy_steps_ = 0;
  // After a reset the env's previous action is the physical zero.
  std::fill(action_.begin(), action_.end(), 0.0);
  if (se3_) se3_->reset();
  if (rates_) rates_->reset();
}

std::vector<std::string> PolicyController::diagnostic_names() const {
  std::vector<std::string> names = {"gates_passed", "laps"};
  for (std::size_t i = 0; i < action_.size(); ++i) {
    std::string n = "action_";
    n += std::to_string(i);
    names.push_back(n);
  }
  return names;
}

void PolicyController::diagnostics(double* out) const {
  out[0] = gates_passed_;
  out[1] = laps_;
  for (std::size_t i = 0; i < action_.size(); ++i) out[2 + i] = action_[i];
}

void PolicyController::advance(const ControlInput& in) {
  const Vec3 p = in.state.segment<3>(state_index::kPosition);
  if (!started_) {
    started_ = true;
    next_policy_time_s_ = in.time_s;
    start_yaw_rad_ = math::to_euler(Vec4(in.state.segment<4>(state_index::kQuaternion)))[2];
    last_position_m_ = p;
  }
  if (env_.task == rl::Task::kRacing) {
    // The env's gate count (rl/vec_env.cpp): the next gate, passed through its opening.
    const Track& track = env_.track;
    const int num_gates = static_cast<int>(track.gates.size());
    if (next_gate_ < num_gates && cross_gate(track.gates[static_cast<std::size_t>(next_gate_)],
                                             last_position_m_, p) == GateCrossing::kThrough) {
      ++gates_passed_;
      if (++next_gate_ == num_gates) {
        ++laps_;
        next_gate_ = track.closed ? 0 : num_gates - 1;
      }
    }
  }
  last_position_m_ = p;
  // Due when the time has come (to a millionth of the period, against rounding of t = k dt).
  if (in.time_s + 1e-6 * period_s_ >= next_policy_time_s_) {
    policy_step(in);
    next_policy_time_s_ += period_s_;
  }
}

void PolicyController::policy_step(const ControlInput& in) {
  const VehicleModel& m = model();
  const std::size_t n = action_.size();
  // The observation (VecEnv::write_observation): the previous action as the policy gave it.
  for (std::size_t i = 0; i < n; ++i) {
    previous_given_[i] = env_.normalized_actions
                             ? 2.0 * (action_[i] - low_[i]) / (high_[i] - low_[i]) - 1.0
                             : action_[i];
  }
  rl::ObservationInput o;
  o.position_m = in.state.segment<3>(state_index::kPosition);
  o.velocity_m_s = in.state.segment<3>(state_index::kVelocity);
  o.quaternion = in.state.segment<4>(state_index::kQuaternion);
  o.body_rates_rad_s = in.state.segment<3>(state_index::kAngularVelocity);
  o.previous_action = previous_given_.data();
  o.track = &env_.track;
  o.next_gate = next_gate_;
  o.gate_lookahead = env_.gate_lookahead;
  if (env_.task == rl::Task::kRacing) {
    o.target_m = env_.track.gates[static_cast<std::size_t>(next_gate_)].center_m;
  } else {
    o.target_m = in.reference.position_m;
    if (env_.task == rl::Task::kTrajectory) o.target_velocity_m_s = in.reference.velocity_m_s;
  }
  rl::write_observation(layout_, o, observation_.data());
  network_.evaluate(observation_.data(), raw_action_.data());
  ++policy_steps_;

  // The action (VecEnv::take_action): clipped to the box, normalised ones mapped onto it.
  for (std::size_t i = 0; i < n; ++i) {
    const double lo = low_[i], hi = high_[i];
    action_[i] = env_.normalized_actions
                     ? lo + 0.5 * (std::clamp(raw_action_[i], -1.0, 1.0) + 1.0) * (hi - lo)
                     : std::clamp(raw_action_[i], lo, hi);
  }
  const Vec3 p = o.position_m;
  switch (env_.action) {
    case rl::ActionMode::kRelativePosition:  // Eq. 4.19
      se3_reference_ = ReferencePoint{};
      se3_reference_.position_m = p + Vec3(action_[0], action_[1], action_[2]);
      se3_reference_.yaw_rad = start_yaw_rad_;
      break;
    case rl::ActionMode::kGlobalPosition:
      se3_reference_ = ReferencePoint{};
      se3_reference_.position_m = Vec3(action_[0], action_[1], action_[2]);
      se3_reference_.yaw_rad = action_[3];
      break;
    case rl::ActionMode::kCtbr:
      rates_->set_command(action_[0], Vec3(action_[1], action_[2], action_[3]));
      break;
    case rl::ActionMode::kGeneralizedForce:
      force_ = GeneralizedForce(action_[0], action_[1], action_[2], action_[3]);
      break;
    case rl::ActionMode::kRotorSpeeds:
      for (int i = 0; i < m.num_rotors(); ++i) speeds_[i] = action_[static_cast<std::size_t>(i)];
      break;
  }
}

GeneralizedForce PolicyController::do_calculate_u(const ControlInput& in) {
  require(env_.action != rl::ActionMode::kRotorSpeeds,
          "PolicyController: a rotor-speed policy has no generalized force; call "
          "calculate_actuator_cmd");
  advance(in);
  switch (env_.action) {
    case rl::ActionMode::kRelativePosition:
    case rl::ActionMode::kGlobalPosition: {
      ControlInput inner = in;
      inner.reference = se3_reference_;
      return se3_->calculate_u(inner);
    }
    case rl::ActionMode::kCtbr:
      return rates_->calculate_u(in);
    default:
      return force_;
  }
}

RotorVector PolicyController::do_calculate_actuator_cmd(const ControlInput& in) {
  if (env_.action != rl::ActionMode::kRotorSpeeds)
    return ControllerBase::do_calculate_actuator_cmd(in);
  advance(in);
  return speeds_;
}

}  // namespace dronetwin
