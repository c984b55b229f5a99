#pragma once
// A synthetic Crazyflie flight made to look like a real one, for the tests of `dronetwin fit` on
// real flights (tests/identification/fit_real_flight_test.cpp, tests/cli/fit_cli_test.cpp).
//
// The vehicle (models/crazyflie21.yaml with some parameters changed: the truth) flies
// config/experiments/identification_flight_crazyflie.yaml through our simulator, physics and log
// at 1 kHz with the force breakdown. The log is then corrupted the way a real Crazyflie log is:
//
//   rotor speeds    from per-motor speed sensors with gain errors: the true speed is
//                   gain_i x the logged one (gains within +-3 %, their mean not 1), plus white
//                   noise;
//   gyro            wx, wy, wz = true body rates + a constant bias + white noise + rare spikes
//                   (vibration, a bad sample);
//   accelerometer   acc_x, acc_y, acc_z = the world-frame specific force dv/dt - g
//                   (FlightData::specific_force_W_m_s2), made from the body-frame specific force
//                   of the true forces (the log's F_<term> columns / m) + bias + white noise +
//                   rare spikes, turned into world axes with the ESTIMATED attitude (as an
//                   onboard estimator logs it);
//   attitude        the true attitude turned by a slowly wandering error (Ornstein-Uhlenbeck,
//                   a few mrad) plus white noise, as an estimator's attitude;
//   position,       the estimator's: the true ones through a first-order low-pass (lag) plus
//   velocity        white noise;
//   rate            every 2nd row: a 500 Hz log; no omega_ref_*, no in_contact (a real log has
//                   neither), no sidecar.
//
// Every random number comes from one seeded generator (noise/random.hpp): the same seed gives the
// same log, bit for bit.

#include <array>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "dronetwin/app/run_experiment.hpp"
#include "dronetwin/config/experiment.hpp"
#include "dronetwin/logging/csv_log.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/model/model_parameters.hpp"
#include "dronetwin/noise/random.hpp"
#include "test_support.hpp"

