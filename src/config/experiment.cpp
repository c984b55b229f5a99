// Strict YAML binding of Experiment (format: docs/experiment-format.md), on the shared strict
// reader of yaml_strict.hpp. Every error starts with the source file and names the field path.
#include "dronetwin/config/experiment.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "dronetwin/config/controller_config.hpp"
#include "dronetwin/config/track_loader.hpp"
#include "dronetwin/control/trajectory_reference.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/planning/min_snap.hpp"
#include "experiment_parts.hpp"
#include "yaml_strict.hpp"

namespace dronetwin {
namespace {

using io_detail::read_nonnegative;
using io_detail::switchable_section;

namespace fs = std::filesystem;

using io_detail::child_path;
using io_detail::describe;
using io_detail::format_number;
using io_detail::item_path;
using io_detail::Map;
using io_detail::name_list;
using io_detail::Reader;

using Names = std::vector<std::string_view>;

// ---- key tables -------------------------------------------------------------------------------

const Names kTopLevelKeys = {
    "name",         "description",  "model",          "seed",       "duration_s",
    "physics_dt_s", "integrator",   "motor_dynamics", "noise",      "wind_m_s",
    "gravity_m_s2", "disturbances", "ground",         "divergence", "initial_state",
    "log",          "metrics",      "input",          "sensors",    "estimation",
    "scene",        "wind",         "faults",         "battery",    "payload"};
const Names kRequiredTopLevelKeys = {"name", "model", "duration_s", "input"};
const Names kNoiseKeys = {"enabled", "drift", "theta", "sigma"};
const Names kBlockKeys = {"a", "b"};
const Names kDisturbanceKeys(kDisturbanceSwitchNames.begin(), kDisturbanceSwitchNames.end());
const Names kGroundKeys = {"enabled", "crash_speed_m_s", "crash_tilt_rad", "friction_coefficient"};
const Names kWindKeys = {"shear", "turbulence", "gusts"};
const Names kShearKeys = {"reference_height_m", "roughness_length_m"};
const Names kTurbulenceKeys = {"wind_at_20ft_m_s"};
const Names kTurbulenceSeverities = {"none", "light", "moderate", "severe"};
const Names kGustKeys = {"start_s", "duration_s", "amplitude_m_s"};
const Names kFaultKeys = {"type", "rotor", "start_s", "effectiveness"};
const Names kFaultTypes(kRotorFaultNames.begin(), kRotorFaultNames.end());
const Names kBatteryKeys = {"enabled",
                            "cells_in_series",
                            "capacity_Ah",
                            "ocv_cell_V",
                            "series_resistance_ohm",
                            "rc_resistance_ohm",
                            "rc_capacitance_F",
                            "efficiency",
                            "motor_speed_constant_rad_per_V_s",
                            "cutoff_voltage_V",
                            "initial_soc"};
const Names kPayloadKeys = {"enabled",      "mass_kg",           "tether_length_m",
                            "drag_area_m2", "air_density_kg_m3", "initial_swing_rad"};
const Names kDivergenceKeys = {"max_position_m", "max_speed_m_s", "max_angular_speed_rad_s"};
const Names kInitialStateKeys = {"position_m",  "velocity_m_s",           "quaternion_wxyz",
                                 "euler_rad",   "angular_velocity_rad_s", "rotor_speeds_rad_s",
                                 "on_reference"};
const Names kLogKeys = {"every_n_steps", "wrench_breakdown", "measured"};
const Names kMetricsKeys = {"window_s"};
// In the order of the ExperimentInput alternatives (input_type_name() indexes it).
const Names kInputTypes = {"constant_rotor_speeds", "piecewise_rotor_speeds",
                           "constant_generalized_force", "hover", "controller"};
static_assert(std::variant_size_v<ExperimentInput> == 5,
              "a new input kind needs a name in kInputTypes and a branch in read_input(), "
              "check_against_model() and run_experiment's InputDriver");
const Names kSegmentKeys = {"start_s", "rotor_speeds_rad_s"};
const Names kIntegrators = {"rk4", "euler"};
const Names kDrifts = {"per_sample", "continuous"};
const Names kAllocations = {"exact", "thesis"};
const Names kControllerInputKeys = {"type",       "controller", "control_rate_hz",
                                    "allocation", "real_time",  "reference"};
const Names kReferenceTypes = {"setpoint",     "thesis_pulse", "piecewise", "circle",
                               "figure_eight", "waypoints",    "min_snap"};
const Names kSetpointKeys = {"type", "position_m", "yaw_rad"};
const Names kPiecewiseKeys = {"type", "segments"};
const Names kPiecewiseSegmentKeys = {"start_s", "position_m", "yaw_rad"};
const Names kCircleKeys = {"type", "center_m", "radius_m", "period_s", "yaw_rad"};
const Names kFigureEightKeys = {"type", "center_m", "amplitude_x_m", "amplitude_y_m", "period_s"};
const Names kWaypointsKeys = {"type", "points"};
const Names kWaypointKeys = {"time_s", "position_m", "yaw_rad"};
const Names kMinSnapKeys = {"type",    "points",      "track",     "laps",
                            "start_s", "time_weight", "unwrap_yaw"};
const Names kMinSnapPointKeys = {"time_s", "position_m", "yaw_rad", "velocity_m_s",
                                 "acceleration_m_s2"};
// `sensors:` items: the keys every sensor has, then each type's own (kSensorTypeNames order).
const Names kSensorTypes(kSensorTypeNames.begin(), kSensorTypeNames.end());
static_assert(kSensorTypeNames.size() == std::variant_size_v<SensorParameters>,
              "a new sensor type needs its keys in kSensorKeys and a branch in read_sensor()");
Names sensor_keys(std::initializer_list<std::string_view> own) {
  Names keys = {"type", "name", "rate_hz", "latency_s", "mounting", "faults"};
  keys.insert(keys.end(), own);
  return keys;
}
const std::array<Names, 8> kSensorKeys = {
    sensor_keys({"gyro", "accel"}),
    sensor_keys({"field_uT", "noise_uT", "hard_iron_uT"}),
    sensor_keys({"noise_Pa", "drift_Pa_per_sqrt_s", "offset_Pa", "origin_altitude_m"}),
    sensor_keys(
        {"position_noise_m", "position_error_m", "position_error_time_s", "velocity_noise_m_s"}),
    sensor_keys({"position_noise_m", "attitude_noise_rad"}),
    sensor_keys({"min_range_m", "max_range_m", "noise_m", "noise_fraction", "dropout_probability"}),
    sensor_keys({"noise_rad_s", "min_distance_m", "max_distance_m"}),
    sensor_keys({"noise_rad_s"})};
const Names kMountingKeys = {"position_m", "rpy_deg"};
const Names kSensorFaultKeys = {"type", "start_s", "end_s", "channel", "value"};
const Names kSensorFaultTypes(kSensorFaultNames.begin(), kSensorFaultNames.end());
// A depth camera is a `sensors:` item too, but not a SensorSuite sensor (it writes frames).
constexpr std::string_view kDepthCameraType = "depth_camera";
const Names kDepthCameraKeys = {"type",
                                "name",
                                "rate_hz",
                                "mounting",
                                "width_px",
                                "height_px",
                                "horizontal_fov_deg",
                                "max_range_m",
                                "noise_at_1m_m"};
const Names kTriadKeys = {"noise_density",           "bias_random_walk", "bias_instability",
                          "bias_correlation_time_s", "turn_on_bias",     "range"};
// Keys that on_reference: true replaces (it sets the whole initial state).
const Names kOnReferenceExcludes = {"position_m", "velocity_m_s",           "quaternion_wxyz",
                                    "euler_rad",  "angular_velocity_rad_s", "rotor_speeds_rad_s"};

// ---- sections ---------------------------------------------------------------------------------

/// `hover`, `stopped` or a list of rotor speeds (rad/s, >= 0; the count is checked with the model).
RotorSpeedSetting read_rotor_speeds(const Reader& rd, const YAML::Node& node,
                                    const std::string& path) {
  const std::string expected = "'hover', 'stopped' or a list of rotor speeds in rad/s";
  if (node.IsScalar()) {
    if (node.Scalar() == "hover") return RotorSpeedSetting::hover();
    if (node.Scalar() == "stopped") return RotorSpeedSetting::stopped();
    rd.fail(node, path, "expected " + expected + ", got " + describe(node));
  }
  std::vector<double> v = rd.numbers(node, path, expected);
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (v[i] < 0.0)
      rd.fail(node[i], item_path(path, i),
              "expected a rotor speed >= 0 rad/s (speeds are magnitudes; the spin direction is a "
              "model parameter), got " +
                  format_number(v[i]));
  }
  return RotorSpeedSetting::values(std::move(v));
}

BlockCoefficients read_block(const Reader& rd, const YAML::Node& node, const std::string& path) {
  const Map m = rd.map(node, path, kBlockKeys, "a map {a, b} (the block a I + b 1 1^T)");
  return {rd.number(m.required("a"), m.path("a")), rd.number(m.required("b"), m.path("b"))};
}

NoiseConfig read_noise(const Reader& rd, const YAML::Node& node, const std::string& path) {
  NoiseConfig noise;
  if (node.IsScalar()) {
    noise.enabled = rd.boolean(node, path);
    return noise;
  }
  const Map m = rd.map(node, path, kNoiseKeys, "true, false or a map of noise settings");
  noise.enabled = m.has("enabled") ? rd.boolean(m.get("enabled"), m.path("enabled")) : true;
  if (m.has("drift")) {
    noise.parameters.drift = rd.choice(m.get("drift"), m.path("drift"), kDrifts, "drift") == 0
                                 ? OuDrift::kPerSample
                                 : OuDrift::kContinuous;
  }
  if (m.has("theta")) noise.parameters.theta.fill(read_block(rd, m.get("theta"), m.path("theta")));
  if (m.has("sigma")) noise.parameters.sigma.fill(read_block(rd, m.get("sigma"), m.path("sigma")));
  return noise;
}

DisturbanceSwitches read_disturbances(const Reader& rd, const YAML::Node& node,
                                      const std::string& path) {
  if (node.IsScalar()) {
    const Names words = {"none", "all"};
    return rd.choice(node, path, words, "disturbance set") == 0 ? DisturbanceSwitches::none()
                                                                : DisturbanceSwitches{};
  }
  const Map m = rd.map(node, path, kDisturbanceKeys, "'none', 'all' or a map of switches");
  DisturbanceSwitches s;
  for (std::size_t i = 0; i < kDisturbanceSwitchMembers.size(); ++i) {
    const std::string_view key = kDisturbanceSwitchNames[i];
    if (m.has(key)) s.*kDisturbanceSwitchMembers[i] = rd.boolean(m.get(key), m.path(key));
  }
  return s;
}

GroundConfig read_ground(const Reader& rd, const YAML::Node& node, const std::string& path) {
  GroundConfig g;
  if (node.IsScalar()) {
    g.enabled = rd.boolean(node, path);
    return g;
  }
  const Map m = rd.map(node, path, kGroundKeys, "true, false or a map of ground settings");
  if (m.has("enabled")) g.enabled = rd.boolean(m.get("enabled"), m.path("enabled"));
  if (m.has("crash_speed_m_s"))
    g.crash_speed_m_s = rd.positive(m.get("crash_speed_m_s"), m.path("crash_speed_m_s"));
  if (m.has("crash_tilt_rad"))
    g.crash_tilt_rad = rd.positive(m.get("crash_tilt_rad"), m.path("crash_tilt_rad"));
  if (m.has("friction_coefficient")) {
    const YAML::Node f = m.get("friction_coefficient");
    g.friction_coefficient = rd.number(f, m.path("friction_coefficient"));
    if (g.friction_coefficient < 0.0)
      rd.fail(f, m.path("friction_coefficient"), "expected a number >= 0, got " + f.Scalar());
  }
  return g;
}

/// `wind:` (docs/wind.md): shear (true, false or a map), turbulence (none, light, moderate,
/// severe or {wind_at_20ft_m_s}) and a list of 1 - cos gusts; the mean wind is `wind_m_s`.
WindSettings read_wind(const Reader& rd, const YAML::Node& node, const std::string& path) {
  WindSettings w;
  const Map m = rd.map(node, path, kWindKeys,
                       "a map of wind settings (shear, turbulence, gusts); the mean wind is "
                       "the top-level wind_m_s");
  if (m.has("shear")) {
    const YAML::Node n = m.get("shear");
    if (n.IsScalar()) {
      w.shear.enabled = rd.boolean(n, m.path("shear"));
    } else {
      const Map sm =
          rd.map(n, m.path("shear"), kShearKeys, "true, false or a map of shear settings");
      w.shear.enabled = true;
      if (sm.has("reference_height_m"))
        w.shear.reference_height_m =
            rd.positive(sm.get("reference_height_m"), sm.path("reference_height_m"));
      if (sm.has("roughness_length_m"))
        w.shear.roughness_length_m =
            rd.positive(sm.get("roughness_length_m"), sm.path("roughness_length_m"));
      if (!(w.shear.reference_height_m > 2.0 * w.shear.roughness_length_m)) {
        char text[160];
        std::snprintf(text, sizeof text,
                      "reference_height_m (%g) must be above twice roughness_length_m (%g)",
                      w.shear.reference_height_m, w.shear.roughness_length_m);
        rd.fail(n, m.path("shear"), text);
      }
    }
  }
  if (m.has("turbulence")) {
    const YAML::Node n = m.get("turbulence");
    if (n.IsScalar()) {
      const std::size_t k = rd.choice(n, m.path("turbulence"), kTurbulenceSeverities, "severity");
      if (k > 0) w.turbulence = TurbulenceSettings::of(static_cast<TurbulenceSeverity>(k - 1));
    } else {
      const Map tm = rd.map(n, m.path("turbulence"), kTurbulenceKeys,
                            "none, light, moderate, severe or {wind_at_20ft_m_s: ...}");
      const YAML::Node v = tm.required("wind_at_20ft_m_s");
      w.turbulence.enabled = true;
      w.turbulence.wind_at_20ft_m_s = rd.number(v, tm.path("wind_at_20ft_m_s"));
      if (w.turbulence.wind_at_20ft_m_s < 0.0)
        rd.fail(v, tm.path("wind_at_20ft_m_s"), "expected a speed >= 0 m/s, got " + v.Scalar());
    }
  }
  if (m.has("gusts")) {
    const YAML::Node list = m.get("gusts");
    const std::string list_path = m.path("gusts");
    if (!list.IsSequence())
      rd.fail(list, list_path, "expected a list of gusts ({start_s, duration_s, amplitude_m_s})");
    if (list.size() > static_cast<std::size_t>(kMaxGusts))
      rd.fail(list, list_path,
              detail::concat("expected at most ", kMaxGusts, " gusts, got ", list.size()));
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string item = detail::concat(list_path, "[", i, "]");
      const Map gm = rd.map(list[i], item, kGustKeys, "a map {start_s, duration_s, amplitude_m_s}");
      Gust& g = w.gusts[i];
      g.start_s = rd.number(gm.required("start_s"), gm.path("start_s"));
      g.duration_s = rd.positive(gm.required("duration_s"), gm.path("duration_s"));
      g.amplitude_W_m_s =
          rd.fixed<3>(gm.required("amplitude_m_s"), gm.path("amplitude_m_s"), "x, y, z in m/s");
    }
    w.num_gusts = static_cast<int>(list.size());
  }
  return w;
}

