#pragma once
// Scene obstacles of a racing track (pillars, walls, balls): axis-aligned boxes, vertical
// cylinders and spheres, with a swept-sphere touch test for a vehicle's path over one step.

#include <cstdint>
#include <string>

#include "dronetwin/core/types.hpp"

namespace dronetwin {

struct Obstacle {
  enum class Shape : std::uint8_t { kBox, kCylinder, kSphere };
  Shape shape = Shape::kBox;
  std::string name;
  Vec3 center_m = Vec3::Zero();  ///< box centre; cylinder: centre of its (vertical) axis
  /// Box: half extents; cylinder: (radius, radius, half height); sphere: (radius, radius, radius).
  Vec3 half_size_m = Vec3::Zero();
};

/// True when a sphere of radius `radius_m` swept along from -> to touches the obstacle.
/// Conservative, never misses a touch: the shape is grown by the radius as a box (a box's
/// corners and edges are then reached up to (sqrt(3) - 1) r early) or as a cylinder of radius
/// R + r and half height h + r (its rims up to (sqrt(2) - 1) r early); faces and spheres are
// exact.
bool touches_obstacle(const Obstacle& o, const Vec3& from, const Vec3& to, double radius_m);

}  // namespace dronetwin
