#include "dronetwin/control/closed_loop.hpp"

#include <algorithm>
#include <cmath>
#include <thread>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

ClosedLoop::ClosedLoop(Simulator& sim, ControllerBase& controller, const Reference& reference,
                       double control_rate_hz)
    : sim_(sim), controller_(controller), reference_(reference) {
  require(std::isfinite(control_rate_hz) && control_rate_hz > 0.0,
          "control_rate_hz: expected > 0, got ", control_rate_hz);
  const double physics_hz = 1.0 / sim.config().dt_s;
  const double ratio = physics_hz / control_rate_hz;
  // Checked before the conversion: a tiny rate gives a ratio no int holds.
  require(std::isfinite(ratio) && ratio >= 0.5 && ratio < 2147483647.0,
          "control_rate_hz: ", control_rate_hz, " Hz gives ", ratio,
          " physics steps per control; expected 1 to ", 2147483646, " (at most the physics rate ",
          physics_hz, " Hz)");
  steps_per_control_ = static_cast<int>(std::lround(ratio));
  require(steps_per_control_ >= 1 && std::abs(ratio - steps_per_control_) < 1e-9 * ratio,
          "control_rate_hz: ", control_rate_hz, " Hz must divide the physics rate (", physics_hz,
          " Hz) into a whole number of steps (thesis Eq. 3.11: f_control <= f_physics)");
  require(controller.model().num_rotors() == sim.model().num_rotors(), "controller '",
          controller.name(), "' was built for ", controller.model().num_rotors(),
          " rotors but the simulator's model has ", sim.model().num_rotors());
  w_cmd_ = sim.rotor_speed_reference_rad_s();
  controller_.set_reference_preview(reference_);  // look-ahead controllers (NMPC) keep a copy
}

void ClosedLoop::control() {
  input_.time_s = sim_.time_s();
  input_.state = source_ != nullptr ? source_->state() : sim_.measured_state();
  if (controller_.uses_state_derivative())
    input_.state_derivative = sim_.measured_state_derivative();
  input_.reference = reference_.at(input_.time_s);
  if (sim_.config().payload.enabled) {
    input_.payload.available = true;
    input_.payload.position_W_m = sim_.payload().position_W_m;
    input_.payload.velocity_W_m_s = sim_.payload().velocity_W_m_s;
  }
  w_cmd_ = controller_.calculate_actuator_cmd(input_);
  if (controller_.level() == ControlLevel::kGeneralizedForce) {
    u_ = controller_.last_allocation().achieved;
    if (controller_.last_allocation().saturated) ++saturated_updates_;
  } else {
    u_ = generalized_force_of(sim_.model(), w_cmd_);  // the motors clamp the commands
  }
  sim_.set_rotor_speed_reference(w_cmd_);
  ++updates_;
}

bool ClosedLoop::update() {
  const std::int64_t k = sim_.step_count();
  if (source_ != nullptr && k != last_sensed_step_) {
    source_->sense(sim_);
    last_sensed_step_ = k;
  }
  if (k == last_update_step_ || k % steps_per_control_ != 0) return false;
  control();
  // Only after a successful run: a controller that threw is called again on the next update().
  last_update_step_ = k;
  return true;
}

StepResult ClosedLoop::step() {
  if (!started_) {
    started_ = true;
    wall_start_ = std::chrono::steady_clock::now();
    sim_start_s_ = sim_.time_s();
  }
  update();
  const StepResult r = sim_.step();
  if (real_time_ && r.ok()) {
    const auto due = wall_start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                       std::chrono::duration<double>(sim_.time_s() - sim_start_s_));
    std::this_thread::sleep_until(due);
  }
  return r;
}

std::int64_t ClosedLoop::steps_for(double duration_s, double dt_s) {
  require(std::isfinite(duration_s) && duration_s >= 0.0, "duration_s: expected >= 0, got ",
          duration_s);
  return static_cast<std::int64_t>(std::ceil(duration_s / dt_s - 1e-9));
}

bool ClosedLoop::guarded_update(StepResult& result) {
  try {
    update();
    return true;
  } catch (const SimulationError& e) {
    failure_message_ = e.what();
  } catch (const InvalidArgument& e) {
    failure_message_ = e.what();
  }
  result.status = StepStatus::kControllerFailed;
  return false;
}

bool ClosedLoop::try_update() {
  StepResult ignored;
  return guarded_update(ignored);
}

StepResult ClosedLoop::run(double duration_s, LoopObserver* observer) {
  const std::int64_t n = steps_for(duration_s, sim_.config().dt_s);
  // One thread flies the loop: another one resetting the simulator or calling the controller
  // meanwhile gets an error instead of corrupting the flight.
  const auto sim_in_use = sim_.exclusive_use("ClosedLoop::run (its simulator)");
  const auto controller_in_use = controller_.exclusive_use("ClosedLoop::run (its controller)");
  StepResult total;
  failure_message_.clear();
  if (guarded_update(total)) {
    if (observer != nullptr) observer->observe(*this);
    for (std::int64_t k = 0; k < n; ++k) {
      // update() already ran for this instant: step() calls it again as a no-op.
      const StepResult r = step();
      if (!r.ok()) {
        total.status = r.status;
        break;
      }
      ++total.steps_taken;
      if (!guarded_update(total)) break;
      if (observer != nullptr) observer->observe(*this);
    }
  }
  if (observer != nullptr) observer->finish(*this, total);
  return total;
}

double ClosedLoop::achieved_real_time_factor() const {
  if (!started_) return 0.0;
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start_).count();
  return wall > 0.0 ? (sim_.time_s() - sim_start_s_) / wall : 0.0;
}

}  // namespace dronetwin
