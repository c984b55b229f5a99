#include "dronetwin/estimation/error_state_ekf.hpp"

#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/math/rotation_vector.hpp"
#include "dronetwin/sensors/bias_process.hpp"

namespace dronetwin {

namespace {

using namespace ekf_index;
using Vec15 = Eigen::Matrix<double, kEkfErrorSize, 1>;

Mat3 skew(const Vec3& v) {
  Mat3 s;
  s << 0, -v[2], v[1], v[2], 0, -v[0], -v[1], v[0], 0;
  return s;
}

/// A Gauss-Markov bias as the random walk with the same short-term growth: 2 sigma^2 / T.
double walk_with_instability(const TriadNoise& n) {
  const double s = gauss_markov_sigma_for_bias_instability(n.bias_instability);
  return std::sqrt(n.bias_random_walk * n.bias_random_walk +
                   2.0 * s * s / n.bias_correlation_time_s);
}

}  // namespace

EkfParameters EkfParameters::from_imu(const ImuParameters& imu, const Mounting& mounting) {
  EkfParameters p;
  p.gyro_noise_density = imu.gyro.noise_density;
  p.accel_noise_density = imu.accel.noise_density;
  p.gyro_bias_walk = walk_with_instability(imu.gyro);
  p.accel_bias_walk = walk_with_instability(imu.accel);
  const auto initial = [](const TriadNoise& n) {
    const double s = gauss_markov_sigma_for_bias_instability(n.bias_instability);
    // Never zero: a filter certain of a bias could not learn it.
    return std::max(std::sqrt(n.turn_on_bias * n.turn_on_bias + s * s), 1e-6);
  };
  p.gyro_bias_sigma_rad_s = initial(imu.gyro);
  p.accel_bias_sigma_m_s2 = initial(imu.accel);
  p.imu_mounting = mounting;
  return p;
}

ErrorStateEkf::ErrorStateEkf(const EkfParameters& p) : prm_(p) {
  const auto check = [](double v, const char* field, bool strictly) {
    require(std::isfinite(v) && (strictly ? v > 0.0 : v >= 0.0), "ekf: ", field,
            ": expected a finite number ", strictly ? "> 0" : ">= 0", ", got ", v);
  };
  check(p.gyro_noise_density, "gyro_noise_density", false);
  check(p.accel_noise_density, "accel_noise_density", false);
  check(p.gyro_bias_walk, "gyro_bias_walk", false);
  check(p.accel_bias_walk, "accel_bias_walk", false);
  check(p.position_sigma_m, "position_sigma_m", true);
  check(p.velocity_sigma_m_s, "velocity_sigma_m_s", true);
  check(p.attitude_sigma_rad, "attitude_sigma_rad", true);
  check(p.gyro_bias_sigma_rad_s, "gyro_bias_sigma_rad_s", true);
  check(p.accel_bias_sigma_m_s2, "accel_bias_sigma_m_s2", true);
  R_BS_imu_ = p.imu_mounting.rotation_BS();
  reset(Simulator::hover_state(Vec3::Zero()), 0.0);
}

void ErrorStateEkf::reset(const StateVector& guess, double time_s) {
  namespace si = state_index;
  require(guess.allFinite(), "ekf reset: the initial guess is not finite");
  time_s_ = time_s;
  p_ = guess.segment<3>(si::kPosition);
  v_ = guess.segment<3>(si::kVelocity);
  q_ = guess.segment<4>(si::kQuaternion).normalized();
  last_rate_B_ = guess.segment<3>(si::kAngularVelocity);
  bg_.setZero();
  ba_.setZero();
  Vec15 sigma;
  sigma << Vec3::Constant(prm_.position_sigma_m), Vec3::Constant(prm_.velocity_sigma_m_s),
      Vec3::Constant(prm_.attitude_sigma_rad), Vec3::Constant(prm_.gyro_bias_sigma_rad_s),
      Vec3::Constant(prm_.accel_bias_sigma_m_s2);
  P_ = sigma.array().square().matrix().asDiagonal();
}

void ErrorStateEkf::propagate(const Vec3& specific_force_S, const Vec3& rate_S, double dt_s) {
  require(std::isfinite(dt_s) && dt_s > 0.0 && dt_s < 1.0,
          "ekf propagate: dt_s: expected 0 < dt < 1 s, got ", dt_s);
  const Vec3 a = R_BS_imu_ * specific_force_S - ba_;
  const Vec3 w = R_BS_imu_ * rate_S - bg_;
  const Mat3 R = math::rotation_matrix<double>(q_);
  const Vec3 acc_W = R * a + prm_.gravity_W_m_s2;
  // Nominal state (Sola Eq. 260).
  p_ += v_ * dt_s + 0.5 * acc_W * dt_s * dt_s;
  v_ += acc_W * dt_s;
  const Vec4 dq = math::rotation_exp(w * dt_s);
  q_ = math::multiply<double>(q_, dq).normalized();
  last_rate_B_ = w;
  time_s_ += dt_s;
  // Error state transition (Sola Eq. 269) and impulses (Eq. 270).
  EkfMatrix F = EkfMatrix::Identity();
  F.block<3, 3>(kPosition, kVelocity) = Mat3::Identity() * dt_s;
  F.block<3, 3>(kVelocity, kAttitude) = -R * skew(a) * dt_s;
  F.block<3, 3>(kVelocity, kAccelBias) = -R * dt_s;
  F.block<3, 3>(kAttitude, kAttitude) = math::rotation_matrix<double>(dq).transpose();
  F.block<3, 3>(kAttitude, kGyroBias) = -Mat3::Identity() * dt_s;
  P_ = F * P_ * F.transpose();
  const double va = prm_.accel_noise_density * prm_.accel_noise_density * dt_s;
  const double vg = prm_.gyro_noise_density * prm_.gyro_noise_density * dt_s;
  const double wa = prm_.accel_bias_walk * prm_.accel_bias_walk * dt_s;
  const double wg = prm_.gyro_bias_walk * prm_.gyro_bias_walk * dt_s;
  for (int i = 0; i < 3; ++i) {
    P_(kVelocity + i, kVelocity + i) += va;
    P_(kAttitude + i, kAttitude + i) += vg;
    P_(kGyroBias + i, kGyroBias + i) += wg;
    P_(kAccelBias + i, kAccelBias + i) += wa;
  }
  P_ = 0.5 * (P_ + P_.transpose());
}

template <int M>
double ErrorStateEkf::correct(const Eigen::Matrix<double, M, 1>& y,
                              const Eigen::Matrix<double, M, kEkfErrorSize>& H,
                              const Eigen::Matrix<double, M, M>& R) {
  require(y.allFinite(), "ekf update: the innovation is not finite (a NaN measurement?)");
  const Eigen::Matrix<double, kEkfErrorSize, M> PHt = P_ * H.transpose();
  const Eigen::Matrix<double, M, M> S = H * PHt + R;
  // M <= 3: Eigen's closed-form inverse of a small symmetric positive definite matrix.
  const Eigen::Matrix<double, M, M> S_inv = S.inverse();
  const Eigen::Matrix<double, kEkfErrorSize, M> K = PHt * S_inv;
  const Vec15 dx = K * y;
  // Joseph form: stays symmetric positive definite in finite precision.
  const EkfMatrix I_KH = EkfMatrix::Identity() - K * H;
  P_ = I_KH * P_ * I_KH.transpose() + K * R * K.transpose();
  inject(dx);
  return y.dot(S_inv * y);
}

void ErrorStateEkf::inject(const Vec15& dx) {
  p_ += dx.segment<3>(kPosition);
  v_ += dx.segment<3>(kVelocity);
  const Vec3 dtheta = dx.segment<3>(kAttitude);
  q_ = math::multiply<double>(q_, math::rotation_exp(dtheta)).normalized();
  bg_ += dx.segment<3>(kGyroBias);
  ba_ += dx.segment<3>(kAccelBias);
  // Reset of the error's mean to zero (Sola Eq. 287): G = diag(I, I, I - [dtheta/2]x, I, I).
  EkfMatrix G = EkfMatrix::Identity();
  G.block<3, 3>(kAttitude, kAttitude) = Mat3::Identity() - skew(0.5 * dtheta);
  P_ = G * P_ * G.transpose();
  P_ = 0.5 * (P_ + P_.transpose());
}

double ErrorStateEkf::update_position(const Vec3& z, double sigma, const Vec3& lever_B) {
  const Mat3 R = math::rotation_matrix<double>(q_);
  Eigen::Matrix<double, 3, kEkfErrorSize> H = Eigen::Matrix<double, 3, kEkfErrorSize>::Zero();
  H.block<3, 3>(0, kPosition) = Mat3::Identity();
  H.block<3, 3>(0, kAttitude) = -R * skew(lever_B);
  const Vec3 y = z - (p_ + R * lever_B);
  return correct<3>(y, H, Mat3::Identity() * sigma * sigma);
}

double ErrorStateEkf::update_velocity(const Vec3& z, double sigma) {
  Eigen::Matrix<double, 3, kEkfErrorSize> H = Eigen::Matrix<double, 3, kEkfErrorSize>::Zero();
  H.block<3, 3>(0, kVelocity) = Mat3::Identity();
  return correct<3>(Vec3(z - v_), H, Mat3::Identity() * sigma * sigma);
}

double ErrorStateEkf::update_attitude(const Vec4& z, double sigma) {
  Eigen::Matrix<double, 3, kEkfErrorSize> H = Eigen::Matrix<double, 3, kEkfErrorSize>::Zero();
  H.block<3, 3>(0, kAttitude) = Mat3::Identity();
  const Vec3 y = math::rotation_log(math::multiply<double>(math::conjugate(q_), z.normalized()));
  return correct<3>(y, H, Mat3::Identity() * sigma * sigma);
}

double ErrorStateEkf::update_height(double z, double sigma) {
  Eigen::Matrix<double, 1, kEkfErrorSize> H = Eigen::Matrix<double, 1, kEkfErrorSize>::Zero();
  H(0, kPosition + 2) = 1.0;
  Eigen::Matrix<double, 1, 1> y, R;
  y << z - p_[2];
  R << sigma * sigma;
  return correct<1>(y, H, R);
}

double ErrorStateEkf::update_magnetometer(const Vec3& z, const Vec3& field_W, double sigma,
                                          const Mounting& mounting) {
  const Mat3 R = math::rotation_matrix<double>(q_);
  const Mat3 R_SB = mounting.rotation_BS().transpose();
  const Vec3 b_B = R.transpose() * field_W;
  Eigen::Matrix<double, 3, kEkfErrorSize> H = Eigen::Matrix<double, 3, kEkfErrorSize>::Zero();
  H.block<3, 3>(0, kAttitude) = R_SB * skew(b_B);
  return correct<3>(Vec3(z - R_SB * b_B), H, Mat3::Identity() * sigma * sigma);
}

double ErrorStateEkf::update_range(double z, double sigma, const Mounting& mounting) {
  const Mat3 R = math::rotation_matrix<double>(q_);
  const Vec3& r = mounting.position_B_m;
  const Vec3 axis_B = mounting.rotation_BS().col(2);
  const double o_z = p_[2] + (R * r)[2];
  const double a_z = (R * axis_B)[2];
  // A beam within 60 deg of straight down: beyond that flat ground is a poor model.
  if (!(a_z < -0.5) || !(o_z > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  const double d = -o_z / a_z;
  // d(o_z)/d(dtheta) = row z of -R [r]x; d(a_z)/d(dtheta) = row z of -R [axis]x.
  const Eigen::RowVector3d do_z = -(R * skew(r)).row(2);
  const Eigen::RowVector3d da_z = -(R * skew(axis_B)).row(2);
  Eigen::Matrix<double, 1, kEkfErrorSize> H = Eigen::Matrix<double, 1, kEkfErrorSize>::Zero();
  H(0, kPosition + 2) = -1.0 / a_z;
  H.block<1, 3>(0, kAttitude) = -do_z / a_z + o_z / (a_z * a_z) * da_z;
  Eigen::Matrix<double, 1, 1> y, Rm;
  y << z - d;
  Rm << sigma * sigma;
  return correct<1>(y, H, Rm);
}

bool ErrorStateEkf::predicted_flow(const Vec15& dx, const Mounting& m,
                                   Eigen::Vector2d& flow) const {
  // The state moved by dx the way inject() moves it (without the covariance).
  const Vec3 p = p_ + dx.segment<3>(kPosition);
  const Vec3 v = v_ + dx.segment<3>(kVelocity);
  const Vec4 q = math::multiply<double>(q_, math::rotation_exp(dx.segment<3>(kAttitude)));
  // The gyro reading behind last_rate_B_ is fixed; a bias error changes the rate it implies.
  const Vec3 w = last_rate_B_ - dx.segment<3>(kGyroBias);
  const Mat3 R = math::rotation_matrix<double>(q);
  const Mat3 R_BS = m.rotation_BS();
  const double o_z = p[2] + (R * m.position_B_m)[2];
  const double a_z = (R * R_BS.col(2))[2];
  if (!(a_z < -0.5) || !(o_z > 0.0)) return false;
  const double d = -o_z / a_z;
  // sensors/optical_flow.hpp: flow_x = -v_x / d - w_y, flow_y = -v_y / d + w_x (sensor frame).
  const Vec3 v_S = R_BS.transpose() * (R.transpose() * v + w.cross(m.position_B_m));
  const Vec3 w_S = R_BS.transpose() * w;
  flow = Eigen::Vector2d(-v_S[0] / d - w_S[1], -v_S[1] / d + w_S[0]);
  return true;
}

double ErrorStateEkf::update_optical_flow(const Eigen::Vector2d& z, double sigma,
                                          const Mounting& m) {
  Eigen::Vector2d h0;
  if (!predicted_flow(Vec15::Zero(), m, h0)) return std::numeric_limits<double>::quiet_NaN();
  Eigen::Matrix<double, 2, kEkfErrorSize> H;
  for (int i = 0; i < kEkfErrorSize; ++i) {
    // Steps of 1e-6 in m, m/s, rad and rad/s: far above round-off, far below the curvature.
    Vec15 e = Vec15::Zero();
    e[i] = 1e-6;
    Eigen::Vector2d plus, minus;
    if (!predicted_flow(e, m, plus) || !predicted_flow(-e, m, minus))
      return std::numeric_limits<double>::quiet_NaN();
    H.col(i) = (plus - minus) / 2e-6;
  }
  return correct<2>(Eigen::Vector2d(z - h0), H, Eigen::Matrix2d::Identity() * sigma * sigma);
}

StateVector ErrorStateEkf::state() const {
  StateVector x;
  x << p_, v_, q_, last_rate_B_;
  return x;
}

Vec15 ErrorStateEkf::error_to(const StateVector& t, const Vec3& bg, const Vec3& ba) const {
  namespace si = state_index;
  Vec15 e;
  e << t.segment<3>(si::kPosition) - p_, t.segment<3>(si::kVelocity) - v_,
      math::rotation_log(
          math::multiply<double>(math::conjugate(q_), Vec4(t.segment<4>(si::kQuaternion)))),
      bg - bg_, ba - ba_;
  return e;
}

double ErrorStateEkf::nees(const StateVector& t, const Vec3& bg, const Vec3& ba) const {
  const Vec15 e = error_to(t, bg, ba);
  return e.dot(P_.ldlt().solve(e));
}

}  // namespace dronetwin
