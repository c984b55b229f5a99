// `dronetwin fit` (fit_command.hpp).
#include "fit_command.hpp"

#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>

#include "dronetwin/config/log_metadata_reader.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/identification/fit.hpp"
#include "dronetwin/logging/atomic_file.hpp"
#include "dronetwin/logging/log_metadata.hpp"

namespace dronetwin::cli {
namespace {

namespace fs = std::filesystem;

DisturbanceSwitches parse_switches(const std::string& text) {
  if (text == "all") return DisturbanceSwitches{};
  DisturbanceSwitches s = DisturbanceSwitches::none();
  if (text == "none") return s;
  std::string valid;
  for (std::string_view n : kDisturbanceSwitchNames)
    valid += (valid.empty() ? "" : ", ") + std::string(n);
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find(',', start);
    if (end == std::string::npos) end = text.size();
    const std::string_view item = std::string_view(text).substr(start, end - start);
    std::size_t i = 0;
    while (i < kDisturbanceSwitchNames.size() && kDisturbanceSwitchNames[i] != item) ++i;
    require(i < kDisturbanceSwitchNames.size(), "--disturbances: unknown term '", item,
            "' (valid: all, none, or a comma-separated list of ", valid, ")");
    s.*kDisturbanceSwitchMembers[i] = true;
    start = end + 1;
  }
  return s;
}

// The option's name in front of a library message ("channels: expected ..." -> "--channels: ...").
template <class F>
auto with_option(const char* option, F&& f) {
  try {
    return f();
  } catch (const InvalidArgument& e) {
    const std::string what = e.what();
    const std::size_t colon = what.find(": ");
    throw InvalidArgument(std::string(option) + ": " +
                          (colon == std::string::npos ? what : what.substr(colon + 2)));
  }
}

// The flight settings (switches, wind, gravity) from the log's sidecar: strict for a run log's
// sidecar, none from an importer's, and an error for anything else (a sidecar the user did not
// mean to be ignored must not be ignored silently).
std::string apply_sidecar(const FitCommand& c, const VehicleModel& model,
                          const std::string& sidecar, FitOptions& o) {
  if (c.ignore_sidecar) return "defaults (all terms, no wind; --ignore-sidecar)";
  if (!fs::exists(sidecar)) return "defaults (all terms, no wind; the log has no sidecar)";
  const std::string hint = " (fix or remove the sidecar, or pass --ignore-sidecar)";
  std::string format;
  try {
    format = log_sidecar_format(sidecar);
    if (format == kRunLogFormat) {
      const LogMetadata meta = read_log_metadata(sidecar);
      require(meta.num_rotors == model.num_rotors(), sidecar, ": the log has ", meta.num_rotors,
              " rotors, the model ", c.model, " has ", model.num_rotors());
      o.switches = meta.disturbances;
      o.environment.wind_W_m_s = meta.wind_m_s;
      o.environment.gravity_W_m_s2 = meta.gravity_m_s2;
      return sidecar;
    }
  } catch (const InvalidArgument& e) {
    throw InvalidArgument(e.what() + hint);
  }
  require(format == kImportedLogFormat, sidecar, ": format: expected \"", kRunLogFormat,
          "\" (a run log) or \"", kImportedLogFormat, "\" (an imported log), got ",
          format.empty() ? std::string("none") : "\"" + format + "\"", hint);
  return "defaults (all terms, no wind; the importer's sidecar " + sidecar +
         " holds no flight settings)";
}

}  // namespace

void register_fit_command(CLI::App& app, FitCommand& c) {
  c.cmd = app.add_subcommand("fit", "Identify model parameters from a logged flight (Ceres)");
  c.cmd->add_option("--model,-m", c.model, "Vehicle model file to start from (YAML)")->required();
  c.cmd->add_option("--log,-l", c.log, "Flight log (CSV, dronetwin log format)")->required();
  c.cmd
      ->add_option("--params,-p", c.params,
                   "Comma-separated parameters or groups: mass, inertia_xx/yy/zz, thrust_k1/k2/k3, "
                   "yaw_moment_per_thrust, drag_moment, rotor_drag, rolling_moment, "
                   "body_drag_x/y/z, ground_effect, tau_rise, tau_fall; groups thrust, inertia, "
                   "body_drag, motor")
      ->required();
  c.cmd->add_option("--out,-o", c.out, "Where to write the fitted model file (YAML)")->required();
  c.cmd->add_option("--report", c.report, "Also write the fit report as JSON here");
  c.cmd->add_option("--method", c.method, "equation, output or both (default both)");
  c.cmd->add_option("--channels", c.channels,
                    "Accelerations to fit: auto (default: linear, and angular only for inertia, "
                    "yaw/drag/rolling moments), linear, angular or linear,angular");
  c.cmd->add_option("--loss", c.loss, "Robust loss: huber (default), cauchy or none");
  c.loss_scale_option =
      c.cmd->add_option("--loss-scale", c.loss_scale,
                        "Loss scale in noise levels (default 1.345 for huber, 2.385 for cauchy)");
  c.cmd->add_option("--speed-gains", c.speed_gains,
                    "Per-rotor speed-sensor gains: auto (default: fitted with the angular "
                    "channel), fit or off");
  c.cmd->add_flag("--force", c.force,
                  "Write the model even when it explains the held-out flight worse than the "
                  "starting model");
  c.cmd->add_option("--holdout", c.holdout,
                    "Share of the flight (at its end) held out (default 0.2)");
  c.cmd->add_option("--window", c.window_s, "Output-error window length, s (default 0.05)");
  c.cmd->add_option("--max-windows", c.max_windows, "At most this many output-error windows (200)");
  c.cmd->add_option("--threads", c.threads,
                    "Threads for the streamed residuals (default 1; same result on any number)");
  c.cmd->add_option("--coarse-intervals", c.coarse_intervals,
                    "A log with more than twice this many fitted intervals starts on every m-th "
                    "of them, at most this many, and finishes on all (default 200000; 0: never)");
  c.cmd->add_option("--disturbances", c.disturbances,
                    "Terms the flight was flown with: all, none, or a list (default: what the "
                    "log's log.json says, else all)");
  c.cmd->add_flag("--ignore-sidecar", c.ignore_sidecar,
                  "Do not read the log's sidecar (log.json): default flight settings");
  c.cmd->add_option("--min-height", c.min_height_m,
                    "Leave out rows below this height, m (take-off and landing in logs without "
                    "in_contact)");
  c.cmd->add_flag("--true-state", c.true_state,
                  "Fit to the true state columns even when the log has measured ones");
}

