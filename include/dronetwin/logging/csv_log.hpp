#pragma once
// Run logs as CSV: one header row of column names, then one row of numbers per logged instant.
// Numbers are written with printf's "%.17g", which reads back to the identical double, so a log
// is bitwise reproducible and round-trips exactly. Booleans are 0/1.
//
//   CsvLogWriter log("out/log.csv", log_column_names({4, true, false}));
//   std::vector<double> row(log.num_columns());
//   ... fill row ...; log.write_row(row);          // no allocation per row
//   log.close();
//   LogTable t = read_csv_log("out/log.csv");
//   double z = t.at(10, t.column("z"));
//
// Column order (log_column_names): t, x, y, z, vx, vy, vz, qw, qx, qy, qz, wx, wy, wz (true state,
// world position/velocity, q_WB, body rates), omega_0..omega_{N-1} (achieved rotor speeds, rad/s),
// omega_ref_0..omega_ref_{N-1} (references), [meas_x .. meas_wz (measured state)], in_contact,
// crashed, [wind_x, wind_y, wind_z (air velocity at the vehicle, world frame)], [battery_soc,
// battery_voltage, battery_current (the pack after the step that reached t)], [payload_x ..
// payload_vz, swing_1, swing_2, swing_rate_1, swing_rate_2, tension (slung payload)],
// [downwash_flow_x .. downwash_moment_z (a fleet's vehicle: other vehicles' wakes)], [F_<term>_x,
// F_<term>_y, F_<term>_z, M_<term>_x, M_<term>_y, M_<term>_z for each term, body frame],
// [<sensor>_t, <sensor>_<channel> for each sensor (its latest delivered reading)], [est_x .. est_wz
// (the EKF's estimate)], [ref_x, ref_y, ref_z, ref_yaw, u_T, u_tau_x, u_tau_y, u_tau_z, saturated
// (closed loop: the reference at t, the generalized force of the rotor command in effect from t on,
// and whether its allocation saturated)]. Bracketed groups are optional; the closed-loop group
// comes last, so an open-loop log's columns are a prefix of the closed-loop log's with the same
// settings.
//
// log_columns() gives the same names with a unit and a one-line meaning each (written to the
// log.json sidecar, io/log_metadata.hpp); the whole format is described in docs/log-format.md.
//
// Trap: the writer buffers; rows reach the file on flush(), close() or destruction. Errors on
// close() throw; the destructor cannot, so close() explicitly when the file matters.

#include <cstddef>
#include <cstdio>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "dronetwin/sensors/depth_camera.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"

namespace dronetwin {

/// Which optional column groups a run log has.
struct LogLayout {
  int num_rotors = 4;
  bool measured = true;
  bool wrench_breakdown = false;
  /// Closed-loop columns ref_x .. saturated (the input is a controller).
  bool controller = false;
  /// With `controller`: the controller's diagnostic_names(), logged after `saturated` as
  /// ctrl_<name> (none for controllers without diagnostics).
  std::vector<std::string> controller_diagnostics = {};
  /// Sensor columns, before the closed-loop group: per sensor <name>_t (the stamp of its latest
  /// delivered reading, NaN before the first) and <name>_<channel> (sensors/sensor_suite.hpp).
  std::vector<SensorSpec> sensors = {};
  /// est_x .. est_wz: the estimator's state (after the sensor columns).
  bool estimate = false;
  /// After the sensors, before est_*: per depth camera <name>_t (when its latest frame was
  /// taken) and <name>_frame (that frame's index in <name>.npy), NaN before the first.
  std::vector<DepthCameraSpec> depth_cameras = {};
  /// wind_x, wind_y, wind_z after `crashed`: the air velocity at the vehicle (logged when the
  /// wind varies: shear, gusts or turbulence).
  bool wind = false;
  /// battery_soc, battery_voltage, battery_current after the wind columns (with a battery).
  bool battery = false;
  /// payload_x .. payload_vz, swing_1, swing_2, swing_rate_1, swing_rate_2, tension after the
  /// battery columns (with a slung payload).
  bool payload = false;
  /// downwash_flow_x/y/z (world, m/s), downwash_force_x/y/z (body, N) and downwash_moment_x/y/z
  /// (body, N m) after the payload columns: what other vehicles' wakes did to this one over
  /// the step that reached t (a fleet's vehicle, Simulator::set_interaction).
  bool downwash = false;
};

/// One column of a log: its header name, its unit ("s", "m", "m/s", "1" (dimensionless, e.g. a
/// quaternion component), "rad", "rad/s", "N", "N m", "bool" (0/1), "ms", ...) and what it holds.
struct LogColumn {
  std::string name;
  std::string unit;
  std::string meaning;

