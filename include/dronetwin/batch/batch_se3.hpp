#pragma once
// BatchSe3Controller<T>: the SE(3) controller (control/se3.hpp) for every lane of a batch, run by
// BatchSimulator::step inside its loop at the physics rate. The law is control/se3_law.hpp
// instantiated on the batch's pack, and the rotor references come from the same thrust-first
// allocation (model/allocation.hpp), so in double a lane equals Se3Controller flown by ClosedLoop
// at the physics rate (tests/batch).
//
//   BatchSimulator<double> batch(model, config, 4096, 2);
//   Se3Options options;
//   options.gravity_compensation = true;
//   BatchSe3Controller<double> se3(model, Se3Gains::thesis(), options, batch.size());
//   se3.set_reference(17, ReferencePoint{Vec3(1, 0, 1.5)});
//   batch.step(1000, se3);                           // 1 s, the controller at every step
//
// References: structure of arrays like the batch's, reference_data()[k * stride + lane] with
// k = 0-2 position (m), 3-5 velocity (m/s), 6-8 acceleration (m/s^2), 9-10 the heading b1d =
// [cos yaw, sin yaw] of Eq. 3.28 (stored as a unit vector so the loop needs no trigonometry),
// 11-13 the desired body rates w_des (rad/s) and 14-16 angular accelerations w_dot_des (rad/s^2)
// of the feed-forward (Se3Options::angular_feed_forward), 17-19 the drag compensation (N, world;
// Se3Options::drag_feed_forward); read only with those options. set_reference computes them from
// the reference in double, as Se3Controller does each step.
// The controller uses the nominal model (its mass in the gains, its inertia and allocation): per
// lane parameters of the batch change the vehicles, not what the controller believes.

#include <memory>
#include <vector>

#include "dronetwin/batch/batch_simulator.hpp"
#include "dronetwin/control/reference.hpp"
#include "dronetwin/control/se3.hpp"

namespace dronetwin {

template <class T>
class BatchSe3Controller final : public BatchInnerLoop<T> {
 public:
  using typename BatchInnerLoop<T>::Lanes;
  using typename BatchInnerLoop<T>::Mask;
  static constexpr int kLanes = BatchInnerLoop<T>::kLanes;
  static constexpr int kReferenceSize = 20;

  /// Gains and options as Se3Controller (the same checks); every lane's reference starts at rest
  /// at the origin with yaw 0.
  BatchSe3Controller(std::shared_ptr<const VehicleModel> model, const Se3Gains& gains,
                     const Se3Options& options, int num_vehicles);

  int size() const override { return num_vehicles_; }
  int num_rotors() const override { return model_->num_rotors(); }
  int stride() const { return stride_; }
  const Se3LawConstants& law() const { return law_; }

  /// Lane `lane` tracks `reference` (position, velocity, acceleration, yaw; with the feed-forward
  /// also jerk, snap, yaw rate and yaw acceleration); InvalidArgument for a bad lane or
  /// non-finite values.
  void set_reference(int lane, const ReferencePoint& reference);
  T* reference_data() { return reference_.data(); }
  /// Per lane, from the last update: 1 when the rotors could not give the requested force.
  const std::uint8_t* saturated_data() const { return saturated_.data(); }
  /// Updates per lane whose allocation saturated, since construction or reset_counters().
  const std::int64_t* saturated_count_data() const { return saturated_count_.data(); }
  void reset_counters();

  void references(int pack, const Mask& running, const StateVectorT<Lanes>& measured,
                  const StateVectorT<Lanes>* measured_derivative,
                  std::array<Lanes, kMaxRotors>& reference, Mask& failed) override;

 private:
  std::shared_ptr<const VehicleModel> model_;
  Se3LawConstants law_;
  int num_vehicles_ = 0;
  int stride_ = 0;
  AlignedArray<T> reference_;
  std::vector<std::uint8_t> saturated_;
  std::vector<std::int64_t> saturated_count_;
};

extern template class BatchSe3Controller<double>;
extern template class BatchSe3Controller<float>;

}  // namespace dronetwin
