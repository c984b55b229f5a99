#pragma once
// A racing gate: a rectangular opening in a frame of square bars (thesis Sec. 4.4, Fig. 4.4-4.5).
// Passage and collision are exact tests on the straight segment a vehicle covers in one step, so
// a fast vehicle cannot tunnel through a gate or its frame between two checks.
//
//   Gate g = make_gate("g1", Vec3(4, 0, 1.5), /*yaw*/ 0, 0, 0, 1.5, 1.5, 0.1);
//   if (cross_gate(g, p_before, p_after) == GateCrossing::kThrough) ++gates;
//   if (touches_frame(g, p_before, p_after, vehicle_radius_m)) crash();

#include <array>
#include <cstdint>
#include <string>

#include "dronetwin/core/types.hpp"

namespace dronetwin {

struct Gate {
  std::string name;
  Vec3 center_m = Vec3::Zero();  ///< centre of the opening
  /// Columns: passage direction n (gate x), width axis (gate y), up axis (gate z); orthonormal
  /// and right-handed.
  Mat3 axes = Mat3::Identity();
  double width_m = 1.0, height_m = 1.0;  ///< inner opening, along gate y and gate z
  double frame_width_m = 0.1;            ///< thickness of the bars around the opening

  Vec3 normal() const { return axes.col(0); }
  Vec3 width_axis() const { return axes.col(1); }
  Vec3 up_axis() const { return axes.col(2); }
  /// The opening's corners in the order (+y,+z), (-y,+z), (-y,-z), (+y,-z) of the gate axes.
  std::array<Vec3, 4> corners() const;
  /// Where the bars' axes meet, in the order of corners(): the frame is the four capsules of
  /// radius frame_width / 2 between consecutive ones.
  std::array<Vec3, 4> bar_corners() const;
  /// Radius of a sphere about center_m that holds the whole frame.
  double bounding_radius_m() const;
};

/// A gate from its centre, yaw/pitch/roll (rad; R = Rz(yaw) Ry(pitch) Rx(roll), yaw 0 passes
/// along +x) and sizes. InvalidArgument naming the value for non-finite numbers or sizes <= 0.
Gate make_gate(std::string name, const Vec3& center_m, double yaw_rad, double pitch_rad,
               double roll_rad, double width_m, double height_m, double frame_width_m);

enum class GateCrossing : std::uint8_t { kNone = 0, kThrough = 1, kBackwards = 2 };

/// How the segment from -> to crosses the gate: kThrough when `from` is behind the plane
/// (n . (from - c) < 0), `to` on or in front of it (>= 0) and the crossing point strictly inside
/// the opening (|y| < w/2, |z| < h/2 in gate axes); kBackwards for the opposite direction inside
/// the opening; kNone otherwise (beside it, parallel to it, not reaching it).
GateCrossing cross_gate(const Gate& g, const Vec3& from, const Vec3& to);

/// The frame is four capsules of radius frame_width / 2 whose axes run along the sides of the
/// rectangle (w + f) x (h + f) about the opening's centre, so the bars' inner faces are the
/// opening's edges. Smallest distance between the segment from -> to and the frame's surface
/// (negative inside a bar).
double frame_distance_m(const Gate& g, const Vec3& from, const Vec3& to);

/// True when a sphere of radius `radius_m` swept along from -> to touches the frame.
bool touches_frame(const Gate& g, const Vec3& from, const Vec3& to, double radius_m);

}  // namespace dronetwin
