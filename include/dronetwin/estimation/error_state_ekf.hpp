#pragma once
// Error-state extended Kalman filter for a multirotor: IMU propagation, updates from motion
// capture, GPS, barometer, magnetometer and a downward range finder (docs/sensors.md,
// "Estimation"; Sola, "Quaternion kinematics for the error-state Kalman filter", 2017, Sec. 5-6).
//
// Nominal state: position p_W, velocity v_W, attitude q_WB, gyro bias b_g, accelerometer bias b_a
// (sensor frame = body frame: the IMU's mounting rotation is applied to its readings first; its
// lever arm is neglected). Error state (15): dp, dv, dtheta (a rotation in the body frame,
// q = q_hat (x) exp(dtheta / 2)), db_g, db_a, with covariance P. After each update the error is
// folded into the nominal state and reset to zero (with the reset Jacobian for dtheta).
//
//   ErrorStateEkf ekf(EkfParameters::from_imu(imu_params));
//   ekf.reset(initial_guess_state, 0.0);
//   ekf.propagate(f_B, w_B, dt);                   // every IMU sample
//   ekf.update_position(p_mocap, 5e-4);            // whenever a fix arrives
//   StateVector x_hat = ekf.state();               // [p, v, q, w] for a controller
//
// Allocation-free: every matrix is fixed-size.

#include <Eigen/Core>

#include "dronetwin/core/types.hpp"
#include "dronetwin/sensors/imu.hpp"
#include "dronetwin/sensors/mounting.hpp"
#include "dronetwin/sim/simulator.hpp"

namespace dronetwin {

inline constexpr int kEkfErrorSize = 15;
using EkfMatrix = Eigen::Matrix<double, kEkfErrorSize, kEkfErrorSize>;

namespace ekf_index {
inline constexpr int kPosition = 0, kVelocity = 3, kAttitude = 6, kGyroBias = 9, kAccelBias = 12;
}

struct EkfParameters {
  /// Process noise: white-noise densities (gyro rad/s/sqrt(Hz), accel m/s^2/sqrt(Hz)) and bias
  /// random walks (per sqrt(s)); a Gauss-Markov bias instability is added to the random walk as
  /// the walk of the same short-term growth (2 sigma^2 / T).
  double gyro_noise_density = 2.44e-4, accel_noise_density = 1.72e-3;
  double gyro_bias_walk = 2.0e-5, accel_bias_walk = 1.0e-4;
  /// Initial standard deviations of the error state.
  double position_sigma_m = 0.1, velocity_sigma_m_s = 0.1, attitude_sigma_rad = 0.05;
  double gyro_bias_sigma_rad_s = 5e-3, accel_bias_sigma_m_s2 = 0.1;
  Vec3 gravity_W_m_s2{0.0, 0.0, -9.81};
  /// How the IMU sits on the body (readings are rotated into the body frame).
  Mounting imu_mounting{};

  /// Process noise matched to an IMU's configuration.
  static EkfParameters from_imu(const ImuParameters& imu, const Mounting& mounting = {});
};

class ErrorStateEkf {
 public:
  explicit ErrorStateEkf(const EkfParameters& p);

  /// Nominal state from `guess` ([p, v, q, w]), biases zero, P from the initial sigmas.
  void reset(const StateVector& guess, double time_s);

  /// One IMU sample (sensor frame, as the IMU reports it) over `dt_s` since the previous one.
  void propagate(const Vec3& specific_force_S, const Vec3& rate_S, double dt_s);

  // ---- updates: each returns the normalised innovation squared (NIS) ---------------------------
  /// Position of a point at `lever_B` on the body (motion capture, GPS antenna), world frame.
  double update_position(const Vec3& measured_W, double sigma_m,
                         const Vec3& lever_B = Vec3::Zero());
  /// Velocity of the body origin, world frame (GPS; lever arm neglected).
  double update_velocity(const Vec3& measured_W, double sigma_m_s);
  /// Attitude q_WB (motion capture), isotropic error sigma (rad).
  double update_attitude(const Vec4& measured_q_WB, double sigma_rad);
  /// Height of the body origin above z = 0 (a barometer's altitude difference, m).
  double update_height(double measured_z_m, double sigma_m);
  /// Magnetic field in the sensor frame of `mounting`, with the known world field.
  double update_magnetometer(const Vec3& measured_S, const Vec3& field_W, double sigma,
                             const Mounting& mounting = {});
  /// Distance along the sensor z axis of `mounting` to flat ground z = 0.
  double update_range(double measured_m, double sigma_m, const Mounting& mounting);
  /// Optical flow [flow_x, flow_y] (rad/s, sensors/optical_flow.hpp) of a downward sensor over
  /// flat ground z = 0, with the body rates of the last gyro sample (the bias is a state: its
  /// part of the Jacobian is kept). Jacobian by central differences of the measurement function
  /// on the error state. NaN (nothing changed) when the axis is more than 60 deg from down.
  double update_optical_flow(const Eigen::Vector2d& measured_rad_s, double sigma_rad_s,
                             const Mounting& mounting);

  double time_s() const { return time_s_; }
  const Vec3& position() const { return p_; }
  const Vec3& velocity() const { return v_; }
  const Vec4& attitude() const { return q_; }
  const Vec3& gyro_bias() const { return bg_; }
  const Vec3& accel_bias() const { return ba_; }
  const EkfMatrix& covariance() const { return P_; }
  /// [p, v, q, w] with w the last bias-corrected rate (what a controller reads).
  StateVector state() const;

  /// e^T P^-1 e of the 15-dim error between the truth and the estimate (attitude error as the
  /// body-frame rotation vector of q_hat^-1 (x) q_true).
  double nees(const StateVector& truth, const Vec3& true_gyro_bias_B,
              const Vec3& true_accel_bias_B) const;
  /// The same error vector.
  Eigen::Matrix<double, kEkfErrorSize, 1> error_to(const StateVector& truth,
                                                   const Vec3& true_gyro_bias_B,
                                                   const Vec3& true_accel_bias_B) const;

 private:
  template <int M>
  double correct(const Eigen::Matrix<double, M, 1>& innovation,
                 const Eigen::Matrix<double, M, kEkfErrorSize>& H,
                 const Eigen::Matrix<double, M, M>& R);
  void inject(const Eigen::Matrix<double, kEkfErrorSize, 1>& dx);
  /// The flow the sensor would see if the nominal state were moved by `dx` (false when the
  /// geometry gives none).
  bool predicted_flow(const Eigen::Matrix<double, kEkfErrorSize, 1>& dx, const Mounting& m,
                      Eigen::Vector2d& flow) const;

  EkfParameters prm_;
  Mat3 R_BS_imu_;
  double time_s_ = 0.0;
  Vec3 p_ = Vec3::Zero(), v_ = Vec3::Zero(), bg_ = Vec3::Zero(), ba_ = Vec3::Zero();
  Vec4 q_ = Vec4(1, 0, 0, 0);
  Vec3 last_rate_B_ = Vec3::Zero();
  EkfMatrix P_ = EkfMatrix::Identity();
};

}  // namespace dronetwin
