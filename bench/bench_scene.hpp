#pragma once
// The scene the ray-casting and depth-camera benchmarks render: the racing circuit
// (config/tracks/circuit.yaml: 8 gates, 32 bars) with 12 obstacles added (8 pillars, 4 boxes).

#include <string>

#include "dronetwin/config/track_loader.hpp"
#include "dronetwin/world/track.hpp"

namespace dronetwin::bench {

inline Track circuit_with_obstacles() {
  Track t = load_track(std::string(DRONETWIN_SOURCE_DIR) + "/config/tracks/circuit.yaml");
  for (int i = 0; i < 8; ++i) {
    Obstacle o;
    o.shape = Obstacle::Shape::kCylinder;
    o.name = "pillar " + std::to_string(i);
    o.center_m = Vec3(-6.0 + 1.7 * i, i % 2 ? 3.0 : -3.0, 2.0);
    o.half_size_m = Vec3(0.2, 0.2, 2.0);
    t.obstacles.push_back(o);
  }
  for (int i = 0; i < 4; ++i) {
    Obstacle o;
    o.name = "box " + std::to_string(i);
    o.center_m = Vec3(-4.0 + 2.5 * i, 0.0, 0.5);
    o.half_size_m = Vec3(0.5, 0.5, 0.5);
    t.obstacles.push_back(o);
  }
  return t;
}

}  // namespace dronetwin::bench
