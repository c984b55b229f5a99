#include "dronetwin/control/trajectory_reference.hpp"

#include <cmath>
#include <utility>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

TrajectoryReference::TrajectoryReference(planning::Trajectory trajectory, double start_time_s)
    : trajectory_(std::make_shared<const planning::Trajectory>(std::move(trajectory))),
      start_time_s_(start_time_s) {
  require(std::isfinite(start_time_s),
          "trajectory reference: start_time_s: expected a finite "
          "time, got ",
          start_time_s);
}

ReferencePoint TrajectoryReference::at(double t_s) const {
  const double tau = t_s - start_time_s_;
  ReferencePoint p;
  if (!(tau > 0.0) || tau >= trajectory_->duration_s()) {
    // Outside the plan (or t is NaN): hold its first or last point at rest.
    const Vec4 hold = trajectory_->evaluate(tau > 0.0 ? trajectory_->duration_s() : 0.0, 0);
    p.position_m = hold.head<3>();
    p.yaw_rad = hold[3];
    return p;
  }
  const planning::FlatOutput f = trajectory_->at(tau);
  p.position_m = f.position_m;
  p.velocity_m_s = f.velocity_m_s;
  p.acceleration_m_s2 = f.acceleration_m_s2;
  p.jerk_m_s3 = f.jerk_m_s3;
  p.snap_m_s4 = f.snap_m_s4;
  p.yaw_rad = f.yaw_rad;
  p.yaw_rate_rad_s = f.yaw_rate_rad_s;
  p.yaw_acceleration_rad_s2 = f.yaw_acceleration_rad_s2;
  return p;
}

std::unique_ptr<Reference> TrajectoryReference::clone() const {
  return std::make_unique<TrajectoryReference>(*this);
}

std::string TrajectoryReference::describe() const {
  return detail::concat("trajectory, ", trajectory_->segments().size(), " segments, ",
                        trajectory_->duration_s(), " s from t = ", start_time_s_, " s");
}

}  // namespace dronetwin
