#include "dronetwin/control/pid.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

namespace {

template <class V>
void require_gains(const V& v, const char* field) {
  for (int i = 0; i < v.size(); ++i)
    require(std::isfinite(v[i]) && v[i] >= 0.0, "cascaded_pid: ", field, "[", i,
            "]: expected a finite gain >= 0, got ", v[i]);
}

double wrap_pi(double a) {
  // remainder() gives a value in [-pi, pi] exactly (no accumulated rounding from repeated +-2 pi).
  return std::remainder(a, 2.0 * std::numbers::pi);
}

}  // namespace

PidGains PidGains::thesis_simulation() {
  // Eq. 3.21.
  PidGains g;
  g.outer_p << 0.471, 0.471, 31.5, 0.075;
  g.outer_d << 0.418, 0.418, 18.67, 0.002;
  g.outer_i << 0.010, 0.010, 6.0, 0.0;
  g.inner_p << 12.0, 12.0, 0.020;
  g.inner_d1 << 0.100, 0.100, 0.0;
  g.inner_d2 << 0.003, 0.003, 0.001;
  return g;
}

PidGains PidGains::thesis_hardware() {
  // Eq. 3.22.
  PidGains g;
  g.outer_p << 0.524, 0.524, 35.0, 1.5;
  g.outer_d << 0.418, 0.418, 18.0, 0.4;
  g.outer_i << 0.010, 0.010, 6.0, 0.0;
  g.inner_p << 12.0, 12.0, 2.0;
  g.inner_d1 << 0.100, 0.100, 0.01;
  g.inner_d2 << 0.003, 0.003, 0.001;
  return g;
}

CascadedPid::CascadedPid(std::shared_ptr<const VehicleModel> model, const PidGains& gains,
                         const PidOptions& options, double control_period_s,
                         AllocationMethod allocation)
    : ControllerBase(std::move(model), allocation), gains_(gains), options_(options), dt_s_(0.0) {
  require_gains(gains_.outer_p, "outer_p");
  require_gains(gains_.outer_d, "outer_d");
  require_gains(gains_.outer_i, "outer_i");
  require_gains(gains_.inner_p, "inner_p");
  require_gains(gains_.inner_d1, "inner_d1");
  require_gains(gains_.inner_d2, "inner_d2");
  require(std::isfinite(gains_.mass_kg) && gains_.mass_kg > 0.0,
          "cascaded_pid: mass_kg: expected > 0, got ", gains_.mass_kg);
  require(std::isfinite(gains_.gravity_m_s2) && gains_.gravity_m_s2 > 0.0,
          "cascaded_pid: gravity_m_s2: expected > 0, got ", gains_.gravity_m_s2);
  require(!std::isnan(options_.max_tilt_rad) && options_.max_tilt_rad > 0.0,
          "cascaded_pid: max_tilt_rad: expected > 0 (infinity: no limit), got ",
          options_.max_tilt_rad);
  for (int i = 0; i < 4; ++i)
    require(!std::isnan(options_.integral_limit[i]) && options_.integral_limit[i] > 0.0,
            "cascaded_pid: integral_limit[", i, "]: expected > 0 (infinity: no limit), got ",
            options_.integral_limit[i]);
  set_control_period(control_period_s);
}

void CascadedPid::set_control_period(double dt_s) {
  require(std::isfinite(dt_s) && dt_s > 0.0, "cascaded_pid: control period: expected > 0 s, got ",
          dt_s);
  dt_s_ = dt_s;
}

std::unique_ptr<ControllerBase> CascadedPid::clone() const {
  return std::make_unique<CascadedPid>(*this);
}

void CascadedPid::reset() { integral_.setZero(); }

