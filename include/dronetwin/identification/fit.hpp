#pragma once
// Parameter identification from a logged flight: the model's own force model
// (through parameter_map.hpp and the force kernel) is fitted to the log with Ceres, in up to three
// ways.
//
//   equation error   the acceleration between two rows, (v_{k+1} - v_k)/dt (or the logged
//                    accelerometer) and (w_{k+1} - w_k)/dt, against the model's mean acceleration
//                    over the interval (trapezoid of f at both rows, logged rotor speeds held as
//                    the simulator holds them): exact to O(dt^2) for logs at the physics rate;
//   output error     multiple shooting: short windows started from the logged state, integrated
//                    with RK4 through the logged rotor speeds, compared with the logged position,
//                    velocity, attitude and body rates (noise in single rows averages out);
//   motor lag        w_{k+1} = a w_k + (1 - a) clamp(w_ref,k), a = exp(-dt/tau) (Eq. 2.45), for
//                    tau_rise / tau_fall, from the rotor-speed and reference columns.
//
// Real flights (docs/identification.md, "Fitting real flights"):
//   channels   the equation error compares the linear and/or the angular accelerations
//              (FitOptions::channels). By default (kAuto) the angular channel is used only when a
//              fitted parameter acts on the angular accelerations alone (inertia, yaw and drag
//              moments, rolling moment): it differences a noisy gyro, and per-motor speed-sensor
//              errors appear in it as torques from rotor-speed differences;
//   loss       Huber (default) or Cauchy on every residual in units of its channel's robust noise
//              level (1.4826 x median |r|), so spikes and glitches lose their pull;
//   gains      per-rotor speed-sensor gains g_i (true speed = g_i x logged), fitted by default
//              whenever the angular channel is used. Their mean is fixed at 1: a scale common to
//              all sensors cannot be told from the thrust coefficients;
//   check      the fitted model and the starting one are compared on the held-out end of the
//              flight; a fit that explains it worse is flagged (FitResult::holdout_check), and
//              `dronetwin fit` then refuses to write the model unless --force.
//
// The equation error and the motor lag are streamed: every solver iteration walks the log once
// and accumulates the normal equations (J^T W J, J^T W r over the free parameters), so the fit
// keeps no per-row Jacobian (Ceres drives the iterations through a square-root information
// block); chunks of the log go to FitOptions::num_threads threads and are summed in a fixed
// order, so the result is bitwise the same on any number of threads. The output-error windows
// (bounded: max_windows) are ordinary Ceres residual blocks.
//
//   VehicleModel model = load_vehicle_model("models/qdrone2.yaml");
//   FlightData data = read_flight_data("out/id/log.csv", model.num_rotors());
//   FitOptions o;  o.parameters = parse_parameter_list("thrust,inertia,body_drag");
//   FitResult r = fit_model(model, data, o);
//   if (!r.holdout_check.worse) save_vehicle_spec(r.fitted_spec, "fitted.yaml");
//
// Rows in ground contact (in_contact = 1), below FitOptions::min_height_m or with a rotor
// (nearly) stopped, and intervals across a gap in time (dt more than FitOptions::max_gap_factor
// times the median) are left out. The last holdout_fraction of the intervals is not fitted;
// FitResult reports the residuals there before and after.
//
// Trap: accelerations depend on forces / mass, so mass and a complete set of force coefficients
// (e.g. mass with thrust) cannot be fitted together: the fit then warns of a correlation near 1.
// Fix the ones you know (thrust from a stand, mass from a scale) and fit the rest.

#include <Eigen/Core>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "dronetwin/core/types.hpp"
#include "dronetwin/dynamics/environment.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/identification/flight_data.hpp"
#include "dronetwin/model/model_parameters.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

enum class FitMethod { kEquationError, kOutputError, kBoth };

/// Which accelerations the equation error compares (and which states the output-error windows
/// compare: position and velocity for linear, attitude and rates for angular).
enum class FitChannels { kAuto, kLinear, kAngular, kLinearAngular };
/// "auto", "linear", "angular", "linear,angular" (also "angular,linear").
FitChannels parse_fit_channels(std::string_view text);
std::string_view fit_channels_name(FitChannels channels);

/// The loss on each residual, in units of its channel's robust noise level: none (least squares),
/// Huber (quadratic, then linear beyond the scale) or Cauchy (logarithmic beyond it).
enum class FitLoss { kNone, kHuber, kCauchy };
FitLoss parse_fit_loss(std::string_view text);  ///< "none", "huber", "cauchy"
std::string_view fit_loss_name(FitLoss loss);
/// The standard scale of a loss: 1.345 (Huber) and 2.385 (Cauchy) noise levels keep 95 % of
/// least squares' efficiency on Gaussian noise; 0 for none.
double default_loss_scale(FitLoss loss);

/// Per-rotor speed-sensor gains g_i (true speed = g_i x logged speed), normalised to mean 1:
/// fitted whenever the angular channel is used (kAuto), always (kFit) or never (kOff).
enum class SpeedSensorGains { kAuto, kFit, kOff };
SpeedSensorGains parse_speed_sensor_gains(std::string_view text);  ///< "auto", "fit", "off"
std::string_view speed_sensor_gains_name(SpeedSensorGains gains);

