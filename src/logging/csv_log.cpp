// CSV run logs (format in include/dronetwin/logging/csv_log.hpp and docs/log-format.md).
#include "dronetwin/logging/csv_log.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <system_error>
#include <utility>

#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/wrench.hpp"

namespace dronetwin {

namespace {
constexpr std::size_t kBufferBytes = 1 << 16;
// "%.17g" of a double is at most 24 characters ("-1.2345678901234567e-308"); one field never
// needs more than this, separator included.
constexpr std::size_t kMaxFieldBytes = 32;

constexpr const char* kAxes[] = {"x", "y", "z"};

/// The 13 state columns: name, unit, meaning.
struct StateColumn {
  const char* name;
  const char* unit;
  const char* meaning;
};
constexpr StateColumn kState[] = {
    {"x", "m", "position p_W x, world frame (z up)"},
    {"y", "m", "position p_W y, world frame (z up)"},
    {"z", "m", "position p_W z (height), world frame (z up)"},
    {"vx", "m/s", "velocity v_W x, world frame"},
    {"vy", "m/s", "velocity v_W y, world frame"},
    {"vz", "m/s", "velocity v_W z, world frame"},
    {"qw", "1", "attitude quaternion q_WB (body to world), w component"},
    {"qx", "1", "attitude quaternion q_WB (body to world), x component"},
    {"qy", "1", "attitude quaternion q_WB (body to world), y component"},
    {"qz", "1", "attitude quaternion q_WB (body to world), z component"},
    {"wx", "rad/s", "body rate w_B x, body frame"},
    {"wy", "rad/s", "body rate w_B y, body frame"},
    {"wz", "rad/s", "body rate w_B z, body frame"},
};

bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() > suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}

/// Unit of a controller diagnostic from its name's suffix (longest suffixes first).
std::string diagnostic_unit(std::string_view name) {
  static constexpr std::pair<std::string_view, std::string_view> kSuffixes[] = {
      {"_rad_s", "rad/s"}, {"_m_s", "m/s"}, {"_ms", "ms"}, {"_Nm", "N m"},
      {"_rad", "rad"},     {"_s", "s"},     {"_m", "m"},   {"_N", "N"}};
  for (const auto& [suffix, unit] : kSuffixes)
    if (ends_with(name, suffix)) return std::string(unit);
  return "1";
}

}  // namespace