GeneralizedForce CascadedPid::do_calculate_u(const ControlInput& in) {
  using namespace state_index;
  const StateVector& x = in.state;
  const ReferencePoint& ref = in.reference;

  // Attitude from the measured quaternion, normalised first: OU noise is added to q without
  // restoring its norm (notes #30). A zero quaternion carries no attitude: read it as level.
  Vec4 q = x.segment<4>(kQuaternion);
  const double q_norm = q.norm();
  q = q_norm > 1e-12 ? Vec4(q / q_norm) : Vec4(1, 0, 0, 0);
  const Vec3 euler = math::to_euler(q);  // atan2-based Eq. 3.16 (notes #23)
  const double phi = euler[0], theta = euler[1], psi = euler[2];
  const Vec3 w_B = x.segment<3>(kAngularVelocity);
  const Vec3 alpha_B = in.state_derivative.segment<3>(kAngularVelocity);

  // psi_dot from the body rates, last row of Eq. 2.8. cos(theta) is floored so that a vehicle
  // pointing straight up or down (theta = +-pi/2) still gives a finite (if meaningless) rate.
  double cos_theta = std::cos(theta);
  if (std::abs(cos_theta) < 1e-6) cos_theta = std::copysign(1e-6, cos_theta);
  const double psi_dot = (std::sin(phi) * w_B[1] + std::cos(phi) * w_B[2]) / cos_theta;

  // ---- outer loop, Eq. 3.15 ------------------------------------------------------------------
  Vec4 e_p;
  e_p.head<3>() = ref.position_m - x.segment<3>(kPosition);
  e_p[3] = ref.yaw_rad - psi;
  if (options_.yaw_error_wrap) e_p[3] = wrap_pi(e_p[3]);

  Vec4 e_v;
  e_v.head<3>() = -x.segment<3>(kVelocity);
  e_v[3] = -psi_dot;
  if (options_.velocity_feedforward) {
    e_v.head<3>() += ref.velocity_m_s;
    e_v[3] += ref.yaw_rate_rad_s;
  }

  // Integral including the current sample (rectangle rule, notes #33), clamped per axis.
  const Vec4 previous_integral = integral_;
  integral_ = (integral_ + e_p * dt_s_)
                  .cwiseMax(-options_.integral_limit)
                  .cwiseMin(options_.integral_limit);

  const auto outer = [&]() -> Vec4 {
    return gains_.outer_p.cwiseProduct(e_p) + gains_.outer_d.cwiseProduct(e_v) +
           gains_.outer_i.cwiseProduct(integral_);
  };
  Vec4 u_outer = outer();

  // ---- mapping, Eq. 3.18 ---------------------------------------------------------------------
  // T = u_z + m g, phi_des = -u_y, theta_des = u_x, psi_des = u_psi. With z up and y left, a
  // positive pitch tilts the thrust toward +x and a positive roll toward -y (R e3 = [cos phi
  // sin theta, -sin phi, cos phi cos theta] at psi = 0), so these printed signs hold in our
  // frames. Optionally the horizontal commands are first expressed in the yaw-aligned frame.
  const auto tilt_commands = [&](const Vec4& u) -> Eigen::Vector2d {
    double ux = u[0], uy = u[1];
    if (options_.yaw_frame_mapping) {
      const double c = std::cos(psi), s = std::sin(psi);
      const double bx = c * ux + s * uy, by = -s * ux + c * uy;
      ux = bx, uy = by;
    }
    return Eigen::Vector2d(-uy, ux);  // [phi_des, theta_des]
  };
  Eigen::Vector2d tilt = tilt_commands(u_outer);
  const double limit = options_.max_tilt_rad;
  const bool clipped = std::abs(tilt[0]) > limit || std::abs(tilt[1]) > limit;
  if (options_.conditional_integration && clipped) {
    // Undo this sample's integration on a horizontal axis whose error pushes its command further
    // into the limit, then recompute the command.
    bool changed = false;
    for (int i = 0; i < 2; ++i) {
      if (e_p[i] * u_outer[i] > 0.0 && integral_[i] != previous_integral[i]) {
        integral_[i] = previous_integral[i];
        changed = true;
      }
    }
    if (changed) {
      u_outer = outer();
      tilt = tilt_commands(u_outer);
    }
  }
  tilt = tilt.cwiseMax(-limit).cwiseMin(limit);
  const double thrust = u_outer[2] + gains_.mass_kg * gains_.gravity_m_s2;
  const double psi_des = u_outer[3];

  // ---- inner loop, Eq. 3.19-3.20 -------------------------------------------------------------
  Vec3 e_att;
  e_att[0] = tilt[0] - phi;
  e_att[1] = tilt[1] - theta;
  // As printed the yaw "attitude error" is psi_des - 0 (notes #32); the rate variant closes a
  // yaw-rate loop on the outer output instead.
  e_att[2] = options_.yaw_loop == PidYawLoop::kThesis ? psi_des : psi_des - w_B[2];
  const Vec3 tau = gains_.inner_p.cwiseProduct(e_att) - gains_.inner_d1.cwiseProduct(w_B) -
                   gains_.inner_d2.cwiseProduct(alpha_B);

  GeneralizedForce u;
  u << thrust, tau;
  return u;
}

}  // namespace dronetwin
