#pragma once
// Ray casting against the world: the ground plane z = 0, the obstacles (boxes, vertical
// cylinders, spheres) and the gates' frames (four capsules each, world/gate.hpp) of a Track.
// The range finder and the depth camera of the sensors read distances from here.
//
//   const RayHit hit = cast_ray(track, origin_m, direction, 10.0);
//   if (hit.kind == RayHit::Kind::kObstacle) std::cout << track.obstacles[hit.index].name;
//
// Every shape is convex (a frame is a union of four convex capsules), so each distance is the
// entry parameter of the ray into the shape: the latest of the entries into the slabs, cylinders
// and spheres that bound it, when that is no later than the earliest exit. A ray that starts
// inside a shape hits it at distance 0. Exact to round-off; tests/world/ray_cast_test.cpp
// checks analytic cases and random rays against sphere tracing of the shapes' distance fields.

#include <cstddef>
#include <cstdint>
#include <limits>

#include "dronetwin/core/types.hpp"
#include "dronetwin/world/gate.hpp"
#include "dronetwin/world/obstacle.hpp"
#include "dronetwin/world/track.hpp"

namespace dronetwin {

inline constexpr double kNoHit = std::numeric_limits<double>::infinity();

/// Distance along the unit direction `d` from `o` to the obstacle's surface (0 when `o` is
/// inside it), or kNoHit.
double ray_obstacle_m(const Obstacle& obstacle, const Vec3& o, const Vec3& d);

/// Distance to the gate's frame (its four bars), or kNoHit; a ray through the opening misses.
double ray_gate_frame_m(const Gate& gate, const Vec3& o, const Vec3& d);

/// Distance to the ground z = 0 (0 when `o` is below it), or kNoHit.
double ray_ground_m(const Vec3& o, const Vec3& d);

struct RayHit {
  enum class Kind : std::uint8_t { kNone = 0, kGround = 1, kObstacle = 2, kGate = 3 };
  Kind kind = Kind::kNone;
  int index = -1;              ///< into Track::obstacles or Track::gates; -1 otherwise
  double distance_m = kNoHit;  ///< kNoHit when nothing is within range
};

/// The nearest thing within `max_range_m` along the ray: the ground, an obstacle or a gate's
/// frame of `world`. InvalidArgument naming the value for a non-finite origin, a direction that
/// is not of unit length (to 1e-9) or a range that is not a positive number.
RayHit cast_ray(const Track& world, const Vec3& origin_m, const Vec3& direction,
                double max_range_m);

/// `count` rays at once (origins and unit directions as rows of 3 doubles): distances (kNoHit
/// beyond `max_range_m`) into `distance_m` and, when not null, what each hit into `kind` and
/// `index`. Checks every ray as cast_ray() does, naming the ray's index, before casting any.
void cast_rays(const Track& world, const double* origins_m, const double* directions,
               std::size_t count, double max_range_m, double* distance_m,
               RayHit::Kind* kind = nullptr, int* index = nullptr);

}  // namespace dronetwin
