// `dronetwin fit` (fit_command.hpp).
#include "fit_command.hpp"

#include <filesystem>
#include <fstream>
#include <iostream>

#include "dronetwin/config/log_metadata_reader.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/identification/fit.hpp"
#include "dronetwin/logging/csv_log.hpp"
#include "dronetwin/logging/log_metadata.hpp"

namespace dronetwin::cli {
namespace {

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
  c.cmd->add_option("--holdout", c.holdout,
                    "Share of the flight (at its end) held out (default 0.2)");
  c.cmd->add_option("--window", c.window_s, "Output-error window length, s (default 0.05)");
  c.cmd->add_option("--max-windows", c.max_windows, "At most this many output-error windows (200)");
  c.cmd->add_option("--disturbances", c.disturbances,
                    "Terms the flight was flown with: all, none, or a list (default: what the "
                    "log's log.json says, else all)");
  c.cmd->add_option("--min-height", c.min_height_m,
                    "Leave out rows below this height, m (take-off and landing in logs without "
                    "in_contact)");
  c.cmd->add_flag("--true-state", c.true_state,
                  "Fit to the true state columns even when the log has measured ones");
}

int run_fit_command(const FitCommand& c) {
  const VehicleModel model = load_vehicle_model(c.model);
  FitOptions o;
  o.parameters = parse_parameter_list(c.params);
  if (c.method == "equation")
    o.method = FitMethod::kEquationError;
  else if (c.method == "output")
    o.method = FitMethod::kOutputError;
  else if (c.method == "both")
    o.method = FitMethod::kBoth;
  else
    throw InvalidArgument("--method: expected equation, output or both, got '" + c.method + "'");
  o.holdout_fraction = c.holdout;
  o.window_s = c.window_s;
  o.max_windows = c.max_windows;
  const std::string sidecar = sidecar_path(c.log);
  std::string settings_from = "defaults (all terms, no wind)";
  // Importers write a sidecar of their own format, without the flight settings.
  if (std::filesystem::exists(sidecar) && log_sidecar_format(sidecar) == kRunLogFormat) {
    const LogMetadata meta = read_log_metadata(sidecar);
    require(meta.num_rotors == model.num_rotors(), sidecar, ": the log has ", meta.num_rotors,
            " rotors, the model ", c.model, " has ", model.num_rotors());
    o.switches = meta.disturbances;
    o.environment.wind_W_m_s = meta.wind_m_s;
    o.environment.gravity_W_m_s2 = meta.gravity_m_s2;
    settings_from = sidecar;
  }
  if (!c.disturbances.empty()) {
    o.switches = parse_switches(c.disturbances);
    settings_from = "--disturbances " + c.disturbances;
  }
  o.min_height_m = c.min_height_m;
  const FlightData data =
      flight_data_from_log(read_csv_log(c.log), model.num_rotors(), !c.true_state);
  const FitResult r = fit_model(model, data, o);
  std::cout << "fit " << c.log << " (" << (data.used_measured ? "measured" : "true")
            << " state) to " << c.model << "; flight settings from " << settings_from << "\n"
            << format_fit_report(r);
  if (!c.report.empty()) {
    std::ofstream out(c.report);
    require(static_cast<bool>(out), c.report, ": cannot open for writing");
    out << fit_result_to_json(r);
    require(static_cast<bool>(out), c.report, ": write failed");
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
  save_vehicle_spec(spec, c.out);
  std::cout << "wrote " << c.out << "\n";
  return 0;
}

}  // namespace dronetwin::cli