std::vector<LogColumn> log_columns(const LogLayout& layout) {
  std::vector<LogColumn> c;
  c.push_back({"t", "s", "simulated time k dt_s of the row"});
  for (const StateColumn& s : kState) c.push_back({s.name, s.unit, s.meaning});
  for (int i = 0; i < layout.num_rotors; ++i) {
    c.push_back({"omega_" + std::to_string(i), "rad/s",
                 "achieved speed of rotor " + std::to_string(i) + " (after the motor lag)"});
  }
  for (int i = 0; i < layout.num_rotors; ++i) {
    c.push_back({"omega_ref_" + std::to_string(i), "rad/s",
                 "speed reference of rotor " + std::to_string(i) + " in effect from t on"});
  }
  if (layout.measured) {
    for (const StateColumn& s : kState)
      c.push_back({std::string("meas_") + s.name, s.unit,
                   std::string("measured (OU noise added) ") + s.meaning});
  }
  c.push_back({"in_contact", "bool", "1 while the vehicle touches the ground"});
  c.push_back({"crashed", "bool", "1 from the first crash on (too fast or too tilted a contact)"});
  if (layout.wind) {
    for (const char* axis : kAxes)
      c.push_back({std::string("wind_") + axis, "m/s",
                   std::string("air velocity at the vehicle (mean wind, shear, gusts, turbulence) "
                               "held over the step from t, world ") +
                       axis + " axis"});
  }
  if (layout.battery) {
    c.push_back({"battery_soc", "1", "battery state of charge (1 full, 0 empty) at t"});
    c.push_back({"battery_voltage", "V",
                 "battery terminal voltage at t under the current of the step that reached t "
                 "(0 once cut off); it caps the rotor speeds at K_V V"});
    c.push_back({"battery_current", "A", "battery current of the step that reached t"});
  }
  if (layout.payload) {
    for (const char* axis : kAxes)
      c.push_back({std::string("payload_") + axis, "m",
                   std::string("slung payload position, world ") + axis + " axis"});
    for (const char* axis : kAxes)
      c.push_back({std::string("payload_v") + axis, "m/s",
                   std::string("slung payload velocity, world ") + axis + " axis"});
    c.push_back({"swing_1", "rad", "payload swing angle gamma1 of Eq. 3.33 (about the y axis)"});
    c.push_back({"swing_2", "rad", "payload swing angle gamma2 of Eq. 3.33 (toward +y)"});
    c.push_back({"swing_rate_1", "rad/s", "rate of swing_1"});
    c.push_back({"swing_rate_2", "rad/s", "rate of swing_2"});
    c.push_back({"tension", "N", "cable tension at t (0 while slack)"});
  }
  if (layout.downwash) {
    for (const char* axis : kAxes)
      c.push_back({std::string("downwash_flow_") + axis, "m/s",
                   std::string("other vehicles' wake at the centre of mass, world ") + axis +
                       " axis, of the step that reached t (added to its wind)"});
    for (const char* axis : kAxes)
      c.push_back({std::string("downwash_force_") + axis, "N",
                   std::string("rotor thrust change in the wake, body ") + axis + " axis"});
    for (const char* axis : kAxes)
      c.push_back({std::string("downwash_moment_") + axis, "N m",
                   std::string("moment of the thrust change, body ") + axis + " axis"});
  }
  if (layout.wrench_breakdown) {
    for (int k = 0; k < kNumTerms; ++k) {
      const std::string term(term_name(static_cast<Term>(k)));
      for (const char* axis : kAxes) {
        c.push_back({"F_" + term + "_" + axis, "N",
                     "force of the " + term + " term, body " + axis + " axis"});
      }
      for (const char* axis : kAxes) {
        c.push_back(
            {"M_" + term + "_" + axis, "N m",
             "moment of the " + term + " term about the centre of mass, body " + axis + " axis"});
      }
    }
  }
  for (const SensorSpec& sensor : layout.sensors) {
    const std::string what =
        detail::concat(sensor.type_name(), " '", sensor.name, "' (", sensor.rate_hz,
                       " Hz, latency ", sensor.latency_s, " s): ");
    c.push_back(
        {detail::concat(sensor.name, "_t"), "s",
         detail::concat(what, "time its latest delivered reading was taken (NaN: none yet)")});
    for (const SensorChannel& ch : sensor_channels(sensor, layout.num_rotors))
      c.push_back(
          {detail::concat(sensor.name, "_", ch.suffix), ch.unit, detail::concat(what, ch.meaning)});
  }
  for (const DepthCameraSpec& camera : layout.depth_cameras) {
    const DepthCameraParameters& p = camera.parameters;
    const std::string what = detail::concat("depth camera '", camera.name, "' (", p.width_px, " x ",
                                            p.height_px, " px, ", p.rate_hz, " Hz): ");
    c.push_back({detail::concat(camera.name, "_t"), "s",
                 detail::concat(what, "time its latest frame was taken (NaN: none yet)")});
    c.push_back({detail::concat(camera.name, "_frame"), "1",
                 detail::concat(what, "index of its latest frame in ", camera.name,
                                ".npy (NaN: none yet)")});
  }
  if (layout.estimate) {
    for (const StateColumn& st : kState)
      c.push_back({detail::concat("est_", st.name), st.unit,
                   detail::concat("estimated (error-state EKF) ", st.meaning)});
  }
  if (layout.controller) {
    for (const char* axis : kAxes) {
      c.push_back({std::string("ref_") + axis, "m",
                   std::string("reference position ") + axis + " at t, world frame"});
    }
    c.push_back({"ref_yaw", "rad", "reference yaw at t (as the reference gives it, not wrapped)"});
    c.push_back({"u_T", "N", "collective thrust of the rotor command in effect from t on"});
    for (const char* axis : kAxes) {
      c.push_back(
          {std::string("u_tau_") + axis, "N m",
           std::string("body ") + axis + " torque of the rotor command in effect from t on"});
    }
    c.push_back({"saturated", "bool", "1 if the allocation of that command saturated"});
    for (const std::string& d : layout.controller_diagnostics) {
      c.push_back({"ctrl_" + d, diagnostic_unit(d),
                   "controller diagnostic '" + d +
                       "' of its most recent update (NaN: not applicable at that update)"});
    }
  }
  // A sensor's columns must not take another column's name ("ref" would write ref_x twice).
  std::set<std::string_view> seen;
  for (const LogColumn& col : c) {
    if (seen.insert(col.name).second) continue;
    for (const SensorSpec& sensor : layout.sensors)
      require(col.name.rfind(sensor.name + "_", 0) != 0, "sensor '", sensor.name,
              "': its log column '", col.name,
              "' is already a column of the log; give the sensor another name");
    for (const DepthCameraSpec& camera : layout.depth_cameras)
      require(col.name.rfind(camera.name + "_", 0) != 0, "depth camera '", camera.name,
              "': its log column '", col.name,
              "' is already a column of the log; give the camera another name");
    throw InvalidArgument(detail::concat("log column '", col.name, "' appears twice"));
  }
  return c;
}

