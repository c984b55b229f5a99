#include "dronetwin/control/reference.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

namespace {
constexpr double kTwoPi = 2.0 * std::numbers::pi;
}

SetpointReference::SetpointReference(const Vec3& position_m, double yaw_rad) {
  require(position_m.allFinite() && std::isfinite(yaw_rad),
          "setpoint reference: expected finite position and yaw");
  point_.position_m = position_m;
  point_.yaw_rad = yaw_rad;
}
ReferencePoint SetpointReference::at(double) const { return point_; }
std::unique_ptr<Reference> SetpointReference::clone() const {
  return std::make_unique<SetpointReference>(*this);
}
std::string SetpointReference::describe() const {
  return detail::concat("setpoint [", point_.position_m.transpose(), "] m, yaw ", point_.yaw_rad);
}

PiecewiseConstantReference::PiecewiseConstantReference(std::vector<Segment> segments)
    : segments_(std::move(segments)) {
  require(!segments_.empty(), "piecewise reference: expected at least one segment");
  require(segments_.front().start_s == 0.0,
          "piecewise reference: segments[0].start_s: expected 0, got ", segments_.front().start_s);
  for (std::size_t i = 0; i < segments_.size(); ++i) {
    const Segment& s = segments_[i];
    require(std::isfinite(s.start_s) && s.position_m.allFinite() && std::isfinite(s.yaw_rad),
            "piecewise reference: segments[", i, "]: expected finite numbers");
    if (i > 0)
      require(s.start_s > segments_[i - 1].start_s, "piecewise reference: segments[", i,
              "].start_s: expected > ", segments_[i - 1].start_s, ", got ", s.start_s);
  }
}

PiecewiseConstantReference PiecewiseConstantReference::thesis_pulse() {
  // Eq. 3.14, with both axes' switching times merged into one segment list.
  return PiecewiseConstantReference({{0.0, Vec3(0, 0, 0), 0.0},
                                     {22.0, Vec3(0, 0, 0.75), 0.0},
                                     {30.0, Vec3(-0.75, 0, 0.75), 0.0},
                                     {35.0, Vec3(0.75, 0, 0.75), 0.0},
                                     {45.0, Vec3(-0.75, 0, 0.75), 0.0},
                                     {50.0, Vec3(0, 0, 0.75), 0.0}});
}

ReferencePoint PiecewiseConstantReference::at(double t_s) const {
  // Last segment whose start is <= t.
  auto it = std::upper_bound(segments_.begin(), segments_.end(), t_s,
                             [](double t, const Segment& s) { return t < s.start_s; });
  const Segment& s = it == segments_.begin() ? segments_.front() : *(it - 1);
  ReferencePoint p;
  p.position_m = s.position_m;
  p.yaw_rad = s.yaw_rad;
  return p;
}
std::unique_ptr<Reference> PiecewiseConstantReference::clone() const {
  return std::make_unique<PiecewiseConstantReference>(*this);
}
std::string PiecewiseConstantReference::describe() const {
  return detail::concat("piecewise constant, ", segments_.size(), " segments");
}

CircleReference::CircleReference(const Vec3& center_m, double radius_m, double period_s,
                                 double yaw_rad)
    : center_m_(center_m), radius_m_(radius_m), period_s_(period_s), yaw_rad_(yaw_rad) {
  require(
      center_m.allFinite() && std::isfinite(radius_m) && radius_m >= 0.0 && std::isfinite(yaw_rad),
      "circle reference: expected a finite centre and yaw and a radius >= 0");
  require(std::isfinite(period_s) && period_s > 0.0,
          "circle reference: period_s: expected > 0, got ", period_s);
}
ReferencePoint CircleReference::at(double t_s) const {
  // Eq. 3.28 and its derivatives.
  const double w = kTwoPi / period_s_, c = std::cos(w * t_s), s = std::sin(w * t_s);
  ReferencePoint p;
  p.position_m = center_m_ + radius_m_ * Vec3(c, s, 0);
  p.velocity_m_s = radius_m_ * w * Vec3(-s, c, 0);
  p.acceleration_m_s2 = -radius_m_ * w * w * Vec3(c, s, 0);
  p.jerk_m_s3 = radius_m_ * w * w * w * Vec3(s, -c, 0);
  p.snap_m_s4 = radius_m_ * w * w * w * w * Vec3(c, s, 0);
  p.yaw_rad = yaw_rad_;
  return p;
}
std::unique_ptr<Reference> CircleReference::clone() const {
  return std::make_unique<CircleReference>(*this);
}
std::string CircleReference::describe() const {
  return detail::concat("circle r = ", radius_m_, " m, T = ", period_s_, " s");
}

