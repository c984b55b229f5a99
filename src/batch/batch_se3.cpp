#include "dronetwin/batch/batch_se3.hpp"

#include <cmath>

#include "dronetwin/batch/lane_allocation.hpp"
#include "dronetwin/core/error.hpp"

namespace dronetwin {

template <class T>
BatchSe3Controller<T>::BatchSe3Controller(std::shared_ptr<const VehicleModel> model,
                                          const Se3Gains& gains, const Se3Options& options,
                                          int num_vehicles)
    : model_(std::move(model)),
      // The scalar controller checks the gains and options and builds the law's constants.
      law_(Se3Controller(model_, gains, options).law()) {
  num_vehicles_ = num_vehicles;
  stride_ = batch_stride<T>(num_vehicles, "BatchSe3Controller");
  const auto n = static_cast<std::size_t>(stride_);
  reference_ = AlignedArray<T>(n * kReferenceSize);
  for (std::size_t l = 0; l < n; ++l) reference_[9 * n + l] = T(1);  // b1d = [1, 0]: yaw 0
  saturated_.assign(n, 0);
  saturated_count_.assign(n, 0);
}

template <class T>
void BatchSe3Controller<T>::set_reference(int lane, const ReferencePoint& r) {
  require(lane >= 0 && lane < num_vehicles_, "BatchSe3Controller::set_reference: lane ", lane,
          " is out of range (", num_vehicles_, " vehicles)");
  const bool finite = r.position_m.allFinite() && r.velocity_m_s.allFinite() &&
                      r.acceleration_m_s2.allFinite() && std::isfinite(r.yaw_rad);
  require(finite, "BatchSe3Controller::set_reference: lane ", lane,
          ": expected finite position, velocity, acceleration and yaw");
  const bool ff = law_.angular_feed_forward || law_.drag_feed_forward;
  require(!ff || (r.jerk_m_s3.allFinite() && r.snap_m_s4.allFinite() &&
                  std::isfinite(r.yaw_rate_rad_s) && std::isfinite(r.yaw_acceleration_rad_s2)),
          "BatchSe3Controller::set_reference: lane ", lane,
          ": expected finite jerk, snap, yaw rate and yaw acceleration (the feed-forward's)");
  const auto n = static_cast<std::size_t>(stride_), l = static_cast<std::size_t>(lane);
  for (int k = 0; k < 3; ++k) {
    reference_[static_cast<std::size_t>(k) * n + l] = static_cast<T>(r.position_m[k]);
    reference_[static_cast<std::size_t>(3 + k) * n + l] = static_cast<T>(r.velocity_m_s[k]);
    reference_[static_cast<std::size_t>(6 + k) * n + l] = static_cast<T>(r.acceleration_m_s2[k]);
  }
  // As Se3Controller: cos and sin of the yaw in double.
  reference_[9 * n + l] = static_cast<T>(std::cos(r.yaw_rad));
  reference_[10 * n + l] = static_cast<T>(std::sin(r.yaw_rad));
  const Se3FeedForward<double> w = se3_feed_forward(r, *model_, law_);
  for (int k = 0; k < 3; ++k) {
    reference_[static_cast<std::size_t>(11 + k) * n + l] = static_cast<T>(w.angular_velocity_B[k]);
    reference_[static_cast<std::size_t>(14 + k) * n + l] =
        static_cast<T>(w.angular_acceleration_B[k]);
    reference_[static_cast<std::size_t>(17 + k) * n + l] = static_cast<T>(w.drag_compensation_W[k]);
  }
}

template <class T>
void BatchSe3Controller<T>::reset_counters() {
  std::fill(saturated_count_.begin(), saturated_count_.end(), 0);
}

template <class T>
void BatchSe3Controller<T>::references(int pack, const Mask& running, const StateVectorT<Lanes>& x,
                                       const StateVectorT<Lanes>*,
                                       std::array<Lanes, kMaxRotors>& reference, Mask& failed) {
  using P = Lanes;
  using namespace state_index;
  const auto n = static_cast<std::size_t>(stride_);
  const std::size_t base = static_cast<std::size_t>(pack) * kLanes;
  const auto ref = [&](int k) {
    return P(&reference_[static_cast<std::size_t>(k) * n + base], stdx::vector_aligned);
  };
  Se3LawInput<P> in;
  for (int k = 0; k < 3; ++k) {
    in.position_m[k] = x[kPosition + k];
    in.velocity_m_s[k] = x[kVelocity + k];
    in.angular_velocity_B[k] = x[kAngularVelocity + k];
    in.position_ref_m[k] = ref(k);
    in.velocity_ref_m_s[k] = ref(3 + k);
    in.acceleration_ref_m_s2[k] = ref(6 + k);
  }
  for (int k = 0; k < 4; ++k) in.quaternion[k] = x[kQuaternion + k];
  in.cos_yaw = ref(9);
  in.sin_yaw = ref(10);
  if (law_.angular_feed_forward || law_.drag_feed_forward)
    for (int k = 0; k < 3; ++k) {
      in.feed_forward.angular_velocity_B[k] = ref(11 + k);
      in.feed_forward.angular_acceleration_B[k] = ref(14 + k);
      in.feed_forward.drag_compensation_W[k] = ref(17 + k);
    }
  allocate_lanes(*model_, se3_law<P>(law_, in), running, reference, failed, &saturated_[base]);
  for (int l = 0; l < kLanes; ++l)
    if (running[l] && !failed[l]) saturated_count_[base + l] += saturated_[base + l];
}

template class BatchSe3Controller<double>;
template class BatchSe3Controller<float>;

}  // namespace dronetwin
