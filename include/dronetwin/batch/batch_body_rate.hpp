#pragma once
// BatchBodyRateController<T>: the body-rate (CTBR) controller of control/body_rate.hpp for every
// lane of a batch, run by BatchSimulator::step inside its loop at the physics rate: each lane's
// command [T, w_x, w_y, w_z] becomes tau = J K_w (w_cmd - w) + w x J w and then rotor references
// through the thrust-first allocation. In double a lane equals BodyRateController flown by
// ClosedLoop at the physics rate (tests/batch).
//
//   BatchBodyRateController<float> rates(model, BodyRateGains{}, batch.size());
//   rates.command_data()[0 * rates.stride() + lane] = thrust_N;      // structure of arrays:
//   rates.command_data()[3 * rates.stride() + lane] = yaw_rate;      // T, w_x, w_y, w_z
//   batch.step(10, rates);                                           // a 100 Hz policy's period
//
// Commands are written straight into the arrays (an RL environment's actions); a lane whose
// command is not finite stops with StepStatus::kControllerFailed. Thrust below 0 is allocated as
// 0 (the rotors cannot pull); saturation is flagged per lane as for the SE(3) controller.

#include <memory>
#include <vector>

#include "dronetwin/batch/batch_simulator.hpp"
#include "dronetwin/control/body_rate.hpp"

namespace dronetwin {

template <class T>
class BatchBodyRateController final : public BatchInnerLoop<T> {
 public:
  using typename BatchInnerLoop<T>::Lanes;
  using typename BatchInnerLoop<T>::Mask;
  static constexpr int kLanes = BatchInnerLoop<T>::kLanes;

  /// Every lane starts with zero thrust and zero rates. InvalidArgument for bad gains or sizes.
  BatchBodyRateController(std::shared_ptr<const VehicleModel> model, const BodyRateGains& gains,
                          int num_vehicles);

  int size() const override { return num_vehicles_; }
  int num_rotors() const override { return model_->num_rotors(); }
  int stride() const { return stride_; }
  const BodyRateGains& gains() const { return gains_; }

  /// One lane's command (checked as BodyRateController::set_command).
  void set_command(int lane, double thrust_N, const Vec3& rates_rad_s);
  /// [T (N), w_x, w_y, w_z (rad/s)] per lane: command_data()[k * stride() + lane].
  T* command_data() { return command_.data(); }
  const std::uint8_t* saturated_data() const { return saturated_.data(); }

  void references(int pack, const Mask& running, const StateVectorT<Lanes>& measured,
                  const StateVectorT<Lanes>* measured_derivative,
                  std::array<Lanes, kMaxRotors>& reference, Mask& failed) override;

 private:
  std::shared_ptr<const VehicleModel> model_;
  BodyRateGains gains_;
  int num_vehicles_ = 0;
  int stride_ = 0;
  AlignedArray<T> command_;
  std::vector<std::uint8_t> saturated_;
};

extern template class BatchBodyRateController<double>;
extern template class BatchBodyRateController<float>;

}  // namespace dronetwin
