#pragma once
// Inertial measurement unit: specific force and angular rate in the sensor frame, each triad with
// white noise, a turn-on bias, a bias random walk and a bias instability (a Gauss-Markov process
// whose Allan deviation peaks at the datasheet's floor), clipped to the measuring range.
//
//   f_S = R_BS^T (R_WB^T (a_W - g_W) + dw_B x r + w_B x (w_B x r))      r: mounting position
//   w_S = R_BS^T w_B
//   y = clip(true + b_on + b_rw + b_gm + n),  n ~ N(0, N^2 f)           f: sampling rate
//
// A density N (units/sqrt(Hz)) sampled at f gives samples of standard deviation N sqrt(f): the
// mean of the f tau samples in a window tau then has the deviation N / sqrt(tau), the Allan
// deviation of white noise. Defaults: Bosch BMI088 datasheet class (gyro 0.014 deg/s/sqrt(Hz),
// 2 deg/h bias instability; accelerometer 175 ug/sqrt(Hz)), docs/sensors.md.

#include "dronetwin/core/types.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/sensors/mounting.hpp"
#include "dronetwin/sensors/sensor_truth.hpp"

namespace dronetwin {

/// Noise of one triad, in the triad's units u (rad/s for the gyro, m/s^2 for the accelerometer).
struct TriadNoise {
  double noise_density = 0.0;            ///< u / sqrt(Hz)
  double bias_random_walk = 0.0;         ///< u / sqrt(s)
  double bias_instability = 0.0;         ///< u (datasheet; modelled as Gauss-Markov)
  double bias_correlation_time_s = 100;  ///< T of the Gauss-Markov bias
  double turn_on_bias = 0.0;             ///< u, standard deviation per axis, drawn at reset
  double range = 0.0;                    ///< u, |reading| clipped to it; 0: no limit
};

struct ImuParameters {
  TriadNoise gyro{2.44e-4, 2.0e-5, 9.7e-6, 100.0, 1.7e-3, 34.9};
  TriadNoise accel{1.72e-3, 1.0e-4, 3.9e-4, 100.0, 0.049, 235.4};
};

/// The triads' bias components (sensor frame), advanced at each sample.
struct ImuState {
  Vec3 gyro_turn_on = Vec3::Zero(), gyro_walk = Vec3::Zero(), gyro_markov = Vec3::Zero();
  Vec3 accel_turn_on = Vec3::Zero(), accel_walk = Vec3::Zero(), accel_markov = Vec3::Zero();
  Vec3 gyro_bias() const { return gyro_turn_on + gyro_walk + gyro_markov; }
  Vec3 accel_bias() const { return accel_turn_on + accel_walk + accel_markov; }
};

/// Draws the turn-on biases (and the Gauss-Markov biases from their stationary distribution).
void reset_imu(const ImuParameters& p, ImuState& s, Random& rng);

/// The specific force and angular rate the sensor frame feels, without errors.
void ideal_imu(const Mounting& m, const SensorTruth& t, Vec3& specific_force_S, Vec3& rate_S);

/// One sample into out[0..5] = [f_x, f_y, f_z (m/s^2), w_x, w_y, w_z (rad/s)]; `dt_s` is the
/// time since the previous sample (the biases' step), `rate_hz` the nominal sampling rate.
void measure_imu(const ImuParameters& p, ImuState& s, const Mounting& m, const SensorTruth& t,
                 double dt_s, double rate_hz, Random& rng, double* out);

}  // namespace dronetwin
