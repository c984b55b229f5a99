#pragma once
// Readers for two Crazyflie 2.1 data sets (tests/data/real/README.md):
//
// * the Bitcraze 2021 thrust-stand sweep (`cf2.1-stock-prop.csv`): one row per sample, columns
//   `weight[g]` (total thrust of the four motors, grams), `pwm` (0..65535, the same on every
//   motor), `vbat[V]`, `rpm1`..`rpm4`, and electrical `v[V]`, `i[A]`, `p[W]`; no timestamps;
// * CrazyPAD flight logs decoded from the uSD deck (`*.fixedFrequency.csv`): `timestamp_ms`, then
//   dotted log-variable names (`pwm.m1_pwm`, `pm.vbatMV`, `stateEstimate.z`, ...).
//
//   ThrustStandData stand = read_thrust_stand_csv("cf2.1-stock-prop.csv");
//   CrazyPadFlight flight = read_crazypad_csv("E8_log00.fixedFrequency.csv");
//   double vbat = flight.vbat_V[i];                    // converted from pm.vbatMV
//
// Both use read_csv_log (io/csv_log.hpp), a named-column numeric CSV reader, so a malformed field
// is reported with file, line and column. On top of that these readers check the columns they
// need exist and that values are in range (PWM 0..65535, battery 2..5 V, rpm >= 0, time strictly
// increasing), naming file, line and column.
//
// Trap: units are converted on read (mV -> V, ms -> s) but frames are not: stateEstimate.ax/ay/az
// stay in g, world frame, az WITHOUT gravity (a hovering vehicle logs az = 0), roll/yaw in degrees.

#include <array>
#include <cstddef>
#include <string>
#include <vector>

namespace dronetwin {

struct ThrustStandData {
  std::string source;
  std::vector<double> weight_g;            ///< total thrust of all four motors, grams (load cell)
  std::vector<double> pwm;                 ///< 0..65535, applied to all four motors
  std::vector<double> vbat_V;              ///< battery voltage under load
  std::array<std::vector<double>, 4> rpm;  ///< per motor, revolutions per minute
  std::vector<double> current_A;
  std::vector<double> power_W;
  std::size_t rows() const { return pwm.size(); }
};

/// Reads the thrust-stand CSV (columns named above; extra columns are ignored).
ThrustStandData read_thrust_stand_csv(const std::string& path);

struct CrazyPadFlight {
  std::string source;
  std::vector<double> t_s;                     ///< timestamp_ms / 1000 (time since boot)
  std::array<std::vector<double>, 4> pwm;      ///< pwm.m1_pwm .. m4_pwm, 0..65535 (motor M1..M4)
  std::vector<double> vbat_V;                  ///< pm.vbatMV / 1000
  std::array<std::vector<double>, 3> pos_m;    ///< stateEstimate.x, y, z (world)
  std::array<std::vector<double>, 3> vel_m_s;  ///< stateEstimate.vx, vy, vz (world)
  std::array<std::vector<double>, 3> acc_g;    ///< stateEstimate.ax, ay, az: g, world, no gravity
  std::vector<double> roll_deg;                ///< stateEstimate.roll
  std::vector<double> yaw_deg;                 ///< stateEstimate.yaw
  std::size_t rows() const { return t_s.size(); }
};

/// Reads a CrazyPAD motor-data flight CSV (columns named above; extra columns are ignored).
CrazyPadFlight read_crazypad_csv(const std::string& path);

}  // namespace dronetwin