/// `faults:` (docs/faults.md): a list of {type, rotor, start_s[, effectiveness]}.
FaultSettings read_faults(const Reader& rd, const YAML::Node& node, const std::string& path) {
  FaultSettings f;
  if (!node.IsSequence())
    rd.fail(node, path, "expected a list of faults ({type, rotor, start_s, effectiveness})");
  if (node.size() > static_cast<std::size_t>(kMaxRotorFaults))
    rd.fail(node, path,
            detail::concat("expected at most ", kMaxRotorFaults, " faults, got ", node.size()));
  for (std::size_t i = 0; i < node.size(); ++i) {
    const std::string item = detail::concat(path, "[", i, "]");
    const Map m = rd.map(node[i], item, kFaultKeys, "a map {type, rotor, start_s, effectiveness}");
    RotorFault& r = f.rotor[i];
    r.kind = static_cast<RotorFaultKind>(
        rd.choice(m.required("type"), m.path("type"), kFaultTypes, "fault type"));
    r.rotor = rd.integer<int>(m.required("rotor"), m.path("rotor"), "a rotor index >= 0");
    // The model's rotor count is checked against it later (check_against_model); here the
    // bound every model has, so that validate(SimConfig) accepts what the parser accepts.
    if (r.rotor < 0 || r.rotor >= kMaxRotors)
      rd.fail(m.get("rotor"), m.path("rotor"),
              detail::concat("expected a rotor index 0 .. ", kMaxRotors - 1, ", got ", r.rotor));
    r.start_s = rd.number(m.required("start_s"), m.path("start_s"));
    if (r.kind == RotorFaultKind::kEffectiveness) {
      const YAML::Node e = m.required("effectiveness");
      r.effectiveness = rd.number(e, m.path("effectiveness"));
      if (r.effectiveness < 0.0 || r.effectiveness > 1.0)
        rd.fail(e, m.path("effectiveness"),
                "expected the fraction of thrust left, in [0, 1], got " + e.Scalar());
    } else if (m.has("effectiveness")) {
      rd.fail(m.get("effectiveness"), m.path("effectiveness"),
              detail::concat("only a rotor_effectiveness fault has an effectiveness (this is a ",
                             kRotorFaultNames[static_cast<std::size_t>(r.kind)], ")"));
    }
  }
  f.num_rotor_faults = static_cast<int>(node.size());
  return f;
}

/// `payload:` (docs/payload.md): true, false or a map of payload settings over the defaults.
PayloadSettings read_payload(const Reader& rd, const YAML::Node& node, const std::string& path) {
  PayloadSettings settings;
  const std::optional<Map> section = switchable_section(
      rd, node, path, kPayloadKeys, "true, false or a map of payload settings", settings.enabled);
  if (!section) return settings;
  const Map& m = *section;
  SlungPayload& p = settings.payload;
  if (m.has("mass_kg")) p.mass_kg = rd.positive(m.get("mass_kg"), m.path("mass_kg"));
  if (m.has("tether_length_m"))
    p.tether_length_m = rd.positive(m.get("tether_length_m"), m.path("tether_length_m"));
  for (const auto& [key, out] :
       {std::pair<std::string_view, double*>{"drag_area_m2", &p.drag_area_m2},
        {"air_density_kg_m3", &p.air_density_kg_m3}}) {
    if (!m.has(key)) continue;
    const YAML::Node n = m.get(key);
    *out = rd.number(n, m.path(key));
    if (*out < 0.0) rd.fail(n, m.path(key), "expected a number >= 0, got " + n.Scalar());
  }
  if (m.has("initial_swing_rad")) {
    const YAML::Node n = m.get("initial_swing_rad");
    const auto a = rd.fixed<2>(n, m.path("initial_swing_rad"),
                               "the swing angles gamma1, gamma2 of Eq. 3.33 in rad");
    if (!(std::abs(a[0]) < 0.5 * std::numbers::pi && std::abs(a[1]) < 0.5 * std::numbers::pi))
      rd.fail(n, m.path("initial_swing_rad"),
              detail::concat("expected angles within (-pi/2, pi/2), got [", a[0], ", ", a[1], "]"));
    settings.initial_swing1_rad = a[0];
    settings.initial_swing2_rad = a[1];
  }
  return settings;
}

