// CrazyPAD flight -> dronetwin log (include/dronetwin/adapters/crazypad_import.hpp).
#include "dronetwin/adapters/crazypad_import.hpp"

#include <cmath>
#include <filesystem>
#include <numbers>

#include "dronetwin/core/error.hpp"
#include "dronetwin/core/version.hpp"
#include "dronetwin/logging/csv_log.hpp"
#include "dronetwin/logging/json_writer.hpp"
#include "dronetwin/logging/log_metadata.hpp"
#include "dronetwin/logging/output_folder.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

namespace {

/// The columns of crazypad_import_columns() with unit, meaning and where each comes from.
std::vector<LogColumn> crazypad_log_columns() {
  std::vector<LogColumn> c = {{"t", "s", "timestamp_ms / 1000 - t0_boot_s (measured)"},
                              {"x", "m", "stateEstimate.x, world frame (estimated)"},
                              {"y", "m", "stateEstimate.y, world frame (estimated)"},
                              {"z", "m", "stateEstimate.z, world frame, z up (estimated)"},
                              {"vx", "m/s", "stateEstimate.vx, world frame (estimated)"},
                              {"vy", "m/s", "stateEstimate.vy, world frame (estimated)"},
                              {"vz", "m/s", "stateEstimate.vz, world frame (estimated)"}};
  for (const char* q : {"qw", "qx", "qy", "qz"}) {
    c.push_back({q, "1",
                 std::string("attitude quaternion q_WB, ") + q[1] +
                     " component, from stateEstimate.roll and .yaw (estimated) and a pitch "
                     "derived as atan2(forward specific force, vertical specific force) while all "
                     "PWM > 0 and the vertical specific force > g/2, else 0 (pitch is not logged; "
                     "assumes thrust is the only non-gravity force)"});
  }
  for (int i = 0; i < 4; ++i) {
    c.push_back({"omega_" + std::to_string(i), "rad/s",
                 "motor M" + std::to_string(i + 1) + " speed from pwm.m" + std::to_string(i + 1) +
                     "_pwm and pm.vbatMV through the thrust-stand speed map (derived, not "
                     "measured)"});
  }
  const char* axes[] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    c.push_back({std::string("acc_") + axes[k], "m/s^2",
                 std::string("world-frame specific force dv/dt + g e3, ") + axes[k] +
                     ": stateEstimate.a" + axes[k] + (k == 2 ? " + 1" : "") +
                     ", times g (estimated; the source az excludes gravity)"});
  }
  return c;
}

}  // namespace

std::vector<std::string> crazypad_import_columns() {
  return {"t",  "x",  "y",       "z",       "vx",      "vy",      "vz",    "qw",    "qx",
          "qy", "qz", "omega_0", "omega_1", "omega_2", "omega_3", "acc_x", "acc_y", "acc_z"};
}

