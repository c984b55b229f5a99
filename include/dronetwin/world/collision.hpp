#pragma once
// Whether a vehicle's collision shape touches the scene while it moves over one step: the
// frames of the gates and the obstacles of a Track (the ground is the simulator's contact model,
// dynamics/ground.hpp). The Simulator ends a run with it (StepStatus::kCollided) and the racing
// environments end an episode with it.
//
//   const SceneContact c = find_scene_contact(track, model.collision_shape(), x_before, x_after);
//   if (c) std::cout << describe_contact(track, c);  // "obstacle 'pillar' (box)"
//
// A sphere is swept exactly along the straight line between the positions of its centre at the
// two ends of the step (world/gate.hpp, world/obstacle.hpp; a box obstacle's corners and a
// cylinder's rims are reached up to (sqrt(3) - 1) r early). A box is tested for overlap
// (math/convex_overlap.hpp) at poses interpolated along the step (position linear, attitude
// normalised-linear), no more than kBoxSweepResolution_m apart at any point of the box: a graze
// shallower than that between two poses can go unseen.

#include <cstdint>
#include <string>

#include "dronetwin/core/types.hpp"
#include "dronetwin/world/collision_shape.hpp"
#include "dronetwin/world/track.hpp"

namespace dronetwin {

/// Largest distance any point of a box-shaped vehicle moves between two tested poses, m.
inline constexpr double kBoxSweepResolution_m = 0.01;

struct SceneContact {
  enum class Kind : std::uint8_t { kNone = 0, kObstacle = 1, kGate = 2 };
  Kind kind = Kind::kNone;
  int index = -1;  ///< into Track::obstacles or Track::gates
  explicit operator bool() const { return kind != Kind::kNone; }
};

/// What `shape` (body frame) touches first while the body moves from pose (p0, q0) to (p1, q1)
/// (q = [w, x, y, z], body to world): a gate's frame (gates checked first, in order) or an
/// obstacle; Kind::kNone when nothing.
SceneContact find_scene_contact(const Track& scene, const CollisionShape& shape, const Vec3& p0_m,
                                const Vec4& q0, const Vec3& p1_m, const Vec4& q1);

/// The same from two 13-element states [p, v, q, w].
SceneContact find_scene_contact(const Track& scene, const CollisionShape& shape,
                                const StateVector& before, const StateVector& after);

/// "obstacle 'pillar' (box)", "the frame of gate 'g3'", or "nothing".
std::string describe_contact(const Track& scene, const SceneContact& contact);

/// True when the box (centre, rotation to world, half extents) overlaps the obstacle.
bool box_overlaps_obstacle(const Vec3& center_m, const Mat3& R, const Vec3& half_size_m,
                           const Obstacle& obstacle);

/// True when the box overlaps the gate's frame (its four bars, world/gate.hpp).
bool box_overlaps_gate_frame(const Vec3& center_m, const Mat3& R, const Vec3& half_size_m,
                             const Gate& gate);

}  // namespace dronetwin
