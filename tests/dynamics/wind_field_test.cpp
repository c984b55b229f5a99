// The wind field's pieces (dynamics/wind_field.hpp): the log-law shear against its values in
// feet, the 1 - cos gust's shape (peak, ends, area A D / 2), the turbulence axes.

#include "dronetwin/dynamics/wind_field.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace dronetwin {
namespace {

TEST(WindField, LogLawShear) {
  const Vec3 mean(5.0, -2.0, 0.0);
  WindShear shear;
  EXPECT_EQ(mean_wind_at(mean, shear, 50.0), mean);  // no shear: the same at any height
  shear.enabled = true;
  EXPECT_TRUE(mean_wind_at(mean, shear, 6.096).isApprox(mean, 1e-15));
  // 200 ft against 20 ft with z0 = 0.15 ft: ln(200 / 0.15) / ln(20 / 0.15).
  const double factor = std::log(200.0 / 0.15) / std::log(20.0 / 0.15);
  EXPECT_TRUE(mean_wind_at(mean, shear, 200.0 * 0.3048).isApprox(factor * mean, 1e-12));
  // In the roughness layer the value at 2 z0 holds (ln 2 / ln(h_ref / z0) of the wind).
  EXPECT_EQ(mean_wind_at(mean, shear, 0.0),
            mean_wind_at(mean, shear, 2.0 * shear.roughness_length_m));
  EXPECT_GT(mean_wind_at(mean, shear, 0.0).x(), 0.0);
}

TEST(WindField, OneMinusCosineGusts) {
  WindSettings w;
  w.gusts[0] = {2.0, 0.5, Vec3(0.0, 3.0, -1.0)};
  w.gusts[1] = {2.25, 1.0, Vec3(1.0, 0.0, 0.0)};
  w.num_gusts = 2;
  EXPECT_EQ(gust_at(w, 1.99), Vec3::Zero());
  EXPECT_TRUE(gust_at(w, 2.25).isApprox(Vec3(0.0, 3.0, -1.0), 1e-15));  // first at its peak
  EXPECT_NEAR(gust_at(w, 2.75).x(), 1.0, 1e-15);                        // second at its peak
  EXPECT_NEAR(gust_at(w, 2.5).y(), 0.0, 1e-15);                         // first ended
  // Area under the first: A D / 2 (midpoint rule, 10 000 points).
  double area = 0.0;
  for (int i = 0; i < 10000; ++i) area += gust_at(w, 2.0 + (i + 0.5) * 0.25 / 10000.0).y();
  EXPECT_NEAR(area * 0.25 / 10000.0, 3.0 * 0.25 / 2.0, 1e-9);
}

TEST(WindField, TurbulenceAxesFollowTheMeanWind) {
  const Mat3 a = turbulence_axes(Vec3(3.0, 4.0, 1.0));
  EXPECT_TRUE(a.col(0).isApprox(Vec3(0.6, 0.8, 0.0), 1e-15));
  EXPECT_TRUE(a.col(2).isApprox(Vec3::UnitZ(), 1e-15));
  EXPECT_TRUE((a.transpose() * a).isApprox(Mat3::Identity(), 1e-15));
  EXPECT_NEAR(a.determinant(), 1.0, 1e-15);
  EXPECT_TRUE(turbulence_axes(Vec3::Zero()).isApprox(Mat3::Identity(), 1e-15));
}

}  // namespace
}  // namespace dronetwin
