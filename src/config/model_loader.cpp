// Strict YAML binding of VehicleSpec (format: docs/model-format.md), on the shared strict reader
// of yaml_strict.hpp, and the writer. Every error names the source, the field path and what was
// expected versus found.
#include "dronetwin/config/model_loader.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/atomic_file.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "yaml_strict.hpp"

namespace dronetwin {
namespace {

using io_detail::describe;
using io_detail::item_path;
using io_detail::Map;
using io_detail::name_list;
using io_detail::NonFinite;
using io_detail::Reader;

/// Shortest decimal text that reads back to exactly `v` (std::to_chars round-trip guarantee; the
/// reader's number parsing is correctly rounded).
std::string format_double(double v) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  std::array<char, 32> buf{};
  const auto [end, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  if (ec != std::errc{}) throw InvalidArgument("vehicle_spec_to_yaml: cannot format a number");
  return std::string(buf.data(), end);
}

// ---- key tables -------------------------------------------------------------------------------

constexpr std::array<std::string_view, 8> kTopLevelKeys = {
    "name",           "mass_kg", "inertia_kgm2", "body_drag_Ns_per_m", "ground_effect_min_height_m",
    "rotor_defaults", "rotors",  "collision",
};
constexpr std::array<std::string_view, 4> kCollisionKeys = {"shape", "radius_m", "half_size_m",
                                                            "center_m"};
constexpr std::array<std::string_view, 2> kCollisionShapes = {"sphere", "box"};
constexpr std::array<std::string_view, 5> kRequiredTopLevelKeys = {
    "name", "mass_kg", "inertia_kgm2", "body_drag_Ns_per_m", "rotors"};

// ---- reader helpers ---------------------------------------------------------------------------

/// "missing required key 'a'" or "missing required keys 'a', 'b'".
std::string missing_keys_message(const std::vector<std::string_view>& missing) {
  std::string keys;
  for (std::string_view k : missing) keys += (keys.empty() ? "'" : ", '") + std::string(k) + "'";
  return (missing.size() == 1 ? "missing required key " : "missing required keys ") + keys;
}

std::array<double, 3> read_three_numbers(const Reader& rd, const YAML::Node& node,
                                         const std::string& path) {
  const Vec3 v = rd.fixed<3>(node, path, "");
  return {v[0], v[1], v[2]};
}

/// Either 3 numbers (the diagonal) or 3 rows of 3 numbers (the full matrix).
Mat3 read_mat3(const Reader& rd, const YAML::Node& node, const std::string& path) {
  const std::string expected = "expected 3 numbers (the diagonal) or 3 rows of 3 numbers, got ";
  if (!node.IsSequence()) rd.fail(node, path, expected + describe(node));
  if (node.size() != 3)
    rd.fail(node, path, expected + "a sequence of " + std::to_string(node.size()));
  std::size_t rows = 0;
  for (std::size_t i = 0; i < 3; ++i) rows += node[i].IsSequence() ? 1 : 0;
  Mat3 m = Mat3::Zero();
  if (rows == 0) {
    m.diagonal() = rd.fixed<3>(node, path, "");
  } else if (rows == 3) {
    for (std::size_t i = 0; i < 3; ++i) {
      m.row(static_cast<Eigen::Index>(i)) =
          rd.fixed<3>(node[i], item_path(path, i), "").transpose();
    }
  } else {
    rd.fail(node, path, expected + "a mix of numbers and rows");
  }
  return m;
}

// ---- rotor fields -----------------------------------------------------------------------------

// The plain-number rotor fields, in the order of RotorParams (the writer uses the same order).
constexpr std::array<std::pair<std::string_view, double RotorParams::*>, 10> kRotorNumbers = {{
    {"yaw_moment_per_thrust_m", &RotorParams::yaw_moment_per_thrust_m},
    {"rotor_drag_coefficient", &RotorParams::rotor_drag_coefficient},
    {"rolling_moment_coefficient", &RotorParams::rolling_moment_coefficient},
    {"drag_moment_coefficient", &RotorParams::drag_moment_coefficient},
    {"ground_effect_coefficient", &RotorParams::ground_effect_coefficient},
    {"inertia_kgm2", &RotorParams::inertia_kgm2},
    {"time_constant_rise_s", &RotorParams::time_constant_rise_s},
    {"time_constant_fall_s", &RotorParams::time_constant_fall_s},
    {"min_speed_rad_s", &RotorParams::min_speed_rad_s},
    {"max_speed_rad_s", &RotorParams::max_speed_rad_s},
}};

/// Every rotor key; all are required (after merging rotor_defaults) except `axis`.
std::vector<std::string_view> rotor_keys(bool with_position) {
  std::vector<std::string_view> keys;
  if (with_position) keys.push_back("position_m");
  keys.insert(keys.end(), {"axis", "spin", "thrust_coefficients"});
  for (const auto& field : kRotorNumbers) keys.push_back(field.first);
  return keys;
}

/// Reads the value of rotor key `key` (already known to be valid) into `rotor`.
void set_rotor_field(const Reader& rd, std::string_view key, const YAML::Node& node,
                     const std::string& path, RotorParams& rotor) {
  if (key == "position_m") {
    rotor.position_m = rd.fixed<3>(node, path, "");
  } else if (key == "axis") {
    rotor.axis = rd.fixed<3>(node, path, "");
  } else if (key == "spin") {
    rotor.spin = rd.integer<int>(node, path, "an integer");
  } else if (key == "thrust_coefficients") {
    rotor.thrust_coefficients = read_three_numbers(rd, node, path);
  } else {
    for (const auto& [name, member] : kRotorNumbers) {
      if (name == key) {
        rotor.*member = rd.number(node, path);
        return;
      }
    }
  }
}

/// Rotor values given in rotor_defaults, and which keys they cover.
struct RotorDefaults {
  RotorParams values;
  std::vector<std::string_view> given;
};

RotorDefaults read_rotor_defaults(const Reader& rd, const YAML::Node& node) {
  const std::string path = "rotor_defaults";
  if (node.IsMap()) {
    for (const auto& kv : node) {
      if (kv.first.IsScalar() && kv.first.Scalar() == "position_m")
        rd.fail(kv.first, path,
                "'position_m' cannot have a default; give every rotor its own position_m");
    }
  }
  const Map m = rd.map(node, path, rotor_keys(false), "a map of rotor keys");
  RotorDefaults out;
  for (std::string_view key : rotor_keys(false)) {
    if (!m.has(key)) continue;
    set_rotor_field(rd, key, m.get(key), m.path(key), out.values);
    out.given.push_back(key);
  }
  return out;
}

RotorParams read_rotor(const Reader& rd, const YAML::Node& node, std::size_t i,
                       const RotorDefaults& defaults) {
  const std::string path = item_path("rotors", i);
  const Map m = rd.map(node, path, rotor_keys(true), "a map of rotor keys");
  RotorParams rotor = defaults.values;
  std::vector<std::string_view> missing;
  for (std::string_view key : rotor_keys(true)) {
    if (m.has(key)) {
      set_rotor_field(rd, key, m.get(key), m.path(key), rotor);
    } else if (key != "axis" && std::find(defaults.given.begin(), defaults.given.end(), key) ==
                                    defaults.given.end()) {
      missing.push_back(key);
    }
  }
  if (!missing.empty()) {
    rd.fail(node, path,
            missing_keys_message(missing) + " (set in neither the rotor nor rotor_defaults)");
  }
  return rotor;
}

// ---- writer helpers ---------------------------------------------------------------------------

void emit_numbers(YAML::Emitter& out, const double* v, std::size_t n) {
  out << YAML::Flow << YAML::BeginSeq;
  for (std::size_t i = 0; i < n; ++i) out << format_double(v[i]);
  out << YAML::EndSeq;
}

void emit_vec3(YAML::Emitter& out, const Vec3& v) { emit_numbers(out, v.data(), 3); }

void emit_mat3(YAML::Emitter& out, const Mat3& m) {
  out << YAML::BeginSeq;
  for (Eigen::Index r = 0; r < 3; ++r) {
    const Vec3 row = m.row(r).transpose();
    emit_vec3(out, row);
  }
  out << YAML::EndSeq;
}

// `collision: {shape: sphere, radius_m: r}` or `{shape: box, half_size_m: [x, y, z]}`, each with
// an optional `center_m` (body frame). The other shape's size key is an error, not ignored.
CollisionShape read_collision(const Reader& rd, const YAML::Node& node) {
  const Map m = rd.map(node, "collision", kCollisionKeys,
                       "a map with the keys shape, radius_m (sphere) or half_size_m (box), "
                       "center_m");
  const bool sphere =
      rd.choice(m.required("shape"), "collision.shape", kCollisionShapes, "collision shape") == 0;
  const std::string_view size_key = sphere ? "radius_m" : "half_size_m";
  const std::string_view other_key = sphere ? "half_size_m" : "radius_m";
  if (m.has(other_key)) {
    rd.fail(
        m.get(other_key), m.path(other_key),
        detail::concat("a ", sphere ? "sphere" : "box", " has no ", other_key, "; use ", size_key));
  }
  CollisionShape c;
  c.kind = sphere ? CollisionShape::Kind::kSphere : CollisionShape::Kind::kBox;
  if (sphere)
    c.radius_m = rd.number(m.required("radius_m"), "collision.radius_m");
  else
    c.half_size_m = rd.fixed<3>(m.required("half_size_m"), "collision.half_size_m",
                                "half extents along body x, y, z in m");
  if (m.has("center_m"))
    c.center_B_m = rd.fixed<3>(m.get("center_m"), "collision.center_m", "x, y, z in m, body frame");
  return c;
}

}  // namespace

// ---- public API -------------------------------------------------------------------------------

VehicleSpec parse_vehicle_spec(const std::string& yaml_text, const std::string& source_name) {
  // Infinite and NaN values read as numbers: VehicleModel's validation rejects them naming the
  // field, with "expected a finite number" rather than "not a number" (docs/model-format.md).
  const Reader rd(source_name, NonFinite::kAllow);
  const std::string top_expected = "a map with the keys " + name_list(kTopLevelKeys);
  const Map top = rd.map(rd.parse(yaml_text, top_expected), "", kTopLevelKeys, top_expected);

  std::vector<std::string_view> missing;
  for (std::string_view k : kRequiredTopLevelKeys)
    if (!top.has(k)) missing.push_back(k);
  if (!missing.empty()) rd.fail("", missing_keys_message(missing));

  VehicleSpec spec;
  spec.source = source_name;
  spec.name = rd.string(top.get("name"), "name");
  spec.mass_kg = rd.number(top.get("mass_kg"), "mass_kg");
  spec.inertia_kgm2 = read_mat3(rd, top.get("inertia_kgm2"), "inertia_kgm2");
  spec.body_drag_Ns_per_m = read_mat3(rd, top.get("body_drag_Ns_per_m"), "body_drag_Ns_per_m");
  if (top.has("ground_effect_min_height_m")) {
    spec.ground_effect_min_height_m =
        rd.number(top.get("ground_effect_min_height_m"), "ground_effect_min_height_m");
  }
  if (top.has("collision")) spec.collision = read_collision(rd, top.get("collision"));
  RotorDefaults defaults;
  if (top.has("rotor_defaults")) defaults = read_rotor_defaults(rd, top.get("rotor_defaults"));

  const YAML::Node rotors = top.get("rotors");
  if (!rotors.IsSequence())
    rd.fail(rotors, "rotors", "expected a sequence of rotor maps, got " + describe(rotors));
  spec.rotors.reserve(rotors.size());
  for (std::size_t i = 0; i < rotors.size(); ++i)
    spec.rotors.push_back(read_rotor(rd, rotors[i], i, defaults));
  return spec;
}

VehicleSpec load_vehicle_spec(const std::string& path) {
  return parse_vehicle_spec(read_text_file(path, "model file"), path);
}

VehicleModel load_vehicle_model(const std::string& path) {
  return VehicleModel(load_vehicle_spec(path));
}

std::string vehicle_spec_to_yaml(const VehicleSpec& spec) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << YAML::DoubleQuoted << spec.name;
  out << YAML::Key << "mass_kg" << YAML::Value << format_double(spec.mass_kg);
  out << YAML::Key << "inertia_kgm2" << YAML::Value;
  emit_mat3(out, spec.inertia_kgm2);
  out << YAML::Key << "body_drag_Ns_per_m" << YAML::Value;
  emit_mat3(out, spec.body_drag_Ns_per_m);
  out << YAML::Key << "ground_effect_min_height_m" << YAML::Value
      << format_double(spec.ground_effect_min_height_m);
  out << YAML::Key << "rotors" << YAML::Value;
  if (spec.rotors.empty()) out << YAML::Flow;  // "rotors: []"
  out << YAML::BeginSeq;
  for (const RotorParams& r : spec.rotors) {
    out << YAML::BeginMap;
    out << YAML::Key << "position_m" << YAML::Value;
    emit_vec3(out, r.position_m);
    out << YAML::Key << "axis" << YAML::Value;
    emit_vec3(out, r.axis);
    out << YAML::Key << "spin" << YAML::Value << std::to_string(r.spin);
    out << YAML::Key << "thrust_coefficients" << YAML::Value;
    emit_numbers(out, r.thrust_coefficients.data(), r.thrust_coefficients.size());
    for (const auto& [key, member] : kRotorNumbers)
      out << YAML::Key << std::string(key) << YAML::Value << format_double(r.*member);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (spec.collision) {
    const CollisionShape& c = *spec.collision;
    const bool sphere = c.kind == CollisionShape::Kind::kSphere;
    out << YAML::Key << "collision" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "shape" << YAML::Value << std::string(collision_kind_name(c.kind));
    if (sphere) {
      out << YAML::Key << "radius_m" << YAML::Value << format_double(c.radius_m);
    } else {
      out << YAML::Key << "half_size_m" << YAML::Value;
      emit_vec3(out, c.half_size_m);
    }
    out << YAML::Key << "center_m" << YAML::Value;
    emit_vec3(out, c.center_B_m);
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  if (!out.good()) throw InvalidArgument("vehicle_spec_to_yaml: " + out.GetLastError());
  return "# Vehicle model written by dronetwin::save_vehicle_spec (format: "
         "docs/model-format.md).\n# Numbers are the shortest decimals that read back bit for "
         "bit.\n" +
         std::string(out.c_str()) + "\n";
}

void save_vehicle_spec(const VehicleSpec& spec, const std::string& path) {
  // Atomic: a failed write (full disk, no permission) leaves an existing model file as it was.
  write_file_atomically(path, vehicle_spec_to_yaml(spec));
}

}  // namespace dronetwin
