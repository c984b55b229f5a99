#include "dronetwin/batch/batch_body_rate.hpp"

#include "dronetwin/batch/lane_allocation.hpp"
#include "dronetwin/core/error.hpp"

namespace dronetwin {

template <class T>
BatchBodyRateController<T>::BatchBodyRateController(std::shared_ptr<const VehicleModel> model,
                                                    const BodyRateGains& gains, int num_vehicles)
    : model_(std::move(model)), gains_(gains) {
  require(model_ != nullptr, "BatchBodyRateController: model is null");
  BodyRateController check(model_, gains_);  // the scalar controller's checks of the gains
  num_vehicles_ = num_vehicles;
  stride_ = batch_stride<T>(num_vehicles, "BatchBodyRateController");
  command_ = AlignedArray<T>(static_cast<std::size_t>(4 * stride_));
  saturated_.assign(static_cast<std::size_t>(stride_), 0);
}

template <class T>
void BatchBodyRateController<T>::set_command(int lane, double thrust_N, const Vec3& rates_rad_s) {
  require(lane >= 0 && lane < num_vehicles_, "BatchBodyRateController::set_command: lane ", lane,
          " is out of range (", num_vehicles_, " vehicles)");
  require(std::isfinite(thrust_N) && thrust_N >= 0.0, "BatchBodyRateController::set_command: lane ",
          lane, ": thrust: expected a finite value >= 0 N, got ", thrust_N);
  require(rates_rad_s.allFinite(), "BatchBodyRateController::set_command: lane ", lane,
          ": rates: expected finite values in rad/s");
  const auto n = static_cast<std::size_t>(stride_), l = static_cast<std::size_t>(lane);
  command_[l] = static_cast<T>(thrust_N);
  for (int k = 0; k < 3; ++k)
    command_[static_cast<std::size_t>(1 + k) * n + l] = static_cast<T>(rates_rad_s[k]);
}

template <class T>
void BatchBodyRateController<T>::references(int pack, const Mask& running,
                                            const StateVectorT<Lanes>& x,
                                            const StateVectorT<Lanes>*,
                                            std::array<Lanes, kMaxRotors>& reference,
                                            Mask& failed) {
  using P = Lanes;
  const auto n = static_cast<std::size_t>(stride_);
  const std::size_t base = static_cast<std::size_t>(pack) * kLanes;
  Vector4<P> cmd;
  for (int k = 0; k < 4; ++k)
    cmd[k] = P(&command_[static_cast<std::size_t>(k) * n + base], stdx::vector_aligned);
  Vector3<P> w_B, rates;
  for (int k = 0; k < 3; ++k) {
    w_B[k] = x[state_index::kAngularVelocity + k];
    rates[k] = cmd[1 + k];
  }
  const Vector3<P> tau = body_rate_law<P>(gains_.rate_p, model_->inertia_kgm2(), w_B, rates);
  // Thrust below 0 is allocated as 0. A non-finite command gives a non-finite u (max keeps a
  // NaN), which allocate_lanes refuses: the lane stops.
  const Vector4<P> u(scalar::max(cmd[0], P(T(0))), tau[0], tau[1], tau[2]);
  allocate_lanes(*model_, u, running, reference, failed, &saturated_[base]);
}

template class BatchBodyRateController<double>;
template class BatchBodyRateController<float>;

}  // namespace dronetwin