  bool operator==(const LogColumn&) const = default;
};

/// The column names of a run log, in order (see the file comment).
std::vector<std::string> log_column_names(const LogLayout& layout);

/// The columns of a run log with units and meanings, in the order of log_column_names().
/// A controller diagnostic ctrl_<name> takes its unit from the name's suffix (the project's
/// naming convention: _ms, _s, _m, _m_s, _rad, _rad_s, _N, _Nm); any other name is "1" (a count,
/// flag, code or dimensionless number).
std::vector<LogColumn> log_columns(const LogLayout& layout);

class CsvLogWriter {
 public:
  /// Creates (truncates) `path` and writes the header. InvalidArgument if it cannot be opened or a
  /// name is empty or holds a comma, quote or line break.
  CsvLogWriter(const std::string& path, std::vector<std::string> columns);
  ~CsvLogWriter();
  CsvLogWriter(const CsvLogWriter&) = delete;
  CsvLogWriter& operator=(const CsvLogWriter&) = delete;

  std::size_t num_columns() const { return columns_.size(); }
  const std::vector<std::string>& columns() const { return columns_; }
  const std::string& path() const { return path_; }
  std::size_t rows_written() const { return rows_; }

  /// Appends one row; `n` must equal num_columns() (InvalidArgument otherwise).
  void write_row(const double* values, std::size_t n);
  void write_row(const std::vector<double>& values) { write_row(values.data(), values.size()); }

  /// Pushes buffered rows to the file.
  void flush();
  /// Flushes and closes; throws InvalidArgument if the data could not be written.
  void close();

 private:
  void write_buffer();

  std::string path_;
  std::vector<std::string> columns_;
  std::FILE* file_ = nullptr;
  std::vector<char> buffer_;
  std::size_t used_ = 0;
  std::size_t rows_ = 0;
  bool write_error_ = false;
};

/// A log read back: column names and row-major values.
struct LogTable {
  /// The file it was read from (for messages).
  std::string source;
  std::vector<std::string> columns;
  /// rows() * columns.size() numbers, row-major.
  std::vector<double> values;

  std::size_t rows() const { return columns.empty() ? 0 : values.size() / columns.size(); }
  /// Index of a column; InvalidArgument naming the missing column otherwise.
  std::size_t column(std::string_view name) const;
  double at(std::size_t row, std::size_t col) const { return values[row * columns.size() + col]; }
  /// One column as a vector.
  std::vector<double> column_values(std::string_view name) const;
};

/// Reads a CSV log. InvalidArgument naming the file, line and column (number and name) for a
/// malformed field or a row with the wrong number of fields.
LogTable read_csv_log(const std::string& path);

/// Reads a CSV log one row at a time, with the checks and messages of read_csv_log(): a reader
/// that keeps only some columns of a long log (identification/flight_data.hpp) never holds the
/// whole table.
///
///   CsvLogReader in("out/id/log.csv");
///   const std::size_t z = in.column("z");
///   std::vector<double> row;
///   while (in.next(row)) use(row[z]);
class CsvLogReader {
 public:
  /// Opens `path` and reads the header. InvalidArgument naming the file (and why it cannot be
  /// opened) otherwise.
  explicit CsvLogReader(const std::string& path);

  const std::string& path() const { return path_; }
  const std::vector<std::string>& columns() const { return columns_; }
  bool has_column(std::string_view name) const;
  /// Index of a column; InvalidArgument "<path>: no column '<name>'" otherwise.
  std::size_t column(std::string_view name) const;
  /// Reads the next row into `values` (resized to columns().size()); false at the end of the file.
  bool next(std::vector<double>& values);
  /// Line of the file the last row came from (the header is line 1).
  std::size_t line_number() const { return line_number_; }

  /// An upper bound of the number of data rows of `path` (its line ends), found by a fast scan
  /// without parsing, to reserve memory before reading.
  static std::size_t count_rows(const std::string& path);

 private:
  std::string path_;
  std::ifstream in_;
  std::vector<std::string> columns_;
  std::string line_;
  std::size_t line_number_ = 0;
};

}  // namespace dronetwin