std::vector<std::string> log_column_names(const LogLayout& layout) {
  std::vector<std::string> names;
  for (LogColumn& c : log_columns(layout)) names.push_back(std::move(c.name));
  return names;
}

// ---- writer -----------------------------------------------------------------------------------

CsvLogWriter::CsvLogWriter(const std::string& path, std::vector<std::string> columns)
    : path_(path), columns_(std::move(columns)), buffer_(kBufferBytes) {
  require(!columns_.empty(), path_, ": a log needs at least one column");
  for (std::size_t i = 0; i < columns_.size(); ++i) {
    const std::string& name = columns_[i];
    require(!name.empty() && name.find_first_of(",\"\r\n") == std::string::npos, path_, ": column ",
            i, ": expected a name without commas, quotes or line breaks, got '", name, "'");
  }
  errno = 0;
  file_ = std::fopen(path_.c_str(), "wb");
  require(file_ != nullptr, path_, ": cannot open for writing (", errno_text(), ")");
  std::string header;
  for (std::size_t i = 0; i < columns_.size(); ++i) header += (i ? "," : "") + columns_[i];
  header += '\n';
  if (std::fwrite(header.data(), 1, header.size(), file_) != header.size()) write_error_ = true;
}

CsvLogWriter::~CsvLogWriter() {
  if (file_ == nullptr) return;
  write_buffer();
  std::fclose(file_);
}

void CsvLogWriter::write_buffer() {
  if (used_ > 0 && std::fwrite(buffer_.data(), 1, used_, file_) != used_) write_error_ = true;
  used_ = 0;
}

void CsvLogWriter::write_row(const double* values, std::size_t n) {
  require(file_ != nullptr, path_, ": write_row after close()");
  require(n == columns_.size(), path_, ": row ", rows_ + 1, ": expected ", columns_.size(),
          " values (one per column), got ", n);
  for (std::size_t i = 0; i < n; ++i) {
    if (buffer_.size() - used_ < kMaxFieldBytes) write_buffer();
    // to_chars with precision 17 in general format is specified to print exactly what
    // printf("%.17g") prints in the C locale; it is ~3x faster and ignores the global locale.
    char* const first = buffer_.data() + used_;
    const auto r =
        std::to_chars(first, first + kMaxFieldBytes - 1, values[i], std::chars_format::general, 17);
    used_ += static_cast<std::size_t>(r.ptr - first);
    buffer_[used_++] = i + 1 < n ? ',' : '\n';
  }
  ++rows_;
}

void CsvLogWriter::flush() {
  if (file_ == nullptr) return;
  write_buffer();
  if (std::fflush(file_) != 0) write_error_ = true;
}

void CsvLogWriter::close() {
  if (file_ == nullptr) return;
  write_buffer();
  const bool close_failed = std::fclose(file_) != 0;
  file_ = nullptr;
  require(!write_error_ && !close_failed, path_, ": error while writing the log");
}

// ---- reader -----------------------------------------------------------------------------------

