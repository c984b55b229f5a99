#pragma once
// Whether two convex shapes overlap, from their support functions alone (the
// Gilbert-Johnson-Keerthi test, IEEE J. Robotics and Automation 4(2), 1988): the shapes meet
// exactly when their Minkowski difference A - B holds the origin, and a simplex of support
// points of A - B either comes to enclose the origin or exposes a direction that separates them.
//
//   auto box = [&](const Vec3& d) { return c + R * d_sign(R.transpose() * d).cwiseProduct(h); };
//   auto ball = [&](const Vec3& d) { return p + r * d.normalized(); };
//   if (math::convex_overlap(box, ball, p - c)) ...
//
// A support function s(d) returns a point of the shape that lies furthest along d (any d != 0).
// Touching counts as overlapping. Used by world/collision.hpp for box-shaped vehicles.

#include <array>

#include "dronetwin/core/types.hpp"

namespace dronetwin::math {

namespace gjk_detail {

// The simplex: up to four support points of A - B, the newest last.
struct Simplex {
  std::array<Vec3, 4> p;
  int n = 0;
};

// Keeps the segment from `b` to `a` (A newest) and aims at the origin square to it: the part of
// A->O perpendicular to A->B, (ab x ao) x ab. True when that is zero: the origin is on the segment.
// Takes the points by value: callers pass the simplex's own points, which this overwrites.
inline bool keep_segment(Simplex& s, const Vec3 a, const Vec3 b, Vec3& d) {
  const Vec3 ab = b - a;
  d = ab.cross(Vec3(-a)).cross(ab);
  s.p[0] = b;
  s.p[1] = a;
  s.n = 2;
  return d.squaredNorm() == 0.0;
}

// The segment B-A (A newest): keep what is closest to the origin and aim at it. True when the
// origin lies on the segment.
inline bool line(Simplex& s, const Vec3& a, const Vec3& b, Vec3& d) {
  const Vec3 ab = b - a, ao = -a;
  if (ab.dot(ao) > 0.0) return keep_segment(s, a, b, d);
  s.p[0] = a;
  s.n = 1;
  d = ao;
  return d.squaredNorm() == 0.0;
}

// The triangle A, B, C (A newest): the feature (edge or face side) whose region holds the origin.
inline bool triangle(Simplex& s, const Vec3& a, const Vec3& b, const Vec3& c, Vec3& d) {
  const Vec3 ab = b - a, ac = c - a, ao = -a;
  const Vec3 n = ab.cross(ac);
  if (n.squaredNorm() == 0.0) return line(s, a, b, d);  // collinear: a segment's test
  if (n.cross(ac).dot(ao) > 0.0) {                      // beyond edge AC, on the side away from B
    if (ac.dot(ao) > 0.0) return keep_segment(s, a, c, d);
    return line(s, a, b, d);
  }
  if (ab.cross(n).dot(ao) > 0.0) return line(s, a, b, d);  // beyond edge AB, away from C
  s.p[0] = c;
  s.p[1] = b;
  s.p[2] = a;
  s.n = 3;
  const double side = n.dot(ao);
  d = side >= 0.0 ? n : Vec3(-n);
  return side == 0.0;  // the origin lies in the triangle
}

// The tetrahedron A, B, C, D (A newest; the origin cannot be beyond face BCD, which the last
// search direction pointed away from): a face that sees the origin, or the origin is inside.
inline bool tetrahedron(Simplex& s, const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& dd,
                        Vec3& d) {
  const Vec3 ao = -a;
  const std::array<std::array<Vec3, 3>, 3> faces = {{{b, c, dd}, {c, dd, b}, {dd, b, c}}};
  for (const auto& f : faces) {
    // Face A, f[0], f[1] with its normal turned away from the opposite vertex f[2].
    Vec3 n = (f[0] - a).cross(f[1] - a);
    if (n.dot(f[2] - a) > 0.0) n = -n;
    if (n.dot(ao) > 0.0) return triangle(s, a, f[0], f[1], d);
  }
  return true;
}

}  // namespace gjk_detail

/// True when the convex shapes with support functions `support_a` and `support_b` overlap or
/// touch. `initial_direction` is any non-zero guess (centre of A minus centre of B converges
/// fastest). Gives up after 64 iterations, which only a touching contact in exact arithmetic can
/// reach, and then reports an overlap.
template <class SupportA, class SupportB>
bool convex_overlap(const SupportA& support_a, const SupportB& support_b, Vec3 initial_direction) {
  using gjk_detail::Simplex;
  const auto support = [&](const Vec3& d) -> Vec3 { return support_a(d) - support_b(-d); };
  Vec3 d = initial_direction.squaredNorm() > 0.0 ? initial_direction : Vec3::UnitX();
  Simplex s;
  s.p[0] = support(d);
  s.n = 1;
  d = -s.p[0];
  for (int iteration = 0; iteration < 64; ++iteration) {
    if (d.squaredNorm() == 0.0) return true;  // the origin is a support point
    const Vec3 w = support(d);
    // Nothing of A - B reaches past the origin along d: d separates the shapes.
    if (w.dot(d) < 0.0) return false;
    bool contains = false;
    switch (s.n) {
      case 1:
        contains = gjk_detail::line(s, w, s.p[0], d);
        break;
      case 2:
        contains = gjk_detail::triangle(s, w, s.p[1], s.p[0], d);
        break;
      default:
        contains = gjk_detail::tetrahedron(s, w, s.p[2], s.p[1], s.p[0], d);
        break;
    }
    if (contains) return true;
  }
  return true;
}

}  // namespace dronetwin::math
