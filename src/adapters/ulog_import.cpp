// PX4 ULog -> dronetwin log (include/dronetwin/adapters/ulog_import.hpp).
#include "dronetwin/adapters/ulog_import.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <utility>

#include "dronetwin/core/error.hpp"
#include "dronetwin/core/version.hpp"
#include "dronetwin/logging/csv_log.hpp"
#include "dronetwin/logging/json_writer.hpp"
#include "dronetwin/logging/log_metadata.hpp"
#include "dronetwin/logging/output_folder.hpp"
#include "dronetwin/logging/text_file.hpp"

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

/// The columns of import_ulog() with unit, meaning and where each comes from.
std::vector<LogColumn> ulog_log_columns(int num_rotors) {
  std::vector<LogColumn> c = {
      {"t", "s", "vehicle_attitude.timestamp - t0_boot_s (rows are attitude samples)"}};
  const char* axes[] = {"x", "y", "z"};
  for (const char* a : axes) {
    c.push_back({a, "m",
                 std::string("vehicle_local_position.") + a +
                     " turned to z up, linearly interpolated (EKF estimate)"});
  }
  for (const char* a : axes) {
    c.push_back({std::string("v") + a, "m/s",
                 std::string("vehicle_local_position.v") + a +
                     " turned to z up, linearly interpolated (EKF estimate)"});
  }
  for (const char* q : {"qw", "qx", "qy", "qz"}) {
    c.push_back({q, "1",
                 std::string("attitude quaternion q_WB, ") + q[1] +
                     " component, from vehicle_attitude.q turned to z up (estimated)"});
  }
  const char* rates[] = {"rollspeed", "pitchspeed", "yawspeed"};
  for (int k = 0; k < 3; ++k) {
    c.push_back({std::string("w") + axes[k], "rad/s",
                 std::string("body rate, body ") + axes[k] + " axis: vehicle_attitude." + rates[k] +
                     " turned to z up, interpolated (estimated)"});
  }
  for (int i = 0; i < num_rotors; ++i) {
    c.push_back({"omega_" + std::to_string(i), "rad/s",
                 "esc_status.esc[" + std::to_string(i) +
                     "].esc_rpm * 2 pi / 60, interpolated, ESC order (measured by the ESC)"});
  }
  for (const char* a : axes) {
    c.push_back({std::string("acc_") + a, "m/s^2",
                 std::string("world-frame specific force dv/dt + g e3 (g = 9.81), ") + a +
                     ": vehicle_local_position.a" + a +
                     " turned to z up, interpolated (EKF estimate)"});
  }
  return c;
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
  for (LogColumn& c : ulog_log_columns(imp.num_rotors)) imp.columns.push_back(std::move(c.name));

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

void write_ulog_import(const ULogImport& imp, const std::string& stem, bool overwrite) {
  const std::filesystem::path csv = stem + ".csv", json = stem + ".json";
  const std::vector<LogColumn> columns = ulog_log_columns(imp.num_rotors);
  std::vector<std::string> names;
  for (const LogColumn& c : columns) names.push_back(c.name);
  require(names == imp.columns, json.string(),
          ": the import's columns are not those of import_ulog(); cannot describe them");
  OutputFolder out(csv.has_parent_path() ? csv.parent_path() : std::filesystem::path("."),
                   {csv.filename().string(), json.filename().string()}, {imp.source}, overwrite,
                   "import");
  {
    CsvLogWriter log(out.partial(csv.filename().string()).string(), imp.columns);
    for (std::size_t r = 0; r < imp.rows(); ++r) {
      log.write_row(imp.values.data() + r * imp.columns.size(), imp.columns.size());
    }
    log.close();
  }
  json::JsonObject j(0);
  j.str("format", kImportedLogFormat)
      .integer("format_version", kImportedLogFormatVersion)
      .str("dronetwin_version", version())
      .str("source", imp.source)
      .str("source_kind", "PX4 ULog")
      .num("t0_boot_s", imp.t0_s)
      .integer("rows", static_cast<long long>(imp.rows()))
      .integer("num_rotors", imp.num_rotors)
      .str("frames",
           "PX4 NED world / FRD body turned 180 deg about x: (x, y, z) -> (x, -y, -z), q -> (qw, "
           "qx, -qy, -qz)")
      .raw("columns", json::json_columns(columns));
  write_text_file(out.partial(json.filename().string()), j.done() + "\n");
  out.commit();
}

}  // namespace dronetwin
