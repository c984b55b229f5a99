#include "dronetwin/batch/batch_pid.hpp"

#include <cmath>

#include "dronetwin/batch/lane_allocation.hpp"
#include "dronetwin/core/error.hpp"

namespace dronetwin {

template <class T>
BatchCascadedPid<T>::BatchCascadedPid(std::shared_ptr<const VehicleModel> model,
                                      const PidGains& gains, const PidOptions& options,
                                      double control_period_s, int num_vehicles)
    : model_(std::move(model)),
      // The scalar controller checks the gains, options and period and builds the constants.
      law_(CascadedPid(model_, gains, options, control_period_s).law()),
      dt_s_(control_period_s) {
  num_vehicles_ = num_vehicles;
  stride_ = batch_stride<T>(num_vehicles, "BatchCascadedPid");
  const auto n = static_cast<std::size_t>(stride_);
  reference_ = AlignedArray<T>(n * kReferenceSize);
  integral_ = AlignedArray<T>(n * 4);
  saturated_.assign(n, 0);
}

template <class T>
void BatchCascadedPid<T>::set_reference(int lane, const ReferencePoint& r) {
  require(lane >= 0 && lane < num_vehicles_, "BatchCascadedPid::set_reference: lane ", lane,
          " is out of range (", num_vehicles_, " vehicles)");
  require(r.position_m.allFinite() && r.velocity_m_s.allFinite() && std::isfinite(r.yaw_rad) &&
              std::isfinite(r.yaw_rate_rad_s) && r.acceleration_m_s2.allFinite() &&
              r.jerk_m_s3.allFinite() && r.snap_m_s4.allFinite() &&
              std::isfinite(r.yaw_acceleration_rad_s2),
          "BatchCascadedPid::set_reference: lane ", lane,
          ": expected finite position, velocity, acceleration, jerk, snap, yaw, yaw rate and yaw "
          "acceleration");
  const auto n = static_cast<std::size_t>(stride_), l = static_cast<std::size_t>(lane);
  for (int k = 0; k < 3; ++k) {
    reference_[static_cast<std::size_t>(k) * n + l] = static_cast<T>(r.position_m[k]);
    reference_[static_cast<std::size_t>(3 + k) * n + l] = static_cast<T>(r.velocity_m_s[k]);
  }
  reference_[6 * n + l] = static_cast<T>(r.yaw_rad);
  reference_[7 * n + l] = static_cast<T>(r.yaw_rate_rad_s);
  Vec3 acceleration, w_ref, dw_ref;
  pid_feed_forward(r, law_, *model_, acceleration, w_ref, dw_ref);
  for (int k = 0; k < 3; ++k) {
    reference_[static_cast<std::size_t>(8 + k) * n + l] = static_cast<T>(acceleration[k]);
    reference_[static_cast<std::size_t>(11 + k) * n + l] = static_cast<T>(w_ref[k]);
    reference_[static_cast<std::size_t>(14 + k) * n + l] = static_cast<T>(dw_ref[k]);
  }
}

template <class T>
void BatchCascadedPid<T>::reset_integral(int lane) {
  require(lane >= 0 && lane < num_vehicles_, "BatchCascadedPid::reset_integral: lane ", lane,
          " is out of range (", num_vehicles_, " vehicles)");
  for (int k = 0; k < 4; ++k)
    integral_[static_cast<std::size_t>(k) * static_cast<std::size_t>(stride_) +
              static_cast<std::size_t>(lane)] = T(0);
}

template <class T>
void BatchCascadedPid<T>::references(int pack, const Mask& running, const StateVectorT<Lanes>& x,
                                     const StateVectorT<Lanes>* x_dot,
                                     std::array<Lanes, kMaxRotors>& reference, Mask& failed) {
  using P = Lanes;
  using namespace state_index;
  const auto n = static_cast<std::size_t>(stride_);
  const std::size_t base = static_cast<std::size_t>(pack) * kLanes;
  const auto at = [&](AlignedArray<T>& a, int k) {
    return &a[static_cast<std::size_t>(k) * n + base];
  };
  PidLawInput<P> in;
  for (int k = 0; k < 3; ++k) {
    in.position_m[k] = x[kPosition + k];
    in.velocity_m_s[k] = x[kVelocity + k];
    in.angular_velocity_B[k] = x[kAngularVelocity + k];
    in.angular_acceleration_B[k] = x_dot != nullptr ? (*x_dot)[kAngularVelocity + k] : P(T(0));
    in.position_ref_m[k] = P(at(reference_, k), stdx::vector_aligned);
    in.velocity_ref_m_s[k] = P(at(reference_, 3 + k), stdx::vector_aligned);
  }
  for (int k = 0; k < 4; ++k) in.quaternion[k] = x[kQuaternion + k];
  in.yaw_ref_rad = P(at(reference_, 6), stdx::vector_aligned);
  in.yaw_rate_ref_rad_s = P(at(reference_, 7), stdx::vector_aligned);
  for (int k = 0; k < 3; ++k) {
    in.acceleration_ref_m_s2[k] =
        law_.acceleration_feed_forward ? P(at(reference_, 8 + k), stdx::vector_aligned) : P(T(0));
    in.angular_velocity_ref_B[k] =
        law_.angular_feed_forward ? P(at(reference_, 11 + k), stdx::vector_aligned) : P(T(0));
    in.angular_acceleration_ref_B[k] =
        law_.angular_feed_forward ? P(at(reference_, 14 + k), stdx::vector_aligned) : P(T(0));
  }
  Vector4<P> integral;
  for (int k = 0; k < 4; ++k) integral[k] = P(at(integral_, k), stdx::vector_aligned);
  const Vector4<P> before = integral;
  const Vector4<P> u = cascaded_pid_law<P>(law_, in, dt_s_, integral);
  allocate_lanes(*model_, u, running, reference, failed, &saturated_[base]);
  // Only lanes that step keep the advanced integral (ClosedLoop calls the controller once per
  // step of a running simulator).
  const Mask kept = running && !failed;
  for (int k = 0; k < 4; ++k) {
    P value = before[k];
    stdx::where(kept, value) = integral[k];
    value.copy_to(at(integral_, k), stdx::vector_aligned);
  }
}

template class BatchCascadedPid<double>;
template class BatchCascadedPid<float>;

}  // namespace dronetwin
