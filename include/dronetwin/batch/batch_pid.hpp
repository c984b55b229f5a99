#pragma once
// BatchCascadedPid<T>: the cascaded PID (control/pid.hpp, thesis Eq. 3.15-3.20) for every lane of
// a batch, run by BatchSimulator::step inside its loop at the physics rate. The law is
// control/pid_law.hpp on the batch's pack (trigonometry lane by lane), with each lane's integral
// kept here, and the rotor references come from the thrust-first allocation; in double a lane
// equals CascadedPid flown by ClosedLoop at the physics rate (tests/batch).
//
//   BatchCascadedPid<double> pid(model, PidGains::thesis_simulation(), options, batch.dt_s(), N);
//   pid.set_reference(lane, ReferencePoint{Vec3(0, 0, 1.5)});
//   batch.step(1000, pid);
//
// References: reference_data()[k * stride + lane], k = 0-2 position, 3-5 velocity, 6 yaw, 7 yaw
// rate, 8-10 acceleration (read with PidOptions::acceleration_feed_forward), 11-13 the flat body
// rates and 14-16 angular accelerations of the reference (PidOptions::angular_feed_forward);
// set_reference computes them in double as CascadedPid does each step. The controller reads the
// measured state derivative (its D2 term on the angular acceleration), so the batch evaluates the
// force model once more per step for it.
//
// Trap: the integral uses `control_period_s` as its dt; the batch runs the controller every
// physics step, so give it the batch's dt_s() (checked: the constructor refuses a non-positive
// period, step() cannot know). reset_integral(lane) clears a lane's memory (a new episode).

#include <memory>
#include <vector>

#include "dronetwin/batch/batch_simulator.hpp"
#include "dronetwin/control/pid.hpp"
#include "dronetwin/control/reference.hpp"

namespace dronetwin {

template <class T>
class BatchCascadedPid final : public BatchInnerLoop<T> {
 public:
  using typename BatchInnerLoop<T>::Lanes;
  using typename BatchInnerLoop<T>::Mask;
  static constexpr int kLanes = BatchInnerLoop<T>::kLanes;
  static constexpr int kReferenceSize = 17;

  /// Gains and options as CascadedPid (the same checks). Every lane's reference starts at the
  /// origin, yaw 0, its integral at zero.
  BatchCascadedPid(std::shared_ptr<const VehicleModel> model, const PidGains& gains,
                   const PidOptions& options, double control_period_s, int num_vehicles);

  int size() const override { return num_vehicles_; }
  int num_rotors() const override { return model_->num_rotors(); }
  bool uses_state_derivative() const override { return true; }
  int stride() const { return stride_; }
  double control_period_s() const { return dt_s_; }

  void set_reference(int lane, const ReferencePoint& reference);
  T* reference_data() { return reference_.data(); }
  /// Integral state per lane, [k * stride + lane], k = x, y, z, psi (m s, rad s).
  const T* integral_data() const { return integral_.data(); }
  void reset_integral(int lane);
  const std::uint8_t* saturated_data() const { return saturated_.data(); }

  void references(int pack, const Mask& running, const StateVectorT<Lanes>& measured,
                  const StateVectorT<Lanes>* measured_derivative,
                  std::array<Lanes, kMaxRotors>& reference, Mask& failed) override;

 private:
  std::shared_ptr<const VehicleModel> model_;
  PidLawConstants law_;
  double dt_s_ = 0.0;
  int num_vehicles_ = 0;
  int stride_ = 0;
  AlignedArray<T> reference_, integral_;
  std::vector<std::uint8_t> saturated_;
};

extern template class BatchCascadedPid<double>;
extern template class BatchCascadedPid<float>;

}  // namespace dronetwin
