// Ray casting (world/ray_cast.hpp): distances to boxes, cylinders, spheres, gate frames and the
// ground against closed forms, and random rays against an independent computation: sphere
// tracing of each shape's exact distance field (march along the ray by the distance to the
// surface until it is below 1e-12 m).

#include "dronetwin/world/ray_cast.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/segment_distance.hpp"
#include "dronetwin/noise/random.hpp"
#include "world/distance_fields.hpp"

namespace dronetwin {
namespace {

Obstacle make(Obstacle::Shape shape, const Vec3& center, const Vec3& half) {
  Obstacle o;
  o.shape = shape;
  o.center_m = center;
  o.half_size_m = half;
  return o;
}

const Obstacle kBox = make(Obstacle::Shape::kBox, Vec3(0, 0, 1), Vec3(1, 0.5, 1));
const Obstacle kPillar = make(Obstacle::Shape::kCylinder, Vec3(0, 0, 2), Vec3(0.3, 0.3, 2));
const Obstacle kBall = make(Obstacle::Shape::kSphere, Vec3(1, 2, 3), Vec3(0.5, 0.5, 0.5));

// ---- closed forms ----------------------------------------------------------------------------

TEST(RayCast, BoxFacesInsideAndMisses) {
  // Along +x at the centre's height: the face x = -1 from x = -4.
  EXPECT_DOUBLE_EQ(ray_obstacle_m(kBox, Vec3(-4, 0, 1), Vec3(1, 0, 0)), 3.0);
  // Down onto the top face z = 2 from z = 7, off-centre but over the box.
  EXPECT_DOUBLE_EQ(ray_obstacle_m(kBox, Vec3(0.9, -0.4, 7), Vec3(0, 0, -1)), 5.0);
  // Inside: 0. Parallel to a face outside its slab, or pointing away: no hit.
  EXPECT_EQ(ray_obstacle_m(kBox, Vec3(0.2, 0.1, 0.5), Vec3(0, 1, 0)), 0.0);
  EXPECT_EQ(ray_obstacle_m(kBox, Vec3(-4, 0.6, 1), Vec3(1, 0, 0)), kNoHit);
  EXPECT_EQ(ray_obstacle_m(kBox, Vec3(-4, 0, 1), Vec3(-1, 0, 0)), kNoHit);
  // A diagonal ray onto the face y = -0.5 from (-2.5, -3.5, 1): 3 / cos 45 deg, at x = 0.5.
  const Vec3 d = Vec3(1, 1, 0).normalized();
  EXPECT_NEAR(ray_obstacle_m(kBox, Vec3(-2.5, -3.5, 1), d), 3.0 * std::sqrt(2.0), 1e-12);
}

TEST(RayCast, CylinderSideCapsAndAxis) {
  // Side: radius 0.3 from x = -2 at mid-height: 1.7.
  EXPECT_NEAR(ray_obstacle_m(kPillar, Vec3(-2, 0, 2), Vec3(1, 0, 0)), 1.7, 1e-15);
  // Off-axis by b: the chord starts at sqrt(R^2 - b^2) before the axis.
  EXPECT_NEAR(ray_obstacle_m(kPillar, Vec3(-2, 0.2, 2), Vec3(1, 0, 0)),
              2.0 - std::sqrt(0.09 - 0.04), 1e-15);
  // Along the axis from above: the top cap z = 4 from z = 6. Beside it, parallel: no hit.
  EXPECT_DOUBLE_EQ(ray_obstacle_m(kPillar, Vec3(0.1, 0.1, 6), Vec3(0, 0, -1)), 2.0);
  EXPECT_EQ(ray_obstacle_m(kPillar, Vec3(0.31, 0, 6), Vec3(0, 0, -1)), kNoHit);
  // Over the top: the ray at z = 4.01 passes.
  EXPECT_EQ(ray_obstacle_m(kPillar, Vec3(-2, 0, 4.01), Vec3(1, 0, 0)), kNoHit);
  EXPECT_EQ(ray_obstacle_m(kPillar, Vec3(0, 0, 1), Vec3(1, 0, 0)), 0.0);
}

TEST(RayCast, SphereAndGround) {
  // Aimed at the centre from 4 m: 4 - R.
  const Vec3 o = kBall.center_m - 4.0 * Vec3(2, -1, 2).normalized();
  EXPECT_NEAR(ray_obstacle_m(kBall, o, Vec3(2, -1, 2).normalized()), 3.5, 1e-14);
  // Passing b = 0.3 from the centre, whose foot is 4 m ahead: 4 - sqrt(R^2 - b^2).
  EXPECT_NEAR(ray_obstacle_m(kBall, Vec3(-3, 2.3, 3), Vec3(1, 0, 0)), 4.0 - std::sqrt(0.25 - 0.09),
              1e-14);
  EXPECT_EQ(ray_obstacle_m(kBall, Vec3(-3, 2.6, 3), Vec3(1, 0, 0)), kNoHit);
  // Ground: height / cos of the angle from straight down; upwards or level: no hit.
  const Vec3 down = Vec3(std::sin(0.3), 0, -std::cos(0.3));
  EXPECT_NEAR(ray_ground_m(Vec3(5, 5, 2), down), 2.0 / std::cos(0.3), 1e-14);
  EXPECT_EQ(ray_ground_m(Vec3(5, 5, 2), Vec3(1, 0, 0)), kNoHit);
  EXPECT_EQ(ray_ground_m(Vec3(5, 5, -0.1), Vec3(1, 0, 0)), 0.0);
}

TEST(RayCast, GateOpeningFramesAndBars) {
  // Gate at (4, 0, 1.5) facing +x, 1.5 x 1.5 opening, bars 0.1 thick.
  const Gate g = make_gate("g", Vec3(4, 0, 1.5), 0.0, 0.0, 0.0, 1.5, 1.5, 0.1);
  // Through the opening, even near an edge: no hit.
  EXPECT_EQ(ray_gate_frame_m(g, Vec3(0, 0, 1.5), Vec3(1, 0, 0)), kNoHit);
  EXPECT_EQ(ray_gate_frame_m(g, Vec3(0, 0.74, 2.24), Vec3(1, 0, 0)), kNoHit);
  // At the top bar's axis (z = 1.5 + 0.75 + 0.05): its front at x = 4 - 0.05.
  EXPECT_NEAR(ray_gate_frame_m(g, Vec3(0, 0.2, 2.3), Vec3(1, 0, 0)), 3.95, 1e-14);
  // Along the top bar's axis from beyond its end: the end cap of the corner, radius 0.05
  // about (4, -0.8, 2.3) approached from y = -3: 3 - 0.8 - 0.05.
  EXPECT_NEAR(ray_gate_frame_m(g, Vec3(4, -3, 2.3), Vec3(0, 1, 0)), 2.15, 1e-14);
  // A yawed gate: the same ray in the gate's own axes gives the same distance.
  const Gate r = make_gate("r", Vec3(1, 2, 1.5), 0.7, 0.0, 0.0, 1.5, 1.5, 0.1);
  const Vec3 o = r.center_m - 4.0 * r.normal() + 0.2 * r.width_axis() + 0.8 * r.up_axis();
  EXPECT_NEAR(ray_gate_frame_m(r, o, r.normal()), 3.95, 1e-13);
}

// ---- random rays against sphere tracing --------------------------------------------------------

using test::sdf_frame;
using test::sdf_obstacle;

// Sphere tracing: the first t where the field is below 1e-12, kNoHit past `range`; `ambiguous`
// when the march crept along a surface (closer than 1e-6) without settling, as at a tangent.
double trace(const std::function<double(const Vec3&)>& sdf, const Vec3& o, const Vec3& d,
             double range, bool& ambiguous) {
  ambiguous = false;
  double t = 0.0, closest = 1e300;
  for (int i = 0; i < 200000 && t <= range; ++i) {
    const double s = sdf(o + t * d);
    if (s < 1e-12) return t;
    closest = std::min(closest, s);
    t += s;
  }
  ambiguous = closest < 1e-6;
  return kNoHit;
}

Vec3 random_unit(Random& rng) {
  const Vec3 v(rng.normal(), rng.normal(), rng.normal());
  return v.normalized();
}

TEST(RayCast, RandomRaysAgreeWithSphereTracingOfTheDistanceFields) {
  Random rng(20261204);
  const Gate gate = make_gate("g", Vec3(0.5, -0.5, 2), 0.4, 0.2, -0.1, 1.2, 0.9, 0.15);
  struct Case {
    std::string name;
    std::function<double(const Vec3&)> sdf;
    std::function<double(const Vec3&, const Vec3&)> cast;
    Vec3 near;  // half the rays aim within 1 m of it
  };
  const std::vector<Case> cases = {
      {"box", [](const Vec3& p) { return sdf_obstacle(kBox, p); },
       [](const Vec3& o, const Vec3& d) { return ray_obstacle_m(kBox, o, d); }, kBox.center_m},
      {"cylinder", [](const Vec3& p) { return sdf_obstacle(kPillar, p); },
       [](const Vec3& o, const Vec3& d) { return ray_obstacle_m(kPillar, o, d); },
       kPillar.center_m},
      {"sphere", [](const Vec3& p) { return sdf_obstacle(kBall, p); },
       [](const Vec3& o, const Vec3& d) { return ray_obstacle_m(kBall, o, d); }, kBall.center_m},
      {"gate frame", [&](const Vec3& p) { return sdf_frame(gate, p); },
       [&](const Vec3& o, const Vec3& d) { return ray_gate_frame_m(gate, o, d); }, gate.center_m},
  };
  for (const Case& c : cases) {
    int hits = 0, misses = 0, inside = 0, checked = 0;
    for (int i = 0; i < 4000; ++i) {
      // Origins around the shapes; half the rays aimed near the shape so that many hit.
      const Vec3 o(rng.uniform() * 8 - 4, rng.uniform() * 8 - 4, rng.uniform() * 6);
      const Vec3 target =
          c.near + Vec3(rng.uniform() * 2 - 1, rng.uniform() * 2 - 1, rng.uniform() * 2 - 1);
      const Vec3 d = i % 2 ? random_unit(rng) : (target - o).normalized();
      const double got = c.cast(o, d);
      if (c.sdf(o) <= 0.0) {
        EXPECT_EQ(got, 0.0) << c.name << " from inside at " << o.transpose();
        ++inside;
        continue;
      }
      bool ambiguous = false;
      const double expected = trace(c.sdf, o, d, 20.0, ambiguous);
      if (ambiguous) continue;
      ++checked;
      if (expected == kNoHit) {
        EXPECT_TRUE(got == kNoHit || got > 20.0)
            << c.name << ": hit at " << got << " where tracing found nothing, from "
            << o.transpose() << " along " << d.transpose();
        ++misses;
      } else {
        EXPECT_NEAR(got, expected, 1e-9)
            << c.name << " from " << o.transpose() << " along " << d.transpose();
        ++hits;
      }
    }
    // The sample means something: many hits, many misses, few rays left undecided.
    EXPECT_GT(hits, 200) << c.name;
    EXPECT_GT(misses, 200) << c.name;
    EXPECT_GT(checked + inside, 3900) << c.name;
  }
}

// ---- the world ---------------------------------------------------------------------------------

Track world() {
  Track t;
  t.obstacles = {kBox, kPillar, kBall};
  t.obstacles[1].center_m = Vec3(5, 0, 2);
  t.gates = {make_gate("g", Vec3(-4, 0, 1.5), 0.0, 0.0, 0.0, 1.5, 1.5, 0.1)};
  return t;
}

TEST(RayCast, TheNearestThingInRangeIsReported) {
  const Track w = world();
  // Along +x at z = 1 from x = -2: the box's face at x = -1 before the pillar at x = 4.7.
  RayHit h = cast_ray(w, Vec3(-2, 0, 1), Vec3(1, 0, 0), 100.0);
  EXPECT_EQ(h.kind, RayHit::Kind::kObstacle);
  EXPECT_EQ(h.index, 0);
  EXPECT_DOUBLE_EQ(h.distance_m, 1.0);
  // Beyond the range: nothing.
  h = cast_ray(w, Vec3(-2, 0, 1), Vec3(1, 0, 0), 0.5);
  EXPECT_EQ(h.kind, RayHit::Kind::kNone);
  EXPECT_EQ(h.distance_m, kNoHit);
  // From above the pillar: its top before the ground.
  h = cast_ray(w, Vec3(5, 0, 9), Vec3(0, 0, -1), 100.0);
  EXPECT_EQ(h.kind, RayHit::Kind::kObstacle);
  EXPECT_EQ(h.index, 1);
  EXPECT_DOUBLE_EQ(h.distance_m, 5.0);
  // Down in the open: the ground.
  h = cast_ray(w, Vec3(2, 3, 1.5), Vec3(0, 0, -1), 100.0);
  EXPECT_EQ(h.kind, RayHit::Kind::kGround);
  EXPECT_DOUBLE_EQ(h.distance_m, 1.5);
  // Into the gate's bottom bar (axis at z = 1.5 - 0.8 = 0.7) from behind.
  h = cast_ray(w, Vec3(-8, 0.3, 0.7), Vec3(1, 0, 0), 100.0);
  EXPECT_EQ(h.kind, RayHit::Kind::kGate);
  EXPECT_EQ(h.index, 0);
  EXPECT_NEAR(h.distance_m, 3.95, 1e-14);
}

TEST(RayCast, ManyRaysEqualOneAtATime) {
  const Track w = world();
  Random rng(7);
  const std::size_t n = 500;
  std::vector<double> origins(3 * n), directions(3 * n), distance(n);
  std::vector<RayHit::Kind> kind(n);
  std::vector<int> index(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 o(rng.uniform() * 10 - 5, rng.uniform() * 6 - 3, rng.uniform() * 4);
    const Vec3 d = random_unit(rng);
    for (int k = 0; k < 3; ++k) {
      origins[3 * i + k] = o[k];
      directions[3 * i + k] = d[k];
    }
  }
  cast_rays(w, origins.data(), directions.data(), n, 30.0, distance.data(), kind.data(),
            index.data());
  for (std::size_t i = 0; i < n; ++i) {
    const RayHit h = cast_ray(w, Vec3(&origins[3 * i]), Vec3(&directions[3 * i]), 30.0);
    EXPECT_EQ(distance[i], h.distance_m) << i;
    EXPECT_EQ(kind[i], h.kind) << i;
    EXPECT_EQ(index[i], h.index) << i;
  }
}

TEST(RayCast, BadRaysAreNamed) {
  const Track w = world();
  const auto message = [&](const std::function<void()>& f) {
    try {
      f();
    } catch (const InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message([&] {
              cast_ray(w, Vec3(0, 0, 1), Vec3(1, 1, 0), 10.0);
            }).find("direction: expected a unit vector"),
            std::string::npos);
  EXPECT_NE(message([&] {
              cast_ray(w, Vec3(0, NAN, 1), Vec3(1, 0, 0), 10.0);
            }).find("origin: expected finite"),
            std::string::npos);
  EXPECT_NE(message([&] {
              cast_ray(w, Vec3(0, 0, 1), Vec3(1, 0, 0), 0.0);
            }).find("max_range_m: expected a positive number"),
            std::string::npos);
  EXPECT_NE(message([&] { cast_ray(w, Vec3(0, 0, 1), Vec3(1, 0, 0), NAN); }).find("max_range_m"),
            std::string::npos);
  // In a batch, the ray's index; nothing is written before the check.
  const double origins[6] = {0, 0, 1, 0, 0, 1};
  const double directions[6] = {1, 0, 0, 0, 0, 2};
  double distance[2] = {-1, -1};
  EXPECT_NE(message([&] {
              cast_rays(w, origins, directions, 2, 10.0, distance);
            }).find("ray 1: direction"),
            std::string::npos);
  EXPECT_EQ(distance[0], -1.0);
}

}  // namespace
}  // namespace dronetwin
