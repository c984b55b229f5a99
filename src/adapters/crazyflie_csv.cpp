// Crazyflie thrust-stand and CrazyPAD CSV readers; see
// include/dronetwin/adapters/crazyflie_csv.hpp.
#include "dronetwin/adapters/crazyflie_csv.hpp"

#include <cmath>

#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/csv_log.hpp"

namespace dronetwin {

namespace {

/// A column of `t` with every value checked to lie in [lo, hi]; the error names file, line
/// (header is line 1) and column.
std::vector<double> checked_column(const LogTable& t, const std::string& name, double lo, double hi,
                                   double scale = 1.0) {
  const std::size_t c = t.column(name);
  std::vector<double> out(t.rows());
  for (std::size_t r = 0; r < t.rows(); ++r) {
    const double v = t.at(r, c);
    require(std::isfinite(v) && v >= lo && v <= hi, t.source, ": line ", r + 2, ", column ", c + 1,
            " (", name, "): expected a value in [", lo, ", ", hi, "], got ", v);
    out[r] = v * scale;
  }
  return out;
}

}  // namespace

ThrustStandData read_thrust_stand_csv(const std::string& path) {
  const LogTable t = read_csv_log(path);
  require(t.rows() > 0, path, ": no data rows");
  ThrustStandData d;
  d.source = path;
  // The load cell reads slightly negative at rest (tare offset), so weight may be below zero.
  d.weight_g = checked_column(t, "weight[g]", -50.0, 500.0);
  d.pwm = checked_column(t, "pwm", 0.0, 65535.0);
  d.vbat_V = checked_column(t, "vbat[V]", 2.0, 5.0);
  for (int m = 0; m < 4; ++m) {
    d.rpm[static_cast<std::size_t>(m)] =
        checked_column(t, "rpm" + std::to_string(m + 1), 0.0, 100000.0);
  }
  d.current_A = checked_column(t, "i[A]", -1.0, 50.0);
  d.power_W = checked_column(t, "p[W]", -5.0, 250.0);
  return d;
}

CrazyPadFlight read_crazypad_csv(const std::string& path) {
  const LogTable t = read_csv_log(path);
  require(t.rows() >= 2, path, ": expected at least 2 data rows, got ", t.rows());
  CrazyPadFlight f;
  f.source = path;
  constexpr double kBig = 1e9;
  f.t_s = checked_column(t, "timestamp_ms", 0.0, kBig, 1e-3);
  const std::size_t tc = t.column("timestamp_ms");
  for (std::size_t r = 1; r < f.t_s.size(); ++r) {
    require(f.t_s[r] > f.t_s[r - 1], path, ": line ", r + 2, ", column ", tc + 1,
            " (timestamp_ms): time must increase, got ", t.at(r, tc), " after ", t.at(r - 1, tc));
  }
  for (int m = 0; m < 4; ++m) {
    f.pwm[static_cast<std::size_t>(m)] =
        checked_column(t, "pwm.m" + std::to_string(m + 1) + "_pwm", 0.0, 65535.0);
  }
  f.vbat_V = checked_column(t, "pm.vbatMV", 2000.0, 5000.0, 1e-3);
  const char* axes[3] = {"x", "y", "z"};
  for (std::size_t k = 0; k < 3; ++k) {
    const std::string a = axes[k];
    f.pos_m[k] = checked_column(t, "stateEstimate." + a, -1e3, 1e3);
    f.vel_m_s[k] = checked_column(t, "stateEstimate.v" + a, -100.0, 100.0);
    f.acc_g[k] = checked_column(t, "stateEstimate.a" + a, -20.0, 20.0);
  }
  f.roll_deg = checked_column(t, "stateEstimate.roll", -180.0, 180.0);
  f.yaw_deg = checked_column(t, "stateEstimate.yaw", -360.0, 360.0);
  return f;
}

}  // namespace dronetwin