int run_fit_command(const FitCommand& c) {
  // Everything that can be checked without the fit, before it: options, then the outputs.
  FitOptions o;
  o.parameters = with_option("--params", [&] { return parse_parameter_list(c.params); });
  if (c.method == "equation")
    o.method = FitMethod::kEquationError;
  else if (c.method == "output")
    o.method = FitMethod::kOutputError;
  else if (c.method == "both")
    o.method = FitMethod::kBoth;
  else
    throw InvalidArgument("--method: expected equation, output or both, got '" + c.method + "'");
  o.channels = with_option("--channels", [&] { return parse_fit_channels(c.channels); });
  o.loss = with_option("--loss", [&] { return parse_fit_loss(c.loss); });
  o.speed_sensor_gains =
      with_option("--speed-gains", [&] { return parse_speed_sensor_gains(c.speed_gains); });
  if (c.loss_scale_option && c.loss_scale_option->count() > 0) {
    require(std::isfinite(c.loss_scale) && c.loss_scale > 0.0,
            "--loss-scale: expected a number of noise levels > 0, got ", c.loss_scale);
    o.loss_scale = c.loss_scale;
  }
  require(std::isfinite(c.holdout) && c.holdout >= 0.0 && c.holdout < 0.9,
          "--holdout: expected a share in [0, 0.9), got ", c.holdout);
  require(std::isfinite(c.window_s) && c.window_s > 0.0,
          "--window: expected a length in s > 0, got ", c.window_s);
  require(c.max_windows >= 1, "--max-windows: expected a count >= 1, got ", c.max_windows);
  require(c.threads >= 1 && c.threads <= 1024, "--threads: expected a count in [1, 1024], got ",
          c.threads);
  require(c.coarse_intervals >= 0, "--coarse-intervals: expected a count >= 0, got ",
          c.coarse_intervals);
  require(std::isfinite(c.min_height_m), "--min-height: expected a height in m, got ",
          c.min_height_m);
  o.holdout_fraction = c.holdout;
  o.window_s = c.window_s;
  o.max_windows = c.max_windows;
  o.num_threads = c.threads;
  o.coarse_intervals = static_cast<std::size_t>(c.coarse_intervals);
  o.min_height_m = c.min_height_m;

  const std::string sidecar = sidecar_path(c.log);
  const std::vector<NamedPath> inputs{
      {"--model file", c.model}, {"--log", c.log}, {"log's sidecar", sidecar}};
  require_not_an_input("--out", c.out, inputs);
  if (!c.report.empty()) {
    require_not_an_input("--report", c.report, inputs);
    require(!same_file(c.out, c.report), "--report ", c.report, ": is also --out (", c.out,
            "); give two files");
  }
  // Created now, committed after the fit: a missing folder or a read-only one fails here.
  AtomicFileWriter model_file(c.out);
  std::unique_ptr<AtomicFileWriter> report_file =
      c.report.empty() ? nullptr : std::make_unique<AtomicFileWriter>(c.report);

  const VehicleModel model = load_vehicle_model(c.model);
  std::string settings_from = apply_sidecar(c, model, sidecar, o);
  if (!c.disturbances.empty()) {
    o.switches = parse_switches(c.disturbances);
    settings_from += "; terms from --disturbances " + c.disturbances;
  }
  const FlightData data = read_flight_data(c.log, model.num_rotors(), !c.true_state);
  const FitResult r = fit_model(model, data, o);
  std::cout << "fit " << c.log << " (" << (data.used_measured() ? "measured" : "true")
            << " state) to " << c.model << "; flight settings from " << settings_from << "\n"
            << format_fit_report(r);
  if (report_file) {
    report_file->commit(fit_result_to_json(r));
    std::cout << "wrote " << c.report << "\n";
  }
  VehicleSpec spec = r.fitted_spec;
  spec.name = model.name() + "_fitted";
  try {
    (void)VehicleModel(spec);
  } catch (const InvalidArgument& e) {
    std::cerr << "error: the estimates do not make a valid model, so " << c.out
              << " was not written: " << e.what() << "\n";
    return 1;
  }
  if (r.holdout_check.worse && !c.force) {
    std::cerr << "error: the fitted model explains the held-out part of the flight worse than "
                 "the starting model, so "
              << c.out << " was not written (--force writes it anyway): " << r.holdout_check.summary
              << "\n";
    return 1;
  }
  model_file.commit(vehicle_spec_to_yaml(spec));
  std::cout << "wrote " << c.out
            << (r.holdout_check.worse ? " (--force: held-out check WORSE)" : "") << "\n";
  return 0;
}

}  // namespace dronetwin::cli