FigureEightReference::FigureEightReference(const Vec3& center_m, double amplitude_x_m,
                                           double amplitude_y_m, double period_s)
    : center_m_(center_m), ax_(amplitude_x_m), ay_(amplitude_y_m), period_s_(period_s) {
  require(center_m.allFinite() && std::isfinite(ax_) && std::isfinite(ay_),
          "figure-eight reference: expected finite centre and amplitudes");
  require(std::isfinite(period_s) && period_s > 0.0,
          "figure-eight reference: period_s: expected > 0, got ", period_s);
}
ReferencePoint FigureEightReference::at(double t_s) const {
  // Eq. 3.25 and its derivatives.
  const double w = kTwoPi / period_s_;
  ReferencePoint p;
  p.position_m = center_m_ + Vec3(ax_ * std::sin(w * t_s), ay_ * std::sin(2 * w * t_s), 0);
  p.velocity_m_s = Vec3(ax_ * w * std::cos(w * t_s), 2 * ay_ * w * std::cos(2 * w * t_s), 0);
  p.acceleration_m_s2 =
      Vec3(-ax_ * w * w * std::sin(w * t_s), -4 * ay_ * w * w * std::sin(2 * w * t_s), 0);
  const double w3 = w * w * w, w4 = w3 * w;
  p.jerk_m_s3 = Vec3(-ax_ * w3 * std::cos(w * t_s), -8 * ay_ * w3 * std::cos(2 * w * t_s), 0);
  p.snap_m_s4 = Vec3(ax_ * w4 * std::sin(w * t_s), 16 * ay_ * w4 * std::sin(2 * w * t_s), 0);
  return p;
}
std::unique_ptr<Reference> FigureEightReference::clone() const {
  return std::make_unique<FigureEightReference>(*this);
}
std::string FigureEightReference::describe() const {
  return detail::concat("figure eight ", ax_, " x ", ay_, " m, T = ", period_s_, " s");
}

WaypointReference::WaypointReference(std::vector<Waypoint> waypoints)
    : waypoints_(std::move(waypoints)) {
  require(!waypoints_.empty(), "waypoint reference: expected at least one waypoint");
  for (std::size_t i = 0; i < waypoints_.size(); ++i) {
    const Waypoint& w = waypoints_[i];
    require(std::isfinite(w.time_s) && w.position_m.allFinite() && std::isfinite(w.yaw_rad),
            "waypoint reference: waypoints[", i, "]: expected finite numbers");
    if (i > 0)
      require(w.time_s > waypoints_[i - 1].time_s, "waypoint reference: waypoints[", i,
              "].time_s: expected > ", waypoints_[i - 1].time_s, ", got ", w.time_s);
  }
}
ReferencePoint WaypointReference::at(double t_s) const {
  ReferencePoint p;
  if (t_s <= waypoints_.front().time_s) {
    p.position_m = waypoints_.front().position_m;
    p.yaw_rad = waypoints_.front().yaw_rad;
    return p;
  }
  if (t_s >= waypoints_.back().time_s) {
    p.position_m = waypoints_.back().position_m;
    p.yaw_rad = waypoints_.back().yaw_rad;
    return p;
  }
  auto it = std::upper_bound(waypoints_.begin(), waypoints_.end(), t_s,
                             [](double t, const Waypoint& w) { return t < w.time_s; });
  const Waypoint& b = *it;
  const Waypoint& a = *(it - 1);
  const double T = b.time_s - a.time_s, s = (t_s - a.time_s) / T;
  // Minimum-jerk blend h(s) = 10 s^3 - 15 s^4 + 6 s^5 with h' and h'' zero at both ends.
  const double h = s * s * s * (10 - 15 * s + 6 * s * s);
  const double dh = 30 * s * s * (1 - s) * (1 - s) / T;
  const double ddh = 60 * s * (1 - s) * (1 - 2 * s) / (T * T);
  const double dddh = 60 * (1 - 6 * s + 6 * s * s) / (T * T * T);
  const double ddddh = 360 * (2 * s - 1) / (T * T * T * T);
  const Vec3 d = b.position_m - a.position_m;
  const double d_yaw = b.yaw_rad - a.yaw_rad;
  p.position_m = a.position_m + h * d;
  p.velocity_m_s = dh * d;
  p.acceleration_m_s2 = ddh * d;
  p.jerk_m_s3 = dddh * d;
  p.snap_m_s4 = ddddh * d;
  p.yaw_rad = a.yaw_rad + h * d_yaw;
  p.yaw_rate_rad_s = dh * d_yaw;
  p.yaw_acceleration_rad_s2 = ddh * d_yaw;
  return p;
}
std::unique_ptr<Reference> WaypointReference::clone() const {
  return std::make_unique<WaypointReference>(*this);
}
std::string WaypointReference::describe() const {
  return detail::concat("waypoints, ", waypoints_.size(), " points");
}

}  // namespace dronetwin
