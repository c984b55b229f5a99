#pragma once
// A planned trajectory (planning/polynomial.hpp, for instance a minimum-snap plan) as a
// controller's reference: position to snap and yaw to yaw acceleration, from the polynomials.
//
//   const planning::Trajectory plan = planning::plan_min_snap(waypoints, times_s, {});
//   const TrajectoryReference ref(plan, 2.0);     // starts 2 s into the run
//   Se3Options options;
//   options.angular_feed_forward = true;          // uses the jerk and snap it provides
//
// Before start_time_s the reference holds the trajectory's first point, after its end the last
// one, both at rest (all derivatives 0, the yaw its value there). A minimum-snap plan starts and
// ends with velocity, acceleration and jerk 0 unless told otherwise, so only snap jumps there.

#include <memory>
#include <string>

#include "dronetwin/control/reference.hpp"
#include "dronetwin/planning/polynomial.hpp"

namespace dronetwin {

class TrajectoryReference final : public Reference {
 public:
  /// Throws InvalidArgument unless start_time_s is finite.
  explicit TrajectoryReference(planning::Trajectory trajectory, double start_time_s = 0.0);
  ReferencePoint at(double t_s) const override;
  std::unique_ptr<Reference> clone() const override;
  std::string describe() const override;

  const planning::Trajectory& trajectory() const { return *trajectory_; }
  double start_time_s() const { return start_time_s_; }
  double end_time_s() const { return start_time_s_ + trajectory_->duration_s(); }

 private:
  // Shared and immutable: clone() copies a pointer, not the polynomials.
  std::shared_ptr<const planning::Trajectory> trajectory_;
  double start_time_s_ = 0.0;
};

}  // namespace dronetwin
