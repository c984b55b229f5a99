#include "dronetwin/config/track_loader.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <set>
#include <string_view>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/core/vec_text.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "yaml_strict.hpp"

namespace dronetwin {

namespace {

using io_detail::Map;
using io_detail::Reader;
using Names = std::vector<std::string_view>;

const Names kTopKeys = {"name",  "description",   "closed", "arena",
                        "start", "frame_width_m", "gates",  "obstacles"};
const Names kArenaKeys = {"min", "max"};
const Names kStartKeys = {"position", "yaw_deg"};
const Names kGateKeys = {"name",     "position", "yaw_deg",  "pitch_deg",
                         "roll_deg", "width_m",  "height_m", "frame_width_m"};
const Names kObstacleKeys = {"name", "type", "center", "size", "radius_m", "height_m"};
const Names kObstacleTypes = {"box", "cylinder", "sphere"};

constexpr double kDeg = M_PI / 180.0;

}  // namespace

Track parse_track(const std::string& yaml_text, const std::string& source_name) {
  const Reader rd(source_name);
  const std::string expected = "a map of track settings";
  const YAML::Node root = rd.parse(yaml_text, expected);
  const Map top = rd.map(root, "", kTopKeys, expected);
  Track t;
  t.name = rd.string(top.required("name"), "name");
  if (top.has("description")) t.description = rd.string(top.get("description"), "description");
  if (top.has("closed")) t.closed = rd.boolean(top.get("closed"), "closed");
  const Map arena = rd.map(top.required("arena"), "arena", kArenaKeys, "a map {min, max}");
  t.arena_min_m = rd.fixed<3>(arena.required("min"), arena.path("min"), "x, y, z in m");
  t.arena_max_m = rd.fixed<3>(arena.required("max"), arena.path("max"), "x, y, z in m");
  if (!(t.arena_min_m.array() < t.arena_max_m.array()).all())
    rd.fail(arena.get("max"), arena.path("max"),
            "expected max > min on every axis, got min " + vec_text(t.arena_min_m) + ", max " +
                vec_text(t.arena_max_m));
  const auto inside = [&](const Vec3& p) {
    return (p.array() > t.arena_min_m.array()).all() && (p.array() < t.arena_max_m.array()).all();
  };
  const Map start = rd.map(top.required("start"), "start", kStartKeys, "a map {position, yaw_deg}");
  t.start_position_m =
      rd.fixed<3>(start.required("position"), start.path("position"), "x, y, z in m");
  if (start.has("yaw_deg"))
    t.start_yaw_rad = rd.number(start.get("yaw_deg"), start.path("yaw_deg")) * kDeg;
  if (!inside(t.start_position_m))
    rd.fail(start.get("position"), start.path("position"),
            "the start " + vec_text(t.start_position_m) + " is outside the arena");
  const double frame =
      top.has("frame_width_m") ? rd.positive(top.get("frame_width_m"), "frame_width_m") : 0.1;

  // No gates is a scene of obstacles (an experiment's `scene:`); the racing task asks for gates
  // itself (rl::validate).
  const YAML::Node gates =
      top.has("gates") ? top.get("gates") : YAML::Node(YAML::NodeType::Sequence);
  if (!gates.IsSequence())
    rd.fail(gates, "gates", "expected a list of gates, got " + io_detail::describe(gates));
  std::set<std::string> names;
  for (std::size_t i = 0; i < gates.size(); ++i) {
    const std::string path = io_detail::item_path("gates", i);
    const Map g = rd.map(gates[i], path, kGateKeys, "a map of gate settings");
    const std::string name =
        g.has("name") ? rd.string(g.get("name"), g.path("name")) : "gate " + std::to_string(i);
    if (!names.insert(name).second)
      rd.fail(g.get("name"), g.path("name"), "gate name '" + name + "' is used twice");
    const Vec3 c = rd.fixed<3>(g.required("position"), g.path("position"), "x, y, z in m");
    const auto angle = [&](std::string_view key) {
      return g.has(key) ? rd.number(g.get(key), g.path(key)) * kDeg : 0.0;
    };
    const double w = rd.positive(g.required("width_m"), g.path("width_m"));
    const double h = rd.positive(g.required("height_m"), g.path("height_m"));
    const double f = g.has("frame_width_m")
                         ? rd.positive(g.get("frame_width_m"), g.path("frame_width_m"))
                         : frame;
    Gate gate =
        make_gate(name, c, angle("yaw_deg"), angle("pitch_deg"), angle("roll_deg"), w, h, f);
    for (const Vec3& k : gate.corners())
      if (!inside(k))
        rd.fail(g.get("position"), g.path("position"),
                "the gate's opening reaches outside the arena (corner " + vec_text(k) + ")");
    if (!t.gates.empty() && (t.gates.back().center_m - c).norm() < 1e-6)
      rd.fail(g.get("position"), g.path("position"),
              "at the same place as the gate before it (" + vec_text(c) + ")");
    t.gates.push_back(std::move(gate));
  }
  if (t.closed && t.gates.size() > 1 &&
      (t.gates.back().center_m - t.gates.front().center_m).norm() < 1e-6)
    rd.fail(gates, "gates", "the last gate is at the first one's place on a closed track");

  if (top.has("obstacles")) {
    const YAML::Node list = top.get("obstacles");
    if (!list.IsSequence())
      rd.fail(list, "obstacles", "expected a list of obstacles, got " + io_detail::describe(list));
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string path = io_detail::item_path("obstacles", i);
      const Map m = rd.map(list[i], path, kObstacleKeys, "a map of obstacle settings");
      Obstacle o;
      o.name = m.has("name") ? rd.string(m.get("name"), m.path("name"))
                             : "obstacle " + std::to_string(i);
      const std::size_t type =
          rd.choice(m.required("type"), m.path("type"), kObstacleTypes, "obstacle type");
      const bool box = type == 0;
      o.shape = box ? Obstacle::Shape::kBox
                    : (type == 1 ? Obstacle::Shape::kCylinder : Obstacle::Shape::kSphere);
      o.center_m = rd.fixed<3>(m.required("center"), m.path("center"), "x, y, z in m");
      if (o.shape == Obstacle::Shape::kSphere) {
        for (std::string_view k : {"size", "height_m"})
          if (m.has(k))
            rd.fail(m.get(k), m.path(k), "not a sphere key (a sphere has center and radius_m)");
        const double r = rd.positive(m.required("radius_m"), m.path("radius_m"));
        o.half_size_m = Vec3(r, r, r);
      } else if (box) {
        for (std::string_view k : {"radius_m", "height_m"})
          if (m.has(k)) rd.fail(m.get(k), m.path(k), "not a box key (a box has center and size)");
        const Vec3 size = rd.fixed<3>(m.required("size"), m.path("size"), "x, y, z extents in m");
        if (!(size.array() > 0.0).all())
          rd.fail(m.get("size"), m.path("size"),
                  "expected three positive extents, got " + vec_text(size));
        o.half_size_m = 0.5 * size;
      } else {
        if (m.has("size"))
          rd.fail(m.get("size"), m.path("size"),
                  "not a cylinder key (a cylinder has center, radius_m and height_m)");
        const double r = rd.positive(m.required("radius_m"), m.path("radius_m"));
        const double h = rd.positive(m.required("height_m"), m.path("height_m"));
        o.half_size_m = Vec3(r, r, 0.5 * h);
      }
      t.obstacles.push_back(std::move(o));
    }
  }
  return t;
}

Track load_track(const std::string& path) {
  return parse_track(read_text_file(path, "track file"), path);
}

}  // namespace dronetwin
