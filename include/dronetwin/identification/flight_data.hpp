#pragma once
// A logged flight as the fit (fit.hpp) sees it: per row the time, the state, the rotor speeds and,
// when the log has them, the rotor speed references, the contact flag and the accelerometer's
// specific force. Stored flat, one array per quantity and only the columns the fit reads, so a
// 1-hour log at 1 kHz (3.6 M rows) of a quadrotor with every column takes 201 bytes per row
// (t 8, state 104, speeds 32, references 32, contact 1, specific force 24); bytes() says how much.
//
//   FlightData d = read_flight_data("out/id/log.csv", 4);     // streams the CSV
//   double z = d.state(k)[2];
//   const double* w = d.rotor_speeds_rad_s(k);                 // num_rotors() numbers
//
// Trap: rows are appended in time order only (append_row checks that t increases); edit a flight
// by building a new one from the rows you keep.

#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <vector>

#include "dronetwin/core/types.hpp"
#include "dronetwin/logging/csv_log.hpp"

namespace dronetwin {

class FlightData {
 public:
  /// What a flight holds besides t, the state and the rotor speeds.
  struct Layout {
    int num_rotors = 4;
    /// omega_ref_0.. are present (needed for the motor time constants).
    bool rotor_references = false;
    /// acc_x, acc_y, acc_z are present.
    bool specific_force = false;
    /// wx, wy, wz are present; without them the rates are derived from successive attitudes
    /// (derive_body_rates) and the angular accelerations cannot be fitted.
    bool body_rates = true;
    /// The state came from the meas_* columns (what a real sensor log holds).
    bool measured = false;
  };

  FlightData() = default;
  /// An empty flight; `source` names it in messages. InvalidArgument for a rotor count outside
  /// [1, kMaxRotors].
  FlightData(std::string source, const Layout& layout);

  const std::string& source() const { return source_; }
  const Layout& layout() const { return layout_; }
  int num_rotors() const { return layout_.num_rotors; }
  bool used_measured() const { return layout_.measured; }
  bool has_body_rates() const { return layout_.body_rates; }
  bool has_rotor_references() const { return layout_.rotor_references; }
  bool has_specific_force() const { return layout_.specific_force; }

  std::size_t rows() const { return t_s_.size(); }
  double t_s(std::size_t k) const { return t_s_[k]; }
  /// [p_W, v_W, q_WB (w, x, y, z), w_B] of row k.
  Eigen::Map<const StateVector> state(std::size_t k) const {
    return Eigen::Map<const StateVector>(state_.data() + kStateSize * k);
  }
  const double* rotor_speeds_rad_s(std::size_t k) const {
    return rotor_speed_.data() + static_cast<std::size_t>(layout_.num_rotors) * k;
  }
  /// Rotor speed references of row k (has_rotor_references() only).
  const double* rotor_references_rad_s(std::size_t k) const {
    return rotor_reference_.data() + static_cast<std::size_t>(layout_.num_rotors) * k;
  }
  /// 1 where the vehicle touched the ground (in_contact); 0 when the log has no such column.
  bool in_contact(std::size_t k) const { return in_contact_[k] != 0; }
  /// World-frame specific force dv/dt - g (acc_x, acc_y, acc_z: what an accelerometer reads,
  /// turned into world axes; has_specific_force() only). The equation error then uses it instead
  /// of differencing the velocity.
  Eigen::Map<const Vec3> specific_force_W_m_s2(std::size_t k) const {
    return Eigen::Map<const Vec3>(specific_force_.data() + 3 * k);
  }

  /// Reserves room for `rows` rows (a reader that knows the row count never reallocates).
  void reserve(std::size_t rows);
  /// Appends a row. `rotor_speeds` (and `references` with rotor_references) hold num_rotors()
  /// numbers; `specific_force` is read with specific_force. InvalidArgument naming the source
  /// and the row for a time that does not increase, a non-finite number or a quaternion whose
  /// norm is not near 1 (it is normalised).
  void append_row(double t_s, const StateVector& state, const double* rotor_speeds,
                  const double* references = nullptr, bool in_contact = false,
                  const Vec3& specific_force = Vec3::Zero());
  /// Without logged rates: w_B from successive attitudes, q_{k+1} = q_k (x) exp(w dt / 2), so
  /// w ~ 2 vec(q_k^-1 q_{k+1}) / dt (the last row takes the last interval's).
  void derive_body_rates();

  /// Bytes held by the rows (what a fit of this flight needs beyond its own bounded scratch).
  std::size_t bytes() const;

 private:
  std::string source_;
  Layout layout_;
  std::vector<double> t_s_, state_, rotor_speed_, rotor_reference_, specific_force_;
  std::vector<char> in_contact_;
};

/// Extracts a FlightData from a log table. Needs t, the state (meas_x..meas_wz when present and
/// `prefer_measured`, else x..wz; the rates may be missing) and omega_0..omega_{N-1};
/// omega_ref_*, in_contact and acc_x..acc_z are used when present. InvalidArgument naming the log
/// and the missing column, or a row whose time does not increase or whose values are not finite.
FlightData flight_data_from_log(const LogTable& log, int num_rotors, bool prefer_measured = true);

/// The same, streaming the CSV file row by row: only the columns the fit reads are kept, so
/// memory is FlightData::bytes() (read_csv_log() would hold every column of every row).
FlightData read_flight_data(const std::string& path, int num_rotors, bool prefer_measured = true);

}  // namespace dronetwin