CrazyPadImport import_crazypad(const CrazyPadFlight& f, const SpeedMap& speed_map,
                               double gravity_m_s2) {
  const std::size_t n = f.rows();
  require(n >= 2, f.source, ": flight has ", n, " rows, need at least 2");
  CrazyPadImport imp;
  imp.source = f.source;
  imp.t0_s = f.t_s.front();
  imp.gravity_m_s2 = gravity_m_s2;
  imp.speed_map = speed_map;
  imp.columns = crazypad_import_columns();
  imp.values.reserve(n * imp.columns.size());
  constexpr double kDeg = std::numbers::pi / 180.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double roll = f.roll_deg[i] * kDeg, yaw = f.yaw_deg[i] * kDeg;
    const double ax = f.acc_g[0][i] * gravity_m_s2, ay = f.acc_g[1][i] * gravity_m_s2;
    // Specific force: the source's az is the kinematic acceleration (0 in hover); add g back.
    const double az = (f.acc_g[2][i] + 1.0) * gravity_m_s2;
    // Thrust direction in the yaw frame (file comment): pitch from the forward component.
    const double a_forward = std::cos(yaw) * ax + std::sin(yaw) * ay;
    // Only meaningful while the rotors push (all PWM > 0) and the specific force points up;
    // on the ground, with the motors off or in a bump, pitch is set to 0.
    const bool thrusting = f.pwm[0][i] > 0 && f.pwm[1][i] > 0 && f.pwm[2][i] > 0 &&
                           f.pwm[3][i] > 0 && az > 0.5 * gravity_m_s2;
    const double pitch = thrusting ? std::atan2(a_forward, az) : 0.0;
    imp.max_abs_pitch_rad = std::max(imp.max_abs_pitch_rad, std::abs(pitch));
    const Vec4 q = math::from_euler(roll, pitch, yaw);
    const double row[] = {f.t_s[i] - imp.t0_s,
                          f.pos_m[0][i],
                          f.pos_m[1][i],
                          f.pos_m[2][i],
                          f.vel_m_s[0][i],
                          f.vel_m_s[1][i],
                          f.vel_m_s[2][i],
                          q[0],
                          q[1],
                          q[2],
                          q[3],
                          speed_map.speed_rad_s(f.pwm[0][i], f.vbat_V[i]),
                          speed_map.speed_rad_s(f.pwm[1][i], f.vbat_V[i]),
                          speed_map.speed_rad_s(f.pwm[2][i], f.vbat_V[i]),
                          speed_map.speed_rad_s(f.pwm[3][i], f.vbat_V[i]),
                          ax,
                          ay,
                          az};
    imp.values.insert(imp.values.end(), std::begin(row), std::end(row));
  }
  return imp;
}

void write_crazypad_import(const CrazyPadImport& imp, const std::string& stem,
                           const std::string& stand_source, bool overwrite) {
  const std::filesystem::path csv = stem + ".csv", json = stem + ".json";
  const std::vector<LogColumn> columns = crazypad_log_columns();
  // The import's columns are crazypad_import_columns() unless a caller edited them.
  std::vector<std::string> names;
  for (const LogColumn& c : columns) names.push_back(c.name);
  require(names == imp.columns, json.string(),
          ": the import's columns are not crazypad_import_columns(); cannot describe them");
  OutputFolder out(csv.has_parent_path() ? csv.parent_path() : std::filesystem::path("."),
                   {csv.filename().string(), json.filename().string()}, {imp.source, stand_source},
                   overwrite, "import");
  {
    CsvLogWriter log(out.partial(csv.filename().string()).string(), imp.columns);
    for (std::size_t r = 0; r < imp.rows(); ++r) {
      log.write_row(imp.values.data() + r * imp.columns.size(), imp.columns.size());
    }
    log.close();
  }
  json::JsonObject speed_map(2);
  speed_map.str("form", "omega = a * (pwm / 65535 * vbat) + b, 0 if pwm = 0")
      .num("a_rad_s_per_V", imp.speed_map.a_rad_s_per_V)
      .num("b_rad_s", imp.speed_map.b_rad_s)
      .str("stand", stand_source);
  json::JsonObject j(0);
  j.str("format", kImportedLogFormat)
      .integer("format_version", kImportedLogFormatVersion)
      .str("dronetwin_version", version())
      .str("source", imp.source)
      .str("source_kind", "CrazyPAD Crazyflie 2.1 uSD log, decoded (.fixedFrequency.csv)")
      .str("source_license",
           "MIT, Copyright (c) 2022 Kamil Masalimov, Tagir Muslimov; cite Masalimov et al., Data "
           "2024, 9, 79")
      .num("t0_boot_s", imp.t0_s)
      .integer("rows", static_cast<long long>(imp.rows()))
      .num("gravity_m_s2", imp.gravity_m_s2)
      .raw("speed_map", speed_map.done())
      .num("max_abs_reconstructed_pitch_rad", imp.max_abs_pitch_rad)
      .integer("num_rotors", 4)
      .raw("columns", json::json_columns(columns))
      .raw("not_logged", R"(["wx", "wy", "wz", "pitch", "rotor speeds"])");
  write_text_file(out.partial(json.filename().string()), j.done() + "\n");
  out.commit();
}

}  // namespace dronetwin
