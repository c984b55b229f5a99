#pragma once
// `dronetwin fit`: identify model parameters from a logged flight (identification/fit.hpp).
//
//   dronetwin fit --model models/qdrone2.yaml --log out/id/log.csv --params thrust,inertia
//                 --out fitted.yaml [--report fit.json] [--method both|equation|output]
//                 [--channels auto|linear|angular|linear,angular] [--loss huber|cauchy|none]
//                 [--loss-scale S] [--speed-gains auto|fit|off] [--force] [--holdout 0.2]
//                 [--true-state] [--window 0.05] [--max-windows 200] [--threads N]
//                 [--disturbances all|none|rotor_drag,body_drag,...] [--ignore-sidecar]
//                 [--min-height M]
//
// The disturbance switches, wind and gravity the flight was flown with come from the log's
// sidecar (log.json, docs/log-format.md) when it has one; --disturbances overrides the switches.
// A sidecar that is neither a run log's nor an importer's, or a malformed one, is an error naming
// the sidecar and the field (--ignore-sidecar fits with the defaults instead).
// Prints the estimates with standard errors, the residuals before/after on the fitted and the
// held-out part, the held-out check and the warnings; writes the fitted model file (and the
// report as JSON).
//
// Outputs: checked before the fit (an output that is an input — the model file, the log, its
// sidecar — or the other output is refused; a missing or read-only folder fails at once) and
// written atomically (temporary file in the same folder + rename). Exit 1 without writing the
// model file (the report is written) when the estimates do not make a valid model (negative
// drag, say), or when the fitted model explains the held-out part of the flight worse than the
// starting model and --force is not given.
#include <CLI/CLI.hpp>
#include <string>

namespace dronetwin::cli {

struct FitCommand {
  CLI::App* cmd = nullptr;
  /// Empty disturbances: the log's sidecar (log.json) says which terms were on, else all.
  std::string model, log, params, out, report, method = "both", disturbances;
  std::string channels = "auto", loss = "huber", speed_gains = "auto";
  /// --loss-scale, read when given (loss_scale_option->count() > 0).
  double loss_scale = 0.0;
  CLI::Option* loss_scale_option = nullptr;
  double holdout = 0.2, window_s = 0.05, min_height_m = -1e300;
  int max_windows = 200, threads = 1;
  long long coarse_intervals = 200000;
  bool true_state = false, force = false, ignore_sidecar = false;
};

void register_fit_command(CLI::App& app, FitCommand& c);
/// Runs the parsed command; returns the exit code (throws InvalidArgument for bad input).
int run_fit_command(const FitCommand& c);

}  // namespace dronetwin::cli
