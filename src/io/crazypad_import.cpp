// CrazyPAD flight -> dronetwin log (include/dronetwin/io/crazypad_import.hpp).
#include "dronetwin/io/crazypad_import.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include "dronetwin/core/error.hpp"
#include "dronetwin/io/csv_log.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

namespace {

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
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
                           const std::string& stand_source) {
  const std::filesystem::path csv = stem + ".csv", json = stem + ".json";
  if (csv.has_parent_path()) std::filesystem::create_directories(csv.parent_path());
  {
    CsvLogWriter log(csv.string(), imp.columns);
    for (std::size_t r = 0; r < imp.rows(); ++r) {
      log.write_row(imp.values.data() + r * imp.columns.size(), imp.columns.size());
    }
    log.close();
  }
  std::ofstream out(json);
  require(static_cast<bool>(out), json.string(), ": cannot open for writing");
  out.precision(17);
  out << "{\n"
      << "  \"format\": \"dronetwin log (docs: include/dronetwin/io/csv_log.hpp)\",\n"
      << "  \"source\": " << json_string(imp.source) << ",\n"
      << "  \"source_kind\": \"CrazyPAD Crazyflie 2.1 uSD log, decoded (.fixedFrequency.csv)\",\n"
      << "  \"source_license\": \"MIT, Copyright (c) 2022 Kamil Masalimov, Tagir Muslimov; "
         "cite Masalimov et al., Data 2024, 9, 79\",\n"
      << "  \"t0_boot_s\": " << imp.t0_s << ",\n"
      << "  \"rows\": " << imp.rows() << ",\n"
      << "  \"gravity_m_s2\": " << imp.gravity_m_s2 << ",\n"
      << "  \"speed_map\": {\"form\": \"omega = a * (pwm / 65535 * vbat) + b, 0 if pwm = 0\", "
      << "\"a_rad_s_per_V\": " << imp.speed_map.a_rad_s_per_V
      << ", \"b_rad_s\": " << imp.speed_map.b_rad_s << ", \"stand\": " << json_string(stand_source)
      << "},\n"
      << "  \"max_abs_reconstructed_pitch_rad\": " << imp.max_abs_pitch_rad << ",\n"
      << "  \"columns\": {\n"
      << "    \"t\": \"timestamp_ms / 1000 - t0_boot_s (measured)\",\n"
      << "    \"x,y,z\": \"stateEstimate.x,y,z, m, world (estimated)\",\n"
      << "    \"vx,vy,vz\": \"stateEstimate.vx,vy,vz, m/s, world (estimated)\",\n"
      << "    \"qw,qx,qy,qz\": \"from stateEstimate.roll and .yaw (estimated) and a pitch derived "
         "as atan2(forward specific force, vertical specific force) while all PWM > 0 and the "
         "vertical specific force > g/2, else 0 (pitch is not logged; assumes thrust is the only "
         "non-gravity force)\",\n"
      << "    \"omega_0..omega_3\": \"motor M1..M4 speed, rad/s, from pwm.mN_pwm and pm.vbatMV "
         "through the thrust-stand speed map (derived, not measured)\",\n"
      << "    \"acc_x,acc_y,acc_z\": \"world-frame specific force dv/dt + g e3, m/s^2 = "
         "stateEstimate.ax, ay, (az + 1) times g (estimated; the source az excludes gravity)\"\n"
      << "  },\n"
      << "  \"not_logged\": [\"wx\", \"wy\", \"wz\", \"pitch\", \"rotor speeds\"]\n"
      << "}\n";
  require(static_cast<bool>(out), json.string(), ": write failed");
}

}  // namespace dronetwin