namespace dronetwin::test {

/// How the log is corrupted (the defaults are the ones the tests and docs/identification.md use).
struct RealLogCorruption {
  /// True rotor speed = gain_i x logged speed. Within +-3 %; mean 1.00375 (a common scale of
  /// all four sensors cannot be told from the thrust coefficient; see the fit's docs).
  std::array<double, 4> speed_sensor_gain{1.03, 0.97, 0.99, 1.025};
  double rotor_speed_noise_rad_s = 10.0;  // 0.5 % of hover speed
  Vec3 gyro_bias_rad_s{0.02, -0.015, 0.01};
  double gyro_noise_rad_s = 0.01;
  Vec3 accelerometer_bias_m_s2{0.05, -0.04, 0.06};
  double accelerometer_noise_m_s2 = 0.3;  // motor vibration
  /// A sample is a spike with this probability (gyro and accelerometer independently).
  double spike_probability = 0.002;
  double gyro_spike_rad_s = 0.5;
  double accelerometer_spike_m_s2 = 5.0;
  /// Estimator attitude error: OU with this standard deviation and time constant, plus white.
  double attitude_wander_rad = 0.005;
  double attitude_wander_time_s = 2.0;
  double attitude_noise_rad = 0.001;
  /// Estimator position and velocity: first-order low-pass of the truth plus white noise.
  double estimator_time_constant_s = 0.02;
  double position_noise_m = 0.002;
  double velocity_noise_m_s = 0.01;
  /// Keep every n-th physics row (1 kHz physics: 2 gives a 500 Hz log).
  int keep_every_n_rows = 2;
  std::uint64_t seed = 2026;
};

struct RealLookingFlight {
  VehicleSpec truth;  ///< the vehicle that flew
  RealLogCorruption corruption;
  std::string log_path;  ///< the corrupted log
};

/// Flies the Crazyflie identification flight for `duration_s` with crazyflie21.yaml changed by
/// `changes` (parameter, factor) and writes the corrupted log to dir/real_looking.csv.
inline RealLookingFlight make_real_looking_crazyflie_flight(
    const std::filesystem::path& dir, double duration_s,
    const std::vector<std::pair<ModelParameter, double>>& changes,
    const RealLogCorruption& corruption = {}) {
  RealLookingFlight f;
  f.corruption = corruption;
  f.truth = load_vehicle_spec(source_path("models/crazyflie21.yaml"));
  for (const auto& [p, factor] : changes)
    set_parameter_value(f.truth, p, factor * parameter_value(f.truth, p));
  Experiment e =
      load_experiment(source_path("config/experiments/identification_flight_crazyflie.yaml"));
  e.duration_s = duration_s;
  const auto truth_model = std::make_shared<const VehicleModel>(f.truth);
  const std::filesystem::path sim_dir = dir / "simulated";
  const RunSummary s = run_experiment(e, truth_model, sim_dir.string());
  EXPECT_TRUE(s.ok()) << s.failure_message;
  const LogTable log = read_csv_log((sim_dir / "log.csv").string());
  const std::size_t n = log.rows();
  const double dt = e.sim.dt_s;
  const double mass = f.truth.mass_kg;

  std::vector<std::string> columns{"t",  "x",  "y",  "z",  "vx", "vy", "vz",
                                   "qw", "qx", "qy", "qz", "wx", "wy", "wz"};
  for (int i = 0; i < 4; ++i) columns.push_back("omega_" + std::to_string(i));
  for (const char* a : {"acc_x", "acc_y", "acc_z"}) columns.emplace_back(a);
  f.log_path = (dir / "real_looking.csv").string();
  CsvLogWriter out(f.log_path, columns);

  // Non-gravity body-frame force columns (every term of the breakdown but gravity).
  std::vector<std::array<std::size_t, 3>> force_columns;
  for (int k = 0; k < kNumTerms; ++k) {
    if (static_cast<Term>(k) == Term::kGravity) continue;
    const std::string term(term_name(static_cast<Term>(k)));
    force_columns.push_back({log.column("F_" + term + "_x"), log.column("F_" + term + "_y"),
                             log.column("F_" + term + "_z")});
  }
  static const char* kState[13] = {"x",  "y",  "z",  "vx", "vy", "vz", "qw",
                                   "qx", "qy", "qz", "wx", "wy", "wz"};
  std::array<std::size_t, 13> state_columns{};
  for (int i = 0; i < 13; ++i) state_columns[static_cast<std::size_t>(i)] = log.column(kState[i]);
  std::array<std::size_t, 4> speed_columns{};
  for (int i = 0; i < 4; ++i)
    speed_columns[static_cast<std::size_t>(i)] = log.column("omega_" + std::to_string(i));
  const std::size_t time_column = log.column("t");

  Random rng(corruption.seed);
  const auto normal3 = [&rng] {  // drawn in order x, y, z (argument order is unspecified)
    Vec3 v;
    for (int a = 0; a < 3; ++a) v[a] = rng.normal();
    return v;
  };
  const double smoothing = 1.0 - std::exp(-dt / corruption.estimator_time_constant_s);
  const double wander_decay = std::exp(-dt / corruption.attitude_wander_time_s);
  const double wander_kick =
      corruption.attitude_wander_rad * std::sqrt(1.0 - wander_decay * wander_decay);
  Vec3 p_est = Vec3::Zero(), v_est = Vec3::Zero(), wander = Vec3::Zero();
  std::vector<double> row(columns.size());
  for (std::size_t k = 0; k < n; ++k) {
    StateVector x;
    for (int i = 0; i < 13; ++i) x[i] = log.at(k, state_columns[static_cast<std::size_t>(i)]);
    const Vec3 p = x.segment<3>(0), v = x.segment<3>(3);
    if (k == 0) {
      p_est = p;
      v_est = v;
    }
    // The estimator runs at the physics rate; the log keeps every n-th row of it.
    p_est += smoothing * (p - p_est);
    v_est += smoothing * (v - v_est);
    wander = wander_decay * wander + wander_kick * normal3();
    if (k % static_cast<std::size_t>(corruption.keep_every_n_rows) != 0) continue;

    const Vec4 q_true = x.segment<4>(6);
    const Vec3 attitude_error = wander + corruption.attitude_noise_rad * normal3();
    const Vec4 q_est = math::multiply<double>(
        q_true, Vec4(1.0, 0.5 * attitude_error[0], 0.5 * attitude_error[1], 0.5 * attitude_error[2])
                    .normalized());
    Vec3 force_B = Vec3::Zero();
    for (const auto& c : force_columns)
      force_B += Vec3(log.at(k, c[0]), log.at(k, c[1]), log.at(k, c[2]));
    Vec3 accelerometer_B = force_B / mass + corruption.accelerometer_bias_m_s2 +
                           corruption.accelerometer_noise_m_s2 * normal3();
    if (rng.uniform() < corruption.spike_probability)
      accelerometer_B += corruption.accelerometer_spike_m_s2 * normal3();
    Vec3 gyro =
        x.segment<3>(10) + corruption.gyro_bias_rad_s + corruption.gyro_noise_rad_s * normal3();
    if (rng.uniform() < corruption.spike_probability)
      gyro += corruption.gyro_spike_rad_s * normal3();

    std::size_t c = 0;
    row[c++] = log.at(k, time_column);
    const Vec3 p_log = p_est + corruption.position_noise_m * normal3();
    const Vec3 v_log = v_est + corruption.velocity_noise_m_s * normal3();
    for (int a = 0; a < 3; ++a) row[c++] = p_log[a];
    for (int a = 0; a < 3; ++a) row[c++] = v_log[a];
    for (int a = 0; a < 4; ++a) row[c++] = q_est[a];
    for (int a = 0; a < 3; ++a) row[c++] = gyro[a];
    for (std::size_t i = 0; i < 4; ++i) {
      row[c++] = log.at(k, speed_columns[i]) / corruption.speed_sensor_gain[i] +
                 corruption.rotor_speed_noise_rad_s * rng.normal();
    }
    const Vec3 accelerometer_W = math::rotation_matrix<double>(q_est) * accelerometer_B;
    for (int a = 0; a < 3; ++a) row[c++] = accelerometer_W[a];
    out.write_row(row);
  }
  out.close();
  return f;
}

}  // namespace dronetwin::test
