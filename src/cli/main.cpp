// The `dronetwin` command-line tool.
//
//   dronetwin run EXPERIMENT.yaml --out DIR [--seed N] [--duration S] [--real-time] [--quiet]
//                 [--progress | --no-progress]
//   dronetwin info MODEL.yaml
//   dronetwin import crazypad|ulog ...; dronetwin identify stand|vertical ...
//   (real_data_commands.hpp) dronetwin --version
//   dronetwin train|evaluate|sweep|export ...   (Python: dronetwin.train, .sweep, .export)
//
// Exit codes: 0 success, 1 internal error, 2 bad input (malformed file, bad option; the message
// goes to stderr as "error: ..."), 3 the run failed (diverged or non-finite state; log and
// summary are still written).
#include <CLI/CLI.hpp>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <exception>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <variant>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "dronetwin/app/progress.hpp"
#include "dronetwin/app/run_experiment.hpp"
#include "dronetwin/app/run_fleet.hpp"
#include "dronetwin/config/experiment.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "fit_command.hpp"
#include "real_data_commands.hpp"

namespace {

using namespace dronetwin;

constexpr int kExitOk = 0;
constexpr int kExitInternal = 1;
constexpr int kExitBadInput = 2;
constexpr int kExitRunFailed = 3;

constexpr double kPi = 3.14159265358979323846;

std::string fixed(double v, int digits) {
  // Values that round to zero print as 0, not -0.000 (e.g. a drift of -7e-32 m).
  if (std::abs(v) < 0.5 * std::pow(10.0, -digits)) v = 0.0;
  std::ostringstream out;
  out << std::fixed << std::setprecision(digits) << v;
  return out.str();
}

std::string vec(const Vec3& v, int digits) {
  return "[" + fixed(v[0], digits) + ", " + fixed(v[1], digits) + ", " + fixed(v[2], digits) + "]";
}

/// "+ 0.5" / "- 0.5" for a polynomial term.
std::string signed_term(double v) {
  std::ostringstream out;
  out << (v < 0.0 ? "- " : "+ ") << std::abs(v);
  return out.str();
}

struct RunOptions {
  std::string experiment;
  std::string out_dir;
  std::string seed;
  double duration_s = 0.0;
  bool quiet = false;
  bool progress = false;
  bool no_progress = false;
  bool real_time = false;
  bool force = false;
  bool seed_given = false;
  bool duration_given = false;
};

/// The run's bar on stderr: on a terminal once the run takes 2 s, always with --progress, never
/// with --no-progress or --quiet.
ProgressBar progress_bar(const RunOptions& o, const std::string& label) {
  const ProgressBar::Mode mode = o.quiet || o.no_progress ? ProgressBar::Mode::kNever
                                 : o.progress             ? ProgressBar::Mode::kAlways
                                                          : ProgressBar::Mode::kAuto;
  return ProgressBar(std::cerr, mode, isatty(STDERR_FILENO) == 1, label);
}

void print_summary(const RunSummary& s) {
  using namespace state_index;
  const double steps_per_s =
      s.wall_clock_s > 0.0 ? static_cast<double>(s.steps) / s.wall_clock_s : 0.0;
  std::cout << s.experiment_name << ": " << status_name(s.status) << ", " << s.steps << " of "
            << s.steps_requested << " steps (" << s.duration_s << " s simulated) in "
            << fixed(s.wall_clock_s, 3) << " s wall clock: " << fixed(steps_per_s, 0)
            << " steps/s, " << fixed(s.real_time_factor, 1) << "x real time\n";
  std::cout << "  model           " << s.model_name << " (" << s.model_path << "), seed " << s.seed
            << ", " << integrator_name(s.integrator) << ", dt " << s.dt_s << " s, input "
            << s.input_type << "\n";
  std::cout << "  final position  " << vec(s.final_state.segment<3>(kPosition), 4) << " m, speed "
            << fixed(s.final_state.segment<3>(kVelocity).norm(), 4) << " m/s\n";
  std::cout << "  z range         [" << fixed(s.min_z_m, 4) << ", " << fixed(s.max_z_m, 4)
            << "] m, max speed " << fixed(s.max_speed_m_s, 4) << " m/s\n";
  std::cout << "  max tilt        " << std::setprecision(6) << s.max_tilt_rad << " rad ("
            << fixed(s.max_tilt_rad * 180.0 / kPi, 3) << " deg)\n";
  std::cout << "  ground          " << (s.crashed ? "CRASHED" : "no crash") << ", touchdowns "
            << s.touchdowns << ", max touchdown speed " << fixed(s.max_touchdown_speed_m_s, 3)
            << " m/s\n";
  if (!s.scene_path.empty())
    std::cout << "  scene           " << s.scene_path << ", "
              << (s.collided_with.empty() ? "nothing touched" : "COLLIDED with " + s.collided_with)
              << "\n";
  if (s.closed_loop) {
    const ClosedLoopSummary& c = *s.closed_loop;
    std::cout << "  controller      " << c.controller_name << " (" << c.controller_path << "), "
              << c.control_rate_hz << " Hz, " << c.allocation << " allocation"
              << (c.real_time ? ", real time" : "") << "\n";
    std::cout << "  reference       " << c.reference_type << ": " << c.reference << "\n";
    std::cout << "  rmse            x " << fixed(c.rmse[0], 4) << " m, y " << fixed(c.rmse[1], 4)
              << " m, z " << fixed(c.rmse[2], 4) << " m, yaw " << fixed(c.rmse[3], 4)
              << " rad over [" << c.rmse_window_s[0] << ", " << c.rmse_window_s[1] << "] s ("
              << c.rmse_samples << " steps)\n";
    std::cout << "  saturation      " << c.saturated_updates << " of " << c.control_updates
              << " control updates (" << fixed(100.0 * c.saturated_fraction, 2) << " %)\n";
  }
  if (s.estimation) {
    const EstimationSummary& es = *s.estimation;
    std::cout << "  estimate        position " << fixed(1000.0 * es.position_rmse_m, 2)
              << " mm, velocity " << fixed(1000.0 * es.velocity_rmse_m_s, 2) << " mm/s, attitude "
              << fixed(es.attitude_rmse_rad * 180.0 / M_PI, 3) << " deg rms, " << es.updates
              << " updates, controller on the "
              << (es.controller_on_estimate ? "estimate" : "measured state") << "\n";
  }
  std::cout << "  wrote           " << s.log_path << " (" << s.log_rows << " rows), "
            << s.summary_path << "\n";
  for (const DepthFramesSummary& d : s.depth_frames)
    std::cout << "  depth frames    " << d.path << " (" << d.frames << " x " << d.height_px << " x "
              << d.width_px << " float32, m)\n";
}

/// `run` of a fleet file (a top-level `vehicles:` list): each vehicle into its own folder.
int run_fleet_command(const RunOptions& o, const std::string& text) {
  require(!o.seed_given,
          "--seed: a fleet file's vehicles each take the seed of their own "
          "experiment file; set it there");
  require(!o.real_time, "--real-time: a fleet steps as fast as it can; not for fleet files");
  FleetExperiment f = parse_fleet_experiment(text, o.experiment);
  if (o.duration_given) {
    require(std::isfinite(o.duration_s) && o.duration_s > 0.0,
            "--duration: expected a number of seconds > 0, got ", o.duration_s);
    f.duration_s = o.duration_s;
    for (FleetVehicleSpec& v : f.vehicles) v.experiment.duration_s = o.duration_s;
  }
  ProgressBar bar = progress_bar(o, f.name);
  const FleetRunSummary s = run_fleet_experiment(f, o.out_dir, o.force, bar.callback());
  bar.finish();
  if (!o.quiet) {
    std::cout << s.experiment_name << ": " << status_name(s.status) << ", " << s.steps << " of "
              << s.steps_requested << " lockstep steps (" << s.duration_s << " s simulated) in "
              << fixed(s.wall_clock_s, 3) << " s wall clock, downwash "
              << (s.downwash.enabled ? "on" : "off") << "\n";
    for (const FleetVehicleSummary& v : s.vehicles) {
      std::cout << "  " << v.name << ": " << status_name(v.run.status) << ", log "
                << v.run.log_path;
      if (v.run.closed_loop)
        std::cout << ", RMSE xyz " << vec(v.run.closed_loop->rmse.head<3>(), 4) << " m";
      std::cout << ", max wake " << fixed(v.max_downwash_flow_m_s, 3) << " m/s, max thrust loss "
                << fixed(v.max_thrust_loss_N, 3) << " N\n";
    }
  }
  if (!s.ok()) {
    std::cerr << "error: run " << status_name(s.status) << ": " << s.failure_message
              << " (logs and summaries written to " << o.out_dir << ")\n";
    return kExitRunFailed;
  }
  return kExitOk;
}

int run_command(const RunOptions& o) {
  const std::string text = read_text_file(o.experiment, "experiment file");
  if (looks_like_fleet_experiment(text)) return run_fleet_command(o, text);
  Experiment e = parse_experiment(text, o.experiment);
  if (o.seed_given) {
    // Parsed here, not by CLI11, whose unsigned conversion wraps "-1" around to 2^64 - 1.
    std::uint64_t seed = 0;
    const char* const end = o.seed.data() + o.seed.size();
    const auto r = std::from_chars(o.seed.data(), end, seed);
    require(!o.seed.empty() && r.ec == std::errc{} && r.ptr == end,
            "--seed: expected an integer in [0, 18446744073709551615], got '", o.seed, "'");
    e.sim.seed = seed;
  }
  if (o.duration_given) {
    require(std::isfinite(o.duration_s) && o.duration_s > 0.0,
            "--duration: expected a number of seconds > 0, got ", o.duration_s);
    e.duration_s = o.duration_s;
  }
  if (o.real_time) {
    auto* loop = std::get_if<ControllerLoopInput>(&e.input);
    require(loop != nullptr,
            "--real-time: only for closed-loop experiments (input type controller), not '",
            input_type_name(e.input), "'");
    loop->real_time = true;
  }
  ProgressBar bar = progress_bar(o, e.name);
  const RunSummary s = run_experiment(e, o.out_dir, o.force, bar.callback());
  bar.finish();
  for (const std::string& w : s.warnings) std::cerr << "warning: " << w << "\n";
  if (!o.quiet) print_summary(s);
  if (!s.ok()) {
    std::cerr << "error: run " << status_name(s.status) << ": " << s.failure_message
              << " (log and summary written to " << o.out_dir << ")\n";
    return kExitRunFailed;
  }
  return kExitOk;
}

int info_command(const std::string& path) {
  const VehicleModel m = load_vehicle_model(path);
  const Eigen::IOFormat matrix(8, 0, "  ", "\n", "    ", "");
  std::cout << "model " << m.name() << " (" << path << ")\n";
  std::cout << "  mass            " << m.mass_kg() << " kg\n";
  std::cout << "  inertia (kg m^2)\n" << m.inertia_kgm2().format(matrix) << "\n";
  std::cout << "  body drag A (N s/m)\n" << m.body_drag_Ns_per_m().format(matrix) << "\n";
  std::cout << "  ground-effect height floor " << m.ground_effect_min_height_m() << " m\n";
  std::cout << "  rotors          " << m.num_rotors() << "\n";
  for (int i = 0; i < m.num_rotors(); ++i) {
    const RotorParams& r = m.rotor(i);
    std::cout << "    [" << i << "] position " << vec(r.position_m, 4) << " m, axis "
              << vec(r.axis, 4) << ", spin " << (r.spin > 0 ? "+1" : "-1") << ", thrust "
              << r.thrust_coefficients[0] << " w^2 " << signed_term(r.thrust_coefficients[1])
              << " w " << signed_term(r.thrust_coefficients[2]) << " N, speed ["
              << r.min_speed_rad_s << ", " << r.max_speed_rad_s << "] rad/s, tau "
              << r.time_constant_rise_s << "/" << r.time_constant_fall_s << " s\n";
  }
  std::cout << "  allocation matrix ([T; tau_x; tau_y; tau_z] = A * rotor thrusts, 4 x "
            << m.num_rotors() << ")\n"
            << m.allocation_matrix().format(matrix) << "\n";
  std::cout << "  pseudo-inverse A^+ (" << m.num_rotors() << " x 4)\n"
            << m.allocation_pseudo_inverse().format(matrix) << "\n";
  std::cout << "  wrench matrix rank " << m.wrench_rank() << "\n";
  const RotorVector thrusts = m.hover_thrusts_N(), speeds = m.hover_speeds_rad_s();
  std::cout << "  hover (g = 9.81 m/s^2)" << (m.can_hover() ? "" : ": NOT POSSIBLE") << "\n";
  for (int i = 0; i < m.num_rotors(); ++i) {
    const RotorParams& r = m.rotor(i);
    const double t_min = r.thrust(r.min_speed_rad_s), t_max = r.thrust(r.max_speed_rad_s);
    std::cout << "    [" << i << "] thrust " << std::setprecision(8) << thrusts[i] << " N";
    if (thrusts[i] > t_max) {
      std::cout << ": more than this rotor gives at its maximum speed (" << t_max << " N at "
                << r.max_speed_rad_s << " rad/s)\n";
    } else if (thrusts[i] < t_min) {
      std::cout << ": less than this rotor gives at its minimum speed (" << t_min << " N at "
                << r.min_speed_rad_s << " rad/s)\n";
    } else {
      std::cout << ", speed " << speeds[i] << " rad/s (" << speeds[i] * 60.0 / (2.0 * kPi)
                << " rpm)\n";
    }
  }
  if (!m.can_hover()) {
    std::cerr << "warning: " << m.name()
              << " cannot hover at g = 9.81 m/s^2 within its rotor speed limits\n";
  }
  return kExitOk;
}

// Runs /usr/bin/python3 (DRONETWIN_PYTHON overrides it) with `args` and `module_dir` first on
// PYTHONPATH; returns its exit status.
int run_python(const std::string& what, std::vector<std::string> args,
               const std::string& module_dir) {
  const char* env_python = std::getenv("DRONETWIN_PYTHON");
  const std::string python = env_python ? env_python : "/usr/bin/python3";
  args.insert(args.begin(), python);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(what + ": fork failed");
  if (pid == 0) {
    const char* old = std::getenv("PYTHONPATH");
    const std::string path = old && *old ? module_dir + ":" + old : module_dir;
    setenv("PYTHONPATH", path.c_str(), 1);
    execv(python.c_str(), argv.data());
    std::fprintf(stderr, "error: %s: cannot run %s (set DRONETWIN_PYTHON)\n", what.c_str(),
                 python.c_str());
    _exit(kExitBadInput);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : kExitInternal;
}

// `dronetwin plot DIR`: runs the plotting script python/dronetwin/plot.py with Debian's
// interpreter. DRONETWIN_PYTHONPATH overrides the directory that holds dronetwin/plot.py. The
// script is run as a file, not as `-m dronetwin.plot`, so plotting needs only numpy and
// matplotlib, not the compiled extension the package imports.
int plot_command(const std::string& run_dir, const std::string& out_dir) {
  std::string module_dir;
  if (const char* p = std::getenv("DRONETWIN_PYTHONPATH")) {
    module_dir = p;
  } else if (std::filesystem::exists(DRONETWIN_PYTHON_SOURCE_DIR "/dronetwin/plot.py")) {
    module_dir = DRONETWIN_PYTHON_SOURCE_DIR;
  } else {
    module_dir = DRONETWIN_PYTHON_INSTALL_DIR;
  }
  std::vector<std::string> args{module_dir + "/dronetwin/plot.py", run_dir};
  if (!out_dir.empty()) {
    args.emplace_back("--out");
    args.push_back(out_dir);
  }
  return run_python("plot", args, module_dir);
}

// Commands written in Python: `dronetwin train ...` and `dronetwin evaluate ...` (the trainer,
// torch) run `python3 -m dronetwin.train <command> ...`, `dronetwin sweep ...` (Dask) runs
// `python3 -m dronetwin.sweep ...`, with every argument passed on. The package must hold the
// compiled extension: the build tree's (DRONETWIN_PYTHON_BUILD_DIR) when it has one, else the
// installed package (on Debian's sys.path); DRONETWIN_PYTHONPATH overrides both.
int python_module_command(const std::string& command, const std::string& module,
                          std::vector<std::string> args, const std::vector<std::string>& rest) {
  std::string module_dir;
  if (const char* p = std::getenv("DRONETWIN_PYTHONPATH")) {
    module_dir = p;
  } else if (std::filesystem::exists(std::filesystem::path(DRONETWIN_PYTHON_BUILD_DIR) /
                                     "dronetwin" / (module + ".py"))) {
    module_dir = DRONETWIN_PYTHON_BUILD_DIR;
  }
  args.insert(args.begin(), {"-m", "dronetwin." + module});
  args.insert(args.end(), rest.begin(), rest.end());
  return run_python(command, args, module_dir);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dronetwin: a deterministic, steppable digital twin of multirotor drones",
               "dronetwin"};
  app.set_version_flag("--version", std::string(dronetwin::version()));
  app.require_subcommand(1);

  RunOptions run;
  CLI::App* run_cmd =
      app.add_subcommand("run", "Run an experiment file; writes DIR/log.csv and DIR/summary.json");
  run_cmd->add_option("experiment", run.experiment, "Experiment file (YAML)")->required();
  run_cmd->add_option("--out,-o", run.out_dir, "Output directory (created if needed)")->required();
  CLI::Option* seed =
      run_cmd->add_option("--seed", run.seed, "Override the experiment's seed (integer >= 0)");
  CLI::Option* duration =
      run_cmd->add_option("--duration", run.duration_s, "Override duration_s (seconds)");
  run_cmd->add_flag("--real-time", run.real_time,
                    "Pace a closed-loop run at real time (overrides the experiment's real_time)");
  run_cmd->add_flag("--quiet,-q", run.quiet, "Print nothing on success");
  CLI::Option* progress = run_cmd->add_flag("--progress", run.progress,
                                            "Show a progress bar on stderr from the start "
                                            "(default: on a terminal, once a run takes 2 s)");
  run_cmd->add_flag("--no-progress", run.no_progress, "Never show a progress bar")
      ->excludes(progress);
  run_cmd->add_flag("--force", run.force,
                    "Replace the log and summary of an earlier run in the output directory");

  std::string model_path;
  CLI::App* info_cmd = app.add_subcommand(
      "info", "Print a vehicle model: mass, inertia, rotors, allocation matrix, hover speeds");
  info_cmd->add_option("model", model_path, "Vehicle model file (YAML)")->required();

  std::string plot_dir, plot_out;
  CLI::App* plot_cmd = app.add_subcommand(
      "plot", "Draw tracking, error, rotor-speed, force and 3-D path figures (PNG) from a run");
  plot_cmd->add_option("run_dir", plot_dir, "Directory with log.csv (from `dronetwin run`)")
      ->required();
  plot_cmd->add_option("--out,-o", plot_out, "Where to write the PNGs (default: run_dir)");

  // Everything after `train` / `evaluate` goes to the Python trainer (its --help included).
  CLI::App* train_cmd = app.add_subcommand(
      "train", "Train a policy with PPO: train CONFIG --out DIR [--resume] (see train --help)");
  train_cmd->prefix_command()->set_help_flag();
  CLI::App* evaluate_cmd = app.add_subcommand(
      "evaluate", "Evaluate a policy file: evaluate POLICY --config CONFIG [--episodes N]");
  evaluate_cmd->prefix_command()->set_help_flag();
  CLI::App* sweep_cmd = app.add_subcommand(
      "sweep",
      "Run a sweep file on Dask: sweep SWEEP.yaml --out DIR [--scheduler ADDR] [--workers N]");
  sweep_cmd->prefix_command()->set_help_flag();
  CLI::App* export_cmd = app.add_subcommand(
      "export",
      "Write a run's log as a ROS 1 bag or MCAP: export RUN_DIR --bag FILE.bag --mcap FILE.mcap "
      "(docs/ros.md)");
  export_cmd->prefix_command()->set_help_flag();
  CLI::App* view_cmd = app.add_subcommand(
      "view",
      "Replay a run in the browser: view RUN_DIR [--out PAGE.html] [--port P] (docs/viewer.md)");
  view_cmd->prefix_command()->set_help_flag();

  dronetwin::cli::RealDataCommands real_data;
  dronetwin::cli::register_real_data_commands(app, real_data);
  dronetwin::cli::FitCommand fit;
  dronetwin::cli::register_fit_command(app, fit);

  // CLI11 reports a mistyped command as "A subcommand is required"; name it instead.
  if (argc > 1 && argv[1][0] != '-') {
    const std::string_view command = argv[1];
    if (command != "run" && command != "info" && command != "plot" && command != "import" &&
        command != "identify" && command != "fit" && command != "train" && command != "evaluate" &&
        command != "sweep" && command != "export" && command != "view") {
      std::cerr << "error: unknown command '" << command
                << "' (valid commands: run, info, plot, import, identify, fit, train, evaluate, "
                   "sweep, export, view)\n"
                << "Run with --help for more information.\n";
      return kExitBadInput;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // Help and --version are "errors" with exit code 0; everything else is bad input.
    return app.exit(e) == 0 ? kExitOk : kExitBadInput;
  }

  try {
    if (*run_cmd) {
      run.seed_given = seed->count() > 0;
      run.duration_given = duration->count() > 0;
      return run_command(run);
    }
    if (*plot_cmd) return plot_command(plot_dir, plot_out);
    if (*train_cmd)
      return python_module_command("train", "train", {"train"}, train_cmd->remaining());
    if (*evaluate_cmd)
      return python_module_command("evaluate", "train", {"evaluate"}, evaluate_cmd->remaining());
    if (*sweep_cmd) return python_module_command("sweep", "sweep", {}, sweep_cmd->remaining());
    if (*export_cmd) return python_module_command("export", "export", {}, export_cmd->remaining());
    if (*view_cmd) return python_module_command("view", "view", {}, view_cmd->remaining());
    if (*fit.cmd) return dronetwin::cli::run_fit_command(fit);
    if (dronetwin::cli::real_data_command_selected(real_data)) {
      return dronetwin::cli::run_real_data_command(real_data);
    }
    return info_command(model_path);
  } catch (const InvalidArgument& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "error: internal error: " << e.what() << "\n";
    return kExitInternal;
  }
}
