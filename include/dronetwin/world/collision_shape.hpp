#pragma once
// The shape that stands for a vehicle when it touches the scene: a sphere or a box fixed in the
// body frame. Plain data; a model file gives it under `collision:` (docs/model-format.md), and
// VehicleModel::collision_shape() gives a sphere over the rotors when the file does not.

#include <cstdint>
#include <string_view>

#include "dronetwin/core/types.hpp"

namespace dronetwin {

struct CollisionShape {
  enum class Kind : std::uint8_t { kSphere, kBox };
  Kind kind = Kind::kSphere;
  /// Centre of the sphere or box in the body frame, m.
  Vec3 center_B_m = Vec3::Zero();
  /// Sphere radius, m (kSphere).
  double radius_m = 0.0;
  /// Half extents along the body axes, m (kBox).
  Vec3 half_size_m = Vec3::Zero();

  static CollisionShape sphere(double radius_m, const Vec3& center_B_m = Vec3::Zero()) {
    CollisionShape s;
    s.radius_m = radius_m;
    s.center_B_m = center_B_m;
    return s;
  }
  static CollisionShape box(const Vec3& half_size_m, const Vec3& center_B_m = Vec3::Zero()) {
    CollisionShape s;
    s.kind = Kind::kBox;
    s.half_size_m = half_size_m;
    s.center_B_m = center_B_m;
    return s;
  }

  /// Radius of a sphere about the body origin that holds the whole shape, m.
  double bounding_radius_m() const {
    return center_B_m.norm() + (kind == Kind::kSphere ? radius_m : half_size_m.norm());
  }
};

constexpr std::string_view collision_kind_name(CollisionShape::Kind k) {
  return k == CollisionShape::Kind::kSphere ? "sphere" : "box";
}

}  // namespace dronetwin
