// Real-data subcommands: importers and identification (see real_data_commands.hpp).
#include "real_data_commands.hpp"

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <numbers>

#include "dronetwin/adapters/crazyflie_csv.hpp"
#include "dronetwin/adapters/crazypad_import.hpp"
#include "dronetwin/adapters/thrust_stand_fit.hpp"
#include "dronetwin/adapters/ulog_import.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/identification/vertical_fit.hpp"
#include "dronetwin/logging/csv_log.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin::cli {

namespace {

namespace fs = std::filesystem;

/// File name without directory and without ".fixedFrequency.csv" / ".csv" / ".ulg".
std::string stem_of(const std::string& path) {
  std::string name = fs::path(path).filename().string();
  for (const std::string suffix : {".fixedFrequency.csv", ".csv", ".ulg"}) {
    if (name.size() > suffix.size() && name.ends_with(suffix)) {
      return name.substr(0, name.size() - suffix.size());
    }
  }
  return name;
}

void json_fit(std::ostream& out, const LinearFit& f, const std::string& indent) {
  out << "{";
  for (std::size_t j = 0; j < f.names.size(); ++j) {
    out << "\n"
        << indent << "  \"" << f.names[j] << "\": {\"value\": " << f.coefficients[j]
        << ", \"std_error\": " << f.std_errors[j] << "},";
  }
  out << "\n"
      << indent << "  \"residual_rms\": " << f.residual_rms << ", \"num_points\": " << f.num_points
      << "\n"
      << indent << "}";
}

void print_fit(const LinearFit& f, const std::string& unit_note) {
  for (std::size_t j = 0; j < f.names.size(); ++j) {
    std::cout << "  " << std::setw(3) << f.names[j] << " = " << std::setprecision(6)
              << f.coefficients[j] << " +- " << std::setprecision(2) << f.std_errors[j] << "\n";
  }
  std::cout << std::setprecision(6) << "  residual RMS " << f.residual_rms << " " << unit_note
            << " over " << f.num_points << " points\n";
}

std::ofstream open_out(const fs::path& p) {
  std::ofstream out(p);
  require(static_cast<bool>(out), p.string(), ": cannot open for writing");
  out.precision(17);
  return out;
}

int identify_stand(const RealDataCommands& c) {
  const ThrustStandData data = read_thrust_stand_csv(c.input);
  const ThrustStandFit f = fit_thrust_stand(data);
  std::cout << "thrust stand " << c.input << ": " << data.rows() << " rows, tare " << f.tare_g
            << " g (" << f.tare_rows << " rest rows)\n"
            << "T(w) = K1 w^2 + K2 w + K3 per motor (N, rad/s), thesis Eq. 2.22:\n";
  print_fit(f.thrust, "N");
  std::cout << "speed map w = a u + b, u = pwm/65535 vbat (V):\n";
  print_fit(f.speed_map_fit, "rad/s");
  std::cout << "  (quadratic in u for comparison: residual RMS "
            << f.speed_map_quadratic.residual_rms << " rad/s)\n"
            << "speed range " << f.min_speed_rad_s << " .. " << f.max_speed_rad_s
            << " rad/s, max thrust " << f.max_thrust_N << " N per motor\n"
            << "motor speed / mean:";
  for (double r : f.motor_speed_ratio) std::cout << " " << r;
  std::cout << "\n";
  if (c.out_dir.empty()) return 0;
  fs::create_directories(c.out_dir);
  {
    std::ofstream out = open_out(fs::path(c.out_dir) / "stand_fit.json");
    out << "{\n  \"source\": \"" << c.input << "\",\n  \"tare_g\": " << f.tare_g
        << ",\n  \"thrust\": ";
    json_fit(out, f.thrust, "  ");
    out << ",\n  \"speed_map\": ";
    json_fit(out, f.speed_map_fit, "  ");
    out << ",\n  \"speed_map_quadratic\": ";
    json_fit(out, f.speed_map_quadratic, "  ");
    out << ",\n  \"min_speed_rad_s\": " << f.min_speed_rad_s
        << ",\n  \"max_speed_rad_s\": " << f.max_speed_rad_s
        << ",\n  \"max_thrust_N\": " << f.max_thrust_N << ",\n  \"motor_speed_ratio\": ["
        << f.motor_speed_ratio[0] << ", " << f.motor_speed_ratio[1] << ", "
        << f.motor_speed_ratio[2] << ", " << f.motor_speed_ratio[3] << "]\n}\n";
  }
  // Every row with its derived quantities and the fitted predictions, for plots.
  std::ofstream pts = open_out(fs::path(c.out_dir) / "stand_points.csv");
  pts << "pwm,vbat_V,u_V,omega_rad_s,omega_1,omega_2,omega_3,omega_4,thrust_N,thrust_fit_N,"
         "omega_fit_rad_s,used\n";
  constexpr double k = 2.0 * std::numbers::pi / 60.0;
  const auto& th = f.thrust.coefficients;
  for (std::size_t i = 0; i < data.rows(); ++i) {
    const double w = (data.rpm[0][i] + data.rpm[1][i] + data.rpm[2][i] + data.rpm[3][i]) / 4.0 * k;
    const bool used = data.pwm[i] > 0 && data.rpm[0][i] > 0 && data.rpm[1][i] > 0 &&
                      data.rpm[2][i] > 0 && data.rpm[3][i] > 0;
    pts << data.pwm[i] << "," << data.vbat_V[i] << "," << data.pwm[i] / 65535.0 * data.vbat_V[i]
        << "," << w << "," << data.rpm[0][i] * k << "," << data.rpm[1][i] * k << ","
        << data.rpm[2][i] * k << "," << data.rpm[3][i] * k << ","
        << (data.weight_g[i] - f.tare_g) * 9.81 / 4000.0 << "," << (th[0] * w + th[1]) * w + th[2]
        << "," << f.speed_map.speed_rad_s(data.pwm[i], data.vbat_V[i]) << "," << (used ? 1 : 0)
        << "\n";
  }
  require(static_cast<bool>(pts), c.out_dir, "/stand_points.csv: write failed");
  return 0;
}

int identify_vertical(const RealDataCommands& c) {
  require(!c.model.empty(), "identify vertical: --model is required");
  const VehicleModel model = load_vehicle_model(c.model);
  const LogTable log = read_csv_log(c.input);
  VerticalFitOptions o;
  o.fit_drag = !c.no_drag;
  if (c.prior_mass_option && c.prior_mass_option->count() > 0) {
    // 0 would silently mean "the model's mass" to fit_vertical; a given mass must be one.
    require(std::isfinite(c.prior_mass_kg) && c.prior_mass_kg > 0.0,
            "--prior-mass: expected a mass in kg > 0, got ", c.prior_mass_kg);
    o.prior_mass_kg = c.prior_mass_kg;
  }
  require(std::isfinite(c.train_fraction) && c.train_fraction > 0.0 && c.train_fraction < 1.0,
          "--train-fraction: expected a share in (0, 1), got ", c.train_fraction);
  o.train_fraction = c.train_fraction;
  const VerticalFitResult r = fit_vertical(log, model, o);
  std::cout << "vertical fit " << c.input << " with thrust curve of " << c.model << ":\n"
            << "  acc_z (= dvz/dt + g) = c R33 sum T_i(omega_i)" << (o.fit_drag ? " - d vz" : "")
            << "\n";
  print_fit(r.fit, "m/s^2 (train)");
  std::cout << "  mass = 1/c = " << r.mass_kg * 1000 << " +- " << r.mass_std_error_kg * 1000
            << " g (stand thrust taken as true)\n"
            << "  train " << r.num_train << " samples, held out " << r.num_test
            << " samples from t = " << r.t_split_s << " s\n"
            << "  held-out RMS: fitted " << r.rms_test_m_s2
            << " m/s^2, prior (m = " << r.prior_mass_kg * 1000 << " g, no drag) "
            << r.rms_test_prior_m_s2 << " m/s^2\n";
  if (c.out_dir.empty()) return 0;
  fs::create_directories(c.out_dir);
  {
    std::ofstream out = open_out(fs::path(c.out_dir) / "vertical_fit.json");
    out << "{\n  \"source\": \"" << c.input << "\",\n  \"model\": \"" << c.model
        << "\",\n  \"fit\": ";
    json_fit(out, r.fit, "  ");
    out << ",\n  \"mass_kg\": " << r.mass_kg
        << ",\n  \"mass_std_error_kg\": " << r.mass_std_error_kg
        << ",\n  \"prior_mass_kg\": " << r.prior_mass_kg << ",\n  \"num_train\": " << r.num_train
        << ",\n  \"num_test\": " << r.num_test << ",\n  \"t_split_s\": " << r.t_split_s
        << ",\n  \"rms_train_m_s2\": " << r.rms_train_m_s2
        << ",\n  \"rms_test_m_s2\": " << r.rms_test_m_s2
        << ",\n  \"rms_test_prior_m_s2\": " << r.rms_test_prior_m_s2 << "\n}\n";
  }
  std::ofstream pts = open_out(fs::path(c.out_dir) / "vertical_points.csv");
  pts << "t,acc_z,fit,prior,thrust_z_N,vz,train\n";
  const double cc = r.fit.coefficients[0], d = o.fit_drag ? r.fit.coefficients[1] : 0.0;
  for (std::size_t i = 0; i < r.t_s.size(); ++i) {
    pts << r.t_s[i] << "," << r.lhs_m_s2[i] << "," << cc * r.thrust_z_N[i] - d * r.vz_m_s[i] << ","
        << r.thrust_z_N[i] / r.prior_mass_kg << "," << r.thrust_z_N[i] << "," << r.vz_m_s[i] << ","
        << (i < r.num_train ? 1 : 0) << "\n";
  }
  require(static_cast<bool>(pts), c.out_dir, "/vertical_points.csv: write failed");
  return 0;
}

}  // namespace

