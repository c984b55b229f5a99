// Strict YAML binding of controller files (format: docs/controllers.md), on the shared strict
// reader of yaml_strict.hpp. Every error starts with the source file and names the field path.
#include "dronetwin/io/controller_config.hpp"

#include <yaml-cpp/yaml.h>

#include <array>
#include <cmath>
#include <numbers>
#include <string_view>
#include <utility>

#include "dronetwin/core/error.hpp"
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

constexpr std::array<std::string_view, 2> kTypes = {"pid", "se3"};
constexpr std::array<std::string_view, 8> kTopKeys = {
    "type", "description", "allocation", "mass_kg", "gravity_m_s2", "gains", "limits", "options"};
constexpr std::array<std::string_view, 2> kAllocations = {"exact", "thesis"};

constexpr std::array<std::string_view, 6> kPidGainKeys = {"outer_p", "outer_d",  "outer_i",
                                                          "inner_p", "inner_d1", "inner_d2"};
constexpr std::array<std::string_view, 2> kPidLimitKeys = {"max_tilt_rad", "integral_limit"};
constexpr std::array<std::string_view, 5> kPidOptionKeys = {
    "conditional_integration", "yaw_error_wrap", "velocity_feedforward", "yaw_frame_mapping",
    "yaw_loop"};
constexpr std::array<std::string_view, 2> kYawLoops = {"thesis", "rate"};

constexpr std::array<std::string_view, 4> kSe3GainKeys = {"position_p", "position_d", "attitude_p",
                                                          "attitude_d"};
constexpr std::array<std::string_view, 1> kSe3LimitKeys = {"max_tilt_rad"};
constexpr std::array<std::string_view, 2> kSe3OptionKeys = {"gravity_compensation",
                                                            "nonnegative_thrust"};

const char* const kOuter = "x, y, z, psi";
const char* const kInner = "roll, pitch, yaw";
const char* const kXyz = "x, y, z";

void read_pid(const Reader& rd, const Map& top, ControllerConfig& c) {
  const Map g = rd.map(top.required("gains"), "gains", kPidGainKeys, "a map of PID gains");
  const auto vec4 = [&](std::string_view key) {
    return gains<4>(rd, g.required(key), g.path(key), kOuter);
  };
  const auto vec3 = [&](std::string_view key) {
    return gains<3>(rd, g.required(key), g.path(key), kInner);
  };
  PidGains& pg = c.pid_gains;
  pg.outer_p = vec4("outer_p");
  pg.outer_d = vec4("outer_d");
  pg.outer_i = vec4("outer_i");
  pg.inner_p = vec3("inner_p");
  pg.inner_d1 = vec3("inner_d1");
  pg.inner_d2 = vec3("inner_d2");

  PidOptions& o = c.pid_options;
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
    if (p.has("yaw_loop"))
      o.yaw_loop = choice(rd, p.get("yaw_loop"), p.path("yaw_loop"), kYawLoops) == 0
                       ? PidYawLoop::kThesis
                       : PidYawLoop::kRate;
  }
}

void read_se3(const Reader& rd, const Map& top, ControllerConfig& c) {
  const Map g = rd.map(top.required("gains"), "gains", kSe3GainKeys, "a map of SE(3) gains");
  const auto vec3 = [&](std::string_view key, const char* meaning) {
    return gains<3>(rd, g.required(key), g.path(key), meaning);
  };
  Se3Gains& sg = c.se3_gains;
  sg.position_p = vec3("position_p", kXyz);
  sg.position_d = vec3("position_d", kXyz);
  sg.attitude_p = vec3("attitude_p", kInner);
  sg.attitude_d = vec3("attitude_d", kInner);

  Se3Options& o = c.se3_options;
  if (top.has("limits")) {
    const Map l = rd.map(top.get("limits"), "limits", kSe3LimitKeys, "a map of limits");
    if (l.has("max_tilt_rad"))
      o.max_tilt_rad = tilt(rd, l.get("max_tilt_rad"), l.path("max_tilt_rad"));
  }
  if (top.has("options")) {
    const Map p = rd.map(top.get("options"), "options", kSe3OptionKeys, "a map of options");
    if (p.has("gravity_compensation"))
      o.gravity_compensation =
          rd.boolean(p.get("gravity_compensation"), p.path("gravity_compensation"));
    if (p.has("nonnegative_thrust"))
      o.nonnegative_thrust = rd.boolean(p.get("nonnegative_thrust"), p.path("nonnegative_thrust"));
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
  c.type = choice(rd, top.required("type"), "type", kTypes) == 0 ? ControllerType::kPid
                                                                 : ControllerType::kSe3;
  if (top.has("description")) c.description = rd.string(top.get("description"), "description");
  if (top.has("allocation"))
    c.allocation = choice(rd, top.get("allocation"), "allocation", kAllocations) == 0
                       ? AllocationMethod::kExact
                       : AllocationMethod::kThesis;
  if (top.has("mass_kg")) c.mass_kg = rd.positive(top.get("mass_kg"), "mass_kg");
  if (top.has("gravity_m_s2"))
    c.gravity_m_s2 = rd.positive(top.get("gravity_m_s2"), "gravity_m_s2");
  if (c.type == ControllerType::kPid) {
    read_pid(rd, top, c);
  } else {
    read_se3(rd, top, c);
  }
  return c;
}

ControllerConfig load_controller_config(const std::string& path) {
  return parse_controller_config(io_detail::read_text_file(path, "controller file"), path);
}

std::unique_ptr<ControllerBase> make_controller(const ControllerConfig& config,
                                                std::shared_ptr<const VehicleModel> model,
                                                double control_rate_hz) {
  require(model != nullptr, config.source, ": controller: model is null");
  require(std::isfinite(control_rate_hz) && control_rate_hz > 0.0, config.source,
          ": control_rate_hz: expected > 0, got ", control_rate_hz);
  const double mass = config.mass_kg.value_or(model->mass_kg());
  if (config.type == ControllerType::kPid) {
    PidGains g = config.pid_gains;
    g.mass_kg = mass;
    g.gravity_m_s2 = config.gravity_m_s2;
    return std::make_unique<CascadedPid>(std::move(model), g, config.pid_options,
                                         1.0 / control_rate_hz, config.allocation);
  }
  Se3Gains g = config.se3_gains;
  g.mass_kg = mass;
  g.gravity_m_s2 = config.gravity_m_s2;
  return std::make_unique<Se3Controller>(std::move(model), g, config.se3_options,
                                         config.allocation);
}

std::unique_ptr<ControllerBase> make_controller_from_yaml(const std::string& yaml_text,
                                                          const std::string& source_name,
                                                          std::shared_ptr<const VehicleModel> model,
                                                          double control_rate_hz) {
  return make_controller(parse_controller_config(yaml_text, source_name), std::move(model),
                         control_rate_hz);
}

std::unique_ptr<ControllerBase> load_controller(const std::string& path,
                                                std::shared_ptr<const VehicleModel> model,
                                                double control_rate_hz) {
  return make_controller(load_controller_config(path), std::move(model), control_rate_hz);
}

}  // namespace dronetwin
