#include "dronetwin/control/pid.hpp"

#include <algorithm>
#include <cmath>

#include "dronetwin/control/feed_forward.hpp"
#include "dronetwin/core/error.hpp"

namespace dronetwin {

namespace {

template <class V>
void require_gains(const V& v, const char* field) {
  for (int i = 0; i < v.size(); ++i)
    require(std::isfinite(v[i]) && v[i] >= 0.0, "cascaded_pid: ", field, "[", i,
            "]: expected a finite gain >= 0, got ", v[i]);
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
  law_ = pid_law_constants(gains_, options_, ControllerBase::model().inertia_kgm2());
}

PidLawConstants pid_law_constants(const PidGains& gains, const PidOptions& options,
                                  const Mat3& inertia_kgm2) {
  PidLawConstants k;
  k.outer_p = gains.outer_p;
  k.outer_d = gains.outer_d;
  k.outer_i = gains.outer_i;
  k.inner_p = gains.inner_p;
  k.inner_d1 = gains.inner_d1;
  k.inner_d2 = gains.inner_d2;
  k.mass_kg = gains.mass_kg;
  k.gravity_m_s2 = gains.gravity_m_s2;
  k.max_tilt_rad = options.max_tilt_rad;
  k.integral_limit = options.integral_limit;
  k.conditional_integration = options.conditional_integration;
  k.yaw_error_wrap = options.yaw_error_wrap;
  k.velocity_feedforward = options.velocity_feedforward;
  k.yaw_frame_mapping = options.yaw_frame_mapping;
  k.yaw_rate_loop = options.yaw_loop == PidYawLoop::kRate;
  k.acceleration_feed_forward = options.acceleration_feed_forward || options.drag_feed_forward;
  k.angular_feed_forward = options.angular_feed_forward;
  k.drag_feed_forward = options.drag_feed_forward;
  k.inertia_kgm2 = inertia_kgm2;
  return k;
}

void pid_feed_forward(const ReferencePoint& reference, const PidLawConstants& k,
                      const VehicleModel& model, Vec3& acceleration_m_s2, Vec3& angular_velocity_B,
                      Vec3& angular_acceleration_B) {
  acceleration_m_s2.setZero();
  angular_velocity_B.setZero();
  angular_acceleration_B.setZero();
  if (k.acceleration_feed_forward) acceleration_m_s2 = reference.acceleration_m_s2;
  planning::FlatAttitude attitude;
  // The flat terms; where the flat attitude is singular they are zero, and the reference's
  // acceleration is still fed forward. With drag, the attitude is the flat one through the drag.
  if (!k.angular_feed_forward && !k.drag_feed_forward) return;
  Vec3 drag_W = Vec3::Zero();
  if (k.drag_feed_forward
          ? !reference_flat_attitude_with_drag(reference, k.gravity_m_s2, model, attitude, drag_W)
          : !reference_flat_attitude(reference, k.gravity_m_s2, attitude))
    return;
  if (k.angular_feed_forward) {
    angular_velocity_B = attitude.angular_velocity_B_rad_s;
    angular_acceleration_B = attitude.angular_acceleration_B_rad_s2;
  }
  if (k.drag_feed_forward) acceleration_m_s2 -= drag_W / k.mass_kg;
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
  // The law itself is control/pid_law.hpp, shared with the batched controller.
  PidLawInput<double> law_in{x.segment<3>(kPosition),
                             x.segment<3>(kVelocity),
                             x.segment<4>(kQuaternion),
                             x.segment<3>(kAngularVelocity),
                             in.state_derivative.segment<3>(kAngularVelocity),
                             ref.position_m,
                             ref.velocity_m_s,
                             ref.yaw_rad,
                             ref.yaw_rate_rad_s,
                             Vec3::Zero(),
                             Vec3::Zero(),
                             Vec3::Zero()};
  pid_feed_forward(ref, law_, model(), law_in.acceleration_ref_m_s2, law_in.angular_velocity_ref_B,
                   law_in.angular_acceleration_ref_B);
  return cascaded_pid_law(law_, law_in, dt_s_, integral_);
}

}  // namespace dronetwin
