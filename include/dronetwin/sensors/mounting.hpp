#pragma once
// Where a sensor sits on the body and how it is turned: its frame S relative to the body frame B.
// In YAML `mounting: {position_m: [x, y, z], rpy_deg: [roll, pitch, yaw]}` (ZYX angles, thesis
// Eq. 2.7 convention), default: at the centre of mass, axes along the body's.

#include "dronetwin/core/types.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

struct Mounting {
  /// Origin of S in the body frame, m.
  Vec3 position_B_m = Vec3::Zero();
  /// q_BS (w, x, y, z): rotates sensor-frame vectors into the body frame.
  Vec4 rotation_BS_wxyz = Vec4(1.0, 0.0, 0.0, 0.0);

  Mat3 rotation_BS() const { return math::rotation_matrix<double>(rotation_BS_wxyz); }

  static Mounting at(const Vec3& position_B_m, double roll_rad = 0.0, double pitch_rad = 0.0,
                     double yaw_rad = 0.0) {
    return Mounting{position_B_m, math::from_euler(roll_rad, pitch_rad, yaw_rad)};
  }
  /// Sensor z along body -z (roll of pi): a range finder or flow camera looking down.
  static Mounting looking_down() { return at(Vec3::Zero(), M_PI); }
};

}  // namespace dronetwin
