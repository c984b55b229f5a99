#pragma once
// ClosedLoop: flies a Simulator with a controller tracking a reference.
//
// The controller runs at its own rate (thesis Eq. 3.11: steps per control = f_physics /
// f_control, an integer) and its command is held between updates (zero-order hold). It sees only
// the measured state and state derivative, i.e. with OU noise when noise is on.
//
//   ClosedLoop loop(sim, controller, reference, /*control_rate_hz=*/100.0);
//   StepResult r = loop.run(60.0);            // 60 s of simulated time
//   loop.last_command(), loop.last_allocation()
//
// Split stepping (sense/act, then integrate), e.g. to log the command in effect from t on:
//
//   loop.update();                            // controller runs if step k is a control instant
//   log(sim, loop.last_command());            // the command the next step will fly
//   loop.step();                              // update() again (a no-op now) + sim.step()
//
// update() is idempotent: it runs the controller at most once per simulator step count, so it
// may be called any number of times between steps. step() = update() + Simulator::step() +
// optional real-time pacing, which sleeps so that simulated time advances no faster than wall
// time (real-time factor 1, for hardware in the loop); achieved_real_time_factor() reports it.
//
// Trap: the loop keys "already ran" on Simulator::step_count(). After Simulator::reset() (the
// count starts again at 0) build a new ClosedLoop, or the controller would skip step 0.

#include <chrono>
#include <cstdint>

#include "dronetwin/control/controller_base.hpp"
#include "dronetwin/control/reference.hpp"
#include "dronetwin/sim/simulator.hpp"

namespace dronetwin {

class ClosedLoop {
 public:
  /// Throws InvalidArgument when control_rate_hz is not positive or does not divide the physics
  /// rate into a whole number of steps, or when controller and simulator models differ in rotor
  /// count. `sim`, `controller` and `reference` must outlive the loop.
  ClosedLoop(Simulator& sim, ControllerBase& controller, const Reference& reference,
             double control_rate_hz);

  /// Runs the controller and sets the simulator's rotor speed reference if the current step count
  /// is a control instant (a multiple of steps_per_control()) and the controller has not yet run
  /// at this step count. Returns true if it ran. Idempotent between two steps.
  bool update();
  /// One physics step: update(), Simulator::step(), then real-time pacing if enabled.
  StepResult step();
  /// Steps until `duration_s` of simulated time has passed (or the run fails).
  StepResult run(double duration_s);

  void set_real_time(bool on) { real_time_ = on; }
  bool real_time() const { return real_time_; }
  /// Simulated seconds per wall-clock second since the loop started stepping.
  double achieved_real_time_factor() const;

  int steps_per_control() const { return steps_per_control_; }
  const Reference& reference() const { return reference_; }
  const Simulator& simulator() const { return sim_; }
  const ControllerBase& controller() const { return controller_; }
  const ControlInput& last_input() const { return input_; }
  /// The generalized force [T, tau_x, tau_y, tau_z] the last rotor command produces (for
  /// generalized-force controllers the allocation's achieved force, equal to the controller's u
  /// unless saturated; for rotor-speed controllers the force of the commanded speeds through the
  /// thrust polynomials and the allocation matrix), and the rotor command itself.
  const GeneralizedForce& last_command() const { return u_; }
  const RotorVector& last_rotor_command() const { return w_cmd_; }
  const AllocationResult& last_allocation() const { return controller_.last_allocation(); }
  /// Controller runs so far, and how many of them saturated the allocation (generalized-force
  /// controllers only; last_allocation().saturated).
  std::int64_t control_updates() const { return updates_; }
  std::int64_t saturated_updates() const { return saturated_updates_; }

 private:
  void control();

  Simulator& sim_;
  ControllerBase& controller_;
  const Reference& reference_;
  int steps_per_control_;
  bool real_time_ = false;
  ControlInput input_;
  GeneralizedForce u_ = GeneralizedForce::Zero();
  RotorVector w_cmd_;
  std::int64_t updates_ = 0;
  std::int64_t saturated_updates_ = 0;
  /// Step count at which the controller last ran (-1: never).
  std::int64_t last_update_step_ = -1;
  std::chrono::steady_clock::time_point wall_start_{};
  double sim_start_s_ = 0.0;
  bool started_ = false;
};

}  // namespace dronetwin
