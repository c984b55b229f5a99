#include "dronetwin/world/ray_cast.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

namespace {

// The part [t0, t1] of the ray o + t d inside one convex piece, narrowed piece by piece; the ray
// enters the intersection of the pieces at max(t0, 0) when t0 <= t1 and t1 >= 0.
struct Span {
  double t0 = -kNoHit, t1 = kNoHit;
  bool empty() const { return t0 > t1; }
  double entry() const { return empty() || t1 < 0.0 ? kNoHit : std::max(t0, 0.0); }
};

// The slab |x - c| <= h along one axis, with o, d that axis' components.
void clip_slab(double o, double d, double c, double h, Span& s) {
  const double lo = c - h - o, hi = c + h - o;
  if (d == 0.0) {
    if (lo > 0.0 || hi < 0.0) s.t0 = kNoHit, s.t1 = -kNoHit;  // parallel and outside
    return;
  }
  double a = lo / d, b = hi / d;
  if (a > b) std::swap(a, b);
  s.t0 = std::max(s.t0, a);
  s.t1 = std::min(s.t1, b);
}

// The roots of a t^2 + 2 b t + c = 0 bound where the quadratic is <= 0 (a > 0): the inside of a
// sphere or an infinite cylinder. a == 0 (a ray along a cylinder's axis): inside everywhere or
// nowhere, as c says.
void clip_quadratic(double a, double b, double c, Span& s) {
  if (a <= 0.0) {
    if (c > 0.0) s.t0 = kNoHit, s.t1 = -kNoHit;
    return;
  }
  const double disc = b * b - a * c;
  if (disc < 0.0) {
    s.t0 = kNoHit, s.t1 = -kNoHit;
    return;
  }
  // The root of larger magnitude without cancellation, the other from the product of roots.
  const double q = -(b + std::copysign(std::sqrt(disc), b));
  double r0 = q / a, r1 = q != 0.0 ? c / q : 0.0;
  if (r0 > r1) std::swap(r0, r1);
  s.t0 = std::max(s.t0, r0);
  s.t1 = std::min(s.t1, r1);
}

double ray_sphere(const Vec3& center, double radius, const Vec3& o, const Vec3& d) {
  const Vec3 oc = o - center;
  Span s;
  clip_quadratic(d.squaredNorm(), d.dot(oc), oc.squaredNorm() - radius * radius, s);
  return s.entry();
}

// The capsule of radius r about the segment p0-p1: the union of the cylinder between the end
// planes and the two end spheres, so the entry is the earliest of the three entries.
double ray_capsule(const Vec3& p0, const Vec3& p1, double r, const Vec3& o, const Vec3& d) {
  const Vec3 axis = p1 - p0;
  const double len = axis.norm();
  const Vec3 u = axis / len;
  // Components across the axis.
  const Vec3 op = (o - p0) - u * u.dot(o - p0), dp = d - u * u.dot(d);
  Span side;
  clip_quadratic(dp.squaredNorm(), dp.dot(op), op.squaredNorm() - r * r, side);
  clip_slab(u.dot(o - p0), u.dot(d), 0.5 * len, 0.5 * len, side);
  return std::min({side.entry(), ray_sphere(p0, r, o, d), ray_sphere(p1, r, o, d)});
}

}  // namespace

double ray_obstacle_m(const Obstacle& ob, const Vec3& o, const Vec3& d) {
  const Vec3& c = ob.center_m;
  const Vec3& h = ob.half_size_m;
  switch (ob.shape) {
    case Obstacle::Shape::kBox: {
      Span s;
      for (int k = 0; k < 3; ++k) clip_slab(o[k], d[k], c[k], h[k], s);
      return s.entry();
    }
    case Obstacle::Shape::kCylinder: {
      Span s;
      clip_slab(o[2], d[2], c[2], h[2], s);
      const Eigen::Vector2d oc = o.head<2>() - c.head<2>(), dxy = d.head<2>();
      clip_quadratic(dxy.squaredNorm(), dxy.dot(oc), oc.squaredNorm() - h[0] * h[0], s);
      return s.entry();
    }
    case Obstacle::Shape::kSphere:
      return ray_sphere(c, h[0], o, d);
  }
  return kNoHit;
}

double ray_gate_frame_m(const Gate& g, const Vec3& o, const Vec3& d) {
  // Broad phase: the frame's bounding sphere.
  if (ray_sphere(g.center_m, g.bounding_radius_m(), o, d) == kNoHit) return kNoHit;
  const std::array<Vec3, 4> k = g.bar_corners();
  const double bar = 0.5 * g.frame_width_m;
  double best = kNoHit;
  for (std::size_t i = 0; i < 4; ++i)
    best = std::min(best, ray_capsule(k[i], k[(i + 1) % 4], bar, o, d));
  return best;
}

double ray_ground_m(const Vec3& o, const Vec3& d) {
  if (o[2] <= 0.0) return 0.0;
  return d[2] < 0.0 ? o[2] / -d[2] : kNoHit;
}

namespace {

void check_ray(const Vec3& o, const Vec3& d, const char* what, std::size_t index) {
  require(o.allFinite(), what, index, ": origin: expected finite x, y, z in m, got [",
          o.transpose(), "]");
  require(d.allFinite() && std::abs(d.norm() - 1.0) <= 1e-9, what, index,
          ": direction: expected a unit vector (length 1 to 1e-9), got [", d.transpose(),
          "] of length ", d.norm());
}

RayHit cast_unchecked(const Track& w, const Vec3& o, const Vec3& d, double max_range_m) {
  RayHit hit;
  const auto consider = [&](double t, RayHit::Kind kind, int index) {
    if (t <= max_range_m && t < hit.distance_m) {
      hit.distance_m = t;
      hit.kind = kind;
      hit.index = index;
    }
  };
  consider(ray_ground_m(o, d), RayHit::Kind::kGround, -1);
  for (std::size_t i = 0; i < w.obstacles.size(); ++i)
    consider(ray_obstacle_m(w.obstacles[i], o, d), RayHit::Kind::kObstacle, static_cast<int>(i));
  for (std::size_t i = 0; i < w.gates.size(); ++i)
    consider(ray_gate_frame_m(w.gates[i], o, d), RayHit::Kind::kGate, static_cast<int>(i));
  return hit;
}

void check_range(double max_range_m) {
  require(max_range_m > 0.0 && !std::isnan(max_range_m),
          "ray cast: max_range_m: expected a positive number of m, got ", max_range_m);
}

}  // namespace

RayHit cast_ray(const Track& world, const Vec3& origin_m, const Vec3& direction,
                double max_range_m) {
  check_range(max_range_m);
  check_ray(origin_m, direction, "ray cast: ray ", 0);
  return cast_unchecked(world, origin_m, direction, max_range_m);
}

void cast_rays(const Track& world, const double* origins_m, const double* directions,
               std::size_t count, double max_range_m, double* distance_m, RayHit::Kind* kind,
               int* index) {
  check_range(max_range_m);
  for (std::size_t i = 0; i < count; ++i)
    check_ray(Vec3(origins_m + 3 * i), Vec3(directions + 3 * i), "ray cast: ray ", i);
  for (std::size_t i = 0; i < count; ++i) {
    const RayHit h =
        cast_unchecked(world, Vec3(origins_m + 3 * i), Vec3(directions + 3 * i), max_range_m);
    distance_m[i] = h.distance_m;
    if (kind) kind[i] = h.kind;
    if (index) index[i] = h.index;
  }
}

}  // namespace dronetwin
