// TrajectoryReference: a planned trajectory as a reference, shifted by its start time and held at
// rest outside it.

#include "dronetwin/control/trajectory_reference.hpp"

#include <gtest/gtest.h>

#include <string>

#include "dronetwin/core/error.hpp"
#include "dronetwin/planning/min_snap.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

planning::Trajectory plan() {
  std::vector<planning::Waypoint> w(3);
  w[0].position_m = Vec3(0, 0, 1);
  w[1].position_m = Vec3(1, 1, 1.5);
  w[1].yaw_rad = 0.5;
  w[2].position_m = Vec3(2, 0, 1);
  w[2].yaw_rad = 1.0;
  return planning::plan_min_snap(w, {1.0, 1.5}, {});
}

TEST(TrajectoryReference, IsTheTrajectoryShiftedByItsStartTime) {
  const planning::Trajectory traj = plan();
  const TrajectoryReference ref(traj, 2.0);
  // Times whose sum with the start is exact, so that t - start gives tau back bit for bit.
  for (const double tau : {0.015625, 0.375, 1.0, 1.75, 2.4375}) {
    const ReferencePoint p = ref.at(2.0 + tau);
    const planning::FlatOutput f = traj.at(tau);
    EXPECT_EQ(p.position_m, f.position_m) << tau;
    EXPECT_EQ(p.velocity_m_s, f.velocity_m_s) << tau;
    EXPECT_EQ(p.acceleration_m_s2, f.acceleration_m_s2) << tau;
    EXPECT_EQ(p.jerk_m_s3, f.jerk_m_s3) << tau;
    EXPECT_EQ(p.snap_m_s4, f.snap_m_s4) << tau;
    EXPECT_EQ(p.yaw_rad, f.yaw_rad) << tau;
    EXPECT_EQ(p.yaw_rate_rad_s, f.yaw_rate_rad_s) << tau;
    EXPECT_EQ(p.yaw_acceleration_rad_s2, f.yaw_acceleration_rad_s2) << tau;
  }
  EXPECT_EQ(ref.end_time_s(), 4.5);
}

TEST(TrajectoryReference, HoldsItsEndsAtRest) {
  const TrajectoryReference ref(plan(), 2.0);
  for (const double t : {-1.0, 0.0, 2.0}) {
    const ReferencePoint p = ref.at(t);
    EXPECT_NEAR((p.position_m - Vec3(0, 0, 1)).norm(), 0.0, 1e-12) << t;
    EXPECT_EQ(p.velocity_m_s.norm() + p.snap_m_s4.norm() + p.yaw_rate_rad_s, 0.0) << t;
  }
  for (const double t : {4.5, 10.0}) {
    const ReferencePoint p = ref.at(t);
    EXPECT_NEAR((p.position_m - Vec3(2, 0, 1)).norm(), 0.0, 1e-12) << t;
    EXPECT_NEAR(p.yaw_rad, 1.0, 1e-12) << t;
    EXPECT_EQ(p.velocity_m_s.norm() + p.acceleration_m_s2.norm() + p.snap_m_s4.norm(), 0.0) << t;
  }
  // A clone is the same reference.
  EXPECT_EQ(ref.clone()->at(3.1).position_m, ref.at(3.1).position_m);
  EXPECT_NE(ref.describe().find("2 segments"), std::string::npos) << ref.describe();
}

TEST(TrajectoryReference, RejectsANonFiniteStartTime) {
  EXPECT_NE(test::error_of([] {
              TrajectoryReference(plan(), std::nan(""));
            }).find("start_time_s: expected a finite time"),
            std::string::npos);
}

}  // namespace
}  // namespace dronetwin