std::size_t LogTable::column(std::string_view name) const {
  for (std::size_t i = 0; i < columns.size(); ++i)
    if (columns[i] == name) return i;
  throw InvalidArgument((source.empty() ? std::string("log") : source) + ": no column '" +
                        std::string(name) + "'");
}

std::vector<double> LogTable::column_values(std::string_view name) const {
  const std::size_t c = column(name);
  std::vector<double> out(rows());
  for (std::size_t r = 0; r < out.size(); ++r) out[r] = at(r, c);
  return out;
}

LogTable read_csv_log(const std::string& path) {
  CsvLogReader in(path);
  LogTable t;
  t.source = path;
  t.columns = in.columns();
  std::vector<double> row;
  while (in.next(row)) t.values.insert(t.values.end(), row.begin(), row.end());
  return t;
}

CsvLogReader::CsvLogReader(const std::string& path) : path_(path) {
  errno = 0;
  in_.open(path, std::ios::binary);
  require(static_cast<bool>(in_), path, ": cannot open log (", errno_text(), ")");
  require(static_cast<bool>(std::getline(in_, line_)), path,
          ": line 1: empty file, expected a header");
  line_number_ = 1;
  if (!line_.empty() && line_.back() == '\r') line_.pop_back();
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line_.find(',', start);
    std::string name =
        line_.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    require(!name.empty(), path, ": line 1, column ", columns_.size() + 1,
            ": expected a column name, got an empty field");
    columns_.push_back(std::move(name));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
}

bool CsvLogReader::has_column(std::string_view name) const {
  return std::find(columns_.begin(), columns_.end(), name) != columns_.end();
}

std::size_t CsvLogReader::column(std::string_view name) const {
  for (std::size_t i = 0; i < columns_.size(); ++i)
    if (columns_[i] == name) return i;
  throw InvalidArgument(path_ + ": no column '" + std::string(name) + "'");
}

bool CsvLogReader::next(std::vector<double>& values) {
  const std::size_t n = columns_.size();
  values.resize(n);
  if (!std::getline(in_, line_)) {
    require(!in_.bad(), path_, ": error while reading the log (", errno_text(), ")");
    return false;
  }
  ++line_number_;
  if (!line_.empty() && line_.back() == '\r') line_.pop_back();
  if (line_.empty() && in_.peek() == std::char_traits<char>::eof()) return false;  // trailing \n
  const char* p = line_.data();
  const char* const end = p + line_.size();
  std::size_t col = 0;
  for (;;) {
    const char* comma =
        static_cast<const char*>(std::memchr(p, ',', static_cast<std::size_t>(end - p)));
    const char* field_end = comma ? comma : end;
    require(col < n, path_, ": line ", line_number_, ": expected ", n, " fields, got more");
    double v = 0.0;
    const auto r = std::from_chars(p, field_end, v);
    if (r.ec != std::errc{} || r.ptr != field_end || p == field_end) {
      require(false, path_, ": line ", line_number_, ", column ", col + 1, " (", columns_[col],
              "): expected a number, got '", std::string(p, field_end), "'");
    }
    values[col++] = v;
    if (!comma) break;
    p = comma + 1;
  }
  require(col == n, path_, ": line ", line_number_, ": expected ", n, " fields, got ", col);
  return true;
}

std::size_t CsvLogReader::count_rows(const std::string& path) {
  errno = 0;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  require(f != nullptr, path, ": cannot open log (", errno_text(), ")");
  std::vector<char> buffer(kBufferBytes * 16);
  std::size_t lines = 0, got = 0;
  char last = '\n';
  while ((got = std::fread(buffer.data(), 1, buffer.size(), f)) > 0) {
    const char* p = buffer.data();
    const char* const end = p + got;
    while (
        (p = static_cast<const char*>(std::memchr(p, '\n', static_cast<std::size_t>(end - p))))) {
      ++lines;
      ++p;
    }
    last = buffer[got - 1];
  }
  std::fclose(f);
  if (last != '\n') ++lines;         // a last line without its line end
  return lines > 0 ? lines - 1 : 0;  // the header
}

}  // namespace dronetwin
