#pragma once
// Real-data subcommands of the `dronetwin` tool (registered by main.cpp):
//
//   dronetwin import crazypad FLIGHT.csv --stand STAND.csv --out DIR   -> DIR/<name>.csv + .json
//   dronetwin import ulog FILE.ulg --out DIR                           -> DIR/<name>.csv + .json
//   dronetwin identify stand STAND.csv [--out DIR]     thrust curve + speed map (stand_fit.json,
//                                                      stand_points.csv)
//   dronetwin identify vertical LOG.csv --model M.yaml [--out DIR] [--no-drag] [--prior-mass KG]
//                                                      thrust-to-mass fit with held-out check
//                                                      (vertical_fit.json, vertical_points.csv)
#include <CLI/CLI.hpp>
#include <string>

namespace dronetwin::cli {

struct RealDataCommands {
  CLI::App* import_cmd = nullptr;
  CLI::App* import_crazypad = nullptr;
  CLI::App* import_ulog = nullptr;
  CLI::App* identify_cmd = nullptr;
  CLI::App* identify_stand = nullptr;
  CLI::App* identify_vertical = nullptr;
  std::string input, stand, out_dir, model;
  /// --prior-mass, read when given (prior_mass_option->count() > 0; else the model's mass).
  double prior_mass_kg = 0.0;
  CLI::Option* prior_mass_option = nullptr;
  double train_fraction = 0.7;
  bool no_drag = false;
  bool force = false;  ///< import: replace an earlier import's files
};

/// Adds `import` and `identify` with their subcommands to `app`.
void register_real_data_commands(CLI::App& app, RealDataCommands& c);

/// True if one of these commands was parsed.
bool real_data_command_selected(const RealDataCommands& c);

/// Runs the parsed command; returns the exit code (throws InvalidArgument for bad input).
int run_real_data_command(const RealDataCommands& c);

}  // namespace dronetwin::cli
