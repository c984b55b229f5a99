#pragma once
// Converts a PX4 ULog flight (io/ulog.hpp) into a dronetwin log plus a JSON sidecar.
//
//   ULogImport imp = import_ulog(read_ulog("flight.ulg"));
//   write_ulog_import(imp, "out/flight");       // out/flight.csv + out/flight.json
//
// Rows are the vehicle_attitude samples inside the time span covered by vehicle_local_position
// (and esc_status, if logged); the other topics are linearly interpolated to those times.
// Columns: t, x, y, z, vx, vy, vz, qw, qx, qy, qz, wx, wy, wz, [omega_0..omega_{N-1}],
// acc_x, acc_y, acc_z.
//
// Frames: PX4 logs NED world and FRD body; dronetwin uses z up. Both are turned by 180 deg about
// their x axis (world x = north, y = west, z = up; body x forward, y left, z up), so
// (x, y, z) -> (x, -y, -z) for every vector and q -> (qw, qx, -qy, -qz).
// omega_i = esc[i].esc_rpm 2 pi / 60 in ESC order (esc_count ESCs); the ESC-to-airframe position
// mapping is not in the log. t is seconds since the first row (boot time in the sidecar).
// acc_x..acc_z is the world-frame specific force dv/dt + g e3 (g = 9.81), as in crazypad_import.
//
// Trap: esc_status is slow (about 3 Hz in the test log), so interpolated rotor speeds miss fast
// changes; position comes from the EKF (estimated), not a measurement.

#include <string>
#include <vector>

#include "dronetwin/adapters/ulog.hpp"

namespace dronetwin {

struct ULogImport {
  std::string source;
  double t0_s = 0.0;
  int num_rotors = 0;
  std::vector<std::string> columns;
  std::vector<double> values;  ///< row-major
  std::size_t rows() const { return columns.empty() ? 0 : values.size() / columns.size(); }
};

ULogImport import_ulog(const ULog& log);

/// Writes `stem`.csv and `stem`.json safely (logging/output_folder.hpp: the folder is locked, the
/// files are written under temporary names and moved into place; existing files are replaced only
/// with `overwrite`, the input never).
void write_ulog_import(const ULogImport& imp, const std::string& stem, bool overwrite = false);

}  // namespace dronetwin