/// `battery:` (docs/battery.md): true, false or a map of pack settings over the defaults.
BatterySettings read_battery(const Reader& rd, const YAML::Node& node, const std::string& path) {
  BatterySettings b;
  const std::optional<Map> section = switchable_section(
      rd, node, path, kBatteryKeys, "true, false or a map of battery settings", b.enabled);
  if (!section) return b;
  const Map& m = *section;
  BatteryPack& p = b.pack;
  const auto fraction = [&](std::string_view key, double& out) {
    if (!m.has(key)) return;
    const YAML::Node n = m.get(key);
    out = rd.number(n, m.path(key));
    if (!(out > 0.0 && out <= 1.0))
      rd.fail(n, m.path(key), "expected a fraction in (0, 1], got " + n.Scalar());
  };
  const auto non_negative = [&](std::string_view key, double& out) {
    if (!m.has(key)) return;
    const YAML::Node n = m.get(key);
    out = rd.number(n, m.path(key));
    if (out < 0.0) rd.fail(n, m.path(key), "expected a number >= 0, got " + n.Scalar());
  };
  if (m.has("cells_in_series")) {
    p.cells_in_series = rd.integer<int>(m.get("cells_in_series"), m.path("cells_in_series"),
                                        "a cell count 1 .. 32");
    if (p.cells_in_series < 1 || p.cells_in_series > 32)
      rd.fail(m.get("cells_in_series"), m.path("cells_in_series"),
              detail::concat("expected a cell count 1 .. 32, got ", p.cells_in_series));
  }
  if (m.has("capacity_Ah"))
    p.capacity_Ah = rd.positive(m.get("capacity_Ah"), m.path("capacity_Ah"));
  if (m.has("ocv_cell_V")) {
    const YAML::Node n = m.get("ocv_cell_V");
    const auto v = rd.fixed<kOcvPoints>(n, m.path("ocv_cell_V"),
                                        "11 cell voltages at SoC 0, 0.1, ..., 1 in V");
    for (int k = 0; k < kOcvPoints; ++k) {
      if (!(v[k] > 0.0) || (k > 0 && v[k] < v[k - 1])) {
        char text[160];
        std::snprintf(text, sizeof text,
                      "[%d]: expected a voltage > 0 not below the one before it, got %g", k, v[k]);
        rd.fail(n, m.path("ocv_cell_V"), text);
      }
      p.ocv_cell_V[static_cast<std::size_t>(k)] = v[k];
    }
  }
  if (m.has("series_resistance_ohm"))
    p.series_resistance_ohm =
        rd.positive(m.get("series_resistance_ohm"), m.path("series_resistance_ohm"));
  non_negative("rc_resistance_ohm", p.rc_resistance_ohm);
  non_negative("rc_capacitance_F", p.rc_capacitance_F);
  fraction("efficiency", p.efficiency);
  if (m.has("motor_speed_constant_rad_per_V_s"))
    p.motor_speed_constant_rad_per_V_s = rd.positive(m.get("motor_speed_constant_rad_per_V_s"),
                                                     m.path("motor_speed_constant_rad_per_V_s"));
  non_negative("cutoff_voltage_V", p.cutoff_voltage_V);
  fraction("initial_soc", p.initial_soc);
  return b;
}

DivergenceLimits read_divergence(const Reader& rd, const YAML::Node& node,
                                 const std::string& path) {
  DivergenceLimits d;
  const Map m = rd.map(node, path, kDivergenceKeys, "a map of divergence limits");
  if (m.has("max_position_m"))
    d.max_position_m = rd.positive(m.get("max_position_m"), m.path("max_position_m"));
  if (m.has("max_speed_m_s"))
    d.max_speed_m_s = rd.positive(m.get("max_speed_m_s"), m.path("max_speed_m_s"));
  if (m.has("max_angular_speed_rad_s")) {
    d.max_angular_speed_rad_s =
        rd.positive(m.get("max_angular_speed_rad_s"), m.path("max_angular_speed_rad_s"));
  }
  return d;
}

InitialStateSpec read_initial_state(const Reader& rd, const YAML::Node& node,
                                    const std::string& path) {
  const Map m = rd.map(node, path, kInitialStateKeys, "a map of initial-state values");
  InitialStateSpec s;
  if (m.has("position_m"))
    s.position_m = rd.fixed<3>(m.get("position_m"), m.path("position_m"), "x, y, z in m");
  if (m.has("velocity_m_s"))
    s.velocity_m_s =
        rd.fixed<3>(m.get("velocity_m_s"), m.path("velocity_m_s"), "vx, vy, vz in m/s");
  if (m.has("quaternion_wxyz") && m.has("euler_rad"))
    rd.fail(m.get("euler_rad"), path, "give either quaternion_wxyz or euler_rad, not both");
  if (m.has("quaternion_wxyz")) {
    const YAML::Node q = m.get("quaternion_wxyz");
    const Vec4 v = rd.fixed<4>(q, m.path("quaternion_wxyz"), "w, x, y, z");
    const double n = v.norm();
    if (!(std::abs(n - 1.0) <= 1e-3))
      rd.fail(q, m.path("quaternion_wxyz"),
              "expected a unit quaternion (norm 1 within 1e-3), got norm " + format_number(n));
    s.quaternion_wxyz = v / n;
  } else if (m.has("euler_rad")) {
    const Vec3 e = rd.fixed<3>(m.get("euler_rad"), m.path("euler_rad"), "roll, pitch, yaw in rad");
    s.quaternion_wxyz = math::from_euler(e[0], e[1], e[2]);
  }
  if (m.has("angular_velocity_rad_s")) {
    s.angular_velocity_rad_s = rd.fixed<3>(
        m.get("angular_velocity_rad_s"), m.path("angular_velocity_rad_s"), "body x, y, z in rad/s");
  }
  if (m.has("rotor_speeds_rad_s"))
    s.rotor_speeds =
        read_rotor_speeds(rd, m.get("rotor_speeds_rad_s"), m.path("rotor_speeds_rad_s"));
  if (m.has("on_reference")) {
    s.on_reference = rd.boolean(m.get("on_reference"), m.path("on_reference"));
    if (s.on_reference) {
      for (std::string_view key : kOnReferenceExcludes) {
        if (m.has(key))
          rd.fail(m.get(key), m.path(key),
                  "on_reference: true sets the whole initial state (position and velocity of the "
                  "reference at t = 0, level at its yaw, hover rotor speeds); remove '" +
                      std::string(key) + "' or set on_reference: false");
      }
    }
  }
  return s;
}

LogSettings read_log(const Reader& rd, const YAML::Node& node, const std::string& path) {
  const Map m = rd.map(node, path, kLogKeys, "a map of log settings");
  LogSettings s;
  if (m.has("every_n_steps")) {
    const YAML::Node n = m.get("every_n_steps");
    const auto v = rd.integer<std::int64_t>(n, m.path("every_n_steps"), "an integer >= 1");
    if (v < 1) rd.fail(n, m.path("every_n_steps"), "expected an integer >= 1, got " + n.Scalar());
    s.every_n_steps = v;
  }
  if (m.has("wrench_breakdown"))
    s.wrench_breakdown = rd.boolean(m.get("wrench_breakdown"), m.path("wrench_breakdown"));
  if (m.has("measured")) s.measured = rd.boolean(m.get("measured"), m.path("measured"));
  return s;
}

/// The `type:` of a map that selects its kind by it (an input, a reference): its index in `types`.
std::size_t read_type(const Reader& rd, const YAML::Node& node, const std::string& path,
                      const Names& types, const std::string& what) {
  const std::string expected = "a map with a 'type' (" + name_list(types) + ")";
  if (!node.IsMap()) rd.fail(node, path, "expected " + expected + ", got " + describe(node));
  YAML::Node type_node(YAML::NodeType::Undefined);
  for (const auto& kv : node)
    if (kv.first.IsScalar() && kv.first.Scalar() == "type") type_node = kv.second;
  if (!type_node.IsDefined())
    rd.fail(node, path, "missing required key 'type' (" + name_list(types) + ")");
  return rd.choice(type_node, child_path(path, "type"), types, what);
}

double read_yaw(const Reader& rd, const Map& m) {
  return m.has("yaw_rad") ? rd.number(m.get("yaw_rad"), m.path("yaw_rad")) : 0.0;
}

/// One item of a reference's list of segments or waypoints.
struct TimedPoint {
  double time_s;
  Vec3 position_m;
  double yaw_rad;
};

/// A non-empty list at `path` of maps with a strictly increasing time `time_key` (the first >= 0,
/// or == 0 when `first_at_zero`), a required position_m and an optional yaw_rad (default 0).
std::vector<TimedPoint> read_timed_points(const Reader& rd, const YAML::Node& list,
                                          const std::string& path, const Names& keys,
                                          std::string_view time_key, bool first_at_zero) {
  const std::string item = "a map {" + name_list(keys) + "}";
  if (!list.IsSequence() || list.size() == 0)
    rd.fail(list, path, "expected a non-empty list of " + item + ", got " + describe(list));
  std::vector<TimedPoint> points;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const Map p = rd.map(list[i], item_path(path, i), keys, item);
    const YAML::Node t_node = p.required(time_key);
    const double t = rd.number(t_node, p.path(time_key));
    if (i == 0 && first_at_zero && t != 0.0)
      rd.fail(t_node, p.path(time_key),
              "expected 0 (the first segment starts the run), got " + t_node.Scalar());
    if (i == 0 && t < 0.0)
      rd.fail(t_node, p.path(time_key), "expected a time >= 0 s, got " + t_node.Scalar());
    if (i > 0 && !(t > points.back().time_s))
      rd.fail(t_node, p.path(time_key),
              "expected a time after " + format_number(points.back().time_s) + " s (the " +
                  std::string(time_key) + " of " + item_path(path, i - 1) +
                  "; times must strictly increase), got " + t_node.Scalar());
    const Vec3 pos = rd.fixed<3>(p.required("position_m"), p.path("position_m"), "x, y, z in m");
    points.push_back({t, pos, read_yaw(rd, p)});
  }
  return points;
}