void register_real_data_commands(CLI::App& app, RealDataCommands& c) {
  c.import_cmd = app.add_subcommand("import", "Convert real flight logs to dronetwin logs");
  c.import_cmd->require_subcommand(1);
  c.import_crazypad = c.import_cmd->add_subcommand(
      "crazypad", "CrazyPAD Crazyflie flight CSV -> DIR/<name>.csv + <name>.json");
  c.import_crazypad->add_option("flight", c.input, "Decoded flight (.fixedFrequency.csv)")
      ->required();
  c.import_crazypad->add_option("--stand", c.stand, "Thrust-stand CSV for the speed map")
      ->required();
  c.import_crazypad->add_option("--out,-o", c.out_dir, "Output directory")->required();
  c.import_crazypad->add_flag("--force", c.force, "Replace an earlier import's files");
  c.import_ulog = c.import_cmd->add_subcommand(
      "ulog", "PX4 ULog -> DIR/<name>.csv + <name>.json (resampled at vehicle_attitude)");
  c.import_ulog->add_option("file", c.input, "ULog file (.ulg)")->required();
  c.import_ulog->add_option("--out,-o", c.out_dir, "Output directory")->required();
  c.import_ulog->add_flag("--force", c.force, "Replace an earlier import's files");

  c.identify_cmd = app.add_subcommand("identify", "Fit parameters to real data");
  c.identify_cmd->require_subcommand(1);
  c.identify_stand = c.identify_cmd->add_subcommand(
      "stand", "Thrust curve (Eq. 2.22) and speed map from a Crazyflie thrust-stand CSV");
  c.identify_stand->add_option("stand", c.input, "Thrust-stand CSV")->required();
  c.identify_stand->add_option("--out,-o", c.out_dir, "Write stand_fit.json, stand_points.csv");
  c.identify_vertical = c.identify_cmd->add_subcommand(
      "vertical",
      "Thrust-to-mass (and vertical drag) from an imported flight, with held-out check");
  c.identify_vertical->add_option("log", c.input, "Imported flight log (CSV)")->required();
  c.identify_vertical->add_option("--model,-m", c.model, "Model with the thrust curve")->required();
  c.identify_vertical->add_option("--out,-o", c.out_dir,
                                  "Write vertical_fit.json, vertical_points.csv");
  c.identify_vertical->add_flag("--no-drag", c.no_drag, "Fit the thrust scale only");
  c.prior_mass_option = c.identify_vertical->add_option(
      "--prior-mass", c.prior_mass_kg, "Mass (kg) of the no-fit prediction (default: the model's)");
  c.identify_vertical->add_option("--train-fraction", c.train_fraction,
                                  "Fraction of airborne samples fitted (default 0.7)");
}

