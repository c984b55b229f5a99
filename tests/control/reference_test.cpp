// References: values from the thesis equations, and derivatives consistent with the positions
// (checked by central differences, independent of the analytic derivative code).

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "dronetwin/control/reference.hpp"
#include "dronetwin/core/error.hpp"

namespace dronetwin {
namespace {

void expect_consistent_derivatives(const Reference& ref, double t0, double t1) {
  const double h = 1e-4;
  for (double t = t0; t <= t1; t += (t1 - t0) / 37) {
    const ReferencePoint a = ref.at(t - h), b = ref.at(t + h), c = ref.at(t);
    const Vec3 v_fd = (b.position_m - a.position_m) / (2 * h);
    const Vec3 a_fd = (b.velocity_m_s - a.velocity_m_s) / (2 * h);
    EXPECT_LT((v_fd - c.velocity_m_s).norm(), 1e-6) << ref.describe() << " t = " << t;
    EXPECT_LT((a_fd - c.acceleration_m_s2).norm(), 1e-6) << ref.describe() << " t = " << t;
    EXPECT_NEAR((b.yaw_rad - a.yaw_rad) / (2 * h), c.yaw_rate_rad_s, 1e-6) << ref.describe();
    // Jerk, snap and yaw acceleration (the SE(3) feed-forward's inputs), the same way.
    const Vec3 j_fd = (b.acceleration_m_s2 - a.acceleration_m_s2) / (2 * h);
    const Vec3 s_fd = (b.jerk_m_s3 - a.jerk_m_s3) / (2 * h);
    EXPECT_LT((j_fd - c.jerk_m_s3).norm(), 1e-6) << ref.describe() << " t = " << t;
    EXPECT_LT((s_fd - c.snap_m_s4).norm(), 1e-6) << ref.describe() << " t = " << t;
    EXPECT_NEAR((b.yaw_rate_rad_s - a.yaw_rate_rad_s) / (2 * h), c.yaw_acceleration_rad_s2, 1e-6)
        << ref.describe();
  }
}

TEST(Reference, ThesisPulseFollowsEq314) {
  const auto pulse = PiecewiseConstantReference::thesis_pulse();
  const struct {
    double t, x, z;
  } expected[] = {{0, 0, 0},         {21.999, 0, 0},      {22, 0, 0.75},    {29.9, 0, 0.75},
                  {30, -0.75, 0.75}, {34.9, -0.75, 0.75}, {35, 0.75, 0.75}, {44.9, 0.75, 0.75},
                  {45, -0.75, 0.75}, {49.9, -0.75, 0.75}, {50, 0, 0.75},    {60, 0, 0.75}};
  for (const auto& e : expected) {
    const ReferencePoint p = pulse.at(e.t);
    EXPECT_EQ(p.position_m.x(), e.x) << "t = " << e.t;
    EXPECT_EQ(p.position_m.y(), 0.0);
    EXPECT_EQ(p.position_m.z(), e.z) << "t = " << e.t;
    EXPECT_EQ(p.velocity_m_s.norm(), 0.0);
  }
}

TEST(Reference, CircleFollowsEq328) {
  const CircleReference circle;  // r = 2 m, T = 7 s, z = 1 m
  for (double t : {0.0, 1.3, 3.5, 6.9}) {
    const ReferencePoint p = circle.at(t);
    const double w = 2 * std::numbers::pi / 7;
    EXPECT_NEAR(p.position_m.x(), 2 * std::cos(w * t), 1e-15);
    EXPECT_NEAR(p.position_m.y(), 2 * std::sin(w * t), 1e-15);
    EXPECT_EQ(p.position_m.z(), 1.0);
    // Eq. 3.28: |v| = 4 pi / 7, |a| = 8 pi^2 / 49.
    EXPECT_NEAR(p.velocity_m_s.norm(), 4 * std::numbers::pi / 7, 1e-14);
    EXPECT_NEAR(p.acceleration_m_s2.norm(), 8 * std::numbers::pi * std::numbers::pi / 49, 1e-14);
  }
  expect_consistent_derivatives(circle, 0.1, 14.0);
}

TEST(Reference, FigureEightFollowsEq325) {
  const FigureEightReference eight;  // 0.8 x 0.6 m, T = 60 s, z = 1.2 m
  const ReferencePoint p = eight.at(7.5);
  EXPECT_NEAR(p.position_m.x(), 0.8 * std::sin(2 * std::numbers::pi * 7.5 / 60), 1e-15);
  EXPECT_NEAR(p.position_m.y(), 0.6 * std::sin(4 * std::numbers::pi * 7.5 / 60), 1e-15);
  EXPECT_EQ(p.position_m.z(), 1.2);
  EXPECT_NEAR(eight.at(0).velocity_m_s.x(), 1.6 * std::numbers::pi / 60, 1e-15);  // Eq. 3.25
  EXPECT_NEAR(eight.at(0).velocity_m_s.y(), 2.4 * std::numbers::pi / 60, 1e-15);
  expect_consistent_derivatives(eight, 0.1, 60.0);
}

TEST(Reference, WaypointsAreSmoothAndHitEveryPoint) {
  const WaypointReference wp(
      {{0.0, Vec3(0, 0, 0), 0.0}, {2.0, Vec3(1, 0, 1), 0.5}, {5.0, Vec3(1, 2, 1), -0.5}});
  EXPECT_EQ(wp.at(2.0).position_m, Vec3(1, 0, 1));
  EXPECT_EQ(wp.at(9.0).position_m, Vec3(1, 2, 1));
  EXPECT_EQ(wp.at(2.0).velocity_m_s.norm(), 0.0);      // each segment starts and ends at rest
  EXPECT_NEAR(wp.at(1.0).position_m.x(), 0.5, 1e-15);  // minimum-jerk midpoint
  expect_consistent_derivatives(wp, 0.05, 4.95);
}

TEST(Reference, RejectsBadDefinitions) {
  EXPECT_THROW(PiecewiseConstantReference({{1.0, Vec3::Zero(), 0.0}}), InvalidArgument);
  EXPECT_THROW(PiecewiseConstantReference({{0.0, Vec3::Zero(), 0.0}, {0.0, Vec3::Zero(), 0.0}}),
               InvalidArgument);
  EXPECT_THROW(CircleReference(Vec3(0, 0, 1), 2.0, 0.0), InvalidArgument);
  EXPECT_THROW(WaypointReference({{0.0, Vec3(0, NAN, 0), 0.0}}), InvalidArgument);
}

}  // namespace
}  // namespace dronetwin
