#include "dronetwin/world/gate.hpp"

#include <cmath>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/segment_distance.hpp"

namespace dronetwin {

std::array<Vec3, 4> Gate::corners() const {
  const Vec3 y = 0.5 * width_m * width_axis(), z = 0.5 * height_m * up_axis();
  return {center_m + y + z, center_m - y + z, center_m - y - z, center_m + y - z};
}

double Gate::bounding_radius_m() const {
  // Half the outer diagonal, plus the bars' radius beyond their axes.
  const double half_w = 0.5 * (width_m + frame_width_m), half_h = 0.5 * (height_m + frame_width_m);
  return std::hypot(half_w, half_h) + 0.5 * frame_width_m;
}

Gate make_gate(std::string name, const Vec3& center_m, double yaw_rad, double pitch_rad,
               double roll_rad, double width_m, double height_m, double frame_width_m) {
  require(center_m.allFinite(), "gate '", name, "': position: expected finite numbers, got [",
          center_m.transpose(), "]");
  for (double a : {yaw_rad, pitch_rad, roll_rad})
    require(std::isfinite(a), "gate '", name, "': orientation: expected finite angles, got ", a);
  require(std::isfinite(width_m) && width_m > 0.0, "gate '", name,
          "': width_m: expected a positive number, got ", width_m);
  require(std::isfinite(height_m) && height_m > 0.0, "gate '", name,
          "': height_m: expected a positive number, got ", height_m);
  require(std::isfinite(frame_width_m) && frame_width_m > 0.0, "gate '", name,
          "': frame_width_m: expected a positive number, got ", frame_width_m);
  Gate g;
  g.name = std::move(name);
  g.center_m = center_m;
  g.axes =
      (Eigen::AngleAxisd(yaw_rad, Vec3::UnitZ()) * Eigen::AngleAxisd(pitch_rad, Vec3::UnitY()) *
       Eigen::AngleAxisd(roll_rad, Vec3::UnitX()))
          .toRotationMatrix();
  g.width_m = width_m;
  g.height_m = height_m;
  g.frame_width_m = frame_width_m;
  return g;
}

GateCrossing cross_gate(const Gate& g, const Vec3& from, const Vec3& to) {
  const Vec3 n = g.normal();
  const double s0 = n.dot(from - g.center_m), s1 = n.dot(to - g.center_m);
  const bool forward = s0 < 0.0 && s1 >= 0.0, backward = s0 >= 0.0 && s1 < 0.0;
  if (!forward && !backward) return GateCrossing::kNone;
  const Vec3 q = from + (s0 / (s0 - s1)) * (to - from) - g.center_m;
  const bool inside = std::abs(g.width_axis().dot(q)) < 0.5 * g.width_m &&
                      std::abs(g.up_axis().dot(q)) < 0.5 * g.height_m;
  if (!inside) return GateCrossing::kNone;
  return forward ? GateCrossing::kThrough : GateCrossing::kBackwards;
}

std::array<Vec3, 4> Gate::bar_corners() const {
  const double bar = 0.5 * frame_width_m;
  const Vec3 y = (0.5 * width_m + bar) * width_axis(), z = (0.5 * height_m + bar) * up_axis();
  const Vec3& c = center_m;
  return {c + y + z, c - y + z, c - y - z, c + y - z};
}

double frame_distance_m(const Gate& g, const Vec3& from, const Vec3& to) {
  const double bar = 0.5 * g.frame_width_m;
  const std::array<Vec3, 4> k = g.bar_corners();
  double d = math::segment_segment_distance(from, to, k[0], k[1]);
  for (std::size_t i = 1; i < 4; ++i)
    d = std::min(d, math::segment_segment_distance(from, to, k[i], k[(i + 1) % 4]));
  return d - bar;
}

bool touches_frame(const Gate& g, const Vec3& from, const Vec3& to, double radius_m) {
  // Broad phase: the segment's distance to the centre against the frame's bounding sphere.
  if (math::point_segment_distance(g.center_m, from, to) > g.bounding_radius_m() + radius_m)
    return false;
  return frame_distance_m(g, from, to) < radius_m;
}

}  // namespace dronetwin
