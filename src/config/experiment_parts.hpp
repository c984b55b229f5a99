#pragma once
// The parts of an experiment file that other file formats share (src/config only): the physics
// settings of the top level, a `reference:` map, switchable sections, and files named relative
// to the file that names them. Defined in experiment.cpp; docs/experiment-format.md describes them.

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "dronetwin/control/reference.hpp"
#include "dronetwin/sensors/depth_camera.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"
#include "dronetwin/sim/sim_config.hpp"
#include "yaml_strict.hpp"

namespace dronetwin::io_detail {

/// Top-level keys read by read_sim_settings.
inline constexpr std::string_view kSimSettingKeys[] = {
    "seed",       "physics_dt_s", "integrator",   "motor_dynamics", "noise",
    "wind_m_s",   "wind",         "gravity_m_s2", "disturbances",   "ground",
    "divergence", "faults",       "battery",      "payload"};

/// seed, physics_dt_s, integrator, motor_dynamics, noise, wind_m_s, wind, gravity_m_s2,
/// disturbances, ground, divergence, faults, battery and payload of map `top`, where present, into
/// `sim`.
void read_sim_settings(const Reader& rd, const Map& top, SimConfig& sim);

/// A `sensors:` list (docs/experiment-format.md, "Sensors") checked against the step `dt_s` at
/// which the sensors sample; items of type depth_camera go to `depth_cameras` (an error where it
/// is null).
std::vector<SensorSpec> read_sensor_list(const Reader& rd, const YAML::Node& node,
                                         const std::string& path, double dt_s,
                                         std::vector<DepthCameraSpec>* depth_cameras);

/// A `reference:` map (type circle, figure_eight, setpoint, ...).
std::shared_ptr<const Reference> read_reference_spec(const Reader& rd, const YAML::Node& node,
                                                     const std::string& path);

/// A section that is true, false or a map of settings with an optional `enabled` (default true):
/// sets `enabled` and returns the map when it is one (`payload:`, `battery:`, a fleet's
/// `downwash:`).
std::optional<Map> switchable_section(const Reader& rd, const YAML::Node& node,
                                      const std::string& path, NameList keys,
                                      const std::string& expected, bool& enabled);

/// The number at `key` of `m`, which must be >= 0 ("expected <what> >= 0"), or `fallback` when
/// the key is absent.
double read_nonnegative(const Reader& rd, const Map& m, std::string_view key, double fallback,
                        const std::string& what);

/// The file named by string node `node`: relative to the reading file's directory if it is
/// there, else to the current directory; fails naming `what` and where it looked.
std::string find_named_file(const Reader& rd, const YAML::Node& node, const std::string& path,
                            const std::string& what);

}  // namespace dronetwin::io_detail
