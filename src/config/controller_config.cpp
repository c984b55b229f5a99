// Strict YAML binding of controller files (format: docs/controllers.md), on the shared strict
// reader of yaml_strict.hpp. Every error starts with the source file and names the field path.
#include "dronetwin/config/controller_config.hpp"

#include <yaml-cpp/yaml.h>

#include <array>
#include <cmath>
#include <numbers>
#include <string_view>
#include <utility>

#include "dronetwin/config/env_config_loader.hpp"
#include "dronetwin/config/policy_io.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "experiment_parts.hpp"
#include "yaml_strict.hpp"

namespace dronetwin {
namespace {

using io_detail::Map;
using io_detail::NameList;
using io_detail::Reader;

/// One of `names`; "expected one of a, b, got 'c'" otherwise. Returns the index.
std::size_t choice(const Reader& rd, const YAML::Node& node, const std::string& path,
                   NameList names) {
  if (node.IsScalar()) {
    for (std::size_t i = 0; i < names.size(); ++i)
      if (names[i] == node.Scalar()) return i;
    rd.fail(node, path,
            "expected one of " + io_detail::name_list(names) + ", got '" + node.Scalar() + "'");
  }
  rd.fail(node, path,
          "expected one of " + io_detail::name_list(names) + ", got " + io_detail::describe(node));
}

/// Exactly N finite numbers >= 0 (> 0 with `positive_only`); `meaning` names the components.
/// "expected 4 numbers [x, y, z, psi], got 3".
template <int N>
Eigen::Matrix<double, N, 1> gains(const Reader& rd, const YAML::Node& node, const std::string& path,
                                  const std::string& meaning, bool positive_only = false) {
  const std::string expected = "expected " + std::to_string(N) + " numbers [" + meaning + "]";
  if (!node.IsSequence()) rd.fail(node, path, expected + ", got " + io_detail::describe(node));
  if (node.size() != static_cast<std::size_t>(N))
    rd.fail(node, path, expected + ", got " + std::to_string(node.size()));
  Eigen::Matrix<double, N, 1> out;
  for (std::size_t i = 0; i < static_cast<std::size_t>(N); ++i) {
    const std::string item = io_detail::item_path(path, i);
    const double v = rd.number(node[i], item);
    if (positive_only && !(v > 0.0))
      rd.fail(node[i], item, "expected a number > 0, got " + node[i].Scalar());
    if (v < 0.0) rd.fail(node[i], item, "expected a gain >= 0, got " + node[i].Scalar());
    out[static_cast<Eigen::Index>(i)] = v;
  }
  return out;
}

/// A tilt limit in (0, pi/2) rad.
double tilt(const Reader& rd, const YAML::Node& node, const std::string& path) {
  const double v = rd.number(node, path);
  if (!(v > 0.0 && v < std::numbers::pi / 2))
    rd.fail(node, path, "expected an angle in (0, pi/2) rad, got " + node.Scalar());
  return v;
}

// ---- key tables -------------------------------------------------------------------------------

constexpr std::array<std::string_view, 4> kTypes = {"pid", "se3", "nmpc", "policy"};
constexpr std::array<std::string_view, 18> kTopKeys = {
    "type",   "description", "allocation",    "mass_kg",  "gravity_m_s2", "gains",
    "limits", "options",     "horizon",       "weights",  "solver",       "disturbance",
    "policy", "env",         "env_overrides", "training", "payload",      "inner_loop"};
constexpr std::array<std::string_view, 4> kPolicyOnlyKeys = {"policy", "env", "env_overrides",
                                                             "training"};
constexpr std::array<std::string_view, 2> kAllocations = {"exact", "thesis"};

constexpr std::array<std::string_view, 6> kPidGainKeys = {"outer_p", "outer_d",  "outer_i",
                                                          "inner_p", "inner_d1", "inner_d2"};
constexpr std::array<std::string_view, 2> kPidLimitKeys = {"max_tilt_rad", "integral_limit"};
constexpr std::array<std::string_view, 8> kPidOptionKeys = {
    "conditional_integration", "yaw_error_wrap",   "velocity_feedforward",
    "yaw_frame_mapping",       "yaw_loop",         "acceleration_feed_forward",
    "angular_feed_forward",    "drag_feed_forward"};
constexpr std::array<std::string_view, 2> kYawLoops = {"thesis", "rate"};

constexpr std::array<std::string_view, 4> kSe3GainKeys = {"position_p", "position_d", "attitude_p",
                                                          "attitude_d"};
constexpr std::array<std::string_view, 2> kSe3LimitKeys = {"max_tilt_rad", "min_thrust_N"};
constexpr std::array<std::string_view, 4> kSe3OptionKeys = {
    "gravity_compensation", "nonnegative_thrust", "angular_feed_forward", "drag_feed_forward"};
constexpr std::array<std::string_view, 3> kSe3PayloadKeys = {"mass_kg", "tether_length_m",
                                                             "shape_reference"};

constexpr std::array<std::string_view, 3> kNmpcHorizonKeys = {"steps", "step_s", "input_blocks"};
constexpr std::array<std::string_view, 4> kNmpcWeightKeys = {"state", "input", "terminal_scale",
                                                             "tilt_penalty"};
constexpr std::array<std::string_view, 3> kNmpcLimitKeys = {"thrust_N", "max_tilt_rad",
                                                            "max_moment_Nm"};
constexpr std::array<std::string_view, 4> kNmpcSolverKeys = {"max_iterations", "max_solve_time_s",
                                                             "function_tolerance", "linear_solver"};
constexpr std::array<std::string_view, 4> kNmpcDisturbanceKeys = {
    "gain", "max_m_s2", "moment_time_constant_s", "max_moment_Nm"};
constexpr std::array<std::string_view, 2> kLinearSolvers = {"dense_normal_cholesky", "dense_qr"};
constexpr std::array<std::string_view, 5> kNmpcOnlyKeys = {"horizon", "weights", "solver",
                                                           "disturbance", "inner_loop"};
constexpr std::array<std::string_view, 1> kNmpcInnerLoopKeys = {"feed_forward"};

const char* const kOuter = "x, y, z, psi";
const char* const kInner = "roll, pitch, yaw";
const char* const kXyz = "x, y, z";

void read_pid(const Reader& rd, const Map& top, PidSettings& c) {
  const Map g = rd.map(top.required("gains"), "gains", kPidGainKeys, "a map of PID gains");
  const auto vec4 = [&](std::string_view key) {
    return gains<4>(rd, g.required(key), g.path(key), kOuter);
  };
  const auto vec3 = [&](std::string_view key) {
    return gains<3>(rd, g.required(key), g.path(key), kInner);
  };
  PidGains& pg = c.gains;
  pg.outer_p = vec4("outer_p");
  pg.outer_d = vec4("outer_d");
  pg.outer_i = vec4("outer_i");
  pg.inner_p = vec3("inner_p");
  pg.inner_d1 = vec3("inner_d1");
  pg.inner_d2 = vec3("inner_d2");

  PidOptions& o = c.options;
  if (top.has("limits")) {
    const Map l = rd.map(top.get("limits"), "limits", kPidLimitKeys, "a map of limits");
    if (l.has("max_tilt_rad"))
      o.max_tilt_rad = tilt(rd, l.get("max_tilt_rad"), l.path("max_tilt_rad"));
    if (l.has("integral_limit"))
      o.integral_limit = gains<4>(rd, l.get("integral_limit"), l.path("integral_limit"),
                                  "x, y, z in m s, psi in rad s", /*positive_only=*/true);
  }
  if (top.has("options")) {
    const Map p = rd.map(top.get("options"), "options", kPidOptionKeys, "a map of options");
    const auto flag = [&](std::string_view key, bool& out) {
      if (p.has(key)) out = rd.boolean(p.get(key), p.path(key));
    };
    flag("conditional_integration", o.conditional_integration);
    flag("yaw_error_wrap", o.yaw_error_wrap);
    flag("velocity_feedforward", o.velocity_feedforward);
    flag("yaw_frame_mapping", o.yaw_frame_mapping);
    flag("acceleration_feed_forward", o.acceleration_feed_forward);
    flag("angular_feed_forward", o.angular_feed_forward);
    flag("drag_feed_forward", o.drag_feed_forward);
    if (p.has("yaw_loop"))
      o.yaw_loop = choice(rd, p.get("yaw_loop"), p.path("yaw_loop"), kYawLoops) == 0
                       ? PidYawLoop::kThesis
                       : PidYawLoop::kRate;
  }
}

void read_se3(const Reader& rd, const Map& top, Se3Settings& c) {
  const Map g = rd.map(top.required("gains"), "gains", kSe3GainKeys, "a map of SE(3) gains");
  const auto vec3 = [&](std::string_view key, const char* meaning) {
    return gains<3>(rd, g.required(key), g.path(key), meaning);
  };
  Se3Gains& sg = c.gains;
  sg.position_p = vec3("position_p", kXyz);
  sg.position_d = vec3("position_d", kXyz);
  sg.attitude_p = vec3("attitude_p", kInner);
  sg.attitude_d = vec3("attitude_d", kInner);

  Se3Options& o = c.options;
  if (top.has("limits")) {
    const Map l = rd.map(top.get("limits"), "limits", kSe3LimitKeys, "a map of limits");
    if (l.has("max_tilt_rad"))
      o.max_tilt_rad = tilt(rd, l.get("max_tilt_rad"), l.path("max_tilt_rad"));
    if (l.has("min_thrust_N"))
      o.min_thrust_N = rd.positive(l.get("min_thrust_N"), l.path("min_thrust_N"));
  }
  if (top.has("payload")) {
    const Map p = rd.map(top.get("payload"), "payload", kSe3PayloadKeys,
                         "a map of payload settings (mass_kg, tether_length_m, shape_reference)");
    if (p.has("mass_kg")) {
      const YAML::Node n = p.get("mass_kg");
      o.payload_mass_kg = rd.number(n, p.path("mass_kg"));
      if (o.payload_mass_kg < 0.0)
        rd.fail(n, p.path("mass_kg"), "expected a mass >= 0, got " + n.Scalar());
    }
    if (p.has("tether_length_m"))
      o.payload_tether_length_m = rd.positive(p.get("tether_length_m"), p.path("tether_length_m"));
    if (p.has("shape_reference")) {
      o.shape_reference_for_payload =
          rd.boolean(p.get("shape_reference"), p.path("shape_reference"));
      if (o.shape_reference_for_payload && !(o.payload_mass_kg > 0.0 && p.has("tether_length_m")))
        rd.fail(p.get("shape_reference"), p.path("shape_reference"),
                "shaping needs the payload's mass_kg > 0 and tether_length_m");
    }
  }
  if (top.has("options")) {
    const Map p = rd.map(top.get("options"), "options", kSe3OptionKeys, "a map of options");
    if (p.has("gravity_compensation"))
      o.gravity_compensation =
          rd.boolean(p.get("gravity_compensation"), p.path("gravity_compensation"));
    if (p.has("nonnegative_thrust"))
      o.nonnegative_thrust = rd.boolean(p.get("nonnegative_thrust"), p.path("nonnegative_thrust"));
    if (p.has("angular_feed_forward"))
      o.angular_feed_forward =
          rd.boolean(p.get("angular_feed_forward"), p.path("angular_feed_forward"));
    if (p.has("drag_feed_forward"))
      o.drag_feed_forward = rd.boolean(p.get("drag_feed_forward"), p.path("drag_feed_forward"));
  }
}

void read_nmpc(const Reader& rd, const Map& top, NmpcSettings& c) {
  NmpcOptions& o = c.options;
  if (top.has("options")) rd.fail(top.get("options"), "options", "not used by type nmpc");

  const Map h = rd.map(top.required("horizon"), "horizon", kNmpcHorizonKeys,
                       "a map with steps, step_s and optionally input_blocks");
  o.horizon_steps = rd.integer<int>(h.required("steps"), h.path("steps"), "an integer >= 1");
  if (o.horizon_steps < 1)
    rd.fail(h.get("steps"), h.path("steps"),
            "expected an integer >= 1, got " + std::to_string(o.horizon_steps));
  o.step_s = rd.positive(h.required("step_s"), h.path("step_s"));
  if (h.has("input_blocks")) {
    const YAML::Node n = h.get("input_blocks");
    const std::string path = h.path("input_blocks");
    if (!n.IsSequence() || n.size() == 0)
      rd.fail(n, path, "expected a non-empty list of block lengths, got " + io_detail::describe(n));
    long sum = 0;
    o.input_blocks.clear();
    for (std::size_t i = 0; i < n.size(); ++i) {
      const std::string item = io_detail::item_path(path, i);
      const int len = rd.integer<int>(n[i], item, "an integer >= 1");
      if (len < 1) rd.fail(n[i], item, "expected an integer >= 1, got " + std::to_string(len));
      o.input_blocks.push_back(len);
      sum += len;
    }
    if (sum != o.horizon_steps)
      rd.fail(n, path,
              "block lengths sum to " + std::to_string(sum) +
                  "; expected horizon.steps = " + std::to_string(o.horizon_steps));
  }

  const Map w = rd.map(top.required("weights"), "weights", kNmpcWeightKeys,
                       "a map with state, input and optionally terminal_scale");
  o.state_weights =
      gains<13>(rd, w.required("state"), w.path("state"), "p (3), v (3), q (4), w (3)");
  o.input_weights = gains<6>(rd, w.required("input"), w.path("input"), "F (3), M (3)");
  if (w.has("terminal_scale")) {
    o.terminal_weight_scale = rd.number(w.get("terminal_scale"), w.path("terminal_scale"));
    if (o.terminal_weight_scale < 0.0)
      rd.fail(w.get("terminal_scale"), w.path("terminal_scale"),
              "expected a number >= 0, got " + w.get("terminal_scale").Scalar());
  }

  if (w.has("tilt_penalty")) {
    o.tilt_penalty_weight = rd.number(w.get("tilt_penalty"), w.path("tilt_penalty"));
    if (o.tilt_penalty_weight < 0.0)
      rd.fail(w.get("tilt_penalty"), w.path("tilt_penalty"),
              "expected a number >= 0, got " + w.get("tilt_penalty").Scalar());
  }
  if (top.has("disturbance")) {
    const Map d =
        rd.map(top.get("disturbance"), "disturbance", kNmpcDisturbanceKeys,
               "a map with gain and optionally max_m_s2, moment_time_constant_s, max_moment_Nm");
    o.disturbance_gain = rd.number(d.required("gain"), d.path("gain"));
    if (!(o.disturbance_gain >= 0.0 && o.disturbance_gain <= 1.0))
      rd.fail(d.get("gain"), d.path("gain"),
              "expected a number in [0, 1], got " + d.get("gain").Scalar());
    if (d.has("max_m_s2"))
      o.max_disturbance_m_s2 = rd.positive(d.get("max_m_s2"), d.path("max_m_s2"));
    if (d.has("moment_time_constant_s"))
      o.moment_observer_time_constant_s =
          rd.positive(d.get("moment_time_constant_s"), d.path("moment_time_constant_s"));
    if (d.has("max_moment_Nm"))
      o.max_moment_disturbance_Nm = rd.positive(d.get("max_moment_Nm"), d.path("max_moment_Nm"));
  }

  if (top.has("inner_loop")) {
    const Map il =
        rd.map(top.get("inner_loop"), "inner_loop", kNmpcInnerLoopKeys, "a map with feed_forward");
    if (il.has("feed_forward"))
      o.inner_feed_forward = rd.boolean(il.get("feed_forward"), il.path("feed_forward"));
  }

  const Map g = rd.map(top.required("gains"), "gains", kSe3GainKeys,
                       "a map of SE(3) gains (inner loop and fallback)");
  const auto vec3 = [&](std::string_view key, const char* meaning) {
    return gains<3>(rd, g.required(key), g.path(key), meaning);
  };
  o.se3.position_p = vec3("position_p", kXyz);
  o.se3.position_d = vec3("position_d", kXyz);
  o.se3.attitude_p = vec3("attitude_p", kInner);
  o.se3.attitude_d = vec3("attitude_d", kInner);

  if (top.has("limits")) {
    const Map l = rd.map(top.get("limits"), "limits", kNmpcLimitKeys, "a map of limits");
    if (l.has("thrust_N")) {
      const Eigen::Vector2d t = gains<2>(rd, l.get("thrust_N"), l.path("thrust_N"), "min, max in N",
                                         /*positive_only=*/true);
      o.min_thrust_N = t[0];
      o.max_thrust_N = t[1];
    }
    if (l.has("max_tilt_rad"))
      o.max_tilt_rad = tilt(rd, l.get("max_tilt_rad"), l.path("max_tilt_rad"));
    if (l.has("max_moment_Nm"))
      o.max_moment_Nm = gains<3>(rd, l.get("max_moment_Nm"), l.path("max_moment_Nm"), kInner,
                                 /*positive_only=*/true);
    if (l.has("thrust_N") && !(o.max_thrust_N * std::cos(o.max_tilt_rad) > o.min_thrust_N))
      rd.fail(l.get("thrust_N"), l.path("thrust_N"),
              "expected max cos(max_tilt_rad) > min (room for a tilted thrust), got [" +
                  l.get("thrust_N")[0].Scalar() + ", " + l.get("thrust_N")[1].Scalar() + "]");
  }

  if (top.has("solver")) {
    const Map p = rd.map(top.get("solver"), "solver", kNmpcSolverKeys, "a map of solver settings");
    if (p.has("max_iterations"))
      o.max_iterations =
          rd.integer<int>(p.get("max_iterations"), p.path("max_iterations"), "an integer >= 0");
    if (o.max_iterations < 0)
      rd.fail(p.get("max_iterations"), p.path("max_iterations"),
              "expected an integer >= 0, got " + std::to_string(o.max_iterations));
    if (p.has("max_solve_time_s"))
      o.max_solve_time_s = rd.positive(p.get("max_solve_time_s"), p.path("max_solve_time_s"));
    if (p.has("function_tolerance"))
      o.function_tolerance = rd.positive(p.get("function_tolerance"), p.path("function_tolerance"));
    if (p.has("linear_solver"))
      o.linear_solver =
          choice(rd, p.get("linear_solver"), p.path("linear_solver"), kLinearSolvers) == 0
              ? NmpcLinearSolver::kDenseNormalCholesky
              : NmpcLinearSolver::kDenseQr;
  }
}

// `type: policy`: the policy file and the env it was trained in, read and matched now so that a
// mismatch is named with this file.
void read_policy_settings(const Reader& rd, const Map& top, PolicySettings& p) {
  for (const std::string_view key : {"gains", "limits", "options", "allocation", "mass_kg"})
    if (top.has(key)) rd.fail(top.get(key), std::string(key), "not used by type policy");
  p.policy_path =
      io_detail::find_named_file(rd, top.required("policy"), "policy", "policy (.dtpolicy)");
  // An environment file names a controller file (se3_controller) and this one names an
  // environment: a loop of such files would recurse without end.
  thread_local int depth = 0;
  if (depth >= 4) rd.fail("policy", "controller and environment files name each other in a loop");
  ++depth;
  struct Leave {
    ~Leave() { --depth; }
  } leave;
  // The env: a training file's `env` and `env_overrides` (the rest of it is the trainer's), or
  // the same two keys here.
  if (top.has("training") == top.has("env")) {
    rd.fail(top.has("env") ? "env" : "training",
            "expected either training (the policy's training file) or env (its environment "
            "file), not both and not neither");
  }
  const std::string where = top.has("training") ? "training" : "env";
  YAML::Node overrides_node;
  if (top.has("training")) {
    const std::string training =
        io_detail::find_named_file(rd, top.get("training"), "training", "training");
    const Reader trd(training);
    YAML::Node t;
    try {
      t = trd.parse(read_text_file(training, "training file"), "a map of training settings");
    } catch (const InvalidArgument& e) {
      rd.fail(top.get("training"), "training", std::string("bad training file: ") + e.what());
    }
    if (!t.IsMap() || !t["env"])
      rd.fail(top.get("training"), "training", "the training file " + training + " has no env");
    overrides_node = t["env_overrides"];
    p.env_path = io_detail::find_named_file(trd, t["env"], "env", "environment");
  } else {
    if (top.has("env_overrides")) overrides_node = top.get("env_overrides");
    p.env_path = io_detail::find_named_file(rd, top.get("env"), "env", "environment");
  }
  std::string overrides;
  if (overrides_node && !overrides_node.IsNull()) {
    if (!overrides_node.IsMap())
      rd.fail(overrides_node, "env_overrides",
              "expected a map of environment keys, got " + io_detail::describe(overrides_node));
    YAML::Emitter out;
    out << YAML::Flow << overrides_node;
    overrides = out.c_str();
  }
  EnvFile env;
  try {
    env = load_env_config(p.env_path, overrides);
  } catch (const InvalidArgument& e) {
    rd.fail(top.get(where), where, std::string("bad environment file: ") + e.what());
  }
  p.env = env.config;
  try {
    p.policy = std::make_shared<const PolicyFile>(read_policy(p.policy_path));
  } catch (const InvalidArgument& e) {
    rd.fail(top.get("policy"), "policy", std::string("bad policy file: ") + e.what());
  }
}

}  // namespace

ControllerConfig parse_controller_config(const std::string& yaml_text,
                                         const std::string& source_name) {
  const Reader rd(source_name);
  const std::string expected = "a map of controller settings";
  const Map top = rd.map(rd.parse(yaml_text, expected), "", kTopKeys, expected);
  ControllerConfig c;
  c.source = source_name;
  const std::size_t type = choice(rd, top.required("type"), "type", kTypes);
  if (type != 2)
    for (const std::string_view key : kNmpcOnlyKeys)
      if (top.has(key)) rd.fail(top.get(key), std::string(key), "only for type nmpc");
  if (type != 1 && top.has("payload"))
    rd.fail(top.get("payload"), "payload", "only for type se3 (its payload awareness)");
  if (type != 3)
    for (const std::string_view key : kPolicyOnlyKeys)
      if (top.has(key)) rd.fail(top.get(key), std::string(key), "only for type policy");
  if (top.has("description")) c.description = rd.string(top.get("description"), "description");
  if (top.has("allocation"))
    c.allocation = choice(rd, top.get("allocation"), "allocation", kAllocations) == 0
                       ? AllocationMethod::kExact
                       : AllocationMethod::kThesis;
  if (top.has("mass_kg")) c.mass_kg = rd.positive(top.get("mass_kg"), "mass_kg");
  if (top.has("gravity_m_s2"))
    c.gravity_m_s2 = rd.positive(top.get("gravity_m_s2"), "gravity_m_s2");
  if (type == 0) {
    read_pid(rd, top, c.settings.emplace<PidSettings>());
  } else if (type == 1) {
    read_se3(rd, top, c.settings.emplace<Se3Settings>());
  } else if (type == 2) {
    read_nmpc(rd, top, c.settings.emplace<NmpcSettings>());
  } else {
    read_policy_settings(rd, top, c.settings.emplace<PolicySettings>());
  }
  return c;
}

ControllerConfig load_controller_config(const std::string& path) {
  return parse_controller_config(read_text_file(path, "controller file"), path);
}

}  // namespace dronetwin
