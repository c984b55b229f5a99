#pragma once
// Runs an Experiment end to end: loads its model, builds the Simulator, applies the input every
// physics step, logs to `out_dir/log.csv` (with its sidecar `out_dir/log.json`, which holds the
// column units and the run settings: io/log_metadata.hpp, docs/log-format.md) and writes
// `out_dir/summary.json`.
//
//   Experiment e = load_experiment("config/experiments/hover_open_loop.yaml");
//   RunSummary s = run_experiment(e, "out/hover");
//   if (!s.ok()) std::cerr << s.failure_message << "\n";
//
// Logging: a row at t = 0 and then after every log.every_n_steps-th step; a run that fails also
// logs its last good state. Statistics (min/max z, max speed, max tilt) are taken over every
// physics step, not only the logged ones. Fields of summary.json: docs/experiment-format.md.
//
// Closed loop (input type controller): the controller is built from its file with
// load_controller() and flown by a ClosedLoop. Before every step (and before the t = 0 row) the
// runner calls ClosedLoop::update(), which runs the controller at its control instants, then logs
// the row, then steps with ClosedLoop::step() (which paces at real time when asked). The log gets
// ref_x, ref_y, ref_z, ref_yaw, u_T, u_tau_x, u_tau_y, u_tau_z, saturated; the summary the
// tracking RMSE over every physics step in the metrics window (ClosedLoopSummary).
//
// Trap: a diverged or non-finite run is not an exception. It returns a summary whose status says
// so (and still writes both files); so does a controller that returns non-finite output (status
// non_finite, its message in failure_message). Bad input (a malformed experiment, a missing model
// or controller file, an unwritable out_dir) throws InvalidArgument before the files are created.

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "dronetwin/app/progress.hpp"
#include "dronetwin/config/experiment.hpp"
#include "dronetwin/core/types.hpp"
#include "dronetwin/core/version.hpp"
#include "dronetwin/integrators/integrator.hpp"
#include "dronetwin/sim/simulator.hpp"

namespace dronetwin {

/// Statistics of one controller diagnostic (ControllerBase::diagnostic_names()) over the
/// controller updates where it was finite (NaN = not applicable at that update).
struct DiagnosticSummary {
  std::string name;
  std::int64_t count = 0;  ///< updates with a finite value
  double sum = 0.0;        ///< e.g. the number of failed solves for a 0/1 flag
  double mean = 0.0, median = 0.0, p99 = 0.0, max = 0.0;  ///< p99: nearest rank; 0 if count = 0
};

/// What a closed-loop run adds to its summary.
struct ClosedLoopSummary {
  std::string controller_name;  ///< ControllerBase::name(), e.g. "cascaded_pid"
  std::string controller_path;
  std::string allocation;      ///< the allocation the controller flew with (exact, thesis)
  std::string reference_type;  ///< setpoint, thesis_pulse, circle, ...
  std::string reference;       ///< Reference::describe()
  double control_rate_hz = 0.0;
  bool real_time = false;
  /// Root-mean-square tracking error [x, y, z, yaw] (m, m, m, rad) of the TRUE state against the
  /// reference at the same instant, over every physics step k (t = k dt, t = 0 included) in the
  /// window; the yaw is atan2-based from q_WB and its error is wrapped into [-pi, pi]. NaN when
  /// the window holds no step.
  Vec4 rmse = Vec4::Constant(std::numeric_limits<double>::quiet_NaN());
  /// The window actually used: the requested one (default [0, end]) clipped to the time reached.
  std::array<double, 2> rmse_window_s{0.0, 0.0};
  std::int64_t rmse_samples = 0;
  std::int64_t control_updates = 0;
  /// Controller runs whose allocation saturated (ClosedLoop::saturated_updates()), and their
  /// share of control_updates (0 when there were none).
  std::int64_t saturated_updates = 0;
  double saturated_fraction = 0.0;
  /// One entry per controller diagnostic, in diagnostic_names() order (empty without any).
  std::vector<DiagnosticSummary> diagnostics;
};

/// What a run with `estimation:` adds to its summary: the estimate against the true state over
/// every physics step.
struct EstimationSummary {
  double position_rmse_m = 0.0;
  double velocity_rmse_m_s = 0.0;
  /// RMS of the rotation angle between the estimated and the true attitude.
  double attitude_rmse_rad = 0.0;
  std::int64_t samples = 0;
  std::int64_t updates = 0;  ///< measurement updates applied
  bool controller_on_estimate = false;
};

/// The frames of one depth camera of a run: <name>.npy, float32, shape (frames, height, width).
struct DepthFramesSummary {
  std::string name;
  std::string path;
  std::int64_t frames = 0;
  int height_px = 0, width_px = 0;
};

struct RunSummary {
  std::string experiment_name;
  std::string experiment_path;
  std::string model_name;
  std::string model_path;
  /// The experiment's scene file; empty without one.
  std::string scene_path;
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
  /// Status collided: what the vehicle touched ("obstacle 'pillar' (box)"); empty otherwise.
  std::string collided_with;
  int touchdowns = 0;
  double max_touchdown_speed_m_s = 0.0;

  /// Set when the input is a controller.
  std::optional<ClosedLoopSummary> closed_loop;
  /// Set when the experiment has `estimation:`.
  std::optional<EstimationSummary> estimation;
  /// One per depth camera of the experiment.
  std::vector<DepthFramesSummary> depth_frames;

  std::int64_t log_rows = 0;
  double wall_clock_s = 0.0;
  /// Simulated seconds per wall-clock second.
  double real_time_factor = 0.0;
  std::string version;
  std::string log_path;
  std::string summary_path;
  /// The log's JSON sidecar (io/log_metadata.hpp), next to log_path.
  std::string metadata_path;

  /// What the run could do but a user should know (the model cannot hover at the experiment's
  /// gravity, so its "hover" rotor speeds are clamped to the limits, ...). Also in summary.json.
  std::vector<std::string> warnings;

  bool ok() const { return status == StepStatus::kOk; }
};

/// Runs `experiment` (checks it against its model first) and writes out_dir/log.csv,
/// out_dir/log.json and out_dir/summary.json, creating out_dir if needed. The folder is locked
/// for the run (a second run into it fails at once), the files are written under temporary
/// names and moved into place when the run ends (logging/output_folder.hpp), and an earlier
/// run's files are replaced only with `overwrite` (the CLI's --force); an output that is one of
/// the inputs is always refused.
/// `progress`, when given, is told how far the run has come (app/progress.hpp).
RunSummary run_experiment(const Experiment& experiment, const std::string& out_dir,
                          bool overwrite = false, const RunProgressFn& progress = {});

/// Same with an already loaded model (sweeps over seeds or settings load it once);
/// experiment.model_path is only reported. The sidecar's model_hash is that file's hash if the
/// file describes the same model (same numbers and name), else null.
RunSummary run_experiment(const Experiment& experiment, std::shared_ptr<const VehicleModel> model,
                          const std::string& out_dir, bool overwrite = false,
                          const RunProgressFn& progress = {});

/// The JSON text of summary.json.
std::string summary_to_json(const RunSummary& summary);

}  // namespace dronetwin