bool real_data_command_selected(const RealDataCommands& c) {
  return c.import_cmd && (c.import_cmd->parsed() || c.identify_cmd->parsed());
}

int run_real_data_command(const RealDataCommands& c) {
  if (c.identify_stand->parsed()) return identify_stand(c);
  if (c.identify_vertical->parsed()) return identify_vertical(c);
  const std::string stem = (fs::path(c.out_dir) / stem_of(c.input)).string();
  if (c.import_crazypad->parsed()) {
    const ThrustStandFit stand = fit_thrust_stand(read_thrust_stand_csv(c.stand));
    const CrazyPadImport imp = import_crazypad(read_crazypad_csv(c.input), stand.speed_map);
    write_crazypad_import(imp, stem, c.stand, c.force);
    std::cout << "wrote " << stem << ".csv (" << imp.rows() << " rows) and " << stem
              << ".json; speed map w = " << stand.speed_map.a_rad_s_per_V << " u + "
              << stand.speed_map.b_rad_s << "\n";
    return 0;
  }
  const ULogImport imp = import_ulog(read_ulog(c.input));
  write_ulog_import(imp, stem, c.force);
  std::cout << "wrote " << stem << ".csv (" << imp.rows() << " rows) and " << stem << ".json\n";
  return 0;
}

}  // namespace dronetwin::cli
