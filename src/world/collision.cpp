#include "dronetwin/world/collision.hpp"

#include <algorithm>
#include <cmath>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/convex_overlap.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/math/segment_distance.hpp"

namespace dronetwin {

namespace {

// Support functions: the point of a shape furthest along d.
Vec3 box_support(const Vec3& c, const Mat3& R, const Vec3& h, const Vec3& d) {
  const Vec3 local = R.transpose() * d;
  Vec3 corner;
  for (int k = 0; k < 3; ++k) corner[k] = local[k] >= 0.0 ? h[k] : -h[k];
  return c + R * corner;
}

Vec3 ball_support(const Vec3& c, double r, const Vec3& d) {
  const double n = d.norm();
  return n > 0.0 ? Vec3(c + (r / n) * d) : c;
}

Vec3 segment_ball_support(const Vec3& a, const Vec3& b, double r, const Vec3& d) {
  return ball_support(d.dot(b - a) > 0.0 ? b : a, r, d);
}

// A vertical cylinder: centre c, radius r, half height h.
Vec3 cylinder_support(const Vec3& c, double r, double h, const Vec3& d) {
  Vec3 p = c;
  p.z() += d.z() >= 0.0 ? h : -h;
  const double horizontal = std::hypot(d.x(), d.y());
  if (horizontal > 0.0) {
    p.x() += r * d.x() / horizontal;
    p.y() += r * d.y() / horizontal;
  }
  return p;
}

// Distance over which nothing of the scene thing can be touched: its bounding radius.
double obstacle_bounding_radius_m(const Obstacle& o) {
  return o.shape == Obstacle::Shape::kCylinder ? std::hypot(o.half_size_m[0], o.half_size_m[2])
                                               : o.half_size_m.norm();
}

Vec4 nlerp(const Vec4& q0, const Vec4& q1, double t) {
  // The shorter way round: q and -q are the same attitude.
  const Vec4 q1_near = q0.dot(q1) >= 0.0 ? q1 : Vec4(-q1);
  return ((1.0 - t) * q0 + t * q1_near).normalized();
}

// Angle between two attitudes, rad.
double rotation_angle(const Vec4& q0, const Vec4& q1) {
  const double c = std::min(1.0, std::abs(q0.normalized().dot(q1.normalized())));
  return 2.0 * std::acos(c);
}

SceneContact sphere_contact(const Track& scene, const CollisionShape& shape, const Vec3& p0,
                            const Vec4& q0, const Vec3& p1, const Vec4& q1) {
  const Vec3 c0 = p0 + math::rotation_matrix<double>(q0) * shape.center_B_m;
  const Vec3 c1 = p1 + math::rotation_matrix<double>(q1) * shape.center_B_m;
  for (std::size_t i = 0; i < scene.gates.size(); ++i)
    if (touches_frame(scene.gates[i], c0, c1, shape.radius_m))
      return {SceneContact::Kind::kGate, static_cast<int>(i)};
  for (std::size_t i = 0; i < scene.obstacles.size(); ++i)
    if (touches_obstacle(scene.obstacles[i], c0, c1, shape.radius_m))
      return {SceneContact::Kind::kObstacle, static_cast<int>(i)};
  return {};
}

SceneContact box_contact(const Track& scene, const CollisionShape& shape, const Vec3& p0,
                         const Vec4& q0, const Vec3& p1, const Vec4& q1) {
  const Mat3 R0 = math::rotation_matrix<double>(q0), R1 = math::rotation_matrix<double>(q1);
  const Vec3 c0 = p0 + R0 * shape.center_B_m, c1 = p1 + R1 * shape.center_B_m;
  const double reach_m = shape.bounding_radius_m();
  // No point of the box moves further than this over the step.
  const double motion_m = (p1 - p0).norm() + rotation_angle(q0, q1) * reach_m;
  const int poses =
      1 + static_cast<int>(std::min(1e4, std::ceil(motion_m / kBoxSweepResolution_m)));
  const double box_radius_m = shape.half_size_m.norm();
  // Only what the box's swept bounding sphere reaches needs the overlap test.
  const auto near = [&](const Vec3& center, double radius_m) {
    return math::point_segment_distance(center, c0, c1) <= radius_m + box_radius_m + motion_m;
  };
  for (int k = 0; k < poses; ++k) {
    const double t = poses == 1 ? 1.0 : static_cast<double>(k) / static_cast<double>(poses - 1);
    const Vec4 q = nlerp(q0, q1, t);
    const Mat3 R = math::rotation_matrix<double>(q);
    const Vec3 c = (1.0 - t) * p0 + t * p1 + R * shape.center_B_m;
    for (std::size_t i = 0; i < scene.gates.size(); ++i) {
      const Gate& g = scene.gates[i];
      if (near(g.center_m, g.bounding_radius_m()) &&
          box_overlaps_gate_frame(c, R, shape.half_size_m, g))
        return {SceneContact::Kind::kGate, static_cast<int>(i)};
    }
    for (std::size_t i = 0; i < scene.obstacles.size(); ++i) {
      const Obstacle& o = scene.obstacles[i];
      if (near(o.center_m, obstacle_bounding_radius_m(o)) &&
          box_overlaps_obstacle(c, R, shape.half_size_m, o))
        return {SceneContact::Kind::kObstacle, static_cast<int>(i)};
    }
  }
  return {};
}

}  // namespace

bool box_overlaps_obstacle(const Vec3& center_m, const Mat3& R, const Vec3& half_size_m,
                           const Obstacle& o) {
  const auto box = [&](const Vec3& d) { return box_support(center_m, R, half_size_m, d); };
  const Vec3 guess = center_m - o.center_m;
  switch (o.shape) {
    case Obstacle::Shape::kBox:
      return math::convex_overlap(
          box,
          [&](const Vec3& d) {
            return box_support(o.center_m, Mat3::Identity(), o.half_size_m, d);
          },
          guess);
    case Obstacle::Shape::kCylinder:
      return math::convex_overlap(
          box,
          [&](const Vec3& d) {
            return cylinder_support(o.center_m, o.half_size_m[0], o.half_size_m[2], d);
          },
          guess);
    case Obstacle::Shape::kSphere:
      return math::convex_overlap(
          box, [&](const Vec3& d) { return ball_support(o.center_m, o.half_size_m[0], d); }, guess);
  }
  return false;
}

bool box_overlaps_gate_frame(const Vec3& center_m, const Mat3& R, const Vec3& half_size_m,
                             const Gate& gate) {
  const auto box = [&](const Vec3& d) { return box_support(center_m, R, half_size_m, d); };
  const std::array<Vec3, 4> corners = gate.bar_corners();
  const double bar_radius_m = 0.5 * gate.frame_width_m;
  for (std::size_t i = 0; i < corners.size(); ++i) {
    const Vec3& a = corners[i];
    const Vec3& b = corners[(i + 1) % corners.size()];
    const auto bar = [&](const Vec3& d) { return segment_ball_support(a, b, bar_radius_m, d); };
    if (math::convex_overlap(box, bar, center_m - 0.5 * (a + b))) return true;
  }
  return false;
}

SceneContact find_scene_contact(const Track& scene, const CollisionShape& shape, const Vec3& p0_m,
                                const Vec4& q0, const Vec3& p1_m, const Vec4& q1) {
  return shape.kind == CollisionShape::Kind::kSphere
             ? sphere_contact(scene, shape, p0_m, q0, p1_m, q1)
             : box_contact(scene, shape, p0_m, q0, p1_m, q1);
}

SceneContact find_scene_contact(const Track& scene, const CollisionShape& shape,
                                const StateVector& before, const StateVector& after) {
  using namespace state_index;
  return find_scene_contact(scene, shape, before.segment<3>(kPosition),
                            before.segment<4>(kQuaternion), after.segment<3>(kPosition),
                            after.segment<4>(kQuaternion));
}

std::string describe_contact(const Track& scene, const SceneContact& contact) {
  const auto i = static_cast<std::size_t>(contact.index);
  switch (contact.kind) {
    case SceneContact::Kind::kNone:
      return "nothing";
    case SceneContact::Kind::kGate:
      return detail::concat("the frame of gate '", scene.gates.at(i).name, "'");
    case SceneContact::Kind::kObstacle: {
      const Obstacle& o = scene.obstacles.at(i);
      const char* shape = o.shape == Obstacle::Shape::kBox        ? "box"
                          : o.shape == Obstacle::Shape::kCylinder ? "cylinder"
                                                                  : "sphere";
      return detail::concat("obstacle '", o.name, "' (", shape, ")");
    }
  }
  return "nothing";
}

}  // namespace dronetwin
