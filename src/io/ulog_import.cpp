// PX4 ULog -> dronetwin log (include/dronetwin/io/ulog_import.hpp).
#include "dronetwin/io/ulog_import.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include "dronetwin/core/error.hpp"
#include "dronetwin/io/csv_log.hpp"

namespace dronetwin {

namespace {

/// Linear interpolation of (t, v) at time x, t increasing, x inside [t.front(), t.back()].
double interpolate(const std::vector<double>& t, const std::vector<double>& v, double x) {
  const auto it = std::upper_bound(t.begin(), t.end(), x);
  if (it == t.begin()) return v.front();
  if (it == t.end()) return v.back();
  const std::size_t i = static_cast<std::size_t>(it - t.begin());
  const double dt = t[i] - t[i - 1];
  if (dt <= 0.0) return v[i];
  const double s = (x - t[i - 1]) / dt;
  return v[i - 1] + s * (v[i] - v[i - 1]);
}

}  // namespace

ULogImport import_ulog(const ULog& log) {
  const ULogTopic& att = log.topic("vehicle_attitude");
  const ULogTopic& pos = log.topic("vehicle_local_position");
  const ULogTopic* esc = log.has_topic("esc_status") ? &log.topic("esc_status") : nullptr;
  ULogImport imp;
  imp.source = log.source;
  if (esc) {
    const double count = esc->column("esc_count").front();
    require(count >= 1 && count <= 8, log.source, ": esc_status.esc_count = ", count,
            ", expected 1..8");
    imp.num_rotors = static_cast<int>(count);
  }
  imp.columns = {"t", "x", "y", "z", "vx", "vy", "vz", "qw", "qx", "qy", "qz", "wx", "wy", "wz"};
  for (int i = 0; i < imp.num_rotors; ++i) imp.columns.push_back("omega_" + std::to_string(i));
  for (const char* c : {"acc_x", "acc_y", "acc_z"}) imp.columns.push_back(c);

  const auto& ta = att.column("timestamp");
  const auto& tp = pos.column("timestamp");
  double lo = tp.front(), hi = tp.back();
  if (esc) {
    lo = std::max(lo, esc->column("timestamp").front());
    hi = std::min(hi, esc->column("timestamp").back());
  }
  // NED/FRD -> z-up: (x, y, z) -> (x, -y, -z).
  const double sign[3] = {1.0, -1.0, -1.0};
  const char* axes[3] = {"x", "y", "z"};
  constexpr double kRpm = 2.0 * std::numbers::pi / 60.0;
  bool first = true;
  for (std::size_t i = 0; i < ta.size(); ++i) {
    const double t = ta[i];
    if (t < lo || t > hi) continue;
    if (first) imp.t0_s = t;
    first = false;
    imp.values.push_back(t - imp.t0_s);
    for (int k = 0; k < 3; ++k) {
      imp.values.push_back(sign[k] * interpolate(tp, pos.column(axes[k]), t));
    }
    for (int k = 0; k < 3; ++k) {
      imp.values.push_back(sign[k] * interpolate(tp, pos.column(std::string("v") + axes[k]), t));
    }
    const double q[4] = {att.column("q[0]")[i], att.column("q[1]")[i], att.column("q[2]")[i],
                         att.column("q[3]")[i]};
    imp.values.insert(imp.values.end(), {q[0], q[1], -q[2], -q[3]});
    imp.values.insert(imp.values.end(), {att.column("rollspeed")[i], -att.column("pitchspeed")[i],
                                         -att.column("yawspeed")[i]});
    for (int e = 0; e < imp.num_rotors; ++e) {
      const auto& rpm = esc->column("esc[" + std::to_string(e) + "].esc_rpm");
      imp.values.push_back(interpolate(esc->column("timestamp"), rpm, t) * kRpm);
    }
    // Specific force dv/dt + g e3 (z up), as in the CrazyPAD import: PX4's a is kinematic.
    for (int k = 0; k < 3; ++k) {
      imp.values.push_back(sign[k] * interpolate(tp, pos.column(std::string("a") + axes[k]), t) +
                           (k == 2 ? 9.81 : 0.0));
    }
  }
  require(imp.rows() >= 2, log.source, ": fewer than 2 vehicle_attitude samples inside the span of",
          " vehicle_local_position", esc ? " and esc_status" : "");
  return imp;
}

void write_ulog_import(const ULogImport& imp, const std::string& stem) {
  const std::filesystem::path csv = stem + ".csv", json = stem + ".json";
  if (csv.has_parent_path()) std::filesystem::create_directories(csv.parent_path());
  {
    CsvLogWriter out(csv.string(), imp.columns);
    for (std::size_t r = 0; r < imp.rows(); ++r) {
      out.write_row(imp.values.data() + r * imp.columns.size(), imp.columns.size());
    }
    out.close();
  }
  std::ofstream out(json);
  require(static_cast<bool>(out), json.string(), ": cannot open for writing");
  out.precision(17);
  out << "{\n  \"format\": \"dronetwin log (docs: include/dronetwin/io/csv_log.hpp)\",\n"
      << "  \"source\": \"" << imp.source << "\",\n"
      << "  \"source_kind\": \"PX4 ULog\",\n"
      << "  \"t0_boot_s\": " << imp.t0_s << ",\n  \"rows\": " << imp.rows() << ",\n"
      << "  \"num_rotors\": " << imp.num_rotors << ",\n"
      << "  \"frames\": \"PX4 NED world / FRD body turned 180 deg about x: (x, y, z) -> "
         "(x, -y, -z), q -> (qw, qx, -qy, -qz)\",\n"
      << "  \"columns\": {\n"
      << "    \"t\": \"vehicle_attitude.timestamp - t0_boot_s (rows are attitude samples)\",\n"
      << "    \"x..vz\": \"vehicle_local_position x,y,z,vx,vy,vz, linearly interpolated "
         "(EKF estimate)\",\n"
      << "    \"qw..qz, wx..wz\": \"vehicle_attitude q and rollspeed/pitchspeed/yawspeed "
         "(estimated)\",\n"
      << "    \"omega_i\": \"esc_status esc[i].esc_rpm * 2 pi / 60, interpolated, ESC order "
         "(measured by the ESC)\",\n"
      << "    \"acc_x..acc_z\": \"specific force dv/dt + g e3 (g = 9.81) from "
         "vehicle_local_position ax, ay, az, interpolated (EKF estimate)\"\n  }\n}\n";
  require(static_cast<bool>(out), json.string(), ": write failed");
}

}  // namespace dronetwin