/// The min_snap reference's plan through `waypoints`: `segment_times_s`, or allocated by
/// `time_weight`; `start_s` and `unwrap_yaw` (default `unwrap_by_default`) from `m`.
std::shared_ptr<const Reference> plan_reference(const Reader& rd, const Map& m,
                                                const std::vector<planning::Waypoint>& waypoints,
                                                std::vector<double> segment_times_s,
                                                bool unwrap_by_default) {
  const bool allocate = m.has("time_weight");
  planning::MinSnapOptions options;
  options.unwrap_yaw = unwrap_by_default;
  if (m.has("unwrap_yaw"))
    options.unwrap_yaw = rd.boolean(m.get("unwrap_yaw"), m.path("unwrap_yaw"));
  const double start_s = m.has("start_s") ? rd.number(m.get("start_s"), m.path("start_s")) : 0.0;
  if (start_s < 0.0)
    rd.fail(m.get("start_s"), m.path("start_s"),
            "expected a time >= 0 s, got " + m.get("start_s").Scalar());
  try {
    if (allocate) {
      const YAML::Node rho = m.get("time_weight");
      planning::TimeAllocationOptions allocation;
      allocation.min_snap = options;  // the yaw steps the plan takes, unwrapped or not
      segment_times_s = planning::allocate_segment_times(
          waypoints, rd.positive(rho, m.path("time_weight")), allocation);
    }
    return std::make_shared<const TrajectoryReference>(
        planning::plan_min_snap(waypoints, segment_times_s, options), start_s);
  } catch (const InvalidArgument& e) {
    // Duplicate or non-finite points: the planner names waypoints[i], which is points[i] (or,
    // for a track, the start for i = 0 and else the (i - 1)-th gate passed).
    const std::string where = m.has("track") ? "track" : "points";
    rd.fail(m.get(where), m.path(where), e.what());
  }
}

std::string resolve_file(const Reader& rd, const YAML::Node& node, const std::string& path,
                         const std::string& given_text, const std::string& what);

/// The waypoints of `track:` (a track file, docs/track-format.md): the start, then every gate's
/// centre `laps` times, each facing along its gate's passage direction (the start: the track's
/// start yaw). A gate has no time, so `time_weight` must allocate them.
std::vector<planning::Waypoint> track_waypoints(const Reader& rd, const Map& m) {
  const YAML::Node node = m.get("track");
  if (m.has("points"))
    rd.fail(m.get("points"), m.path("points"),
            "expected either points or track, not both (track: the start and the gates are the "
            "points)");
  if (!m.has("time_weight"))
    rd.fail(node, m.path("track"),
            "a track's gates have no times: give time_weight (rho > 0) to allocate them");
  const std::string file =
      resolve_file(rd, node, m.path("track"), rd.string(node, m.path("track")), "track");
  Track track;
  try {
    track = load_track(file);
  } catch (const InvalidArgument& e) {
    rd.fail(node, m.path("track"), e.what());
  }
  if (track.gates.empty())
    rd.fail(node, m.path("track"), "track '" + file + "' has no gates to plan through");
  const int laps =
      m.has("laps") ? rd.integer<int>(m.get("laps"), m.path("laps"), "an integer in [1, 1000]") : 1;
  if (laps < 1 || laps > 1000)
    rd.fail(m.get("laps"), m.path("laps"),
            "expected an integer in [1, 1000], got " + m.get("laps").Scalar());
  if (laps > 1 && !track.closed)
    rd.fail(m.get("laps"), m.path("laps"),
            "track '" + file + "' is open (one pass through its gates); expected laps: 1, got " +
                m.get("laps").Scalar());
  std::vector<planning::Waypoint> waypoints;
  waypoints.push_back({track.start_position_m, track.start_yaw_rad, {}, {}});
  for (int lap = 0; lap < laps; ++lap)
    for (const Gate& g : track.gates)
      waypoints.push_back({g.center_m, std::atan2(g.normal().y(), g.normal().x()), {}, {}});
  return waypoints;
}

/// `type: min_snap`: a minimum-snap plan (planning/min_snap.hpp) through `points` or through a
/// `track`'s start and gates (`laps` times; yaw unwrapped by default), flown from `start_s`
/// (default 0). Either every point has a time_s (the first 0, strictly increasing) or none has
/// and `time_weight` (rho > 0) allocates the segment times (minimum snap + rho T).
std::shared_ptr<const Reference> read_min_snap(const Reader& rd, const Map& m) {
  if (!m.has("track") && m.has("laps"))
    rd.fail(m.get("laps"), m.path("laps"), "laps goes with track; no track is given");
  if (m.has("track")) return plan_reference(rd, m, track_waypoints(rd, m), {}, true);
  const YAML::Node list = m.required("points");
  const std::string path = m.path("points");
  const std::string item = "a map {" + name_list(kMinSnapPointKeys) + "}";
  if (!list.IsSequence() || list.size() < 2)
    rd.fail(list, path,
            "expected a list of at least 2 points (" + item + "), got " + describe(list));
  const bool allocate = m.has("time_weight");
  std::vector<planning::Waypoint> waypoints;
  std::vector<double> segment_times_s;
  double last_time_s = 0.0;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const Map p = rd.map(list[i], item_path(path, i), kMinSnapPointKeys, item);
    planning::Waypoint w;
    w.position_m = rd.fixed<3>(p.required("position_m"), p.path("position_m"), "x, y, z in m");
    w.yaw_rad = read_yaw(rd, p);
    if (p.has("velocity_m_s"))
      w.velocity_m_s = rd.fixed<3>(p.get("velocity_m_s"), p.path("velocity_m_s"), "x, y, z in m/s");
    if (p.has("acceleration_m_s2"))
      w.acceleration_m_s2 =
          rd.fixed<3>(p.get("acceleration_m_s2"), p.path("acceleration_m_s2"), "x, y, z in m/s^2");
    waypoints.push_back(w);
    if (allocate) {
      if (p.has("time_s"))
        rd.fail(p.get("time_s"), p.path("time_s"),
                "expected no time_s: time_weight allocates the times (give either time_s at "
                "every point or time_weight)");
      continue;
    }
    const YAML::Node t_node = p.required("time_s");
    const double t = rd.number(t_node, p.path("time_s"));
    if (i == 0 && t != 0.0)
      rd.fail(t_node, p.path("time_s"),
              "expected 0 (times count from start_s), got " + t_node.Scalar());
    if (i > 0 && !(t > last_time_s))
      rd.fail(t_node, p.path("time_s"),
              "expected a time after " + format_number(last_time_s) + " s (the time_s of " +
                  item_path(path, i - 1) + "; times must strictly increase), got " +
                  t_node.Scalar());
    if (i > 0) segment_times_s.push_back(t - last_time_s);
    last_time_s = t;
  }
  return plan_reference(rd, m, waypoints, segment_times_s, false);
}

/// `reference:` of a controller input: a Reference (control/reference.hpp) and its type name.
std::pair<std::shared_ptr<const Reference>, std::string> read_reference(const Reader& rd,
                                                                        const YAML::Node& node,
                                                                        const std::string& path) {
  const std::size_t type = read_type(rd, node, path, kReferenceTypes, "reference type");
  const std::string expected =
      "a map with a 'type' (" + name_list(kReferenceTypes) + ") and its keys";
  const std::string name(kReferenceTypes[type]);
  const auto center = [&](const Map& m, const Vec3& fallback) -> Vec3 {
    return m.has("center_m") ? rd.fixed<3>(m.get("center_m"), m.path("center_m"), "x, y, z in m")
                             : fallback;
  };
  const auto period = [&](const Map& m, double fallback) {
    return m.has("period_s") ? rd.positive(m.get("period_s"), m.path("period_s")) : fallback;
  };
  std::shared_ptr<const Reference> ref;
  switch (type) {
    case 0: {
      const Map m = rd.map(node, path, kSetpointKeys, expected);
      const Vec3 p = rd.fixed<3>(m.required("position_m"), m.path("position_m"), "x, y, z in m");
      ref = std::make_shared<const SetpointReference>(p, read_yaw(rd, m));
      break;
    }
    case 1:
      rd.map(node, path, Names{"type"}, expected);
      ref = std::make_shared<const PiecewiseConstantReference>(
          PiecewiseConstantReference::thesis_pulse());
      break;
    case 2: {
      const Map m = rd.map(node, path, kPiecewiseKeys, expected);
      std::vector<PiecewiseConstantReference::Segment> segments;
      for (const TimedPoint& p :
           read_timed_points(rd, m.required("segments"), m.path("segments"), kPiecewiseSegmentKeys,
                             "start_s", /*first_at_zero=*/true))
        segments.push_back({p.time_s, p.position_m, p.yaw_rad});
      ref = std::make_shared<const PiecewiseConstantReference>(std::move(segments));
      break;
    }
    case 3: {
      // Defaults: thesis Eq. 3.28 (r = 2 m, T = 7 s, centre (0, 0, 1), yaw 0).
      const Map m = rd.map(node, path, kCircleKeys, expected);
      ref = std::make_shared<const CircleReference>(
          center(m, Vec3(0, 0, 1)), read_nonnegative(rd, m, "radius_m", 2.0, "a radius"),
          period(m, 7.0), read_yaw(rd, m));
      break;
    }
    case 4: {
      // Defaults: thesis Eq. 3.25 (0.8 x 0.6 m, T = 60 s, centre (0, 0, 1.2)).
      const Map m = rd.map(node, path, kFigureEightKeys, expected);
      ref = std::make_shared<const FigureEightReference>(
          center(m, Vec3(0, 0, 1.2)), read_nonnegative(rd, m, "amplitude_x_m", 0.8, "an amplitude"),
          read_nonnegative(rd, m, "amplitude_y_m", 0.6, "an amplitude"), period(m, 60.0));
      break;
    }
    case 6:
      ref = read_min_snap(rd, rd.map(node, path, kMinSnapKeys, expected));
      break;
    default: {
      const Map m = rd.map(node, path, kWaypointsKeys, expected);
      std::vector<WaypointReference::Waypoint> points;
      for (const TimedPoint& p :
           read_timed_points(rd, m.required("points"), m.path("points"), kWaypointKeys, "time_s",
                             /*first_at_zero=*/false))
        points.push_back({p.time_s, p.position_m, p.yaw_rad});
      ref = std::make_shared<const WaypointReference>(std::move(points));
      break;
    }
  }
  return {std::move(ref), name};
}

