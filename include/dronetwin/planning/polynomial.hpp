#pragma once
// A piecewise polynomial trajectory of the flat outputs of a multirotor: position x, y, z (m) and
// yaw (rad), degree 7 per segment, as planned by planning/min_snap.hpp.
//
//   const Trajectory traj = plan_min_snap(waypoints, times_s, {});
//   const FlatOutput f = traj.at(2.5);                 // f.position_m, f.velocity_m_s, ...
//   const Vec4 snap = traj.evaluate(2.5, 4);           // d^4/dt^4 of [x, y, z, yaw]
//
// Segment i runs for segments[i].duration_s; on it, axis a is
//   p_a(t) = sum_k coefficients(k, a) * tau^k,  tau = t - (start of segment i),  k = 0..7,
// columns 0..3 = x, y, z, yaw. A time is looked up by binary search over the knot times.
// The trap: outside [0, duration_s()] the time is clamped, so before the start you get the state
// *at* t = 0 with the polynomial's own derivatives there (zero for a plan that starts at rest,
// not in general), and likewise after the end. The trajectory never extrapolates.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <utility>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/core/types.hpp"

namespace dronetwin::planning {

/// Polynomial degree of every segment and the number of coefficients per axis.
inline constexpr int kPolynomialDegree = 7;
inline constexpr int kCoefficientCount = kPolynomialDegree + 1;
/// Axes: x, y, z (m) and yaw (rad).
inline constexpr int kAxisCount = 4;

using SegmentCoefficients = Eigen::Matrix<double, kCoefficientCount, kAxisCount>;

struct PolynomialSegment {
  double duration_s = 0.0;
  /// Row k = coefficient of tau^k (tau in s from the segment's start); columns x, y, z, yaw.
  SegmentCoefficients coefficients = SegmentCoefficients::Zero();
};

/// The flat outputs and their derivatives at one time (differential flatness: enough to compute
/// the attitude, body rates and their derivatives a tracking controller needs).
struct FlatOutput {
  Vec3 position_m = Vec3::Zero();
  Vec3 velocity_m_s = Vec3::Zero();
  Vec3 acceleration_m_s2 = Vec3::Zero();
  Vec3 jerk_m_s3 = Vec3::Zero();
  Vec3 snap_m_s4 = Vec3::Zero();
  double yaw_rad = 0.0;
  double yaw_rate_rad_s = 0.0;
  double yaw_acceleration_rad_s2 = 0.0;
};

/// The `order`-th derivative (0..7) at tau of one segment, all four axes. Horner's scheme on the
/// differentiated coefficients k!/(k-order)! c_k.
inline Vec4 evaluate_segment(const PolynomialSegment& segment, double tau_s, int order) {
  require(order >= 0 && order <= kPolynomialDegree,
          "evaluate_segment: derivative order: expected 0..7, got ", order);
  Vec4 value = Vec4::Zero();
  for (int k = kPolynomialDegree; k >= order; --k) {
    double falling = 1.0;  // k (k-1) ... (k-order+1)
    for (int j = 0; j < order; ++j) falling *= static_cast<double>(k - j);
    value = value * tau_s + falling * segment.coefficients.row(k).transpose();
  }
  return value;
}

/// Segments joined end to start, time starting at 0. Immutable after construction.
class Trajectory {
 public:
  /// Throws InvalidArgument on no segments, a non-positive or non-finite duration or a non-finite
  /// coefficient (naming the segment).
  explicit Trajectory(std::vector<PolynomialSegment> segments) : segments_(std::move(segments)) {
    require(!segments_.empty(), "Trajectory: expected at least 1 segment, got 0");
    knot_times_s_.reserve(segments_.size() + 1);
    knot_times_s_.push_back(0.0);
    for (std::size_t i = 0; i < segments_.size(); ++i) {
      const double d = segments_[i].duration_s;
      require(std::isfinite(d) && d > 0.0, "Trajectory: segments[", i,
              "].duration_s: expected a positive finite duration, got ", d);
      require(all_finite(segments_[i].coefficients), "Trajectory: segments[", i,
              "].coefficients: expected finite numbers");
      knot_times_s_.push_back(knot_times_s_.back() + d);
    }
  }

  const std::vector<PolynomialSegment>& segments() const { return segments_; }
  /// Start times of the segments and the end time: 0, d_0, d_0 + d_1, ..., duration_s().
  const std::vector<double>& knot_times_s() const { return knot_times_s_; }
  double duration_s() const { return knot_times_s_.back(); }

  /// Index of the segment that holds t (clamped to [0, duration_s()]); a knot belongs to the
  /// segment it starts, the end time to the last segment.
  std::size_t segment_index(double t_s) const {
    // First knot after t among the interior knots, minus one: binary search, O(log n).
    const auto first = knot_times_s_.begin() + 1, last = knot_times_s_.end() - 1;
    return static_cast<std::size_t>(std::upper_bound(first, last, t_s) - first);
  }

  /// The `order`-th time derivative (0..7) of [x, y, z, yaw] at t, t clamped to [0, duration_s()].
  Vec4 evaluate(double t_s, int order) const {
    require(!std::isnan(t_s), "Trajectory::evaluate: t_s is NaN");
    const double t = std::clamp(t_s, 0.0, duration_s());
    const std::size_t i = segment_index(t);
    // min(): rounding in the knot sums must not push tau past the segment's end.
    const double tau = std::min(t - knot_times_s_[i], segments_[i].duration_s);
    return evaluate_segment(segments_[i], tau, order);
  }

  /// Position, yaw and their derivatives up to snap (position) and acceleration (yaw) at t.
  FlatOutput at(double t_s) const {
    FlatOutput out;
    const Vec4 p = evaluate(t_s, 0), v = evaluate(t_s, 1), a = evaluate(t_s, 2);
    out.position_m = p.head<3>();
    out.velocity_m_s = v.head<3>();
    out.acceleration_m_s2 = a.head<3>();
    out.jerk_m_s3 = evaluate(t_s, 3).head<3>();
    out.snap_m_s4 = evaluate(t_s, 4).head<3>();
    out.yaw_rad = p[3];
    out.yaw_rate_rad_s = v[3];
    out.yaw_acceleration_rad_s2 = a[3];
    return out;
  }

 private:
  std::vector<PolynomialSegment> segments_;
  std::vector<double> knot_times_s_;
};

}  // namespace dronetwin::planning
