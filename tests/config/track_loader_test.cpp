// Track files (config/track_loader.hpp): the shipped tracks load and the circuit meets what the
// racing task asks of it; malformed files are refused naming the field.

#include "dronetwin/config/track_loader.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

TEST(TrackLoader, TheCircuitIsAClosedLoopOfFacingGatesWithHeightChanges) {
  const Track t = load_track(test::source_path("config/tracks/circuit.yaml"));
  ASSERT_GE(t.gates.size(), 7u);
  EXPECT_TRUE(t.closed);
  double lo = 1e9, hi = -1e9;
  for (std::size_t i = 0; i < t.gates.size(); ++i) {
    const Gate& g = t.gates[i];
    lo = std::min(lo, g.center_m.z());
    hi = std::max(hi, g.center_m.z());
    // Each gate faces within 60 degrees of the direction from the gate before it (the start for
    // the first, on the first lap).
    const Vec3 from = i == 0 ? t.start_position_m : t.gates[i - 1].center_m;
    const Vec3 dir = (g.center_m - from).normalized();
    EXPECT_GT(dir.dot(g.normal()), std::cos(60.0 * M_PI / 180.0)) << g.name;
    for (const Vec3& c : g.corners()) {
      EXPECT_TRUE((c.array() > t.arena_min_m.array()).all()) << g.name;
      EXPECT_TRUE((c.array() < t.arena_max_m.array()).all()) << g.name;
    }
  }
  // ... and the closing leg, last gate to the first.
  const Vec3 back = (t.gates[0].center_m - t.gates.back().center_m).normalized();
  EXPECT_GT(back.dot(t.gates[0].normal()), std::cos(60.0 * M_PI / 180.0));
  EXPECT_GE(hi - lo, 1.0);
  EXPECT_GT(t.length_m(), 30.0);
}

TEST(TrackLoader, TheStraightTrackIsOpen) {
  const Track t = load_track(test::source_path("config/tracks/straight.yaml"));
  EXPECT_FALSE(t.closed);
  ASSERT_EQ(t.gates.size(), 3u);
  // Start at the origin, gates at x = 2, 5, 8: 8 m.
  EXPECT_DOUBLE_EQ(t.length_m(), 8.0);
}

TEST(TrackLoader, ObstaclesOfEveryShape) {
  const Track t = parse_track(R"(
name: t
arena: {min: [-5, -5, -1], max: [5, 5, 5]}
start: {position: [0, 0, 1]}
gates: [{position: [2, 0, 1], width_m: 1, height_m: 1}]
obstacles:
  - {type: box, center: [0, 3, 1], size: [2, 1, 2]}
  - {name: p, type: cylinder, center: [-3, 0, 2], radius_m: 0.5, height_m: 4}
  - {name: ball, type: sphere, center: [3, -3, 2], radius_m: 0.25}
)",
                              "t.yaml");
  ASSERT_EQ(t.obstacles.size(), 3u);
  EXPECT_EQ(t.obstacles[2].shape, Obstacle::Shape::kSphere);
  EXPECT_EQ(t.obstacles[2].half_size_m, Vec3(0.25, 0.25, 0.25));
  EXPECT_EQ(t.obstacles[0].half_size_m, Vec3(1, 0.5, 1));
  EXPECT_EQ(t.obstacles[1].shape, Obstacle::Shape::kCylinder);
  EXPECT_EQ(t.obstacles[1].half_size_m, Vec3(0.5, 0.5, 2));
  EXPECT_EQ(t.gates[0].name, "gate 0");
  EXPECT_EQ(t.gates[0].frame_width_m, 0.1);
}

TEST(TrackLoader, ASceneNeedsNoGates) {
  // An experiment's scene of obstacles alone (the racing task asks for gates itself).
  const Track t = parse_track(
      "name: room\narena: {min: [-5, -5, -1], max: [5, 5, 5]}\nstart: {position: [0, 0, 1]}\n"
      "obstacles: [{name: pillar, type: cylinder, center: [2, 0, 1], radius_m: 0.2, "
      "height_m: 2}]\n",
      "room.yaml");
  EXPECT_TRUE(t.gates.empty());
  ASSERT_EQ(t.obstacles.size(), 1u);
  EXPECT_EQ(t.obstacles[0].name, "pillar");
  EXPECT_EQ(parse_track("name: empty\narena: {min: [-1, -1, -1], max: [1, 1, 1]}\n"
                        "start: {position: [0, 0, 0]}\ngates: []\n",
                        "empty.yaml")
                .gates.size(),
            0u);
}

TEST(TrackLoader, MalformedFilesNameTheField) {
  const std::string head =
      "name: t\narena: {min: [-5, -5, -1], max: [5, 5, 5]}\nstart: {position: [0, 0, 1]}\n";
  const std::string gate = "gates: [{position: [2, 0, 1], width_m: 1, height_m: 1}]\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {head + "gates: [{position: [2, 0, 1], width_m: -1, height_m: 1}]\n", "gates[0].width_m"},
      {head + "gates: [{position: [2, 0], width_m: 1, height_m: 1}]\n", "gates[0].position"},
      {head + "gates: [{position: [2, 0, 1], width_m: 1}]\n", "height_m"},
      {head + "gates: [{position: [2, 0, 1], width_m: 1, height_m: 1, colour: red}]\n", "colour"},
      {head + "gates: {a: 1}\n", "gates: expected a list of gates"},
      {head + "gates: [{position: [9, 0, 1], width_m: 1, height_m: 1}]\n", "outside the arena"},
      {head + "gates: [{name: a, position: [2, 0, 1], width_m: 1, height_m: 1}, {name: a, "
              "position: [3, 0, 1], width_m: 1, height_m: 1}]\n",
       "gates[1].name"},
      {head + "gates: [{position: [2, 0, 1], width_m: 1, height_m: 1}, {position: [2, 0, 1], "
              "width_m: 1, height_m: 1}]\n",
       "gates[1].position"},
      {"name: t\narena: {min: [-5, -5, -1], max: [5, 5, 5]}\nstart: {position: [0, 0, 9]}\n" + gate,
       "start.position"},
      {"name: t\narena: {min: [5, -5, -1], max: [5, 5, 5]}\nstart: {position: [0, 0, 1]}\n" + gate,
       "arena.max"},
      {head + gate + "obstacles: [{type: cone, center: [0, 0, 0]}]\n", "obstacles[0].type"},
      {head + gate + "obstacles: [{type: box, center: [0, 0, 0], size: [1, 0, 1]}]\n",
       "obstacles[0].size"},
      {head + gate + "obstacles: [{type: cylinder, center: [0, 0, 0], radius_m: 1}]\n", "height_m"},
      {head + gate + "obstacles: [{type: sphere, center: [0, 0, 0], radius_m: 0}]\n",
       "obstacles[0].radius_m"},
      {head + gate + "obstacles: [{type: sphere, center: [0, 0, 0], size: [1, 1, 1]}]\n",
       "obstacles[0].size"},
      {head + gate + "laps: 3\n", "laps"},
  };
  for (const auto& [text, field] : cases) {
    try {
      parse_track(text, "bad.yaml");
      ADD_FAILURE() << "accepted:\n" << text;
    } catch (const InvalidArgument& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("bad.yaml"), std::string::npos) << m;
      EXPECT_NE(m.find(field), std::string::npos) << "expected '" << field << "' in: " << m;
    }
  }
  EXPECT_THROW(load_track("/nonexistent/track.yaml"), InvalidArgument);
}

}  // namespace
}  // namespace dronetwin
