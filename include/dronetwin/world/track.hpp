#pragma once
// A racing track: gates in racing order, a start pose, the arena, obstacles. Plain data; read
// from YAML by config/track_loader.hpp (docs/track-format.md).

#include <string>
#include <vector>

#include "dronetwin/world/gate.hpp"
#include "dronetwin/world/obstacle.hpp"

namespace dronetwin {

struct Track {
  std::string name, description;
  std::vector<Gate> gates;  ///< in racing order
  bool closed = true;       ///< after the last gate the first comes again (laps)
  Vec3 start_position_m = Vec3::Zero();
  double start_yaw_rad = 0.0;
  Vec3 arena_min_m = Vec3::Zero(), arena_max_m = Vec3::Zero();  ///< leaving it ends an episode
  std::vector<Obstacle> obstacles;

  /// Centre-to-centre length from the start through every gate (and back to the first gate
  /// when closed), m.
  double length_m() const {
    double L = 0.0;
    Vec3 at = start_position_m;
    for (const Gate& g : gates) {
      L += (g.center_m - at).norm();
      at = g.center_m;
    }
    if (closed && !gates.empty()) L += (gates.front().center_m - at).norm();
    return L;
  }
};

}  // namespace dronetwin
