#pragma once
// Closest distances between points and straight segments in 3-D, exact (no sampling), for the
// swept-sphere collision tests of world/ (a vehicle's path over one env step against gate bars).

#include <algorithm>
#include <cmath>

#include "dronetwin/core/types.hpp"

namespace dronetwin::math {

/// Distance from point x to the segment p0-p1 (a point when p0 == p1).
inline double point_segment_distance(const Vec3& x, const Vec3& p0, const Vec3& p1) {
  const Vec3 d = p1 - p0;
  const double dd = d.squaredNorm();
  const double t = dd > 0.0 ? std::clamp((x - p0).dot(d) / dd, 0.0, 1.0) : 0.0;
  return (p0 + t * d - x).norm();
}

/// Smallest distance between the segments p0-p1 and q0-q1 (either may be a point).
inline double segment_segment_distance(const Vec3& p0, const Vec3& p1, const Vec3& q0,
                                       const Vec3& q1) {
  // Minimise |p0 + s d1 - q0 - t d2|^2 over s, t in [0, 1]: the interior stationary point when
  // the segments are not parallel, else the best of the four endpoint-to-segment distances
  // (the minimum of a convex quadratic on a square lies inside or on an edge, and on an edge it
  // is an endpoint-to-segment distance).
  const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm();
  double best =
      std::min(std::min(point_segment_distance(p0, q0, q1), point_segment_distance(p1, q0, q1)),
               std::min(point_segment_distance(q0, p0, p1), point_segment_distance(q1, p0, p1)));
  if (a > 0.0 && e > 0.0) {
    const double b = d1.dot(d2), c = d1.dot(r), f = d2.dot(r);
    const double den = a * e - b * b;
    // Parallel (den ~ 0): the edge candidates above are exact.
    if (den > 1e-12 * a * e) {
      const double s = (b * f - c * e) / den, t = (a * f - b * c) / den;
      if (s > 0.0 && s < 1.0 && t > 0.0 && t < 1.0)
        best = std::min(best, (r + s * d1 - t * d2).norm());
    }
  }
  return best;
}

}  // namespace dronetwin::math
