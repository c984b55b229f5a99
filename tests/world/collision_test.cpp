// Scene contact (world/collision.hpp): the sphere's swept test and the box's overlap test
// (math/convex_overlap.hpp) against closed forms, and random boxes against an independent
// computation: the smallest value of a shape's exact distance field over the box (a convex
// function of the box's local coordinates, minimised by nested ternary searches) is <= 0
// exactly when they overlap.

#include "dronetwin/world/collision.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <string>

#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/noise/random.hpp"
#include "world/distance_fields.hpp"

namespace dronetwin {
namespace {

Obstacle make(std::string name, Obstacle::Shape shape, const Vec3& center, const Vec3& half) {
  Obstacle o;
  o.name = std::move(name);
  o.shape = shape;
  o.center_m = center;
  o.half_size_m = half;
  return o;
}

const Vec4 kLevel(1.0, 0.0, 0.0, 0.0);

// Smallest value of the convex function f over [-1, 1], by golden-section search (to ~1e-7).
double minimise_1d(const std::function<double(double)>& f) {
  const double r = 0.5 * (std::sqrt(5.0) - 1.0);
  double lo = -1.0, hi = 1.0;
  double a = hi - r * (hi - lo), b = lo + r * (hi - lo);
  double fa = f(a), fb = f(b);
  for (int i = 0; i < 34; ++i) {
    if (fa <= fb) {
      hi = b;
      b = a;
      fb = fa;
      a = hi - r * (hi - lo);
      fa = f(a);
    } else {
      lo = a;
      a = b;
      fa = fb;
      b = lo + r * (hi - lo);
      fb = f(b);
    }
  }
  return std::min(fa, fb);
}

// min over the box c + R (u o h), u in [-1, 1]^3, of the distance field `sdf`: partial minima
// of a jointly convex function stay convex, so three nested searches find it.
double min_over_box(const Vec3& c, const Mat3& R, const Vec3& h,
                    const std::function<double(const Vec3&)>& sdf) {
  return minimise_1d([&](double x) {
    return minimise_1d([&](double y) {
      return minimise_1d([&](double z) { return sdf(c + R * Vec3(x * h[0], y * h[1], z * h[2])); });
    });
  });
}

Vec4 random_attitude(Random& rng) {
  return Vec4(rng.normal(), rng.normal(), rng.normal(), rng.normal()).normalized();
}

TEST(SceneContact, RandomBoxesAgreeWithTheMinimumOfEachShapesDistanceField) {
  Random rng(20261204);
  const Obstacle box = make("box", Obstacle::Shape::kBox, Vec3(0, 0, 1), Vec3(0.5, 0.3, 1.0));
  const Obstacle pillar =
      make("pillar", Obstacle::Shape::kCylinder, Vec3(0, 0, 1), Vec3(0.4, 0.4, 1.0));
  const Obstacle ball = make("ball", Obstacle::Shape::kSphere, Vec3(0, 0, 1), Vec3(0.6, 0.6, 0.6));
  const Gate gate = make_gate("g", Vec3(0, 0, 1), 0.4, 0.2, -0.1, 1.2, 0.9, 0.15);
  int overlaps = 0, apart = 0, ambiguous = 0;
  for (int i = 0; i < 150; ++i) {
    const Vec3 c(rng.uniform() * 2.4 - 1.2, rng.uniform() * 2.4 - 1.2,
                 1 + rng.uniform() * 2.4 - 1.2);
    const Mat3 R = math::rotation_matrix<double>(random_attitude(rng));
    const Vec3 h(0.05 + 0.4 * rng.uniform(), 0.05 + 0.4 * rng.uniform(),
                 0.02 + 0.2 * rng.uniform());
    for (const Obstacle* o : {&box, &pillar, &ball}) {
      const double d =
          min_over_box(c, R, h, [&](const Vec3& p) { return test::sdf_obstacle(*o, p); });
      if (std::abs(d) < 1e-4) {
        ++ambiguous;
        continue;
      }
      EXPECT_EQ(box_overlaps_obstacle(c, R, h, *o), d < 0.0)
          << o->name << " case " << i << ": smallest distance " << d;
      ++(d < 0.0 ? overlaps : apart);
    }
    // The frame overlaps when any bar does; each bar is convex.
    double d = 1e300;
    for (int bar = 0; bar < 4; ++bar)
      d = std::min(
          d, min_over_box(c, R, h, [&](const Vec3& p) { return test::sdf_bar(gate, bar, p); }));
    if (std::abs(d) < 1e-4) {
      ++ambiguous;
      continue;
    }
    EXPECT_EQ(box_overlaps_gate_frame(c, R, h, gate), d < 0.0)
        << "frame case " << i << ": smallest distance " << d;
    ++(d < 0.0 ? overlaps : apart);
  }
  // Both answers are well represented, and boundary cases rare.
  EXPECT_GT(overlaps, 100);
  EXPECT_GT(apart, 100);
  EXPECT_LT(ambiguous, 5);
}

TEST(SceneContact, ABoxPassesAPillarAtAMillimetreAndTouchesItAtMinusOne) {
  // A level box (half width 0.1 m in y) flies along +x past a pillar of radius 0.3 m whose axis
  // is at y = 0.1 + 0.3 + gap: it touches exactly when the gap is negative.
  const CollisionShape shape = CollisionShape::box(Vec3(0.2, 0.1, 0.05));
  for (double gap : {0.001, -0.001}) {
    Track scene;
    scene.obstacles.push_back(
        make("pillar", Obstacle::Shape::kCylinder, Vec3(1.0, 0.4 + gap, 1.0), Vec3(0.3, 0.3, 1.0)));
    const SceneContact c =
        find_scene_contact(scene, shape, Vec3(0, 0, 1), kLevel, Vec3(2, 0, 1), kLevel);
    EXPECT_EQ(static_cast<bool>(c), gap < 0.0) << "gap " << gap;
  }
}

TEST(SceneContact, AFastBoxCannotTunnelThroughAThinWall) {
  // 1 m in one step through a 2 cm wall: the poses tested are at most 1 cm apart.
  Track scene;
  scene.obstacles.push_back(
      make("wall", Obstacle::Shape::kBox, Vec3(0.5, 0, 1), Vec3(0.01, 2.0, 2.0)));
  const CollisionShape shape = CollisionShape::box(Vec3(0.004, 0.1, 0.05));
  const SceneContact c =
      find_scene_contact(scene, shape, Vec3(0, 0, 1), kLevel, Vec3(1, 0, 1), kLevel);
  ASSERT_TRUE(c);
  EXPECT_EQ(c.kind, SceneContact::Kind::kObstacle);
  EXPECT_EQ(describe_contact(scene, c), "obstacle 'wall' (box)");
}

TEST(SceneContact, ALongBoxPassesAGateLengthwaysButNotSideways) {
  // Opening 1.5 m x 1.5 m; a box 1.6 m long and 0.4 m wide fits through only along its length.
  Track scene;
  scene.gates.push_back(make_gate("g1", Vec3(2, 0, 1.5), 0, 0, 0, 1.5, 1.5, 0.1));
  const CollisionShape shape = CollisionShape::box(Vec3(0.8, 0.2, 0.05));
  const Vec4 sideways = math::from_euler(0, 0, std::numbers::pi / 2);
  EXPECT_FALSE(find_scene_contact(scene, shape, Vec3(0, 0, 1.5), kLevel, Vec3(4, 0, 1.5), kLevel));
  const SceneContact c =
      find_scene_contact(scene, shape, Vec3(0, 0, 1.5), sideways, Vec3(4, 0, 1.5), sideways);
  ASSERT_TRUE(c);
  EXPECT_EQ(c.kind, SceneContact::Kind::kGate);
  EXPECT_EQ(describe_contact(scene, c), "the frame of gate 'g1'");
}

TEST(SceneContact, ASphereSitsAtItsBodyFrameCentre) {
  // A sphere 1 m ahead of the body along body x: turning the body by 90 degrees of yaw carries
  // it onto a ball at (0, 1, 1).
  Track scene;
  scene.obstacles.push_back(
      make("ball", Obstacle::Shape::kSphere, Vec3(0, 1, 1), Vec3::Constant(0.2)));
  const CollisionShape shape = CollisionShape::sphere(0.1, Vec3(1, 0, 0));
  const Vec4 yawed = math::from_euler(0, 0, std::numbers::pi / 2);
  const Vec3 p(0, 0, 1);
  EXPECT_FALSE(find_scene_contact(scene, shape, p, kLevel, p, kLevel));
  EXPECT_TRUE(find_scene_contact(scene, shape, p, yawed, p, yawed));
  // The swept sphere is exact: passing the ball at 0.31 m misses, at 0.29 m touches.
  const CollisionShape centred = CollisionShape::sphere(0.1);
  EXPECT_FALSE(
      find_scene_contact(scene, centred, Vec3(-1, 1.31, 1), kLevel, Vec3(1, 1.31, 1), kLevel));
  EXPECT_TRUE(
      find_scene_contact(scene, centred, Vec3(-1, 1.29, 1), kLevel, Vec3(1, 1.29, 1), kLevel));
}

TEST(SceneContact, GatesAreCheckedBeforeObstaclesAndNothingIsDescribed) {
  Track scene;
  scene.obstacles.push_back(
      make("ball", Obstacle::Shape::kSphere, Vec3(2, 0.8, 1.5), Vec3::Constant(0.2)));
  scene.gates.push_back(make_gate("g1", Vec3(2, 0, 1.5), 0, 0, 0, 1.5, 1.5, 0.1));
  const SceneContact c = find_scene_contact(scene, CollisionShape::sphere(0.1), Vec3(2, 0.8, 1.5),
                                            kLevel, Vec3(2, 0.8, 1.5), kLevel);
  EXPECT_EQ(c.kind, SceneContact::Kind::kGate);
  EXPECT_EQ(describe_contact(scene, SceneContact{}), "nothing");
}

}  // namespace
}  // namespace dronetwin
