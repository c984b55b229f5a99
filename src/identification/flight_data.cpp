// Flights as the fit sees them (flight_data.hpp): flat storage, from a log table or streamed
// from a CSV file.
#include "dronetwin/identification/flight_data.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

FlightData::FlightData(std::string source, const Layout& layout)
    : source_(std::move(source)), layout_(layout) {
  require(layout.num_rotors >= 1 && layout.num_rotors <= kMaxRotors, source_,
          ": num_rotors must be in [1, ", kMaxRotors, "], got ", layout.num_rotors);
}

void FlightData::reserve(std::size_t rows) {
  const auto nr = static_cast<std::size_t>(layout_.num_rotors);
  t_s_.reserve(rows);
  state_.reserve(kStateSize * rows);
  rotor_speed_.reserve(nr * rows);
  if (layout_.rotor_references) rotor_reference_.reserve(nr * rows);
  if (layout_.specific_force) specific_force_.reserve(3 * rows);
  in_contact_.reserve(rows);
}

void FlightData::append_row(double t, const StateVector& x, const double* speeds,
                            const double* references, bool contact, const Vec3& specific_force) {
  const std::size_t row = rows() + 1;  // 1-based data row, as in the messages of the log reader
  require(std::isfinite(t), source_, ": row ", row, ": t is not finite");
  require(t_s_.empty() || t > t_s_.back(), source_, ": row ", row, ": t = ", t,
          " does not increase (previous ", t_s_.empty() ? 0.0 : t_s_.back(), ")");
  static const char* kStateNames[kStateSize] = {"x",  "y",  "z",  "vx", "vy", "vz", "qw",
                                                "qx", "qy", "qz", "wx", "wy", "wz"};
  for (int i = 0; i < kStateSize; ++i) {
    require(std::isfinite(x[i]), source_, ": row ", row, ": column ",
            layout_.measured ? "meas_" : "", kStateNames[i], " is not finite");
  }
  const double qn = x.segment<4>(6).norm();
  require(qn > 0.5 && qn < 1.5, source_, ": row ", row, ": quaternion norm ", qn, " is not near 1");
  for (int i = 0; i < layout_.num_rotors; ++i) {
    require(std::isfinite(speeds[i]), source_, ": row ", row, ": omega_", i, " is not finite");
  }
  if (layout_.specific_force) {
    require(specific_force.allFinite(), source_, ": row ", row, ": acc_x/y/z is not finite");
  }
  t_s_.push_back(t);
  for (int i = 0; i < kStateSize; ++i) state_.push_back(i >= 6 && i < 10 ? x[i] / qn : x[i]);
  rotor_speed_.insert(rotor_speed_.end(), speeds, speeds + layout_.num_rotors);
  if (layout_.rotor_references)
    rotor_reference_.insert(rotor_reference_.end(), references, references + layout_.num_rotors);
  in_contact_.push_back(contact ? 1 : 0);
  if (layout_.specific_force)
    specific_force_.insert(specific_force_.end(), specific_force.data(), specific_force.data() + 3);
}

void FlightData::derive_body_rates() {
  const std::size_t n = rows();
  if (n < 2) return;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t a = k + 1 < n ? k : k - 1;
    const Vec4 qa = state(a).segment<4>(6), qb = state(a + 1).segment<4>(6);
    Vec4 e = math::multiply<double>(Vec4(qa[0], -qa[1], -qa[2], -qa[3]), qb);
    if (e[0] < 0) e = -e;
    Eigen::Map<StateVector>(state_.data() + kStateSize * k).segment<3>(10) =
        2.0 * e.segment<3>(1) / (t_s_[a + 1] - t_s_[a]);
  }
}

std::size_t FlightData::bytes() const {
  return sizeof(double) * (t_s_.capacity() + state_.capacity() + rotor_speed_.capacity() +
                           rotor_reference_.capacity() + specific_force_.capacity()) +
         in_contact_.capacity();
}

