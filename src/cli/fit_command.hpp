#pragma once
// `dronetwin fit`: identify model parameters from a logged flight (identification/fit.hpp).
//
//   dronetwin fit --model models/qdrone2.yaml --log out/id/log.csv --params thrust,inertia
//                 --out fitted.yaml [--report fit.json] [--method both|equation|output]
//                 [--holdout 0.2] [--true-state] [--window 0.05] [--max-windows 200]
//                 [--disturbances all|none|rotor_drag,body_drag,...] [--min-height M]
//
// The disturbance switches, wind and gravity the flight was flown with come from the log's
// sidecar (log.json, docs/log-format.md) when it has one; --disturbances overrides them.
// Prints the estimates with standard errors, the residuals before/after on the fitted and the
// held-out part, and the warnings; writes the fitted model file (and the report as JSON). A fit
// whose estimates do not make a valid model (negative drag, say) writes the report but not the
// model, and exits with 1.
#include <CLI/CLI.hpp>
#include <string>

namespace dronetwin::cli {

struct FitCommand {
  CLI::App* cmd = nullptr;
  /// Empty disturbances: the log's sidecar (log.json) says which terms were on, else all.
  std::string model, log, params, out, report, method = "both", disturbances;
  double holdout = 0.2, window_s = 0.05, min_height_m = -1e300;
  int max_windows = 200;
  bool true_state = false;
};

void register_fit_command(CLI::App& app, FitCommand& c);
/// Runs the parsed command; returns the exit code (throws InvalidArgument for bad input).
int run_fit_command(const FitCommand& c);

}  // namespace dronetwin::cli