/// A file named in the experiment (model, controller): relative to the experiment's directory
/// if it exists there, else relative to the current directory (or absolute). `what` names it in
/// the error ("model file 'x.yaml' not found (looked for ...)").
std::string resolve_file(const Reader& rd, const YAML::Node& node, const std::string& path,
                         const std::string& given_text, const std::string& what) {
  const fs::path given(given_text);
  std::vector<fs::path> candidates;
  if (given.is_absolute()) {
    candidates.push_back(given);
  } else {
    candidates.push_back(fs::path(rd.source()).parent_path() / given);
    candidates.push_back(given);
  }
  std::string tried;
  for (const fs::path& c : candidates) {
    std::error_code ec;
    if (fs::is_regular_file(c, ec)) return c.lexically_normal().string();
    tried += (tried.empty() ? "'" : " and '") + c.lexically_normal().string() + "'";
  }
  // A folder where a file belongs is a different mistake from a typo: say which.
  for (const fs::path& c : candidates) {
    std::error_code ec;
    if (fs::is_directory(c, ec))
      rd.fail(node, path,
              what + " file '" + given_text + "' is a directory ('" +
                  c.lexically_normal().string() + "'); expected a " + what + " YAML file");
  }
  rd.fail(node, path, what + " file '" + given_text + "' not found (looked for " + tried + ")");
}

ControllerLoopInput read_controller_input(const Reader& rd, const Map& m) {
  ControllerLoopInput in;
  const YAML::Node c = m.required("controller");
  in.controller_path =
      resolve_file(rd, c, m.path("controller"), rd.string(c, m.path("controller")), "controller");
  // Parse the controller file now, so that a bad one fails before anything runs.
  try {
    (void)load_controller_config(in.controller_path);
  } catch (const InvalidArgument& e) {
    rd.fail(c, m.path("controller"), std::string("bad controller file: ") + e.what());
  }
  if (m.has("control_rate_hz"))
    in.control_rate_hz = rd.positive(m.get("control_rate_hz"), m.path("control_rate_hz"));
  if (m.has("allocation")) {
    in.allocation =
        rd.choice(m.get("allocation"), m.path("allocation"), kAllocations, "allocation") == 0
            ? AllocationMethod::kExact
            : AllocationMethod::kThesis;
  }
  if (m.has("real_time")) in.real_time = rd.boolean(m.get("real_time"), m.path("real_time"));
  auto [ref, type] = read_reference(rd, m.required("reference"), m.path("reference"));
  in.reference = std::move(ref);
  in.reference_type = std::move(type);
  return in;
}

MetricsSettings read_metrics(const Reader& rd, const YAML::Node& node, const std::string& path) {
  const Map m = rd.map(node, path, kMetricsKeys, "a map of metrics settings");
  MetricsSettings s;
  if (m.has("window_s")) {
    const YAML::Node w = m.get("window_s");
    const Eigen::Vector2d v = rd.fixed<2>(w, m.path("window_s"), "t0, t1 in s");
    if (!(v[0] >= 0.0 && v[1] > v[0]))
      rd.fail(
          w, m.path("window_s"),
          "expected 0 <= t0 < t1, got [" + format_number(v[0]) + ", " + format_number(v[1]) + "]");
    s.window_s = std::array<double, 2>{v[0], v[1]};
  }
  return s;
}

ExperimentInput read_input(const Reader& rd, const YAML::Node& node, const std::string& path) {
  const std::string expected = "a map with a 'type' (" + name_list(kInputTypes) + ")";
  const std::size_t type = read_type(rd, node, path, kInputTypes, "input type");

  switch (type) {
    case 0: {
      const Map m = rd.map(node, path, Names{"type", "rotor_speeds_rad_s"}, expected);
      return ConstantRotorSpeedsInput{
          read_rotor_speeds(rd, m.required("rotor_speeds_rad_s"), m.path("rotor_speeds_rad_s"))};
    }
    case 1: {
      const Map m = rd.map(node, path, Names{"type", "segments"}, expected);
      const YAML::Node segs = m.required("segments");
      const std::string segs_path = m.path("segments");
      if (!segs.IsSequence() || segs.size() == 0)
        rd.fail(
            segs, segs_path,
            "expected a non-empty list of {start_s, rotor_speeds_rad_s}, got " + describe(segs));
      PiecewiseRotorSpeedsInput in;
      for (std::size_t i = 0; i < segs.size(); ++i) {
        const Map s = rd.map(segs[i], item_path(segs_path, i), kSegmentKeys,
                             "a map {start_s, rotor_speeds_rad_s}");
        RotorSpeedSegment seg;
        const YAML::Node start = s.required("start_s");
        seg.start_s = rd.number(start, s.path("start_s"));
        if (i == 0 && seg.start_s != 0.0)
          rd.fail(start, s.path("start_s"),
                  "expected 0 (the first segment starts the run), got " + start.Scalar());
        if (i > 0 && !(seg.start_s > in.segments.back().start_s))
          rd.fail(start, s.path("start_s"),
                  "expected a start after " + format_number(in.segments.back().start_s) +
                      " s (the start of " + item_path(segs_path, i - 1) +
                      "; starts must strictly increase), got " + start.Scalar());
        seg.rotor_speeds =
            read_rotor_speeds(rd, s.required("rotor_speeds_rad_s"), s.path("rotor_speeds_rad_s"));
        in.segments.push_back(std::move(seg));
      }
      return in;
    }
    case 2: {
      const Map m = rd.map(node, path, Names{"type", "u", "allocation"}, expected);
      ConstantGeneralizedForceInput in;
      in.u = rd.fixed<4>(m.required("u"), m.path("u"), "T in N, tau_x, tau_y, tau_z in N m");
      if (m.has("allocation")) {
        in.allocation =
            rd.choice(m.get("allocation"), m.path("allocation"), kAllocations, "allocation") == 0
                ? AllocationMethod::kExact
                : AllocationMethod::kThesis;
      }
      return in;
    }
    case 3:
      rd.map(node, path, Names{"type"}, expected);
      return HoverInput{};
    default:
      return read_controller_input(rd, rd.map(node, path, kControllerInputKeys, expected));
  }
}

// ---- sensors ----------------------------------------------------------------------------------

void read_number(const Reader& rd, const Map& m, std::string_view key, double& out) {
  if (m.has(key)) out = rd.number(m.get(key), m.path(key));
}

void read_vec3(const Reader& rd, const Map& m, std::string_view key, Vec3& out,
               const std::string& meaning) {
  if (m.has(key)) out = rd.fixed<3>(m.get(key), m.path(key), meaning);
}

/// `gyro:` or `accel:` of an IMU: the TriadNoise fields given, over `t`.
void read_triad(const Reader& rd, const YAML::Node& node, const std::string& path, TriadNoise& t) {
  const Map m =
      rd.map(node, path, kTriadKeys, detail::concat("a map {", name_list(kTriadKeys), "}"));
  read_number(rd, m, "noise_density", t.noise_density);
  read_number(rd, m, "bias_random_walk", t.bias_random_walk);
  read_number(rd, m, "bias_instability", t.bias_instability);
  read_number(rd, m, "bias_correlation_time_s", t.bias_correlation_time_s);
  read_number(rd, m, "turn_on_bias", t.turn_on_bias);
  read_number(rd, m, "range", t.range);
}

/// `mounting: {position_m, rpy_deg}`: each key given replaces that part of `mounting`.
void read_mounting(const Reader& rd, const YAML::Node& node, const std::string& path,
                   Mounting& mounting) {
  const Map m = rd.map(node, path, kMountingKeys, "a map {position_m, rpy_deg}");
  read_vec3(rd, m, "position_m", mounting.position_B_m, "x, y, z in m, body frame");
  if (m.has("rpy_deg")) {
    const Vec3 rpy =
        rd.fixed<3>(m.get("rpy_deg"), m.path("rpy_deg"), "roll, pitch, yaw in deg, ZYX") *
        (std::numbers::pi / 180.0);
    mounting.rotation_BS_wxyz = math::from_euler(rpy[0], rpy[1], rpy[2]);
  }
}

/// A sensor's `faults:` (docs/faults.md): a list of {type: dropout, start_s[, end_s]} and
/// {type: bias_step, start_s[, end_s], channel, value}; validate() checks the values.
std::vector<SensorFault> read_sensor_faults(const Reader& rd, const YAML::Node& node,
                                            const std::string& path) {
  if (!node.IsSequence() || node.size() > kMaxSensorFaults)
    rd.fail(node, path,
            detail::concat("expected a list of at most ", kMaxSensorFaults,
                           " faults ({type: dropout, start_s, end_s} or {type: bias_step, "
                           "start_s, end_s, channel, value})"));
  std::vector<SensorFault> faults(node.size());
  for (std::size_t i = 0; i < node.size(); ++i) {
    const std::string item = detail::concat(path, "[", i, "]");
    const Map m = rd.map(node[i], item, kSensorFaultKeys,
                         "a map {type, start_s, end_s} (dropout) or {type, start_s, end_s, "
                         "channel, value} (bias_step)");
    SensorFault& f = faults[i];
    f.kind = static_cast<SensorFaultKind>(
        rd.choice(m.required("type"), m.path("type"), kSensorFaultTypes, "sensor fault type"));
    f.start_s = rd.number(m.required("start_s"), m.path("start_s"));
    if (m.has("end_s")) f.end_s = rd.number(m.get("end_s"), m.path("end_s"));
    if (f.kind == SensorFaultKind::kBiasStep) {
      f.channel = rd.string(m.required("channel"), m.path("channel"));
      f.value = rd.number(m.required("value"), m.path("value"));
    } else {
      for (const std::string_view key : {"channel", "value"})
        if (m.has(key))
          rd.fail(m.get(key), m.path(key),
                  "only a bias_step has a channel and a value (a dropout loses whole samples)");
    }
  }
  return faults;
}

/// The node of `field` ("gyro.noise_density", "position_noise_m[1]") inside `at` (a sensor map),
/// or the deepest node on its way that the file has (the sensor itself when the value is a
/// default): where a message about the field points. Recursive, since assigning a YAML::Node
/// would write into the document.
YAML::Node field_node(const YAML::Node& at, std::string_view field) {
  if (field.empty() || !at.IsMap()) return at;
  const std::size_t dot = field.find('.');
  std::string_view part = field.substr(0, dot);
  const std::string_view rest =
      dot == std::string_view::npos ? std::string_view() : field.substr(dot + 1);
  std::size_t index = std::string_view::npos;
  if (const std::size_t open = part.find('['); open != std::string_view::npos) {
    index = 0;
    for (std::size_t k = open + 1; k < part.size() && part[k] >= '0' && part[k] <= '9'; ++k)
      index = index * 10 + static_cast<std::size_t>(part[k] - '0');
    part = part.substr(0, open);
  }
  const YAML::Node child = at[std::string(part)];  // const operator[]: no insertion
  if (!child.IsDefined()) return at;
  if (index == std::string_view::npos) return field_node(child, rest);
  if (!child.IsSequence() || index >= child.size()) return child;
  return field_node(child[index], rest);
}