namespace {

// Where each quantity of a FlightData sits in a log's columns.
struct ColumnMap {
  FlightData::Layout layout;
  std::size_t t = 0;
  std::array<std::size_t, kStateSize> state{};
  std::vector<std::size_t> speeds, references;
  std::size_t contact = 0;
  bool has_contact = false;
  std::array<std::size_t, 3> acc{};
};

ColumnMap map_columns(const std::vector<std::string>& names, const std::string& source,
                      int num_rotors, bool prefer_measured) {
  static const char* kStateNames[kStateSize] = {"x",  "y",  "z",  "vx", "vy", "vz", "qw",
                                                "qx", "qy", "qz", "wx", "wy", "wz"};
  require(num_rotors >= 1 && num_rotors <= kMaxRotors, source, ": num_rotors must be in [1, ",
          kMaxRotors, "], got ", num_rotors);
  const auto has = [&](const std::string& name) {
    return std::find(names.begin(), names.end(), name) != names.end();
  };
  const auto column = [&](const std::string& name) {
    const auto it = std::find(names.begin(), names.end(), name);
    require(it != names.end(), source, ": no column '", name, "'");
    return static_cast<std::size_t>(it - names.begin());
  };
  ColumnMap m;
  m.layout.num_rotors = num_rotors;
  m.layout.measured = prefer_measured && has("meas_x");
  const std::string prefix = m.layout.measured ? "meas_" : "";
  m.layout.body_rates = has(prefix + "wx");
  m.layout.rotor_references = has("omega_ref_0");
  m.layout.specific_force = has("acc_x");
  m.t = column("t");
  const int state_columns = m.layout.body_rates ? kStateSize : 10;
  for (int i = 0; i < state_columns; ++i)
    m.state[static_cast<std::size_t>(i)] = column(prefix + kStateNames[i]);
  for (int i = 0; i < num_rotors; ++i) m.speeds.push_back(column("omega_" + std::to_string(i)));
  if (m.layout.rotor_references) {
    for (int i = 0; i < num_rotors; ++i)
      m.references.push_back(column("omega_ref_" + std::to_string(i)));
  }
  m.has_contact = has("in_contact");
  if (m.has_contact) m.contact = column("in_contact");
  if (m.layout.specific_force) m.acc = {column("acc_x"), column("acc_y"), column("acc_z")};
  return m;
}

void append(FlightData& d, const ColumnMap& m, const double* row) {
  StateVector x = StateVector::Zero();
  const int state_columns = m.layout.body_rates ? kStateSize : 10;
  for (int i = 0; i < state_columns; ++i) x[i] = row[m.state[static_cast<std::size_t>(i)]];
  std::array<double, kMaxRotors> speeds{}, references{};
  for (std::size_t i = 0; i < m.speeds.size(); ++i) speeds[i] = row[m.speeds[i]];
  for (std::size_t i = 0; i < m.references.size(); ++i) references[i] = row[m.references[i]];
  d.append_row(
      row[m.t], x, speeds.data(), references.data(), m.has_contact && row[m.contact] != 0.0,
      m.layout.specific_force ? Vec3(row[m.acc[0]], row[m.acc[1]], row[m.acc[2]]) : Vec3::Zero());
}

}  // namespace

FlightData flight_data_from_log(const LogTable& log, int num_rotors, bool prefer_measured) {
  const ColumnMap m = map_columns(log.columns, log.source, num_rotors, prefer_measured);
  FlightData d(log.source, m.layout);
  const std::size_t n = log.rows();
  d.reserve(n);
  for (std::size_t row = 0; row < n; ++row)
    append(d, m, log.values.data() + row * log.columns.size());
  if (!m.layout.body_rates) d.derive_body_rates();
  return d;
}

FlightData read_flight_data(const std::string& path, int num_rotors, bool prefer_measured) {
  const std::size_t rows = CsvLogReader::count_rows(path);
  CsvLogReader in(path);
  const ColumnMap m = map_columns(in.columns(), path, num_rotors, prefer_measured);
  FlightData d(path, m.layout);
  d.reserve(rows);
  std::vector<double> row;
  while (in.next(row)) append(d, m, row.data());
  if (!m.layout.body_rates) d.derive_body_rates();
  return d;
}

}  // namespace dronetwin
