#pragma once
// Converts a CrazyPAD Crazyflie flight (io/crazyflie_csv.hpp) into a dronetwin log
// (io/csv_log.hpp format) plus a JSON sidecar that says where every column came from.
//
//   CrazyPadFlight f = read_crazypad_csv("E8_log00.fixedFrequency.csv");
//   ThrustStandFit stand = fit_thrust_stand(read_thrust_stand_csv("cf2.1-stock-prop.csv"));
//   CrazyPadImport imp = import_crazypad(f, stand.speed_map);
//   write_crazypad_import(imp, "out/E8_log00");     // out/E8_log00.csv + out/E8_log00.json
//
// Columns: t, x, y, z, vx, vy, vz, qw, qx, qy, qz, omega_0..omega_3, acc_x, acc_y, acc_z.
// * t: seconds from the first sample (the log's boot time of that sample is in the sidecar).
// * position, velocity: the Crazyflie state estimate (world frame, z up; Crazyflie and dronetwin
//   both use x forward, y left, z up).
// * attitude: roll and yaw are logged; pitch is NOT. It is reconstructed from the estimated
//   world acceleration on the assumption that the thrust is the only non-gravity force (drag
//   neglected): rotating a_W + g e3 into the yaw frame gives [T/m sin(pitch) cos(roll),
//   -T/m sin(roll), T/m cos(pitch) cos(roll)], so pitch = atan2(a_h,x, a_z + g). Right-handed
//   ZYX angles (the Crazyflie logs roll and yaw right-handed; only its pitch is left-handed).
//   Where that assumption cannot hold (a motor at PWM 0, or a vertical specific force below
//   g / 2: on the ground, motors off, impacts) pitch is set to 0.
// * omega_i: rotor M(i+1) speed from PWM and battery voltage through the stand's speed map.
// * acc_x..acc_z: the world-frame specific force dv/dt + g e3 in m/s^2 (what an accelerometer
//   measures, in world axes: +g at rest, thrust / m in flight): stateEstimate.ax, ay, az + 1
//   times g (the source logs the kinematic acceleration, az without gravity).
//
// Trap: everything except t, PWM and vbat is an on-board estimate (Kalman filter), not a
// measurement; the sidecar marks which columns are estimated or derived.

#include <string>
#include <vector>

#include "dronetwin/adapters/crazyflie_csv.hpp"
#include "dronetwin/adapters/thrust_stand_fit.hpp"

namespace dronetwin {

struct CrazyPadImport {
  std::string source;
  double t0_s = 0.0;  ///< boot time of the first sample
  double gravity_m_s2 = 9.81;
  SpeedMap speed_map;
  std::vector<std::string> columns;
  /// rows() * columns.size(), row-major.
  std::vector<double> values;
  std::size_t rows() const { return columns.empty() ? 0 : values.size() / columns.size(); }
  double max_abs_pitch_rad = 0.0;  ///< of the reconstructed pitch
};

/// The column names of an imported flight (see the file comment).
std::vector<std::string> crazypad_import_columns();

CrazyPadImport import_crazypad(const CrazyPadFlight& flight, const SpeedMap& speed_map,
                               double gravity_m_s2 = 9.81);

/// Writes `stem`.csv and `stem`.json (creates the parent directory) safely, like
/// write_ulog_import(). `stand_source` names the thrust-stand file the speed map came from (for
/// the sidecar).
void write_crazypad_import(const CrazyPadImport& imp, const std::string& stem,
                           const std::string& stand_source, bool overwrite = false);

}  // namespace dronetwin