/// Runs `check` on the item at `path`, whose InvalidArgument message starts with the field
/// relative to the item ("gyro.noise_density: ..."), and reports it as "<path>.<message>" at
/// that field's line in the file.
template <class Check>
void check_item(const Reader& rd, const YAML::Node& node, const std::string& path, Check&& check) {
  try {
    check();
  } catch (const InvalidArgument& e) {
    const std::string message = e.what();
    rd.fail(field_node(node, std::string_view(message).substr(0, message.find(": "))), "",
            detail::concat(path, ".", message));
  }
}

/// One item of `sensors:`: the defaults of its type (SensorSpec::defaults) with the keys given
/// laid over them, validated against the physics step.
SensorSpec read_sensor(const Reader& rd, const YAML::Node& node, const std::string& path,
                       double physics_dt_s) {
  const std::size_t type = read_type(rd, node, path, kSensorTypes, "sensor type");
  const Names& keys = kSensorKeys[type];
  const std::string_view type_name = kSensorTypes[type];
  // A key of another type (noise_Pa under an imu) says so; any other stranger is the strict
  // map's "unknown key" with its suggestion.
  for (const auto& kv : node) {
    if (!kv.first.IsScalar()) continue;
    const std::string& key = kv.first.Scalar();
    if (std::find(keys.begin(), keys.end(), key) != keys.end()) continue;
    Names owners;
    for (std::size_t other = 0; other < kSensorKeys.size(); ++other) {
      const Names& theirs = kSensorKeys[other];
      if (std::find(theirs.begin(), theirs.end(), key) != theirs.end())
        owners.push_back(kSensorTypes[other]);
    }
    if (!owners.empty())
      rd.fail(kv.first, path,
              detail::concat("unknown key '", key, "' for a sensor of type ", type_name,
                             " (it is a key of type ", name_list(owners),
                             "); valid keys: ", name_list(keys)));
  }
  const Map m = rd.map(node, path, keys,
                       detail::concat("a map of ", type_name, " settings (", name_list(keys), ")"));
  SensorSpec s =
      SensorSpec::defaults(type_name, m.has("name") ? rd.string(m.get("name"), m.path("name"))
                                                    : std::string(kSensorDefaultNames[type]));
  read_number(rd, m, "rate_hz", s.rate_hz);
  read_number(rd, m, "latency_s", s.latency_s);
  if (m.has("mounting")) read_mounting(rd, m.get("mounting"), m.path("mounting"), s.mounting);
  if (m.has("faults")) s.faults = read_sensor_faults(rd, m.get("faults"), m.path("faults"));
  switch (type) {
    case 0: {
      auto& p = std::get<ImuParameters>(s.parameters);
      if (m.has("gyro")) read_triad(rd, m.get("gyro"), m.path("gyro"), p.gyro);
      if (m.has("accel")) read_triad(rd, m.get("accel"), m.path("accel"), p.accel);
      break;
    }
    case 1: {
      auto& p = std::get<MagnetometerParameters>(s.parameters);
      read_vec3(rd, m, "field_uT", p.field_W_uT, "x, y, z in uT, world frame");
      read_number(rd, m, "noise_uT", p.noise_uT);
      read_vec3(rd, m, "hard_iron_uT", p.hard_iron_uT, "x, y, z in uT, sensor frame");
      break;
    }
    case 2: {
      auto& p = std::get<BarometerParameters>(s.parameters);
      read_number(rd, m, "noise_Pa", p.noise_Pa);
      read_number(rd, m, "drift_Pa_per_sqrt_s", p.drift_Pa_per_sqrt_s);
      read_number(rd, m, "offset_Pa", p.offset_Pa);
      read_number(rd, m, "origin_altitude_m", p.origin_altitude_m);
      break;
    }
    case 3: {
      auto& p = std::get<GpsParameters>(s.parameters);
      read_vec3(rd, m, "position_noise_m", p.position_noise_m, "x, y, z in m");
      read_vec3(rd, m, "position_error_m", p.position_error_m, "x, y, z in m");
      read_number(rd, m, "position_error_time_s", p.position_error_time_s);
      read_vec3(rd, m, "velocity_noise_m_s", p.velocity_noise_m_s, "x, y, z in m/s");
      break;
    }
    case 4: {
      auto& p = std::get<MotionCaptureParameters>(s.parameters);
      read_number(rd, m, "position_noise_m", p.position_noise_m);
      read_number(rd, m, "attitude_noise_rad", p.attitude_noise_rad);
      break;
    }
    case 5: {
      auto& p = std::get<RangeFinderParameters>(s.parameters);
      read_number(rd, m, "min_range_m", p.min_range_m);
      read_number(rd, m, "max_range_m", p.max_range_m);
      read_number(rd, m, "noise_m", p.noise_m);
      read_number(rd, m, "noise_fraction", p.noise_fraction);
      read_number(rd, m, "dropout_probability", p.dropout_probability);
      break;
    }
    case 6: {
      auto& p = std::get<OpticalFlowParameters>(s.parameters);
      read_number(rd, m, "noise_rad_s", p.noise_rad_s);
      read_number(rd, m, "min_distance_m", p.min_distance_m);
      read_number(rd, m, "max_distance_m", p.max_distance_m);
      break;
    }
    default:
      read_number(rd, m, "noise_rad_s",
                  std::get<RotorSpeedSensorParameters>(s.parameters).noise_rad_s);
      break;
  }
  check_item(rd, node, path, [&] { validate(s, physics_dt_s); });
  return s;
}

/// Checks a depth camera's settings against the physics step: "<field>: ..." as validate() says.
void check_depth_camera(const DepthCameraParameters& p, double physics_dt_s) {
  validate(p);
  require(p.rate_hz * physics_dt_s <= 1.0 + 1e-9, "rate_hz: ", p.rate_hz,
          " Hz is faster than the physics step (", 1.0 / physics_dt_s,
          " Hz): expected at most one frame per step");
}

/// An item of `sensors:` of type depth_camera: DepthCameraParameters' defaults with the keys
/// given laid over them. `mounting.rpy_deg` turns the camera from looking forward along body x
/// (pitch > 0 looks down).
DepthCameraSpec read_depth_camera(const Reader& rd, const YAML::Node& node, const std::string& path,
                                  double physics_dt_s) {
  const Map m =
      rd.map(node, path, kDepthCameraKeys,
             detail::concat("a map of depth_camera settings (", name_list(kDepthCameraKeys), ")"));
  DepthCameraSpec c;
  if (m.has("name")) c.name = rd.string(m.get("name"), m.path("name"));
  DepthCameraParameters& p = c.parameters;
  read_number(rd, m, "rate_hz", p.rate_hz);
  for (const auto& [key, out] : {std::pair<std::string_view, int*>{"width_px", &p.width_px},
                                 std::pair<std::string_view, int*>{"height_px", &p.height_px}})
    if (m.has(key)) *out = rd.integer<int>(m.get(key), m.path(key), "a whole number of pixels");
  read_number(rd, m, "horizontal_fov_deg", p.horizontal_fov_deg);
  read_number(rd, m, "max_range_m", p.max_range_m);
  read_number(rd, m, "noise_at_1m_m", p.noise_at_1m_m);
  if (m.has("mounting")) {
    Mounting turn;
    read_mounting(rd, m.get("mounting"), m.path("mounting"), turn);
    p.mounting.position_B_m = turn.position_B_m;
    p.mounting.rotation_BS_wxyz =
        math::multiply<double>(turn.rotation_BS_wxyz, p.mounting.rotation_BS_wxyz);
  }
  check_item(rd, node, path, [&] { check_depth_camera(p, physics_dt_s); });
  return c;
}

/// `sensors:`: a list of sensor maps with unique names. Depth cameras go to `depth_cameras`;
/// where there is no such list (Python's SensorSuite), one is an error.
std::vector<SensorSpec> read_sensors(const Reader& rd, const YAML::Node& node,
                                     const std::string& path, double physics_dt_s,
                                     std::vector<DepthCameraSpec>* depth_cameras = nullptr) {
  Names types = kSensorTypes;
  types.push_back(kDepthCameraType);
  if (!node.IsSequence())
    rd.fail(node, path,
            detail::concat("expected a list of sensor maps, each with a 'type' (", name_list(types),
                           "), got ", describe(node)));
  std::vector<SensorSpec> sensors;
  std::vector<std::pair<std::string, std::size_t>> names;  // every name and its item
  for (std::size_t i = 0; i < node.size(); ++i) {
    const YAML::Node item = node[i];
    const std::string item_at = item_path(path, i);
    std::string name;
    if (types[read_type(rd, item, item_at, types, "sensor type")] == kDepthCameraType) {
      if (depth_cameras == nullptr)
        rd.fail(item, item_at,
                "a depth_camera renders frames, it is not a sensor of a SensorSuite: use "
                "DepthCamera (Python: dronetwin.DepthCamera) or an experiment's sensors:");
      depth_cameras->push_back(read_depth_camera(rd, item, item_at, physics_dt_s));
      name = depth_cameras->back().name;
    } else {
      sensors.push_back(read_sensor(rd, item, item_at, physics_dt_s));
      name = sensors.back().name;
    }
    for (const auto& [other, j] : names) {
      if (other != name) continue;
      const YAML::Node name_node = item["name"];  // const operator[]: no insertion
      rd.fail(name_node.IsDefined() ? name_node : item, detail::concat(item_at, ".name"),
              detail::concat("'", name, "' is already the name of ", item_path(path, j),
                             name_node.IsDefined() ? ""
                                                   : " (the default name of its type; give one "
                                                     "of them a 'name')"));
    }
    names.emplace_back(name, i);
  }
  return sensors;
}

const Names kEstimationKeys = {"imu", "updates", "controller_input"};
const Names kControllerInputs = {"estimate", "measured_state"};

