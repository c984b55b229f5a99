#pragma once
// Exact signed distance fields of the scene's shapes (negative inside), written independently of
// world/ for the tests to check the library's ray casts and collision tests against.

#include <algorithm>
#include <array>
#include <cmath>

#include "dronetwin/math/segment_distance.hpp"
#include "dronetwin/world/gate.hpp"
#include "dronetwin/world/obstacle.hpp"

namespace dronetwin::test {

inline double sdf_obstacle(const Obstacle& ob, const Vec3& p) {
  const Vec3 q = p - ob.center_m;
  switch (ob.shape) {
    case Obstacle::Shape::kBox: {
      const Vec3 e = q.cwiseAbs() - ob.half_size_m;
      return e.cwiseMax(0.0).norm() + std::min(e.maxCoeff(), 0.0);
    }
    case Obstacle::Shape::kCylinder: {
      const Eigen::Vector2d e(q.head<2>().norm() - ob.half_size_m[0],
                              std::abs(q[2]) - ob.half_size_m[2]);
      return e.cwiseMax(0.0).norm() + std::min(e.maxCoeff(), 0.0);
    }
    case Obstacle::Shape::kSphere:
      return q.norm() - ob.half_size_m[0];
  }
  return 1e300;
}

/// The ends of a gate's four bars (capsules of radius frame_width / 2), from the gate's axes.
inline std::array<std::array<Vec3, 2>, 4> frame_bars(const Gate& g) {
  const double bar = 0.5 * g.frame_width_m;
  const Vec3 y = (0.5 * g.width_m + bar) * g.width_axis(),
             z = (0.5 * g.height_m + bar) * g.up_axis();
  const Vec3& c = g.center_m;
  const std::array<Vec3, 4> k = {c + y + z, c - y + z, c - y - z, c + y - z};
  return {{{k[0], k[1]}, {k[1], k[2]}, {k[2], k[3]}, {k[3], k[0]}}};
}

/// Distance to one bar of the frame.
inline double sdf_bar(const Gate& g, int bar, const Vec3& p) {
  const auto ends = frame_bars(g)[static_cast<std::size_t>(bar)];
  return math::point_segment_distance(p, ends[0], ends[1]) - 0.5 * g.frame_width_m;
}

/// Distance to the whole frame (the nearest bar).
inline double sdf_frame(const Gate& g, const Vec3& p) {
  double d = 1e300;
  for (int i = 0; i < 4; ++i) d = std::min(d, sdf_bar(g, i, p));
  return d;
}

}  // namespace dronetwin::test
