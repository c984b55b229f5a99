#pragma once
// Parameter identification from a logged flight: the model's own force model
// (through parameter_map.hpp and the force kernel) is fitted to the log with Ceres, in up to three
// ways.
//
//   equation error   the acceleration between two rows, (v_{k+1} - v_k)/dt and
//                    (w_{k+1} - w_k)/dt, against the model's mean acceleration over the interval
//                    (trapezoid of f at both rows, logged rotor speeds held as the simulator holds
//                    them): fast, and exact to O(dt^2) for logs at the physics rate;
//   output error     multiple shooting: short windows started from the logged state, integrated
//                    with RK4 through the logged rotor speeds, compared with the logged position,
//                    velocity, attitude and body rates (noise in single rows averages out);
//   motor lag        w_{k+1} = a w_k + (1 - a) clamp(w_ref,k), a = exp(-dt/tau) (Eq. 2.45), for
//                    tau_rise / tau_fall, from the rotor-speed and reference columns.
//
// Residual channels are weighted by 1/RMS at a first solution and the problem solved again, so
// m/s^2, rad/s^2, m and rad are comparable and the standard errors (Ceres covariance,
// sigma^2 = 2 cost / (n - p)) are in the data's own noise units.
//
//   VehicleModel model = load_vehicle_model("models/qdrone2.yaml");
//   FlightData data = flight_data_from_log(read_csv_log("out/id/log.csv"), model.num_rotors());
//   FitOptions o;  o.parameters = parse_parameter_list("thrust,inertia,body_drag");
//   FitResult r = fit_model(model, data, o);
//   save_vehicle_spec(r.fitted_spec, "fitted.yaml");
//
// Rows in ground contact (in_contact = 1), below FitOptions::min_height_m or with a rotor
// (nearly) stopped, and intervals across a gap in time (dt more than FitOptions::max_gap_factor
// times the median) are left out. The last holdout_fraction of the
// intervals is not fitted; FitResult reports the residuals there before and after.
//
// Trap: accelerations depend on forces / mass, so mass and a complete set of force coefficients
// (e.g. mass with thrust) cannot be fitted together: the fit then warns of a correlation near 1.
// Fix the ones you know (thrust from a stand, mass from a scale) and fit the rest.

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "dronetwin/core/types.hpp"
#include "dronetwin/dynamics/environment.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/identification/model_parameters.hpp"
#include "dronetwin/logging/csv_log.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

/// A flight as the fit sees it: one entry per log row.
struct FlightData {
  std::string source;
  int num_rotors = 0;
  std::vector<double> t_s;
  std::vector<StateVector> state;  ///< measured state when the log has it (see used_measured)
  std::vector<RotorVector> rotor_speed_rad_s;
  /// Rotor speed references (omega_ref_i); empty when the log has none.
  std::vector<RotorVector> rotor_reference_rad_s;
  /// 1 where the vehicle touched the ground (in_contact); all 0 when the log has no such column.
  std::vector<char> in_contact;
  /// True when the state came from the meas_* columns (what a real sensor log holds).
  bool used_measured = false;
  /// False when the log has no wx, wy, wz: the rates are then derived from successive
  /// quaternions and the angular-acceleration residuals are not used.
  bool has_body_rates = true;
  /// World-frame specific force dv/dt - g (acc_x, acc_y, acc_z, what an accelerometer reads
  /// turned into world axes) when the log has it; the equation error then uses it instead of
  /// differencing the velocity. Empty otherwise.
  std::vector<Vec3> specific_force_W_m_s2;
};

/// Extracts a FlightData from a log. Needs t, the state (meas_x..meas_wz when present and
/// `prefer_measured`, else x..wz; the rates may be missing) and omega_0..omega_{N-1};
/// omega_ref_*, in_contact and acc_x..acc_z are used when present. InvalidArgument naming the log
/// and the missing column, or a row whose time does not increase or whose values are not finite.
FlightData flight_data_from_log(const LogTable& log, int num_rotors, bool prefer_measured = true);

enum class FitMethod { kEquationError, kOutputError, kBoth };

struct FitOptions {
  std::vector<ModelParameter> parameters;
  FitMethod method = FitMethod::kBoth;
  /// Disturbance terms and environment the flight was flown with (the log's sidecar says).
  DisturbanceSwitches switches{};
  Environment environment{};
  /// Share of the flight (the last intervals) kept out of the fit for validation.
  double holdout_fraction = 0.2;
  /// An interval longer than this times the median interval is a gap.
  double max_gap_factor = 1.5;
  /// Rows below this height (m) are left out, like rows in contact: a real log without an
  /// in_contact column still holds take-off and landing, where the ground pushes.
  double min_height_m = -std::numeric_limits<double>::infinity();
  /// Rows with a rotor slower than this (rad/s) are left out (motors off or stalling: the
  /// thrust curve is not meant for them).
  double min_rotor_speed_rad_s = 1.0;
  /// Output error: window length, s, and at most this many windows (spread evenly).
  double window_s = 0.05;
  int max_windows = 200;
  int max_iterations = 50;
  /// Threads for Ceres' Jacobian evaluation (results do not depend on it).
  int num_threads = 1;
};

struct FittedParameter {
  ModelParameter parameter{};
  std::string name;
  std::string unit;
  double initial = 0.0;
  double estimate = 0.0;
  double std_error = 0.0;  ///< NaN when the covariance could not be computed
};

/// RMS of the residual channels on a set of intervals (NaN for a channel that was not used).
struct ResidualStats {
  std::size_t intervals = 0;
  double linear_acceleration_m_s2 = 0.0;  ///< equation error, per axis
  double angular_acceleration_rad_s2 = 0.0;
  double position_m = 0.0;  ///< output error over the windows
  double attitude_rad = 0.0;
  double motor_speed_rad_s = 0.0;  ///< motor-lag residual
};

struct FitResult {
  std::vector<FittedParameter> parameters;
  /// Correlation of the estimates (parameters order); empty when the covariance failed.
  Eigen::MatrixXd correlation;
  /// Poorly identifiable parameters, high correlations, and anything else a user should know.
  std::vector<std::string> warnings;
  ResidualStats fit_before, fit_after, holdout_before, holdout_after;
  std::size_t rows = 0, intervals_used = 0, intervals_holdout = 0, gaps = 0, contact_rows = 0;
  /// Rows left out for being below min_height_m or having a rotor below min_rotor_speed_rad_s.
  std::size_t excluded_rows = 0;
  std::size_t windows = 0;
  double median_dt_s = 0.0;
  int iterations = 0;
  std::string termination;  ///< Ceres' termination type of the last solve
  double solve_time_s = 0.0;
  /// The input model with the estimates written in.
  VehicleSpec fitted_spec;
};

/// Fits options.parameters of `model` to `data`. InvalidArgument for an empty parameter list,
/// motor parameters without a reference column, too few usable intervals, or bad options.
FitResult fit_model(const VehicleModel& model, const FlightData& data, const FitOptions& options);

/// A human-readable report (estimates, standard errors, residuals, warnings).
std::string format_fit_report(const FitResult& result);
/// The same as JSON.
std::string fit_result_to_json(const FitResult& result);

}  // namespace dronetwin
