#pragma once
// Reference trajectories for tracking controllers, with the derivatives controllers need:
// position, velocity, acceleration, jerk and snap (world frame), yaw and its first two
// derivatives. Jerk, snap and yaw acceleration feed the SE(3) controller's body-rate and
// angular-acceleration feed-forward (control/se3.hpp); a reference that holds still leaves them 0.
//
//   auto ref = FigureEightReference{};          // thesis Eq. 3.25
//   ReferencePoint r = ref.at(12.5);            // r.position_m, r.velocity_m_s, ...
//
// Every reference is immutable after construction and cheap to copy (clone()).

#include <memory>
#include <string>
#include <vector>

#include "dronetwin/core/types.hpp"

namespace dronetwin {

struct ReferencePoint {
  Vec3 position_m = Vec3::Zero();
  Vec3 velocity_m_s = Vec3::Zero();
  Vec3 acceleration_m_s2 = Vec3::Zero();
  double yaw_rad = 0.0;
  double yaw_rate_rad_s = 0.0;
  Vec3 jerk_m_s3 = Vec3::Zero();
  Vec3 snap_m_s4 = Vec3::Zero();
  double yaw_acceleration_rad_s2 = 0.0;
};

class Reference {
 public:
  virtual ~Reference() = default;
  virtual ReferencePoint at(double t_s) const = 0;
  virtual std::unique_ptr<Reference> clone() const = 0;
  virtual std::string describe() const = 0;
};

/// A fixed point and yaw (hover).
class SetpointReference final : public Reference {
 public:
  explicit SetpointReference(const Vec3& position_m, double yaw_rad = 0.0);
  ReferencePoint at(double t_s) const override;
  std::unique_ptr<Reference> clone() const override;
  std::string describe() const override;

 private:
  ReferencePoint point_;
};

/// Piecewise-constant position/yaw held from each segment's start time (zero derivatives), e.g.
/// the pulse of thesis Eq. 3.14. Segments must start at 0 and be strictly increasing.
class PiecewiseConstantReference final : public Reference {
 public:
  struct Segment {
    double start_s = 0.0;
    Vec3 position_m = Vec3::Zero();
    double yaw_rad = 0.0;
  };
  explicit PiecewiseConstantReference(std::vector<Segment> segments);
  /// Thesis Eq. 3.14: x pulses -0.75/0.75/-0.75 m between 30 and 50 s, z = 0.75 m from 22 s.
  static PiecewiseConstantReference thesis_pulse();
  ReferencePoint at(double t_s) const override;
  std::unique_ptr<Reference> clone() const override;
  std::string describe() const override;
  const std::vector<Segment>& segments() const { return segments_; }

 private:
  std::vector<Segment> segments_;
};

/// Horizontal circle p = c + r [cos(2 pi t / T + phase), sin(...), 0] (thesis Eq. 3.28:
/// r = 2 m, T = 7 s, centre (0, 0, 1)).
class CircleReference final : public Reference {
 public:
  CircleReference(const Vec3& center_m = Vec3(0, 0, 1), double radius_m = 2.0,
                  double period_s = 7.0, double yaw_rad = 0.0);
  ReferencePoint at(double t_s) const override;
  std::unique_ptr<Reference> clone() const override;
  std::string describe() const override;

 private:
  Vec3 center_m_;
  double radius_m_, period_s_, yaw_rad_;
};

/// Figure eight p = c + [a_x sin(2 pi t / T), a_y sin(4 pi t / T), 0] (thesis Eq. 3.25:
/// a_x = 0.8 m, a_y = 0.6 m, T = 60 s, centre (0, 0, 1.2)).
class FigureEightReference final : public Reference {
 public:
  FigureEightReference(const Vec3& center_m = Vec3(0, 0, 1.2), double amplitude_x_m = 0.8,
                       double amplitude_y_m = 0.6, double period_s = 60.0);
  ReferencePoint at(double t_s) const override;
  std::unique_ptr<Reference> clone() const override;
  std::string describe() const override;

 private:
  Vec3 center_m_;
  double ax_, ay_, period_s_;
};

/// Timed waypoints joined by quintic (minimum-jerk) segments that start and end at rest, so
/// position, velocity and acceleration are continuous (jerk and snap jump at the waypoints). Holds
/// the last waypoint afterwards.
class WaypointReference final : public Reference {
 public:
  struct Waypoint {
    double time_s = 0.0;
    Vec3 position_m = Vec3::Zero();
    double yaw_rad = 0.0;
  };
  explicit WaypointReference(std::vector<Waypoint> waypoints);
  ReferencePoint at(double t_s) const override;
  std::unique_ptr<Reference> clone() const override;
  std::string describe() const override;

 private:
  std::vector<Waypoint> waypoints_;
};

}  // namespace dronetwin
