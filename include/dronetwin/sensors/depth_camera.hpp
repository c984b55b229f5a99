#pragma once
// Depth camera by ray casting the scene (world/ray_cast.hpp): a pinhole camera of width x height
// pixels with a horizontal field of view, square pixels and the principal point at the image
// centre. The camera frame is the optical frame (z along the optical axis, x to the image's
// right, y down); mounted by default at the centre of mass looking along body x. Each pixel holds
// the depth (the hit point's z in the camera frame, as stereo and time-of-flight cameras report
// it, not the distance along the ray) plus white noise proportional to depth squared (the error
// of a stereo pair); a pixel that sees nothing within max_range_m holds max_range_m, as a
// learning-based perception input wants (no inf or NaN in an observation).
//
//   DepthCamera cam(DepthCameraParameters{});          // 64 x 48, 90 deg, 30 Hz
//   std::vector<float> frame(cam.pixels());
//   cam.render(state, &scene, frame.data());           // row-major, row 0 at the top
//   cam.render_batch(states, n, &scene, frames);       // n vehicles, (n, 48, 64)
//
// The rays in the camera frame are computed once, at construction; render() allocates nothing.
// Cost: docs/performance.md ("Depth camera").

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "dronetwin/core/types.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/sensors/mounting.hpp"
#include "dronetwin/world/track.hpp"

namespace dronetwin {

struct DepthCameraParameters {
  int width_px = 64;
  int height_px = 48;
  double horizontal_fov_deg = 90.0;
  double max_range_m = 20.0;
  /// Depth noise at 1 m, m; it grows with depth^2 (stereo). 0: exact depths.
  double noise_at_1m_m = 0.0;
  double rate_hz = 30.0;
  /// Camera (optical) frame in the body frame; default at the centre of mass, looking forward.
  Mounting mounting = forward_looking();

  /// The optical frame looking along body x: z_C = x_B, x_C = -y_B, y_C = -z_B.
  static Mounting forward_looking();
};

/// A depth camera of an experiment (`sensors:` item of type depth_camera): its name names the
/// frames file <name>.npy and the log columns <name>_t, <name>_frame of a run.
struct DepthCameraSpec {
  std::string name = "depth";
  DepthCameraParameters parameters;
};

/// Throws InvalidArgument "<field>: expected ..., got ..." for a camera with no pixels, more than
/// 4096 on a side, a field of view outside (0, 179] deg, a non-positive range, rate or a negative
/// noise.
void validate(const DepthCameraParameters& p);

class DepthCamera {
 public:
  explicit DepthCamera(const DepthCameraParameters& p);

  const DepthCameraParameters& parameters() const { return p_; }
  std::size_t pixels() const {
    return static_cast<std::size_t>(p_.width_px) * static_cast<std::size_t>(p_.height_px);
  }
  /// Focal length in pixels, from the horizontal field of view.
  double focal_px() const { return focal_px_; }

  /// One frame of the vehicle at `state` ([p, v, q, w]); `scene` null: the ground alone. Noise
  /// (when configured) from `rng`, else `rng` may be null.
  void render(const StateVector& state, const Track* scene, float* depth_m,
              Random* rng = nullptr) const;
  /// Frames of `count` vehicles: states row-major (count x 13), frames (count x height x width).
  void render_batch(const double* states, std::size_t count, const Track* scene, float* depth_m,
                    Random* rng = nullptr) const;

 private:
  DepthCameraParameters p_;
  double focal_px_ = 0.0;
  /// Unit ray of each pixel in the camera frame, and its z (the cosine to the optical axis).
  std::vector<Vec3> rays_C_;
};

}  // namespace dronetwin
