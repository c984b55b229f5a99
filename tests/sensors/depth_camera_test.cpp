// Depth camera: depth is the optical-axis coordinate (a wall square to the axis reads the same
// depth in every pixel, flat ground below a camera looking down reads the height), pixels that see
// nothing read max_range_m, a sphere appears at its pinhole projection, batches equal single
// frames, and bad parameters are named.

#include "dronetwin/sensors/depth_camera.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

StateVector pose(const Vec3& p, const Vec4& q = Vec4(1, 0, 0, 0)) {
  StateVector x = StateVector::Zero();
  x << p, Vec3::Zero(), q, Vec3::Zero();
  return x;
}

Track wall_at_x(double x) {
  Track t;
  Obstacle o;
  o.shape = Obstacle::Shape::kBox;
  o.center_m = Vec3(x + 1.0, 0.0, 0.0);
  o.half_size_m = Vec3(1.0, 100.0, 100.0);
  t.obstacles.push_back(o);
  return t;
}

TEST(DepthCamera, AWallSquareToTheAxisHasOneDepth) {
  const DepthCamera cam(DepthCameraParameters{});
  const Track wall = wall_at_x(3.0);
  std::vector<float> f(cam.pixels());
  // Level and facing it: every pixel reads 3 m, the edges as well as the centre.
  cam.render(pose(Vec3(0, 0, 50)), &wall, f.data());
  for (const float d : f) EXPECT_NEAR(d, 3.0, 1e-6);
  // Yawed by 0.3 rad the wall is oblique: one side of the image is nearer than the other.
  cam.render(pose(Vec3(0, 0, 50), math::from_euler(0, 0, 0.3)), &wall, f.data());
  EXPECT_GT(*std::max_element(f.begin(), f.end()) - *std::min_element(f.begin(), f.end()), 0.5);
}

TEST(DepthCamera, FlatGroundBelowACameraLookingDownReadsTheHeight) {
  DepthCameraParameters p;
  p.mounting = Mounting::looking_down();  // z_C = -z_B
  const DepthCamera cam(p);
  std::vector<float> f(cam.pixels());
  cam.render(pose(Vec3(1, 2, 4.5)), nullptr, f.data());
  for (const float d : f) EXPECT_NEAR(d, 4.5, 1e-5);
  // Looking up: nothing within range.
  p.mounting = Mounting::at(Vec3::Zero());  // z_C = z_B: up
  const DepthCamera up(p);
  up.render(pose(Vec3(0, 0, 1)), nullptr, f.data());
  for (const float d : f) EXPECT_EQ(d, static_cast<float>(p.max_range_m));
}

TEST(DepthCamera, ASphereAppearsAtItsPinholeProjection) {
  DepthCameraParameters p;
  p.width_px = 160;
  p.height_px = 120;
  const DepthCamera cam(p);
  Track t;
  Obstacle ball;
  ball.shape = Obstacle::Shape::kSphere;
  ball.center_m = Vec3(6.0, 1.0, 50.5);  // ahead, to the left, above the camera
  ball.half_size_m = Vec3::Constant(0.2);
  t.obstacles.push_back(ball);
  std::vector<float> f(cam.pixels());
  cam.render(pose(Vec3(0, 0, 50)), &t, f.data());
  // Camera frame: x_C = -y_B, y_C = -z_B, z_C = x_B: the centre is at (-1, -0.5, 6).
  const double u = cam.focal_px() * (-1.0 / 6.0) + 0.5 * p.width_px;
  const double v = cam.focal_px() * (-0.5 / 6.0) + 0.5 * p.height_px;
  const auto at = [&](int uu, int vv) { return f[static_cast<std::size_t>(vv * p.width_px + uu)]; };
  const int uc = static_cast<int>(u), vc = static_cast<int>(v);
  // The pixel holding the projection sees the near side of the ball: depth a little under 6.
  EXPECT_NEAR(at(uc, vc), 6.0 - 0.2, 0.02);
  // Its apparent radius is about f r / z = 2.7 px at this size: 6 px away is background.
  EXPECT_EQ(at(uc + 6, vc), static_cast<float>(p.max_range_m));
  EXPECT_EQ(at(uc, vc - 6), static_cast<float>(p.max_range_m));
}

TEST(DepthCamera, BatchEqualsSingleFramesAndNoiseGrowsWithDepth) {
  const DepthCamera cam(DepthCameraParameters{});
  const Track wall = wall_at_x(4.0);
  std::vector<double> states;
  for (int n = 0; n < 5; ++n) {
    const StateVector x = pose(Vec3(0.1 * n, 0.2, 50), math::from_euler(0.05 * n, 0, -0.1 * n));
    states.insert(states.end(), x.data(), x.data() + kStateSize);
  }
  std::vector<float> batch(5 * cam.pixels()), one(cam.pixels());
  cam.render_batch(states.data(), 5, &wall, batch.data());
  for (std::size_t n = 0; n < 5; ++n) {
    cam.render(Eigen::Map<const StateVector>(states.data() + n * kStateSize), &wall, one.data());
    for (std::size_t i = 0; i < one.size(); ++i) ASSERT_EQ(batch[n * cam.pixels() + i], one[i]);
  }
  DepthCameraParameters p;
  p.noise_at_1m_m = 0.01;
  const DepthCamera noisy(p);
  Random rng(3);
  std::vector<float> f(noisy.pixels());
  double s2 = 0.0;
  int count = 0;
  for (int k = 0; k < 50; ++k) {
    noisy.render(pose(Vec3(0, 0, 50)), &wall, f.data(), &rng);
    for (const float d : f) {
      s2 += (d - 4.0) * (d - 4.0);
      ++count;
    }
  }
  // sigma = 0.01 * 4^2 = 0.16 m; 153 600 samples: 0.2 % standard error of the deviation.
  EXPECT_NEAR(std::sqrt(s2 / count) / 0.16, 1.0, 0.02);
}

TEST(DepthCamera, BadParametersAreNamed) {
  DepthCameraParameters p;
  p.width_px = 0;
  EXPECT_EQ(test::error_of([&] { DepthCamera c(p); }),
            "width_px: expected 1 .. 4096 pixels, got 0");
  p = {};
  p.horizontal_fov_deg = 180.0;
  EXPECT_EQ(test::error_of([&] { DepthCamera c(p); }),
            "horizontal_fov_deg: expected a number in (0, 179], got 180");
  p = {};
  p.max_range_m = -1.0;
  EXPECT_EQ(test::error_of([&] { DepthCamera c(p); }),
            "max_range_m: expected a finite number > 0, got -1");
}

}  // namespace
}  // namespace dronetwin
