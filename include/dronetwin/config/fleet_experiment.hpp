#pragma once
// A fleet experiment file: several vehicles flying at once, each described by an ordinary
// experiment file, with the downwash between them (docs/fleet.md, docs/experiment-format.md
// "Fleet experiments").
//
//   name: crossing
//   duration_s: 14
//   downwash: true            # or false, or a map of DownwashSettings
//   vehicles:
//     - {name: upper, experiment: crossing_upper.yaml}
//     - {name: lower, experiment: crossing_lower.yaml}
//
// Each vehicle's experiment gives its model, settings, seed, initial state, controller and
// reference, sensors and log; the fleet's duration replaces theirs. The vehicles must share one
// physics step.
//
//   FleetExperiment f = load_fleet_experiment("config/experiments/crossing_downwash.yaml");
//
// Trap: parsing reads and checks every vehicle's experiment file too (their errors name them).

#include <string>
#include <vector>

#include "dronetwin/config/experiment.hpp"
#include "dronetwin/dynamics/downwash.hpp"

namespace dronetwin {

struct FleetVehicleSpec {
  std::string name;
  std::string experiment_path;
  Experiment experiment;
};

struct FleetExperiment {
  std::string source;
  std::string name;
  std::string description;
  double duration_s = 0.0;
  DownwashSettings downwash;
  std::vector<FleetVehicleSpec> vehicles;
};

FleetExperiment load_fleet_experiment(const std::string& path);
/// `source_name` stands for the file in messages; vehicle experiments are found relative to it.
FleetExperiment parse_fleet_experiment(const std::string& yaml_text,
                                       const std::string& source_name);

/// True when `yaml_text` is a map with a top-level `vehicles` key (what the CLI's `run` uses to
/// tell a fleet file from a single-vehicle one). Never throws.
bool looks_like_fleet_experiment(const std::string& yaml_text);

}  // namespace dronetwin