/// The names and types of an estimation's sensors, by SensorFusion's own check.
void check_estimation(const EstimationSettings& s, const std::vector<SensorSpec>& sensors) {
  (void)SensorFusion(sensors, s.fusion, Simulator::hover_state(Vec3::Zero()));
}

/// `estimation:` {imu, updates, controller_input}; after the sensors.
EstimationSettings read_estimation(const Reader& rd, const YAML::Node& node, const Experiment& e) {
  const Map m =
      rd.map(node, "estimation", kEstimationKeys, "a map {imu, updates, controller_input}");
  EstimationSettings s;
  s.fusion.imu = rd.string(m.required("imu"), m.path("imu"));
  const YAML::Node updates = m.required("updates");
  if (!updates.IsSequence())
    rd.fail(updates, m.path("updates"),
            "expected a list of sensor names (motion_capture, gps, barometer, magnetometer, "
            "range_finder or optical_flow sensors), got " +
                describe(updates));
  for (std::size_t i = 0; i < updates.size(); ++i)
    s.fusion.updates.push_back(rd.string(updates[i], item_path(m.path("updates"), i)));
  if (m.has("controller_input"))
    s.control_on_estimate = rd.choice(m.get("controller_input"), m.path("controller_input"),
                                      kControllerInputs, "controller input") == 0;
  if (e.sensors.empty())
    rd.fail(node, "estimation", "needs sensors: add a `sensors:` list with an imu");
  try {
    check_estimation(s, e.sensors);
  } catch (const InvalidArgument& x) {
    // "updates[1]: no sensor named ..." -> field estimation.updates[1].
    const std::string what = x.what();
    const std::size_t colon = what.find(": ");
    const std::string field = what.substr(0, colon);
    const YAML::Node at = field == "imu" ? m.get("imu") : updates;
    rd.fail(at, detail::concat("estimation.", field), what.substr(colon + 2));
  }
  return s;
}

void check_experiment(const Experiment& e, const std::string& source) {
  const auto fail = [&](const std::string& field, const std::string& message) {
    throw InvalidArgument(source + ": " + field + ": " + message);
  };
  // The name goes into summaries, sidecars and file names of sweeps: one printable line.
  if (e.name.empty()) fail("name", "expected a non-empty name");
  for (const char c : e.name) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f)
      fail("name", "expected printable characters on one line, got control character " +
                       std::to_string(static_cast<int>(static_cast<unsigned char>(c))));
  }
  if (!(std::isfinite(e.duration_s) && e.duration_s > 0.0))
    fail("duration_s", "expected a number > 0, got " + format_number(e.duration_s));
  if (!(std::isfinite(e.sim.dt_s) && e.sim.dt_s > 0.0 && e.sim.dt_s <= 0.1))
    fail("physics_dt_s", "expected a step in (0, 0.1] s, got " + format_number(e.sim.dt_s));
  if (!(e.duration_s / e.sim.dt_s <= 1e12))
    fail("duration_s", "expected at most 1e12 physics steps, got duration_s / physics_dt_s = " +
                           format_number(e.duration_s / e.sim.dt_s));
  if (e.sim.ground.enabled && e.initial_state.position_m.z() < 0.0)
    fail("initial_state.position_m[2]",
         "expected z >= 0 (the ground is at z = 0; set ground.enabled: false to start below it), "
         "got " +
             format_number(e.initial_state.position_m.z()));
  // OU stability (as in validate(SimConfig), but naming the experiment's field): the per-step map
  // of a block is I - s Theta, with eigenvalues 1 - s a and 1 - s (a + N b), N = 3 or 4.
  const double s = e.sim.noise.parameters.drift == OuDrift::kPerSample ? 1.0 : e.sim.dt_s;
  const BlockCoefficients th = e.sim.noise.parameters.theta[0];
  for (const double n : {3.0, 4.0}) {
    const double e1 = 1.0 - s * th.a, e2 = 1.0 - s * (th.a + n * th.b);
    if (!(std::abs(e1) < 1.0 && std::abs(e2) < 1.0))
      fail("noise.theta",
           "the OU process is unstable: the per-step decay factors 1 - s a = " + format_number(e1) +
               " and 1 - s (a + " + format_number(n) + " b) = " + format_number(e2) +
               " must lie in (-1, 1) (s = " + format_number(s) + ", from the drift setting)");
  }
  if (const auto* p = std::get_if<PiecewiseRotorSpeedsInput>(&e.input)) {
    // Segments closer than a physics step would land on one step, and all but the last of them
    // would never fly: say so instead of dropping one.
    for (std::size_t i = 1; i < p->segments.size(); ++i) {
      const std::int64_t k = segment_start_step(p->segments[i].start_s, e.sim.dt_s);
      if (k == segment_start_step(p->segments[i - 1].start_s, e.sim.dt_s)) {
        fail("input.segments[" + std::to_string(i) + "].start_s",
             format_number(p->segments[i].start_s) + " s takes effect at the same physics step (" +
                 std::to_string(k) + ", t = " + format_number(static_cast<double>(k) * e.sim.dt_s) +
                 " s) as input.segments[" + std::to_string(i - 1) + "] (" +
                 format_number(p->segments[i - 1].start_s) + " s) with physics_dt_s " +
                 format_number(e.sim.dt_s) +
                 ": the earlier segment would never fly; starts must be at least one step apart");
      }
    }
  }
  if (const auto* loop = std::get_if<ControllerLoopInput>(&e.input)) {
    // As ClosedLoop checks it (thesis Eq. 3.11: f_physics / f_control steps per control).
    const double physics_hz = 1.0 / e.sim.dt_s;
    const double ratio = physics_hz / loop->control_rate_hz;
    const double n = std::round(ratio);
    if (!(std::isfinite(loop->control_rate_hz) && loop->control_rate_hz > 0.0 && n >= 1.0 &&
          n <= 2147483647.0 && std::abs(ratio - n) < 1e-9 * ratio))
      fail("input.control_rate_hz",
           "expected a rate that divides the physics rate " + format_number(physics_hz) +
               " Hz (1 / physics_dt_s) into a whole number of steps (thesis Eq. 3.11), got " +
               format_number(loop->control_rate_hz) + " Hz (" + format_number(ratio) +
               " steps per control)");
    if (loop->reference == nullptr) fail("input.reference", "missing (null reference)");
    // A reference built from finite numbers can still evaluate to inf (a period of 1e-320 s):
    // the controller would refuse it at t = 0; name the field here instead.
    const ReferencePoint r0 = loop->reference->at(0.0);
    if (!(r0.position_m.allFinite() && r0.velocity_m_s.allFinite() &&
          r0.acceleration_m_s2.allFinite() && std::isfinite(r0.yaw_rad) &&
          std::isfinite(r0.yaw_rate_rad_s))) {
      fail("input.reference",
           "is not finite at t = 0 s (" + loop->reference->describe() +
               "): check its numbers (a period or duration too small to divide by?)");
    }
  }
  // The sensors, as read_sensors() checks them (a caller may have changed physics_dt_s).
  for (std::size_t i = 0; i < e.sensors.size(); ++i) {
    const std::string item = item_path("sensors", i);
    try {
      validate(e.sensors[i], e.sim.dt_s);
    } catch (const InvalidArgument& x) {
      throw InvalidArgument(detail::concat(source, ": ", item, ".", x.what()));
    }
    for (std::size_t j = 0; j < i; ++j)
      if (e.sensors[j].name == e.sensors[i].name)
        fail(detail::concat(item, ".name"),
             detail::concat("'", e.sensors[i].name, "' is already the name of ",
                            item_path("sensors", j)));
  }
  for (std::size_t i = 0; i < e.depth_cameras.size(); ++i) {
    try {
      check_depth_camera(e.depth_cameras[i].parameters, e.sim.dt_s);
    } catch (const InvalidArgument& x) {
      throw InvalidArgument(
          detail::concat(source, ": depth camera '", e.depth_cameras[i].name, "': ", x.what()));
    }
  }
  if (e.estimation) {
    try {
      check_estimation(*e.estimation, e.sensors);
    } catch (const InvalidArgument& x) {
      throw InvalidArgument(detail::concat(source, ": estimation.", x.what()));
    }
  }
  // The remaining run settings with the simulator's own check.
  (void)e.sim_config();
}

template <class... Fs>
struct Overloaded : Fs... {
  using Fs::operator()...;
};
template <class... Fs>
Overloaded(Fs...) -> Overloaded<Fs...>;

}  // namespace

namespace io_detail {

std::optional<Map> switchable_section(const Reader& rd, const YAML::Node& node,
                                      const std::string& path, NameList keys,
                                      const std::string& expected, bool& enabled) {
  if (node.IsScalar()) {
    enabled = rd.boolean(node, path);
    return std::nullopt;
  }
  Map m = rd.map(node, path, keys, expected);
  enabled = m.has("enabled") ? rd.boolean(m.get("enabled"), m.path("enabled")) : true;
  return m;
}

double read_nonnegative(const Reader& rd, const Map& m, std::string_view key, double fallback,
                        const std::string& what) {
  if (!m.has(key)) return fallback;
  const YAML::Node n = m.get(key);
  const double v = rd.number(n, m.path(key));
  if (v < 0.0) rd.fail(n, m.path(key), "expected " + what + " >= 0, got " + n.Scalar());
  return v;
}

std::vector<SensorSpec> read_sensor_list(const Reader& rd, const YAML::Node& node,
                                         const std::string& path, double dt_s,
                                         std::vector<DepthCameraSpec>* depth_cameras) {
  return read_sensors(rd, node, path, dt_s, depth_cameras);
}

void read_sim_settings(const Reader& rd, const Map& top, SimConfig& sim) {
  if (top.has("seed")) {
    sim.seed = rd.integer<std::uint64_t>(top.get("seed"), "seed",
                                         "an integer in [0, 18446744073709551615]");
  }
  if (top.has("physics_dt_s")) sim.dt_s = rd.positive(top.get("physics_dt_s"), "physics_dt_s");
  if (top.has("integrator")) {
    sim.integrator = rd.choice(top.get("integrator"), "integrator", kIntegrators, "integrator") == 0
                         ? Integrator::kRk4
                         : Integrator::kEuler;
  }
  if (top.has("motor_dynamics"))
    sim.motor_dynamics = rd.boolean(top.get("motor_dynamics"), "motor_dynamics");
  if (top.has("noise")) sim.noise = read_noise(rd, top.get("noise"), "noise");
  if (top.has("wind_m_s"))
    sim.environment.wind_W_m_s = rd.fixed<3>(top.get("wind_m_s"), "wind_m_s", "x, y, z in m/s");
  if (top.has("wind")) sim.wind = read_wind(rd, top.get("wind"), "wind");
  if (top.has("gravity_m_s2"))
    sim.environment.gravity_W_m_s2 =
        rd.fixed<3>(top.get("gravity_m_s2"), "gravity_m_s2", "x, y, z in m/s^2");
  if (top.has("disturbances"))
    sim.disturbances = read_disturbances(rd, top.get("disturbances"), "disturbances");
  if (top.has("ground")) sim.ground = read_ground(rd, top.get("ground"), "ground");
  if (top.has("divergence"))
    sim.divergence = read_divergence(rd, top.get("divergence"), "divergence");
  if (top.has("faults")) sim.faults = read_faults(rd, top.get("faults"), "faults");
  if (top.has("battery")) sim.battery = read_battery(rd, top.get("battery"), "battery");
  if (top.has("payload")) sim.payload = read_payload(rd, top.get("payload"), "payload");
}

std::shared_ptr<const Reference> read_reference_spec(const Reader& rd, const YAML::Node& node,
                                                     const std::string& path) {
  return read_reference(rd, node, path).first;
}

std::string find_named_file(const Reader& rd, const YAML::Node& node, const std::string& path,
                            const std::string& what) {
  return resolve_file(rd, node, path, rd.string(node, path), what);
}

}  // namespace io_detail