struct FitOptions {
  std::vector<ModelParameter> parameters;
  FitMethod method = FitMethod::kBoth;
  FitChannels channels = FitChannels::kAuto;
  FitLoss loss = FitLoss::kHuber;
  /// Loss scale in noise levels; empty: default_loss_scale(loss).
  std::optional<double> loss_scale;
  SpeedSensorGains speed_sensor_gains = SpeedSensorGains::kAuto;
  /// Disturbance terms and environment the flight was flown with (the log's sidecar says).
  DisturbanceSwitches switches{};
  Environment environment{};
  /// Share of the flight (the last intervals) kept out of the fit for validation.
  double holdout_fraction = 0.2;
  /// The fit is flagged as worse (FitResult::holdout_check) when a fitted channel's held-out
  /// loss grows by more than this share over the starting model's.
  double holdout_tolerance = 0.01;
  /// An interval longer than this times the median interval is a gap.
  double max_gap_factor = 1.5;
  /// Rows below this height (m) are left out, like rows in contact: a real log without an
  /// in_contact column still holds take-off and landing, where the ground pushes.
  double min_height_m = -std::numeric_limits<double>::infinity();
  /// Rows with a rotor slower than this (rad/s) are left out (motors off or stalling: the
  /// thrust curve is not meant for them).
  double min_rotor_speed_rad_s = 1.0;
  /// Output error: window length, s (at least two log intervals), and at most this many
  /// windows (spread evenly, >= 1).
  double window_s = 0.05;
  int max_windows = 200;
  int max_iterations = 50;
  /// A log with more than twice this many fitted intervals is first solved on every m-th of
  /// them (m = the smallest stride leaving at most this many), then finished on all: the same
  /// solution at a fraction of the passes over the whole log. 0: always all.
  std::size_t coarse_intervals = 200000;
  /// Threads for the streamed residuals (results are bitwise the same on any number).
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

/// One speed-sensor gain: true speed = estimate x logged speed of that rotor.
struct FittedGain {
  int rotor = 0;
  double estimate = 1.0;
  double std_error = 0.0;  ///< NaN when the covariance could not be computed
};

/// The fitted model against the starting one on the held-out intervals, channel by channel, in
/// the fit's own terms: the mean loss per residual with the fit's final noise levels.
struct HoldoutCheck {
  struct Channel {
    std::string name;  ///< "linear acceleration", "angular acceleration", "window position", ...
    double before = 0.0, after = 0.0;
  };
  bool available = false;         ///< false when nothing was held out
  std::vector<Channel> channels;  ///< the channels the fit used
  /// A fitted channel explains the held-out part worse than the starting model did (by more than
  /// FitOptions::holdout_tolerance).
  bool worse = false;
  /// One line saying what was compared and the outcome, for reports and refusals.
  std::string summary;
};

struct FitResult {
  std::vector<FittedParameter> parameters;
  /// Empty unless the gains were fitted; one per rotor (the last one is num_rotors minus the sum
  /// of the others: their mean is 1).
  std::vector<FittedGain> speed_sensor_gains;
  /// Correlation of the estimates (parameters, then the free gains, rotors 0..N-2); empty when
  /// the covariance failed.
  Eigen::MatrixXd correlation;
  /// Poorly identifiable parameters, high correlations, and anything else a user should know.
  std::vector<std::string> warnings;
  ResidualStats fit_before, fit_after, holdout_before, holdout_after;
  HoldoutCheck holdout_check;
  /// What the fit used, with kAuto resolved.
  bool used_linear = false, used_angular = false;
  FitLoss loss = FitLoss::kNone;
  double loss_scale = 0.0;
  std::size_t rows = 0, intervals_used = 0, intervals_holdout = 0, gaps = 0, contact_rows = 0;
  /// Rows left out for being below min_height_m or having a rotor below min_rotor_speed_rad_s.
  std::size_t excluded_rows = 0;
  std::size_t windows = 0;
  double median_dt_s = 0.0;
  int iterations = 0;
  /// 1, or the stride m of the coarse start (FitOptions::coarse_intervals).
  std::size_t coarse_stride = 1;
  std::string termination;  ///< Ceres' termination type of the last solve
  double solve_time_s = 0.0;
  /// The input model with the estimates written in.
  VehicleSpec fitted_spec;
};

/// Fits options.parameters of `model` to `data`. InvalidArgument for an empty parameter list,
/// motor parameters without a reference column, too few usable intervals, or bad options (each
/// named with its value: NaN, out of range, a window shorter than two log intervals, ...).
FitResult fit_model(const VehicleModel& model, const FlightData& data, const FitOptions& options);

/// A human-readable report (estimates, standard errors, residuals, warnings).
std::string format_fit_report(const FitResult& result);
/// The same as JSON.
std::string fit_result_to_json(const FitResult& result);

}  // namespace dronetwin
