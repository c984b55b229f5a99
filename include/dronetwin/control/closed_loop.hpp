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
// run() is THE run loop of dronetwin: the experiment runner, Python's record() and plain runs all
// go through it. An observer sees the loop at the start and after every step, once the
// controller has run for that instant (the row of a log at time t shows the command in effect
// from t on), and once more when the run stops:
//
//   struct Log : LoopObserver {
//     void observe(const ClosedLoop& l) override { rows.push_back(l.simulator().state()); }
//     std::vector<StateVector> rows;
//   } log;
//   StepResult r = loop.run(10.0, &log);     // r.status: ok, non_finite, diverged or
//                                            // controller_failed (loop.failure_message() says why)
//
// Trap: the loop keys "already ran" on Simulator::step_count(). After Simulator::reset() (the
// count starts again at 0) build a new ClosedLoop, or the controller would skip step 0.

#include <chrono>
#include <cstdint>
#include <string>

#include "dronetwin/control/controller_base.hpp"
#include "dronetwin/control/reference.hpp"
#include "dronetwin/sim/simulator.hpp"

namespace dronetwin {

class ClosedLoop;

/// What run() shows a run to (logs, statistics, recorders).
class LoopObserver {
 public:
  virtual ~LoopObserver() = default;
  /// At the start and after every step, after the controller has run for that instant.
  virtual void observe(const ClosedLoop& loop) = 0;
  /// Once, when the run stops: finished, refused by the simulator, or the controller failed.
  virtual void finish(const ClosedLoop& loop, const StepResult& result) {
    (void)loop;
    (void)result;
  }
};

/// Where the controller's state comes from when it is not the simulator's measured state: a
/// sensor suite and an estimator (app/run_experiment.cpp). sense() runs once per physics step,
/// before the controller may run at that step (and at step 0), so a controller at step k reads
/// an estimate that has seen the sensors' readings up to step k.
class StateSource {
 public:
  virtual ~StateSource() = default;
  virtual void sense(const Simulator& sim) = 0;
  /// The state the controller reads ([p, v, q, w]).
  virtual const StateVector& state() const = 0;
};

class ClosedLoop {
 public:
  /// Throws InvalidArgument when control_rate_hz is not positive or does not divide the physics
  /// rate into a whole number of steps, or when controller and simulator models differ in rotor
  /// count. `sim`, `controller` and `reference` must outlive the loop.
  ClosedLoop(Simulator& sim, ControllerBase& controller, const Reference& reference,
             double control_rate_hz);
  /// A temporary reference would dangle as soon as the constructor returns: refused at compile
  /// time (found by AddressSanitizer in a test that passed SetpointReference(...) inline).
  ClosedLoop(Simulator& sim, ControllerBase& controller, const Reference&& reference,
             double control_rate_hz) = delete;

  /// Runs the controller and sets the simulator's rotor speed reference if the current step count
  /// is a control instant (a multiple of steps_per_control()) and the controller has not yet run
  /// at this step count. Returns true if it ran. Idempotent between two steps.
  bool update();
  /// update() for code that steps the loop itself (a Fleet): a controller that throws returns
  /// false, its message in failure_message(), as in run().
  bool try_update();
  /// One physics step: update(), Simulator::step(), then real-time pacing if enabled.
  StepResult step();
  /// Steps until `duration_s` of simulated time has passed (steps_for(duration_s, dt) steps) or
  /// the run fails, showing every instant to `observer` (may be null). A controller that throws
  /// (a non-finite command, or an InvalidArgument such as a non-finite reference) ends the run with
  /// status controller_failed and its message in failure_message(); nothing is stepped after it.
  StepResult run(double duration_s, LoopObserver* observer = nullptr);

  /// Physics steps in `duration_s`: duration_s / dt_s rounded up, a duration within 1e-9 steps of
  /// a whole multiple giving exactly that multiple (as Experiment::num_steps()).
  static std::int64_t steps_for(double duration_s, double dt_s);

  /// Why run() stopped with controller_failed; empty otherwise.
  const std::string& failure_message() const { return failure_message_; }

  /// Controllers read `source->state()` instead of Simulator::measured_state(), and the source
  /// senses every physics step (null: back to the measured state). Must outlive the loop.
  void set_state_source(StateSource* source) { source_ = source; }

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
  /// update() for run(): a controller failure becomes `result.status` and failure_message_.
  bool guarded_update(StepResult& result);

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
  StateSource* source_ = nullptr;
  std::int64_t last_sensed_step_ = -1;
  /// Step count at which the controller last ran (-1: never).
  std::int64_t last_update_step_ = -1;
  std::chrono::steady_clock::time_point wall_start_{};
  double sim_start_s_ = 0.0;
  bool started_ = false;
  std::string failure_message_;
};

}  // namespace dronetwin