// ---- public API -------------------------------------------------------------------------------

RotorVector RotorSpeedSetting::resolve(const VehicleModel& model, double gravity_m_s2) const {
  switch (kind) {
    case Kind::kStopped:
      return RotorVector::Zero(model.num_rotors());
    case Kind::kHover:
      return model.hover_speeds_rad_s(gravity_m_s2);
    case Kind::kValues:
      break;
  }
  require(static_cast<int>(values_rad_s.size()) == model.num_rotors(), "rotor speeds: expected ",
          model.num_rotors(), " numbers (rotors of ", model.name(), "), got ", values_rad_s.size());
  RotorVector w(model.num_rotors());
  for (int i = 0; i < model.num_rotors(); ++i) w[i] = values_rad_s[static_cast<std::size_t>(i)];
  return w;
}

std::string_view input_type_name(const ExperimentInput& input) {
  return kInputTypes[input.index()];
}

StateVector InitialStateSpec::state() const {
  using namespace state_index;
  StateVector x;
  x.segment<3>(kPosition) = position_m;
  x.segment<3>(kVelocity) = velocity_m_s;
  x.segment<4>(kQuaternion) = quaternion_wxyz;
  x.segment<3>(kAngularVelocity) = angular_velocity_rad_s;
  return x;
}

SimConfig Experiment::sim_config() const {
  try {
    dronetwin::validate(sim);
  } catch (const InvalidArgument& e) {
    throw InvalidArgument(source + ": " + e.what());
  }
  return sim;
}

std::int64_t Experiment::num_steps() const {
  return static_cast<std::int64_t>(std::ceil(duration_s / sim.dt_s - 1e-9));
}

std::int64_t segment_start_step(double start_s, double dt_s) {
  const double k = std::ceil(start_s / dt_s - 1e-9);
  // A start beyond the int64 range (start_s: 1e300) is a step no run reaches: saturate, since
  // converting such a k to an integer is undefined behaviour.
  constexpr double kNever = 9223372036854775807.0;  // 2^63, the first double past INT64_MAX
  if (!(k < kNever)) return std::numeric_limits<std::int64_t>::max();
  return k > 0.0 ? static_cast<std::int64_t>(k) : 0;
}

std::vector<SensorSpec> parse_sensor_specs(const std::string& yaml_text,
                                           const std::string& source_name, double physics_dt_s) {
  require(std::isfinite(physics_dt_s) && physics_dt_s > 0.0, source_name,
          ": physics_dt_s: expected a number > 0, got ", physics_dt_s);
  const Reader rd(source_name);
  return read_sensors(rd, rd.parse(yaml_text, "a list of sensor maps"), "sensors", physics_dt_s);
}

Experiment parse_experiment(const std::string& yaml_text, const std::string& source_name) {
  const Reader rd(source_name);
  const std::string expected = "a map of experiment settings";
  const Map top = rd.map(rd.parse(yaml_text, expected), "", kTopLevelKeys, expected);
  for (std::string_view key : kRequiredTopLevelKeys) (void)top.required(key);

  Experiment e;
  e.source = source_name;
  e.name = rd.string(top.get("name"), "name");
  if (top.has("description")) e.description = rd.string(top.get("description"), "description");
  e.model_path =
      resolve_file(rd, top.get("model"), "model", rd.string(top.get("model"), "model"), "model");
  io_detail::read_sim_settings(rd, top, e.sim);
  e.duration_s = rd.positive(top.get("duration_s"), "duration_s");
  if (top.has("initial_state"))
    e.initial_state = read_initial_state(rd, top.get("initial_state"), "initial_state");
  if (top.has("log")) e.log = read_log(rd, top.get("log"), "log");
  if (top.has("metrics")) e.metrics = read_metrics(rd, top.get("metrics"), "metrics");
  e.input = read_input(rd, top.get("input"), "input");
  const auto* loop = std::get_if<ControllerLoopInput>(&e.input);
  if (top.has("metrics") && loop == nullptr)
    rd.fail(top.get("metrics"), "metrics",
            "only for input type 'controller' (it sets where the tracking RMSE is taken), not '" +
                std::string(input_type_name(e.input)) + "'");
  if (e.initial_state.on_reference) {
    const YAML::Node initial = top.get("initial_state");
    const YAML::Node on_ref = initial["on_reference"];  // const operator[]: no insertion
    if (loop == nullptr)
      rd.fail(on_ref, "initial_state.on_reference",
              "only for input type 'controller' (it starts on the controller's reference), not '" +
                  std::string(input_type_name(e.input)) + "'");
    // At the reference at t = 0: its position and velocity, level at its yaw, rotors at hover.
    const ReferencePoint r0 = loop->reference->at(0.0);
    e.initial_state.position_m = r0.position_m;
    e.initial_state.velocity_m_s = r0.velocity_m_s;
    e.initial_state.quaternion_wxyz = math::from_euler(0.0, 0.0, r0.yaw_rad);
    e.initial_state.angular_velocity_rad_s = Vec3::Zero();
    e.initial_state.rotor_speeds = RotorSpeedSetting::hover();
    if (e.sim.ground.enabled && r0.position_m.z() < 0.0)
      rd.fail(on_ref, "initial_state.on_reference",
              "the reference starts below the ground (z = " + format_number(r0.position_m.z()) +
                  " m at t = 0); set ground.enabled: false to start there");
  }
  if (top.has("scene")) {
    e.scene_path =
        resolve_file(rd, top.get("scene"), "scene", rd.string(top.get("scene"), "scene"), "scene");
    try {
      e.scene = std::make_shared<const Track>(load_track(e.scene_path));
    } catch (const InvalidArgument& err) {
      rd.fail(top.get("scene"), "scene", err.what());
    }
  }
  check_experiment(e, source_name);
  // After the checks above, so that the physics step the sensor rates are checked against is
  // known to be valid.
  if (top.has("sensors"))
    e.sensors = read_sensors(rd, top.get("sensors"), "sensors", e.sim.dt_s, &e.depth_cameras);
  if (top.has("estimation")) e.estimation = read_estimation(rd, top.get("estimation"), e);
  return e;
}

Experiment load_experiment(const std::string& path) {
  return parse_experiment(read_text_file(path, "experiment file"), path);
}

void validate(const Experiment& experiment) { check_experiment(experiment, experiment.source); }

void check_against_model(const Experiment& e, const VehicleModel& model) {
  const auto check = [&](const RotorSpeedSetting& s, const std::string& field) {
    if (s.kind != RotorSpeedSetting::Kind::kValues) return;
    const int n = model.num_rotors();
    require(static_cast<int>(s.values_rad_s.size()) == n, e.source, ": ", field, ": expected ", n,
            " numbers (rotors of ", model.name(), "), got ", s.values_rad_s.size());
    for (int i = 0; i < n; ++i) {
      const RotorParams& r = model.rotor(i);
      const double w = s.values_rad_s[static_cast<std::size_t>(i)];
      require(w >= r.min_speed_rad_s && w <= r.max_speed_rad_s, e.source, ": ", field, "[", i,
              "]: expected a speed within the limits of rotor ", i, " of ", model.name(), " [",
              r.min_speed_rad_s, ", ", r.max_speed_rad_s, "] rad/s, got ", w,
              " (rotor speeds are rad/s, not RPM)");
    }
  };
  check(e.initial_state.rotor_speeds, "initial_state.rotor_speeds_rad_s");
  std::visit(Overloaded{
                 [&](const ConstantRotorSpeedsInput& in) {
                   check(in.rotor_speeds, "input.rotor_speeds_rad_s");
                 },
                 [&](const PiecewiseRotorSpeedsInput& in) {
                   for (std::size_t i = 0; i < in.segments.size(); ++i)
                     check(in.segments[i].rotor_speeds,
                           "input.segments[" + std::to_string(i) + "].rotor_speeds_rad_s");
                 },
                 [&](const ConstantGeneralizedForceInput&) {},
                 [&](const HoverInput&) {},
                 // The controller is built for the model by run_experiment (load_controller).
                 [&](const ControllerLoopInput&) {},
             },
             e.input);
  for (int j = 0; j < e.sim.faults.num_rotor_faults; ++j) {
    const int rotor = e.sim.faults.rotor[static_cast<std::size_t>(j)].rotor;
    require(rotor < model.num_rotors(), e.source, ": faults[", j, "].rotor: expected 0 .. ",
            model.num_rotors() - 1, " (rotors of ", model.name(), "), got ", rotor);
  }
}

}  // namespace dronetwin
