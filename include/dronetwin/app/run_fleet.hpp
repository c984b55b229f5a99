#pragma once
// Runs a fleet experiment (config/fleet_experiment.hpp) end to end: every vehicle's experiment
// built as run_experiment() would, the vehicles stepped together by a Fleet (fleet/fleet.hpp),
// each logged to its own folder, plus a fleet summary.
//
//   FleetExperiment f = load_fleet_experiment("config/experiments/crossing_downwash.yaml");
//   FleetRunSummary s = run_fleet_experiment(f, "out/crossing");
//   // out/crossing/upper/{log.csv, log.json, summary.json}, out/crossing/lower/...,
//   // out/crossing/fleet_summary.json
//
// A vehicle's folder is exactly what run_experiment() writes (its log has the downwash_*
// columns besides), so every tool that reads a run reads it. Trap: as with run_experiment(), a
// failed flight is a status, not an exception; bad files throw InvalidArgument before any output
// is in place.

#include <cstdint>
#include <string>
#include <vector>

#include "dronetwin/app/progress.hpp"
#include "dronetwin/app/run_experiment.hpp"
#include "dronetwin/config/fleet_experiment.hpp"

namespace dronetwin {

struct FleetVehicleSummary {
  std::string name;
  std::string folder;
  RunSummary run;
  /// Over every step: the largest wake speed at the centre of mass, m/s, and the largest drop of
  /// the rotors' total thrust in the wake (-downwash_force_z), N.
  double max_downwash_flow_m_s = 0.0;
  double max_thrust_loss_N = 0.0;
};

struct FleetRunSummary {
  std::string experiment_name;
  std::string experiment_path;
  DownwashSettings downwash;
  std::int64_t steps_requested = 0;
  std::int64_t steps = 0;
  double duration_s = 0.0;
  StepStatus status = StepStatus::kOk;
  /// Which vehicle failed and why ("vehicle 'lower': touched vehicle 'upper' at t = ...").
  std::string failure_message;
  std::vector<FleetVehicleSummary> vehicles;
  std::string summary_path;
  double wall_clock_s = 0.0;
  bool ok() const { return status == StepStatus::kOk; }
};

/// Writes out_dir/<vehicle>/ for each vehicle and out_dir/fleet_summary.json; `overwrite` and
/// `progress` as for run_experiment().
FleetRunSummary run_fleet_experiment(const FleetExperiment& fleet, const std::string& out_dir,
                                     bool overwrite = false, const RunProgressFn& progress = {});

std::string fleet_summary_to_json(const FleetRunSummary& summary);

}  // namespace dronetwin
