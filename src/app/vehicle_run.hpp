#pragma once
// One vehicle's run of an experiment, in parts (src/app only): run_experiment() flies it alone
// with fly(); run_fleet_experiment() steps several together through a Fleet, then finishes each.
//
//   VehicleRun run(e, model, "out/upper", false, hash);   // checks, builds, opens the log
//   fleet.add("upper", run.simulator(), run.loop(), &run.observer());
//   ... fleet.run(...) ...
//   RunSummary s = run.finish(result);                    // summary.json, files moved into place
//
// Everything run_experiment() promises about the output folder holds: nothing is written until
// every input has been checked, the files go to temporaries, and finish() moves them into place.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dronetwin/app/progress.hpp"
#include "dronetwin/app/run_experiment.hpp"
#include "dronetwin/control/closed_loop.hpp"

namespace dronetwin::app_detail {

class VehicleRun {
 public:
  /// `interaction_columns` adds the downwash_* log columns; `more_inputs` are files the output
  /// may not replace besides the experiment's own (a fleet file).
  VehicleRun(const Experiment& experiment, std::shared_ptr<const VehicleModel> model,
             const std::string& out_dir, bool overwrite, std::optional<std::string> model_hash,
             bool interaction_columns = false, std::vector<std::string> more_inputs = {});
  ~VehicleRun();
  VehicleRun(const VehicleRun&) = delete;
  VehicleRun& operator=(const VehicleRun&) = delete;

  Simulator& simulator();
  ClosedLoop& loop();
  LoopObserver& observer();
  const Experiment& experiment() const;
  /// Told the run's progress (app/progress.hpp) as it flies; none by default.
  void set_progress(RunProgressFn progress);

  /// ClosedLoop::run() over the experiment's duration, shown to the observer.
  StepResult fly();
  /// Writes summary.json and moves the files into place. `collided_with` names what a fleet
  /// vehicle touched ("vehicle 'upper'"); empty otherwise.
  RunSummary finish(const StepResult& result, const std::string& collided_with = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dronetwin::app_detail
