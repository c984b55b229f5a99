// app/metrics.hpp: the one tracking RMSE (summary.json and dronetwin.rmse) against hand-computed
// values: window edges in steps with the 1e-9-step tolerance, the yaw error wrapped through
// +-pi, and the row-based form equal to the incremental one.

#include "dronetwin/app/metrics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {
namespace {

StateVector at(const Vec3& p, double yaw) {
  StateVector x = StateVector::Zero();
  x.head<3>() = p;
  x.segment<4>(6) = math::from_euler(0.0, 0.0, yaw);
  return x;
}

TEST(TrackingRmse, ConstantErrorsGiveThemselves) {
  TrackingRmse m(1e-3, std::nullopt);
  for (int k = 0; k <= 100; ++k) m.add(k, at(Vec3(1.0, 2.0, 3.0), 0.25), Vec3(1.1, 1.8, 3.3), 0.5);
  const Vec4 e = m.rmse();
  EXPECT_NEAR(e[0], 0.1, 1e-15);
  EXPECT_NEAR(e[1], 0.2, 1e-15);
  EXPECT_NEAR(e[2], 0.3, 1e-15);
  EXPECT_NEAR(e[3], 0.25, 1e-15);
  EXPECT_EQ(m.samples(), 101);
}

TEST(TrackingRmse, YawErrorIsWrappedThroughPi) {
  TrackingRmse m(1e-3, std::nullopt);
  // Reference just below +pi, vehicle just above -pi: 0.2 rad apart, not 2 pi - 0.2.
  m.add(0, at(Vec3::Zero(), -std::numbers::pi + 0.1), Vec3::Zero(), std::numbers::pi - 0.1);
  EXPECT_NEAR(m.rmse()[3], 0.2, 1e-12);
}

TEST(TrackingRmse, WindowEdgesAreWholeStepsWithinATolerance) {
  const double dt = 1e-3;
  // [1.5 ms, 3 ms] holds steps 2 and 3 (t = 2 ms, 3 ms), a start within 1e-9 steps of 2 ms too.
  for (const double t0 : {0.0015, 0.002 - 1e-16, 0.002}) {
    TrackingRmse m(dt, std::array<double, 2>{t0, 0.003});
    for (int k = 0; k <= 10; ++k) m.add(k, at(Vec3(k, 0, 0), 0), Vec3::Zero(), 0.0);
    EXPECT_EQ(m.samples(), 2) << t0;
    EXPECT_NEAR(m.rmse()[0], std::sqrt((4.0 + 9.0) / 2.0), 1e-14) << t0;
  }
  TrackingRmse later(dt, std::array<double, 2>{0.0021, 0.003});
  for (int k = 0; k <= 10; ++k) later.add(k, at(Vec3(k, 0, 0), 0), Vec3::Zero(), 0.0);
  EXPECT_EQ(later.samples(), 1);
  const auto clipped = later.window_s(0.0025);
  EXPECT_EQ(clipped[0], 0.0021);
  EXPECT_EQ(clipped[1], 0.0025);
}

TEST(TrackingRmse, NoStepInTheWindowIsNaN) {
  TrackingRmse m(1e-3, std::array<double, 2>{5.0, 6.0});
  m.add(0, at(Vec3::Ones(), 0), Vec3::Zero(), 0.0);
  EXPECT_TRUE(m.rmse().array().isNaN().all());
  EXPECT_THROW(TrackingRmse(0.0, std::nullopt), InvalidArgument);
  EXPECT_THROW(TrackingRmse(1e-3, std::array<double, 2>{2.0, 1.0}), InvalidArgument);
}

TEST(TrackingRmse, RowsGiveTheIncrementalResultBitForBit) {
  const double dt = 1e-3;
  const int rows = 50;
  std::vector<double> t, states, refs;
  TrackingRmse m(dt, std::array<double, 2>{0.010, 0.037});
  for (int k = 0; k < rows; ++k) {
    const StateVector x = at(Vec3(std::sin(k), std::cos(3.0 * k), 0.01 * k), 0.1 * k);
    const Vec3 r(0.5, -0.25, 1.0);
    const double yaw = 3.0 - 0.05 * k;
    m.add(k, x, r, yaw);
    t.push_back(static_cast<double>(k) * dt);
    states.insert(states.end(), x.data(), x.data() + kStateSize);
    refs.insert(refs.end(), {r[0], r[1], r[2], yaw});
  }
  const Vec4 e = tracking_rmse(t.data(), states.data(), refs.data(), rows, dt,
                               std::array<double, 2>{0.010, 0.037});
  EXPECT_EQ(e, m.rmse());
  EXPECT_EQ(m.samples(), 28);
}

}  // namespace
}  // namespace dronetwin
