#include "dronetwin/control/se3.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dronetwin/control/feed_forward.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/model/allocation.hpp"

namespace dronetwin {

namespace {

void require_gains(const Vec3& v, const char* field) {
  for (int i = 0; i < 3; ++i)
    require(std::isfinite(v[i]) && v[i] >= 0.0, "se3_geometric: ", field, "[", i,
            "]: expected a finite gain >= 0, got ", v[i]);
}

}  // namespace

Vec3 se3_attitude_moment(const Mat3& R, const Vec3& w_B, const Vec3& b3d, double yaw_rad,
                         const Vec3& attitude_p, const Vec3& attitude_d, const Mat3& J) {
  return se3_attitude_law<double>(R, w_B, b3d, std::cos(yaw_rad), std::sin(yaw_rad), attitude_p,
                                  attitude_d, J);
}

Se3FeedForward<double> se3_feed_forward(const ReferencePoint& ref, const VehicleModel& model,
                                        const Se3LawConstants& k) {
  Se3FeedForward<double> ff{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  if (!k.angular_feed_forward && !k.drag_feed_forward) return ff;
  planning::FlatAttitude attitude;
  // Singular reference (free fall, thrust along the heading): no feed-forward this step. With
  // the drag compensated, the desired thrust direction is the flat one through the drag, so the
  // rates fed forward are that attitude's.
  if (k.drag_feed_forward) {
    Vec3 drag_W;
    if (!reference_flat_attitude_with_drag(ref, k.gravity_m_s2, model, attitude, drag_W)) return ff;
    ff.drag_compensation_W = -drag_W;
  } else if (!reference_flat_attitude(ref, k.gravity_m_s2, attitude)) {
    return ff;
  }
  if (k.angular_feed_forward) {
    ff.angular_velocity_B = attitude.angular_velocity_B_rad_s;
    ff.angular_acceleration_B = attitude.angular_acceleration_B_rad_s2;
  }
  return ff;
}

Se3LawConstants se3_law_constants(const Se3Gains& gains, const Se3Options& options, const Mat3& J) {
  Se3LawConstants k;
  k.position_p = gains.position_p;
  k.position_d = gains.position_d;
  k.attitude_p = gains.attitude_p;
  k.attitude_d = gains.attitude_d;
  k.mass_kg = gains.mass_kg + options.payload_mass_kg;
  k.gravity_m_s2 = gains.gravity_m_s2;
  k.gravity_compensation = options.gravity_compensation;
  k.limit_tilt = !std::isinf(options.max_tilt_rad);
  if (k.limit_tilt) {
    k.cos_tilt = std::cos(options.max_tilt_rad);
    k.sin_tilt = std::sin(options.max_tilt_rad);
    k.tan_tilt = std::tan(options.max_tilt_rad);
  }
  k.nonnegative_thrust = options.nonnegative_thrust;
  k.min_thrust_N = options.min_thrust_N;
  k.inertia_kgm2 = J;
  k.angular_feed_forward = options.angular_feed_forward;
  k.drag_feed_forward = options.drag_feed_forward;
  return k;
}

Se3Gains Se3Gains::thesis() {
  // Eq. 3.29.
  Se3Gains g;
  g.position_p << 33.5757, 33.5757, 33.0;
  g.position_d << 5.7746, 6.0022, 14.5;
  g.attitude_p << 20.75, 20.75, 1.0;
  g.attitude_d << 4.5, 4.5, 0.05;
  return g;
}

Se3Controller::Se3Controller(std::shared_ptr<const VehicleModel> model, const Se3Gains& gains,
                             const Se3Options& options, AllocationMethod allocation)
    : ControllerBase(std::move(model), allocation), gains_(gains), options_(options) {
  require_gains(gains_.position_p, "position_p");
  require_gains(gains_.position_d, "position_d");
  require_gains(gains_.attitude_p, "attitude_p");
  require_gains(gains_.attitude_d, "attitude_d");
  require(std::isfinite(gains_.mass_kg) && gains_.mass_kg > 0.0,
          "se3_geometric: mass_kg: expected > 0, got ", gains_.mass_kg);
  require(std::isfinite(gains_.gravity_m_s2) && gains_.gravity_m_s2 > 0.0,
          "se3_geometric: gravity_m_s2: expected > 0, got ", gains_.gravity_m_s2);
  require(std::isinf(options_.max_tilt_rad) ||
              (options_.max_tilt_rad > 0.0 && options_.max_tilt_rad < std::numbers::pi / 2),
          "se3_geometric: max_tilt_rad: expected in (0, pi/2) (infinity: no limit), got ",
          options_.max_tilt_rad);
  require(std::isfinite(options_.min_thrust_N) && options_.min_thrust_N >= 0.0,
          "se3_geometric: min_thrust_N: expected a number >= 0 (0: no floor), got ",
          options_.min_thrust_N);
  require(std::isfinite(options_.payload_mass_kg) && options_.payload_mass_kg >= 0.0,
          "se3_geometric: payload_mass_kg: expected a mass >= 0, got ", options_.payload_mass_kg);
  law_ = se3_law_constants(gains_, options_, this->model().inertia_kgm2());
  if (options_.shape_reference_for_payload) {
    require(options_.payload_mass_kg > 0.0,
            "se3_geometric: shape_reference_for_payload needs payload_mass_kg > 0, got ",
            options_.payload_mass_kg);
    require(
        std::isfinite(options_.payload_tether_length_m) && options_.payload_tether_length_m > 0.0,
        "se3_geometric: shape_reference_for_payload needs payload_tether_length_m > 0, got ",
        options_.payload_tether_length_m);
    for (int i = 0; i < 2; ++i)
      shapers_[static_cast<std::size_t>(i)] = zv_shaper(slung_payload_swing_modes(
          gains_.mass_kg, options_.payload_mass_kg, options_.payload_tether_length_m,
          gains_.gravity_m_s2, gains_.position_p[i], gains_.position_d[i]));
  }
}

void Se3Controller::set_reference_preview(const Reference& reference) {
  if (options_.shape_reference_for_payload) preview_ = reference.clone();
}

std::unique_ptr<ControllerBase> Se3Controller::clone() const {
  return std::make_unique<Se3Controller>(*this);
}

GeneralizedForce Se3Controller::do_calculate_u(const ControlInput& in) {
  using namespace state_index;
  const StateVector& x = in.state;
  ReferencePoint ref = in.reference;
  if (preview_ != nullptr) {
    // x and y from the shaped reference: each a weighted sum of the reference at delayed times.
    for (int i = 0; i < 2; ++i) {
      const InputShaper& shaper = shapers_[static_cast<std::size_t>(i)];
      ref.position_m[i] = ref.velocity_m_s[i] = ref.acceleration_m_s2[i] = 0.0;
      ref.jerk_m_s3[i] = ref.snap_m_s4[i] = 0.0;
      for (int k = 0; k < shaper.count; ++k) {
        const ShaperImpulse& impulse = shaper.impulses[static_cast<std::size_t>(k)];
        const ReferencePoint r = preview_->at(in.time_s - impulse.delay_s);
        ref.position_m[i] += impulse.amplitude * r.position_m[i];
        ref.velocity_m_s[i] += impulse.amplitude * r.velocity_m_s[i];
        ref.acceleration_m_s2[i] += impulse.amplitude * r.acceleration_m_s2[i];
        ref.jerk_m_s3[i] += impulse.amplitude * r.jerk_m_s3[i];
        ref.snap_m_s4[i] += impulse.amplitude * r.snap_m_s4[i];
      }
    }
  }
  // The law itself is control/se3_law.hpp, shared with the batched controller.
  Se3LawInput<double> law_in{x.segment<3>(kPosition),
                             x.segment<3>(kVelocity),
                             x.segment<4>(kQuaternion),
                             x.segment<3>(kAngularVelocity),
                             ref.position_m,
                             ref.velocity_m_s,
                             ref.acceleration_m_s2,
                             std::cos(ref.yaw_rad),
                             std::sin(ref.yaw_rad),
                             se3_feed_forward(ref, model(), law_)};
  return se3_law(law_, law_in);
}

}  // namespace dronetwin
