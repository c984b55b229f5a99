#pragma once
// Fleet: several vehicles in one world, stepped in lockstep (docs/fleet.md).
//
// Each vehicle is a Simulator with its own model, settings and seed, flown by its own ClosedLoop
// (controller and reference). Every step the fleet
//
//   1. computes each vehicle's wake (dynamics/downwash.hpp) from the states and rotor speeds at
//      the step's start, and hands every vehicle the others' effect (Simulator::set_interaction:
//      held over the step, as the rotor speeds are);
//   2. steps every vehicle, in the order they were added (each reads only its own data, so the
//      order does not change the result);
//   3. checks every pair for contact: the collision shapes' spheres (a box's circumscribed one)
//      overlapping is a crash of both, status kCollided;
//   4. runs the controllers due at the new instant and shows every vehicle to its observer.
//
// The first vehicle to fail (diverged, crashed into another, its controller threw) stops the
// whole fleet: FleetResult names it.
//
//   Fleet fleet(DownwashSettings{});
//   fleet.add("upper", upper_sim, upper_loop);
//   fleet.add("lower", lower_sim, lower_loop, &lower_log);   // a LoopObserver, may be null
//   FleetResult r = fleet.run(10.0);
//   fleet.downwash(1).wrench_B   // what the upper one's wake did to the lower one, last step
//
// Threads: one thread runs a fleet; its simulators and controllers are held for the run (another
// thread using them meanwhile gets a SimulationError, as with ClosedLoop::run()).

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/dynamics/downwash.hpp"
#include "dronetwin/sim/simulator.hpp"

namespace dronetwin {

struct FleetResult {
  StepStatus status = StepStatus::kOk;
  /// Lockstep steps every vehicle took.
  std::int64_t steps_taken = 0;
  /// The vehicle that failed first (-1 while ok) and, for a collision, the one it hit.
  int failed_vehicle = -1;
  int other_vehicle = -1;
  std::string failure_message;
  bool ok() const { return status == StepStatus::kOk; }
};

class Fleet {
 public:
  explicit Fleet(DownwashSettings downwash = {});

  /// Adds a vehicle: `sim` flown by `loop` (loop.simulator() must be `sim`), shown to `observer`
  /// (may be null). All three must outlive the fleet. InvalidArgument for an empty or repeated
  /// name, another simulator's loop, or a time step different from the first vehicle's.
  int add(std::string name, Simulator& sim, ClosedLoop& loop, LoopObserver* observer = nullptr);

  /// Steps all vehicles together until `duration_s` has passed (ClosedLoop::steps_for) or one
  /// fails. Every observer sees its loop at the start, after every step, and once at the end
  /// (LoopObserver::finish, with that vehicle's own status).
  FleetResult run(double duration_s);

  int size() const { return static_cast<int>(vehicles_.size()); }
  const std::string& name(int i) const { return vehicles_.at(static_cast<std::size_t>(i)).name; }
  const Simulator& simulator(int i) const { return *vehicles_.at(static_cast<std::size_t>(i)).sim; }
  /// What the other vehicles' wakes did to vehicle i over the last step (zero before the first).
  const DownwashEffect& downwash(int i) const {
    return vehicles_.at(static_cast<std::size_t>(i)).downwash;
  }
  const DownwashSettings& downwash_settings() const { return downwash_; }
  /// The first pair (i < j) whose contact spheres overlap now, or {-1, -1}.
  std::pair<int, int> find_contact() const;
  /// Centre distance below which vehicles i and j touch, m (sum of their spheres' radii).
  double contact_distance_m(int i, int j) const;

 private:
  struct Vehicle {
    std::string name;
    Simulator* sim = nullptr;
    ClosedLoop* loop = nullptr;
    LoopObserver* observer = nullptr;
    DownwashEffect downwash;
    StepResult result;
  };
  void apply_downwash();
  /// run() with the simulators and controllers from i on taken for this thread.
  FleetResult run_holding(std::size_t i, double duration_s);
  FleetResult run_held(double duration_s);

  DownwashSettings downwash_;
  std::vector<Vehicle> vehicles_;
  std::vector<WakeSource> wakes_;  // scratch, one per vehicle
  std::vector<WakeSource> others_;
};

}  // namespace dronetwin
