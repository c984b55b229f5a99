// Fleet experiment files (config/fleet_experiment.hpp).
#include "dronetwin/config/fleet_experiment.hpp"

#include <array>
#include <cmath>
#include <optional>
#include <string_view>
#include <utility>

#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "experiment_parts.hpp"
#include "yaml_strict.hpp"

namespace dronetwin {

namespace {

using io_detail::Map;
using io_detail::Reader;

constexpr std::array<std::string_view, 5> kTopKeys{"name", "description", "duration_s", "downwash",
                                                   "vehicles"};
constexpr std::array<std::string_view, 2> kVehicleKeys{"name", "experiment"};
constexpr std::array<std::string_view, 5> kDownwashKeys{
    "enabled", "spreading_rate", "propeller_radius_m", "thrust_lapse", "air_density_kg_m3"};

DownwashSettings read_downwash(const Reader& rd, const YAML::Node& node) {
  DownwashSettings d;
  const std::optional<Map> m = io_detail::switchable_section(
      rd, node, "downwash", kDownwashKeys, "true, false or a map of downwash settings", d.enabled);
  if (!m) return d;
  for (const auto& [key, out] :
       {std::pair<std::string_view, double*>{"spreading_rate", &d.spreading_rate},
        {"propeller_radius_m", &d.propeller_radius_m},
        {"air_density_kg_m3", &d.air_density_kg_m3}}) {
    if (m->has(key)) *out = rd.positive(m->get(key), m->path(key));
  }
  d.thrust_lapse =
      io_detail::read_nonnegative(rd, *m, "thrust_lapse", d.thrust_lapse, "a thrust lapse");
  return d;
}

}  // namespace

FleetExperiment parse_fleet_experiment(const std::string& yaml_text,
                                       const std::string& source_name) {
  const Reader rd(source_name);
  const YAML::Node root = rd.parse(yaml_text, "a map describing a fleet experiment");
  const Map top = rd.map(root, "", kTopKeys, "a map describing a fleet experiment");
  FleetExperiment f;
  f.source = source_name;
  f.name = rd.string(top.required("name"), "name");
  if (top.has("description")) f.description = rd.string(top.get("description"), "description");
  f.duration_s = rd.positive(top.required("duration_s"), "duration_s");
  if (top.has("downwash")) f.downwash = read_downwash(rd, top.get("downwash"));
  const YAML::Node list = top.required("vehicles");
  if (!list.IsSequence() || list.size() < 1)
    rd.fail(list, "vehicles",
            "expected a list of vehicles ({name, experiment}), got " + io_detail::describe(list));
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string path = io_detail::item_path("vehicles", i);
    const Map v = rd.map(list[i], path, kVehicleKeys, "a map {name, experiment}");
    FleetVehicleSpec spec;
    spec.name = rd.string(v.required("name"), v.path("name"));
    if (spec.name.empty() || spec.name.find_first_of("/\\ \t\n") != std::string::npos ||
        spec.name == "." || spec.name == "..")
      rd.fail(v.get("name"), v.path("name"),
              "expected a name usable as a folder (no spaces or slashes, not . or ..), got '" +
                  spec.name + "'");
    for (const FleetVehicleSpec& other : f.vehicles)
      if (other.name == spec.name)
        rd.fail(v.get("name"), v.path("name"), "two vehicles are called '" + spec.name + "'");
    spec.experiment_path = io_detail::find_named_file(rd, v.required("experiment"),
                                                      v.path("experiment"), "experiment");
    spec.experiment = load_experiment(spec.experiment_path);
    spec.experiment.duration_s = f.duration_s;
    if (const auto* c = std::get_if<ControllerLoopInput>(&spec.experiment.input);
        c != nullptr && c->real_time)
      rd.fail(v.get("experiment"), v.path("experiment"),
              "'" + spec.experiment_path +
                  "' paces at real time (input.real_time): a fleet steps as fast as it can");
    if (!f.vehicles.empty()) {
      const Experiment& first = f.vehicles.front().experiment;
      if (spec.experiment.sim.dt_s != first.sim.dt_s)
        rd.fail(v.get("experiment"), v.path("experiment"),
                detail::concat("physics_dt_s of '", spec.experiment_path, "' is ",
                               spec.experiment.sim.dt_s, " s, but ", first.sim.dt_s, " s in '",
                               f.vehicles.front().experiment_path,
                               "': a fleet steps its vehicles in lockstep"));
    }
    f.vehicles.push_back(std::move(spec));
  }
  return f;
}

FleetExperiment load_fleet_experiment(const std::string& path) {
  return parse_fleet_experiment(read_text_file(path, "fleet experiment file"), path);
}

bool looks_like_fleet_experiment(const std::string& yaml_text) {
  try {
    const YAML::Node root = YAML::Load(yaml_text);
    return root.IsMap() && root["vehicles"].IsDefined();
  } catch (...) {
    return false;
  }
}

}  // namespace dronetwin
