// Obstacle touch tests (world/obstacle.hpp): faces exact, corners conservative, never a miss.

#include "dronetwin/world/obstacle.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "dronetwin/noise/random.hpp"

namespace dronetwin {
namespace {

Obstacle box() {
  Obstacle o;
  o.center_m = Vec3(0, 0, 1);
  o.half_size_m = Vec3(1, 0.5, 1);
  return o;
}

Obstacle pillar() {
  Obstacle o;
  o.shape = Obstacle::Shape::kCylinder;
  o.center_m = Vec3(0, 0, 2);
  o.half_size_m = Vec3(0.3, 0.3, 2);
  return o;
}

TEST(Obstacle, BoxFacesAreExact) {
  const Obstacle o = box();
  // Passing 0.2 above the top face (z = 2) with radius 0.19 / 0.21.
  EXPECT_FALSE(touches_obstacle(o, Vec3(-3, 0, 2.2), Vec3(3, 0, 2.2), 0.19));
  EXPECT_TRUE(touches_obstacle(o, Vec3(-3, 0, 2.2), Vec3(3, 0, 2.2), 0.21));
  // Through it, and a segment ending before it.
  EXPECT_TRUE(touches_obstacle(o, Vec3(-3, 0, 1), Vec3(3, 0, 1), 0.0));
  EXPECT_FALSE(touches_obstacle(o, Vec3(-3, 0, 1), Vec3(-1.5, 0, 1), 0.3));
  EXPECT_TRUE(touches_obstacle(o, Vec3(-3, 0, 1), Vec3(-1.5, 0, 1), 0.51));
}

TEST(Obstacle, SpheresAreExact) {
  Obstacle o;
  o.shape = Obstacle::Shape::kSphere;
  o.center_m = Vec3(1, 2, 3);
  o.half_size_m = Vec3(0.5, 0.5, 0.5);
  // A segment passing 0.7 from the centre touches a vehicle sphere of radius 0.21, not 0.19.
  EXPECT_FALSE(touches_obstacle(o, Vec3(-3, 2.7, 3), Vec3(3, 2.7, 3), 0.19));
  EXPECT_TRUE(touches_obstacle(o, Vec3(-3, 2.7, 3), Vec3(3, 2.7, 3), 0.21));
  // A segment ending 1 m short of the surface along the line to the centre.
  EXPECT_FALSE(touches_obstacle(o, Vec3(-3, 2, 3), Vec3(-0.5, 2, 3), 0.99));
  EXPECT_TRUE(touches_obstacle(o, Vec3(-3, 2, 3), Vec3(-0.5, 2, 3), 1.01));
}

TEST(Obstacle, CylinderSidesAreExact) {
  const Obstacle o = pillar();
  // A horizontal pass at 0.5 from the axis: 0.2 from the surface.
  EXPECT_FALSE(touches_obstacle(o, Vec3(-2, 0.5, 1), Vec3(2, 0.5, 1), 0.19));
  EXPECT_TRUE(touches_obstacle(o, Vec3(-2, 0.5, 1), Vec3(2, 0.5, 1), 0.21));
  // Over the top (z = 4) by 0.3.
  EXPECT_FALSE(touches_obstacle(o, Vec3(-2, 0, 4.3), Vec3(2, 0, 4.3), 0.29));
  EXPECT_TRUE(touches_obstacle(o, Vec3(-2, 0, 4.3), Vec3(2, 0, 4.3), 0.31));
}

// Never a miss: whenever a sampled point of the path is within r of the shape, the test says
// touch; and it says touch only within the documented slack.
TEST(Obstacle, NeverMissesATouchAgainstSampling) {
  Random rng(3);
  for (const Obstacle& o : {box(), pillar()}) {
    for (int trial = 0; trial < 2000; ++trial) {
      const Vec3 a(4 * rng.normal(), 4 * rng.normal(), 2 + 2 * rng.normal());
      const Vec3 b = a + Vec3(3 * rng.normal(), 3 * rng.normal(), 3 * rng.normal());
      const double r = 0.3 * rng.uniform();
      double nearest = 1e9;
      for (int i = 0; i <= 400; ++i) {
        const Vec3 p = a + (b - a) * (i / 400.0) - o.center_m;
        double d;
        if (o.shape == Obstacle::Shape::kBox) {
          d = (p.cwiseAbs() - o.half_size_m).cwiseMax(0.0).norm();
        } else {
          const double radial = std::max(0.0, p.head<2>().norm() - o.half_size_m[0]);
          const double axial = std::max(0.0, std::abs(p[2]) - o.half_size_m[2]);
          d = std::hypot(radial, axial);
        }
        nearest = std::min(nearest, d);
      }
      const bool touch = touches_obstacle(o, a, b, r);
      if (nearest < r) {
        EXPECT_TRUE(touch) << trial;
      }
      // Slack: sqrt(3) r at box corners (sqrt(2) at a cylinder's rim), plus the sampling step.
      if (touch) {
        EXPECT_LT(nearest, std::sqrt(3.0) * r + (b - a).norm() / 400 + 1e-9) << trial;
      }
    }
  }
}

}  // namespace
}  // namespace dronetwin
