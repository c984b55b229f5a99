#include "dronetwin/sensors/depth_camera.hpp"

#include <algorithm>
#include <cmath>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/world/ray_cast.hpp"

namespace dronetwin {

Mounting DepthCameraParameters::forward_looking() {
  Mat3 R_BC;
  R_BC.col(0) = Vec3(0, -1, 0);  // image right = body right (-y)
  R_BC.col(1) = Vec3(0, 0, -1);  // image down = body down (-z)
  R_BC.col(2) = Vec3(1, 0, 0);   // optical axis = body forward
  const Eigen::Quaterniond q(R_BC);
  Mounting m;
  m.rotation_BS_wxyz = Vec4(q.w(), q.x(), q.y(), q.z());
  if (m.rotation_BS_wxyz[0] < 0.0) m.rotation_BS_wxyz = -m.rotation_BS_wxyz;
  return m;
}

void validate(const DepthCameraParameters& p) {
  const auto fail = [](const char* field, const char* expected, double got) {
    throw InvalidArgument(detail::concat(field, ": expected ", expected, ", got ", got));
  };
  if (p.width_px < 1 || p.width_px > 4096) fail("width_px", "1 .. 4096 pixels", p.width_px);
  if (p.height_px < 1 || p.height_px > 4096) fail("height_px", "1 .. 4096 pixels", p.height_px);
  if (!(p.horizontal_fov_deg > 0.0 && p.horizontal_fov_deg <= 179.0))
    fail("horizontal_fov_deg", "a number in (0, 179]", p.horizontal_fov_deg);
  if (!(std::isfinite(p.max_range_m) && p.max_range_m > 0.0))
    fail("max_range_m", "a finite number > 0", p.max_range_m);
  if (!(std::isfinite(p.noise_at_1m_m) && p.noise_at_1m_m >= 0.0))
    fail("noise_at_1m_m", "a finite number >= 0", p.noise_at_1m_m);
  if (!(std::isfinite(p.rate_hz) && p.rate_hz > 0.0))
    fail("rate_hz", "a finite number > 0", p.rate_hz);
  const double qn = p.mounting.rotation_BS_wxyz.norm();
  if (!(std::abs(qn - 1.0) < 1e-9)) fail("mounting.rotation", "a unit quaternion (norm)", qn);
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(p.mounting.position_B_m[i]))
      fail("mounting.position_m", "finite numbers", p.mounting.position_B_m[i]);
}

DepthCamera::DepthCamera(const DepthCameraParameters& p) : p_(p) {
  validate(p_);
  focal_px_ = 0.5 * p_.width_px / std::tan(0.5 * p_.horizontal_fov_deg * M_PI / 180.0);
  rays_C_.reserve(pixels());
  for (int v = 0; v < p_.height_px; ++v) {
    for (int u = 0; u < p_.width_px; ++u) {
      // Pixel centres: u + 0.5 to the right of the left edge, v + 0.5 below the top.
      const Vec3 d((u + 0.5 - 0.5 * p_.width_px) / focal_px_,
                   (v + 0.5 - 0.5 * p_.height_px) / focal_px_, 1.0);
      rays_C_.push_back(d.normalized());
    }
  }
}

void DepthCamera::render(const StateVector& state, const Track* scene, float* depth_m,
                         Random* rng) const {
  using namespace state_index;
  const Mat3 R_WB = math::rotation_matrix<double>(state.segment<4>(kQuaternion));
  const Mat3 R_WC = R_WB * p_.mounting.rotation_BS();
  const Vec3 eye = state.segment<3>(kPosition) + R_WB * p_.mounting.position_B_m;
  static const Track kEmpty{};
  const Track& world = scene != nullptr ? *scene : kEmpty;
  const bool noisy = p_.noise_at_1m_m > 0.0 && rng != nullptr;
  for (std::size_t i = 0; i < rays_C_.size(); ++i) {
    const Vec3 d_W = R_WC * rays_C_[i];
    // Ray length at which the depth reaches max_range_m: depth = distance * cos.
    const double reach = p_.max_range_m / rays_C_[i][2];
    const double distance = cast_ray(world, eye, d_W.normalized(), reach).distance_m;
    double depth = distance == kNoHit ? p_.max_range_m : distance * rays_C_[i][2];
    if (noisy && distance != kNoHit)
      depth =
          std::clamp(depth + p_.noise_at_1m_m * depth * depth * rng->normal(), 0.0, p_.max_range_m);
    depth_m[i] = static_cast<float>(depth);
  }
}

void DepthCamera::render_batch(const double* states, std::size_t count, const Track* scene,
                               float* depth_m, Random* rng) const {
  for (std::size_t n = 0; n < count; ++n) {
    const StateVector x = Eigen::Map<const StateVector>(states + n * kStateSize);
    render(x, scene, depth_m + n * pixels(), rng);
  }
}

}  // namespace dronetwin
