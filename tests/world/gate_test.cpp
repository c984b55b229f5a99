// Gate passage and frame collision (world/gate.hpp) against geometry worked out by hand, and the
// segment distances (math/segment_distance.hpp) against dense sampling.

#include "dronetwin/world/gate.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/segment_distance.hpp"
#include "dronetwin/noise/random.hpp"

namespace dronetwin {
namespace {

// 1.5 m x 1.0 m opening at (4, 0, 2), passing along +x, 0.1 m bars.
Gate straight_gate() { return make_gate("g", Vec3(4, 0, 2), 0, 0, 0, 1.5, 1.0, 0.1); }

TEST(Gate, CornersAndAxesOfAYawedGate) {
  const Gate g = make_gate("g", Vec3(1, 2, 3), M_PI / 2, 0, 0, 2.0, 1.0, 0.1);
  // Yaw 90 deg: passage +y, width axis -x, up +z.
  EXPECT_NEAR((g.normal() - Vec3(0, 1, 0)).norm(), 0.0, 1e-15);
  EXPECT_NEAR((g.width_axis() - Vec3(-1, 0, 0)).norm(), 0.0, 1e-15);
  const auto c = g.corners();
  EXPECT_NEAR((c[0] - Vec3(0, 2, 3.5)).norm(), 0.0, 1e-15);  // (+y, +z): x = 1 - 1
  EXPECT_NEAR((c[2] - Vec3(2, 2, 2.5)).norm(), 0.0, 1e-15);  // (-y, -z)
}

TEST(Gate, ThroughTheCentreBesideBackwardsAndOnTheEdge) {
  const Gate g = straight_gate();
  EXPECT_EQ(cross_gate(g, Vec3(3, 0, 2), Vec3(5, 0, 2)), GateCrossing::kThrough);
  EXPECT_EQ(cross_gate(g, Vec3(5, 0, 2), Vec3(3, 0, 2)), GateCrossing::kBackwards);
  // Beside the opening (y = 1 > 0.75) and above it (z = 2.6 > 2.5).
  EXPECT_EQ(cross_gate(g, Vec3(3, 1.0, 2), Vec3(5, 1.0, 2)), GateCrossing::kNone);
  EXPECT_EQ(cross_gate(g, Vec3(3, 0, 2.6), Vec3(5, 0, 2.6)), GateCrossing::kNone);
  // Exactly on the edge is not strictly inside.
  EXPECT_EQ(cross_gate(g, Vec3(3, 0.75, 2), Vec3(5, 0.75, 2)), GateCrossing::kNone);
  EXPECT_EQ(cross_gate(g, Vec3(3, 0.7499, 2), Vec3(5, 0.7499, 2)), GateCrossing::kThrough);
  // Not reaching the plane, parallel to it, a point.
  EXPECT_EQ(cross_gate(g, Vec3(3, 0, 2), Vec3(3.9, 0, 2)), GateCrossing::kNone);
  EXPECT_EQ(cross_gate(g, Vec3(3, -1, 2), Vec3(3, 1, 2)), GateCrossing::kNone);
  EXPECT_EQ(cross_gate(g, Vec3(4, 0, 2), Vec3(4, 0, 2)), GateCrossing::kNone);
  // Ending exactly on the plane counts (on or in front); starting on it does not.
  EXPECT_EQ(cross_gate(g, Vec3(3, 0, 2), Vec3(4, 0, 2)), GateCrossing::kThrough);
  EXPECT_EQ(cross_gate(g, Vec3(4, 0, 2), Vec3(5, 0, 2)), GateCrossing::kNone);
}

TEST(Gate, AStepThatJumpsOverThePlaneStillCounts) {
  const Gate g = straight_gate();
  // 10 m in one step, crossing at y = 0.5 (inside), diagonal.
  EXPECT_EQ(cross_gate(g, Vec3(-1, 0, 2), Vec3(9, 1.0, 2)), GateCrossing::kThrough);
  // The same jump crossing at y = 1.0 (outside).
  EXPECT_EQ(cross_gate(g, Vec3(-1, 0.5, 2), Vec3(9, 1.5, 2)), GateCrossing::kNone);
}

TEST(Gate, APitchedGateUsesItsOwnPlane) {
  // Pitched 90 deg: the passage direction is Ry(90) e_x = -z (flown downwards).
  const Gate g = make_gate("g", Vec3(0, 0, 3), 0, M_PI / 2, 0, 1.0, 1.0, 0.1);
  EXPECT_NEAR((g.normal() - Vec3(0, 0, -1)).norm(), 0.0, 1e-15);
  EXPECT_EQ(cross_gate(g, Vec3(0.2, 0.1, 4), Vec3(0.2, 0.1, 2)), GateCrossing::kThrough);
  EXPECT_EQ(cross_gate(g, Vec3(0.2, 0.1, 2), Vec3(0.2, 0.1, 4)), GateCrossing::kBackwards);
  EXPECT_EQ(cross_gate(g, Vec3(0.6, 0.1, 4), Vec3(0.6, 0.1, 2)), GateCrossing::kNone);
}

TEST(Gate, FrameDistanceFromTheBarsAxes) {
  const Gate g = straight_gate();
  // The +y bar's axis is the line y = 0.75 + 0.05 = 0.8, x = 4, z in [1.45, 2.55]; its surface
  // is 0.05 from it. A point at (4, 1.3, 2) is 0.5 from the axis: 0.45 from the surface.
  EXPECT_NEAR(frame_distance_m(g, Vec3(4, 1.3, 2), Vec3(4, 1.3, 2)), 0.45, 1e-12);
  // Through the centre of the opening: the nearest bars are the top and bottom ones (h / 2 =
  // 0.5 from the centre to the inner face) rather than the sides (0.75).
  EXPECT_NEAR(frame_distance_m(g, Vec3(3, 0, 2), Vec3(5, 0, 2)), 0.5, 1e-12);
  EXPECT_TRUE(touches_frame(g, Vec3(3, 0, 2), Vec3(5, 0, 2), 0.51));
  EXPECT_FALSE(touches_frame(g, Vec3(3, 0, 2), Vec3(5, 0, 2), 0.49));
  // Far away: the broad phase says no.
  EXPECT_FALSE(touches_frame(g, Vec3(-10, 0, 2), Vec3(-9, 0, 2), 0.3));
  // Inside a bar: negative.
  EXPECT_LT(frame_distance_m(g, Vec3(4, 0.8, 2), Vec3(4, 0.8, 2)), 0.0);
}

TEST(Gate, BadSizesAreRefusedByName) {
  EXPECT_THROW(make_gate("g", Vec3(0, 0, 1), 0, 0, 0, -1.0, 1.0, 0.1), InvalidArgument);
  try {
    make_gate("g7", Vec3(0, 0, 1), 0, 0, 0, 1.0, 0.0, 0.1);
    FAIL();
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("g7"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("height_m"), std::string::npos);
  }
}

TEST(SegmentDistance, KnownConfigurations) {
  // Crossing segments: 0. Skew perpendicular lines 1 apart in z.
  EXPECT_NEAR(
      math::segment_segment_distance(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, -1, 0), Vec3(0, 1, 0)),
      0.0, 1e-15);
  EXPECT_NEAR(
      math::segment_segment_distance(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, -1, 1), Vec3(0, 1, 1)),
      1.0, 1e-15);
  // Parallel, overlapping, 2 apart; parallel and disjoint along the line (endpoint gap 3, 4).
  EXPECT_NEAR(
      math::segment_segment_distance(Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(1, 2, 0), Vec3(3, 2, 0)),
      2.0, 1e-15);
  EXPECT_NEAR(
      math::segment_segment_distance(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(4, 4, 0), Vec3(6, 4, 0)),
      5.0, 1e-15);
  // Degenerate: two points; a point and a segment.
  EXPECT_NEAR(
      math::segment_segment_distance(Vec3(0, 0, 0), Vec3(0, 0, 0), Vec3(3, 4, 0), Vec3(3, 4, 0)),
      5.0, 1e-15);
  EXPECT_NEAR(math::point_segment_distance(Vec3(0, 1, 0), Vec3(-1, 0, 0), Vec3(1, 0, 0)), 1.0,
              1e-15);
}

// The exact distance is never above a dense sampling of both segments, and close to it.
TEST(SegmentDistance, AgreesWithDenseSampling) {
  Random rng(5);
  const auto point = [&] { return Vec3(rng.normal(), rng.normal(), rng.normal()); };
  for (int trial = 0; trial < 200; ++trial) {
    const Vec3 p0 = point(), p1 = point(), q0 = point(), q1 = point();
    const double exact = math::segment_segment_distance(p0, p1, q0, q1);
    double sampled = 1e9;
    constexpr int kN = 400;
    for (int i = 0; i <= kN; ++i)
      for (int j = 0; j <= kN; ++j)
        sampled = std::min(
            sampled,
            (p0 + (p1 - p0) * (double(i) / kN) - (q0 + (q1 - q0) * (double(j) / kN))).norm());
    EXPECT_LE(exact, sampled + 1e-12) << trial;
    // The sample grid is within half a cell of the true closest pair.
    const double cell = ((p1 - p0).norm() + (q1 - q0).norm()) / kN;
    EXPECT_GE(exact, sampled - cell) << trial;
  }
}

}  // namespace
}  // namespace dronetwin
