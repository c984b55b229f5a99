#pragma once
// Runs an Experiment end to end: loads its model, builds the Simulator, applies the input every
// physics step, logs to `out_dir/log.csv` and writes `out_dir/summary.json`.
//
//   Experiment e = load_experiment("config/experiments/hover_open_loop.yaml");
//   RunSummary s = run_experiment(e, "out/hover");
//   if (!s.ok()) std::cerr << s.failure_message << "\n";
//
// Logging: a row at t = 0 and then after every log.every_n_steps-th step; a run that fails also
// logs its last good state. Statistics (min/max z, max speed, max tilt) are taken over every
// physics step, not only the logged ones. Fields of summary.json: docs/experiment-format.md.
//
// Trap: a diverged or non-finite run is not an exception. It returns a summary whose status says
// so (and still writes both files); bad input (a malformed experiment, a missing model, an
// unwritable out_dir) throws InvalidArgument before or while the files are created.

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "dronetwin/core/types.hpp"
#include "dronetwin/integrators/integrator.hpp"
#include "dronetwin/io/experiment.hpp"
#include "dronetwin/sim/simulator.hpp"

namespace dronetwin {

/// The dronetwin version this library was built as (the CMake project version).
std::string_view version();

struct RunSummary {
  std::string experiment_name;
  std::string experiment_path;
  std::string model_name;
  std::string model_path;
  std::uint64_t seed = 0;
  double dt_s = 0.0;
  Integrator integrator = Integrator::kRk4;
  std::string input_type;
  /// Steps the experiment asked for and steps actually taken (fewer when the run failed).
  std::int64_t steps_requested = 0;
  std::int64_t steps = 0;
  /// Simulated time reached, s.
  double duration_s = 0.0;
  StepStatus status = StepStatus::kOk;
  std::string failure_message;

  double final_time_s = 0.0;
  StateVector final_state = StateVector::Zero();
  RotorVector final_rotor_speeds_rad_s;

  double min_z_m = 0.0;
  double max_z_m = 0.0;
  double max_speed_m_s = 0.0;
  /// Largest angle between body z and world z, rad.
  double max_tilt_rad = 0.0;
  bool crashed = false;
  int touchdowns = 0;
  double max_touchdown_speed_m_s = 0.0;

  std::int64_t log_rows = 0;
  double wall_clock_s = 0.0;
  /// Simulated seconds per wall-clock second.
  double real_time_factor = 0.0;
  std::string version;
  std::string log_path;
  std::string summary_path;

  bool ok() const { return status == StepStatus::kOk; }
};

/// Runs `experiment` (checks it against its model first) and writes out_dir/log.csv and
/// out_dir/summary.json, creating out_dir if needed.
RunSummary run_experiment(const Experiment& experiment, const std::string& out_dir);

/// Same with an already loaded model (sweeps over seeds or settings load it once);
/// experiment.model_path is only reported.
RunSummary run_experiment(const Experiment& experiment, std::shared_ptr<const VehicleModel> model,
                          const std::string& out_dir);

/// The JSON text of summary.json.
std::string summary_to_json(const RunSummary& summary);

}  // namespace dronetwin
