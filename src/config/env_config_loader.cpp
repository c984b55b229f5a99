#include "dronetwin/config/env_config_loader.hpp"

#include <yaml-cpp/yaml.h>

#include <string_view>
#include <vector>

#include "dronetwin/config/controller_config.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/config/track_loader.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "experiment_parts.hpp"
#include "yaml_strict.hpp"

namespace dronetwin {

namespace {

using io_detail::Map;
using io_detail::Reader;
using Names = std::vector<std::string_view>;

Names top_level_keys() {
  Names k = {"description",
             "model",
             "task",
             "action",
             "observation",
             "gate_lookahead",
             "control_rate_hz",
             "episode_time_s",
             "observation_dtype",
             "normalized_actions",
             "relative_scale_m",
             "max_body_rate_rad_s",
             "max_thrust_to_weight",
             "se3_controller",
             "body_rate_gains",
             "vehicle_radius_m",
             "max_tilt_rad",
             "min_height_m",
             "arena",
             "hover",
             "trajectory",
             "racing",
             "reward",
             "randomization",
             "sensors"};
  for (std::string_view s : io_detail::kSimSettingKeys) k.push_back(s);
  return k;
}
const Names kArenaKeys = {"min", "max"};
const Names kHoverKeys = {"target_m", "target_range_m", "start_offset_m"};
const Names kTrajectoryKeys = {"reference", "time_offset_max_s"};
const Names kRacingKeys = {"track", "laps", "random_start_gate"};
const Names kRewardKeys = {"progress", "action_rate", "angular", "crash",
                           "gate",     "distance",    "alive"};
const Names kRandomizationKeys = {
    "mass_scale",         "inertia_scale", "thrust_scale", "motor_time_scale", "drag_scale",
    "wind_speed_max_m_s", "position_m",    "velocity_m_s", "attitude_rad",     "body_rate_rad_s"};
const Names kDtypes = {"float64", "float32"};

// Overrides merged into the file's tree: maps key by key, anything else replaced.
YAML::Node merged(const YAML::Node& base, const YAML::Node& over) {
  if (!base.IsMap() || !over.IsMap()) return YAML::Clone(over);
  YAML::Node out = YAML::Clone(base);
  for (const auto& kv : over) {
    const std::string key = kv.first.Scalar();
    const YAML::Node existing = base[key];
    out[key] = existing.IsDefined() ? merged(existing, kv.second) : YAML::Clone(kv.second);
  }
  return out;
}

Vec3 nonnegative3(const Reader& rd, const Map& m, std::string_view key, const std::string& unit) {
  const Vec3 v = rd.fixed<3>(m.get(key), m.path(key), unit);
  if ((v.array() < 0.0).any())
    rd.fail(m.get(key), m.path(key), "expected three numbers >= 0, got negative values");
  return v;
}

rl::Interval interval(const Reader& rd, const Map& m, std::string_view key) {
  const Eigen::Vector2d v = rd.fixed<2>(m.get(key), m.path(key), "lo, hi scale factors");
  if (!(v[0] > 0.0 && v[0] <= v[1]))
    rd.fail(m.get(key), m.path(key),
            "expected 0 < lo <= hi, got [" + io_detail::format_number(v[0]) + ", " +
                io_detail::format_number(v[1]) + "]");
  return {v[0], v[1]};
}

}  // namespace

EnvFile parse_env_config(const std::string& yaml_text, const std::string& source_name,
                         const std::string& overrides) {
  const std::string source = overrides.empty() ? source_name : source_name + " (with overrides)";
  const Reader rd(source);
  const std::string expected = "a map of environment settings";
  YAML::Node root = rd.parse(yaml_text, expected);
  if (!overrides.empty()) {
    const Reader over_rd(source_name + " overrides");
    const YAML::Node over = over_rd.parse(overrides, "a map of overrides");
    if (!over.IsMap()) over_rd.fail(over, "", "expected a map, got " + io_detail::describe(over));
    root = merged(root, over);
  }
  const Names keys = top_level_keys();
  const Map top = rd.map(root, "", keys, expected);
  // Files named in the text are found relative to the original file.
  const Reader files(source_name);

  EnvFile f;
  f.source = source_name;
  rl::EnvConfig& c = f.config;
  if (top.has("description")) f.description = rd.string(top.get("description"), "description");
  const std::string model_path =
      io_detail::find_named_file(files, top.required("model"), "model", "model");
  f.model = std::make_shared<const VehicleModel>(load_vehicle_model(model_path));

  io_detail::read_sim_settings(rd, top, c.sim);
  if (c.sim.payload.enabled)
    rd.fail(top.get("payload"), "payload",
            "the slung payload is flown by the Simulator (experiments), not by the batched engine "
            "the environments run on");
  c.seed = c.sim.seed;
  const auto name = [&](std::string_view key) { return rd.string(top.get(key), top.path(key)); };
  const auto checked = [&](std::string_view key, auto&& convert) {
    try {
      return convert(name(key));
    } catch (const InvalidArgument& e) {
      rd.fail(top.get(key), top.path(key), e.what());
    }
  };
  if (top.has("task")) c.task = checked("task", rl::task_from_name);
  if (top.has("action")) c.action = checked("action", rl::action_mode_from_name);
  if (top.has("observation")) {
    const YAML::Node list = top.get("observation");
    if (!list.IsSequence() || list.size() == 0)
      rd.fail(list, "observation",
              "expected a list of observation pieces, got " + io_detail::describe(list));
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string path = io_detail::item_path("observation", i);
      const std::string piece = rd.string(list[i], path);
      try {
        c.observation.push_back(rl::observation_piece_from_name(piece));
      } catch (const InvalidArgument& e) {
        rd.fail(list[i], path, e.what());
      }
    }
  }
  if (top.has("gate_lookahead"))
    c.gate_lookahead =
        rd.integer<int>(top.get("gate_lookahead"), "gate_lookahead", "an integer from 1 to 8");
  if (top.has("control_rate_hz"))
    c.control_rate_hz = rd.positive(top.get("control_rate_hz"), "control_rate_hz");
  if (top.has("episode_time_s"))
    c.episode_time_s = rd.positive(top.get("episode_time_s"), "episode_time_s");
  if (top.has("observation_dtype"))
    c.observation_float32 = rd.choice(top.get("observation_dtype"), "observation_dtype", kDtypes,
                                      "observation dtype") == 1;
  if (top.has("normalized_actions"))
    c.normalized_actions = rd.boolean(top.get("normalized_actions"), "normalized_actions");
  if (top.has("relative_scale_m"))
    c.relative_scale_m =
        rd.fixed<3>(top.get("relative_scale_m"), "relative_scale_m", "x, y, z in m");
  if (top.has("max_body_rate_rad_s"))
    c.max_body_rate_rad_s = rd.fixed<3>(top.get("max_body_rate_rad_s"), "max_body_rate_rad_s",
                                        "roll, pitch, yaw rates in rad/s");
  if (top.has("max_thrust_to_weight")) {
    c.max_thrust_to_weight = rd.number(top.get("max_thrust_to_weight"), "max_thrust_to_weight");
    if (c.max_thrust_to_weight < 0.0) {
      rd.fail(top.get("max_thrust_to_weight"), "max_thrust_to_weight",
              "expected a number >= 0 (0: the full rotor range), got " +
                  io_detail::format_number(c.max_thrust_to_weight));
    }
  }
  // SE(3) inner loop of the position modes: a controller file (its mass, or the model's).
  c.se3_gains.mass_kg = f.model->mass_kg();
  c.se3_options = Se3Options{};
  if (top.has("se3_controller")) {
    const std::string path = io_detail::find_named_file(files, top.get("se3_controller"),
                                                        "se3_controller", "controller");
    ControllerConfig cc;
    try {
      cc = load_controller_config(path);
    } catch (const InvalidArgument& e) {
      rd.fail(top.get("se3_controller"), "se3_controller",
              std::string("bad controller file: ") + e.what());
    }
    const auto* se3 = std::get_if<Se3Settings>(&cc.settings);
    if (se3 == nullptr)
      rd.fail(top.get("se3_controller"), "se3_controller",
              "expected a controller file of type se3, got type " +
                  std::string(controller_type_name(cc.type())));
    c.se3_gains = se3->gains;
    c.se3_gains.mass_kg = cc.mass_kg.value_or(f.model->mass_kg());
    c.se3_gains.gravity_m_s2 = cc.gravity_m_s2;
    c.se3_options = se3->options;
  }
  if (top.has("body_rate_gains"))
    c.rate_gains.rate_p =
        rd.fixed<3>(top.get("body_rate_gains"), "body_rate_gains", "K_w roll, pitch, yaw in 1/s");
  if (top.has("vehicle_radius_m"))
    c.vehicle_radius_m = rd.positive(top.get("vehicle_radius_m"), "vehicle_radius_m");
  if (top.has("max_tilt_rad"))
    c.max_tilt_rad = rd.positive(top.get("max_tilt_rad"), "max_tilt_rad");
  if (top.has("min_height_m")) c.min_height_m = rd.number(top.get("min_height_m"), "min_height_m");
  if (top.has("arena")) {
    const Map m = rd.map(top.get("arena"), "arena", kArenaKeys, "a map {min, max}");
    c.arena_min_m = rd.fixed<3>(m.required("min"), m.path("min"), "x, y, z in m");
    c.arena_max_m = rd.fixed<3>(m.required("max"), m.path("max"), "x, y, z in m");
  }
  if (top.has("hover")) {
    const Map m = rd.map(top.get("hover"), "hover", kHoverKeys, "a map of hover-task settings");
    if (m.has("target_m"))
      c.hover_target_m = rd.fixed<3>(m.get("target_m"), m.path("target_m"), "x, y, z in m");
    if (m.has("target_range_m"))
      c.hover_target_range_m = nonnegative3(rd, m, "target_range_m", "x, y, z in m");
    if (m.has("start_offset_m"))
      c.hover_start_offset_m =
          rd.fixed<3>(m.get("start_offset_m"), m.path("start_offset_m"), "x, y, z in m");
  }
  if (top.has("trajectory")) {
    const Map m = rd.map(top.get("trajectory"), "trajectory", kTrajectoryKeys,
                         "a map of trajectory-task settings");
    c.reference = io_detail::read_reference_spec(rd, m.required("reference"), m.path("reference"));
    if (m.has("time_offset_max_s")) {
      c.reference_time_offset_max_s =
          rd.number(m.get("time_offset_max_s"), m.path("time_offset_max_s"));
      if (c.reference_time_offset_max_s < 0.0)
        rd.fail(m.get("time_offset_max_s"), m.path("time_offset_max_s"), "expected a number >= 0");
    }
  }
  if (top.has("racing")) {
    const Map m = rd.map(top.get("racing"), "racing", kRacingKeys, "a map of racing-task settings");
    if (m.has("track")) {
      const YAML::Node t = m.get("track");
      const std::string path = io_detail::find_named_file(files, t, m.path("track"), "track");
      try {
        c.track = load_track(path);
      } catch (const InvalidArgument& e) {
        rd.fail(t, m.path("track"), std::string("bad track file: ") + e.what());
      }
    }
    if (m.has("laps"))
      c.laps = rd.integer<int>(m.get("laps"), m.path("laps"), "an integer >= 0 (0: no limit)");
    if (m.has("random_start_gate"))
      c.random_start_gate = rd.boolean(m.get("random_start_gate"), m.path("random_start_gate"));
  }
  if (top.has("reward")) {
    const Map m = rd.map(top.get("reward"), "reward", kRewardKeys, "a map of reward weights");
    rl::RewardWeights& w = c.reward;
    const auto weight = [&](std::string_view key, double& out) {
      if (m.has(key)) out = rd.number(m.get(key), m.path(key));
    };
    weight("progress", w.progress);
    weight("action_rate", w.action_rate);
    weight("angular", w.angular);
    weight("crash", w.crash);
    weight("gate", w.gate);
    weight("distance", w.distance);
    weight("alive", w.alive);
  }
  if (top.has("randomization")) {
    const Map m = rd.map(top.get("randomization"), "randomization", kRandomizationKeys,
                         "a map of randomisation ranges");
    rl::Randomization& r = c.randomization;
    if (m.has("mass_scale")) r.mass_scale = interval(rd, m, "mass_scale");
    if (m.has("inertia_scale")) r.inertia_scale = interval(rd, m, "inertia_scale");
    if (m.has("thrust_scale")) r.thrust_scale = interval(rd, m, "thrust_scale");
    if (m.has("motor_time_scale")) r.motor_time_scale = interval(rd, m, "motor_time_scale");
    if (m.has("drag_scale")) r.drag_scale = interval(rd, m, "drag_scale");
    if (m.has("wind_speed_max_m_s")) {
      r.wind_speed_max_m_s = rd.number(m.get("wind_speed_max_m_s"), m.path("wind_speed_max_m_s"));
      if (r.wind_speed_max_m_s < 0.0)
        rd.fail(m.get("wind_speed_max_m_s"), m.path("wind_speed_max_m_s"),
                "expected a number >= 0");
    }
    if (m.has("position_m")) r.position_m = nonnegative3(rd, m, "position_m", "+- x, y, z in m");
    if (m.has("velocity_m_s"))
      r.velocity_m_s = nonnegative3(rd, m, "velocity_m_s", "+- x, y, z in m/s");
    if (m.has("attitude_rad"))
      r.attitude_rad = nonnegative3(rd, m, "attitude_rad", "+- roll, pitch, yaw in rad");
    if (m.has("body_rate_rad_s"))
      r.body_rate_rad_s = nonnegative3(rd, m, "body_rate_rad_s", "+- x, y, z in rad/s");
  }
  if (top.has("sensors")) {
    // They sample at most once per env step: their rates are checked against it.
    c.sensors = io_detail::read_sensor_list(rd, top.get("sensors"), "sensors",
                                            1.0 / c.control_rate_hz, &c.depth_cameras);
  }
  try {
    rl::validate(c);
  } catch (const InvalidArgument& e) {
    throw InvalidArgument(source + ": " + e.what());
  }
  return f;
}

EnvFile load_env_config(const std::string& path, const std::string& overrides) {
  return parse_env_config(read_text_file(path, "environment file"), path, overrides);
}

}  // namespace dronetwin
