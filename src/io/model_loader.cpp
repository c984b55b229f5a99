// Strict YAML binding of VehicleSpec (format: docs/model-format.md). The only file that includes
// yaml-cpp. Every error names the source, the field path and what was expected versus found.
#include "dronetwin/io/model_loader.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "dronetwin/core/error.hpp"

namespace dronetwin {
namespace {

// ---- scalar grammar ---------------------------------------------------------------------------
// Numbers follow the YAML 1.2 core schema: [-+]?(digits[.digits]|.digits)([eE][-+]?digits)?, plus
// .inf/.Inf/.INF (signed) and .nan/.NaN/.NAN. std::from_chars is locale-independent and correctly
// rounded, so the writer's shortest round-trip output reads back bit for bit.

bool is_digit(char c) { return c >= '0' && c <= '9'; }

bool parse_float_text(std::string_view s, double& out) {
  std::string_view body = s;
  bool negative = false;
  if (!body.empty() && (body.front() == '+' || body.front() == '-')) {
    negative = body.front() == '-';
    body.remove_prefix(1);
  }
  if (body == ".inf" || body == ".Inf" || body == ".INF") {
    out = negative ? -std::numeric_limits<double>::infinity()
                   : std::numeric_limits<double>::infinity();
    return true;
  }
  if (s == ".nan" || s == ".NaN" || s == ".NAN") {
    out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  // Check the grammar ourselves: from_chars would also accept "inf", "nan" and "infinity".
  std::size_t i = 0, mantissa_digits = 0;
  while (i < body.size() && is_digit(body[i])) ++i, ++mantissa_digits;
  if (i < body.size() && body[i] == '.') {
    ++i;
    while (i < body.size() && is_digit(body[i])) ++i, ++mantissa_digits;
  }
  if (mantissa_digits == 0) return false;
  if (i < body.size() && (body[i] == 'e' || body[i] == 'E')) {
    ++i;
    if (i < body.size() && (body[i] == '+' || body[i] == '-')) ++i;
    std::size_t exponent_digits = 0;
    while (i < body.size() && is_digit(body[i])) ++i, ++exponent_digits;
    if (exponent_digits == 0) return false;
  }
  if (i != body.size()) return false;
  // from_chars takes a leading '-' but not '+'.
  const std::string_view text = s.front() == '+' ? body : s;
  double value = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc{} || end != text.data() + text.size()) return false;
  out = value;
  return true;
}

bool parse_int_text(std::string_view s, long long& out) {
  std::string_view digits = s;
  if (!digits.empty() && (digits.front() == '+' || digits.front() == '-')) digits.remove_prefix(1);
  if (digits.empty() || !std::all_of(digits.begin(), digits.end(), is_digit)) return false;
  const std::string_view text = s.front() == '+' ? digits : s;  // from_chars rejects '+'
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  return ec == std::errc{} && end == text.data() + text.size();
}

/// Shortest decimal text that reads back to exactly `v` (std::to_chars round-trip guarantee).
std::string format_double(double v) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  std::array<char, 32> buf{};
  const auto [end, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  if (ec != std::errc{}) throw InvalidArgument("vehicle_spec_to_yaml: cannot format a number");
  return std::string(buf.data(), end);
}

// ---- key tables -------------------------------------------------------------------------------

constexpr std::array<std::string_view, 7> kTopLevelKeys = {
    "name",           "mass_kg", "inertia_kgm2", "body_drag_Ns_per_m", "ground_effect_min_height_m",
    "rotor_defaults", "rotors",
};
constexpr std::array<std::string_view, 5> kRequiredTopLevelKeys = {
    "name", "mass_kg", "inertia_kgm2", "body_drag_Ns_per_m", "rotors"};

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0u : 1u)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

template <class Keys>
std::string suggestion(std::string_view unknown, const Keys& valid) {
  std::string_view best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  for (std::string_view k : valid) {
    const std::size_t d = edit_distance(unknown, k);
    if (d < best_distance) best_distance = d, best = k;
  }
  if (best.empty() || best_distance > std::max<std::size_t>(2, unknown.size() / 3)) return {};
  return "; did you mean '" + std::string(best) + "'?";
}

template <class Keys>
std::string key_list(const Keys& keys) {
  std::string out;
  for (std::string_view k : keys) out += (out.empty() ? "" : ", ") + std::string(k);
  return out;
}

// ---- reader -----------------------------------------------------------------------------------

/// Path of a field for messages: "mass_kg", "rotors[2].position_m", "inertia_kgm2[1][0]".
std::string join(const std::string& parent, std::string_view key) {
  return parent.empty() ? std::string(key) : parent + "." + std::string(key);
}
std::string index(const std::string& parent, std::size_t i) {
  return parent + "[" + std::to_string(i) + "]";
}

/// A scalar that may hold a number: plain (untagged) or tagged !!float / !!int. A quoted "1.5" or
/// a !!str scalar is a string, and a string is not a number.
bool plain_or_numeric(const YAML::Node& node) {
  if (!node.IsScalar()) return false;
  const std::string& tag = node.Tag();
  return tag == "?" || tag == "tag:yaml.org,2002:float" || tag == "tag:yaml.org,2002:int";
}

/// What a node is, for "got ..." in messages.
std::string describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Undefined:
    case YAML::NodeType::Null:
      return "nothing (null)";
    case YAML::NodeType::Scalar:
      if (!plain_or_numeric(node)) return "the string \"" + node.Scalar() + "\"";
      return "'" + node.Scalar() + "'";
    case YAML::NodeType::Sequence:
      return node.size() == 1 ? "a sequence of 1 item"
                              : "a sequence of " + std::to_string(node.size()) + " items";
    case YAML::NodeType::Map:
      return "a map";
  }
  return "an unknown node";
}

/// A key/value pair of a YAML map, with the key node kept for its line number.
struct Entry {
  YAML::Node key;
  YAML::Node value;
};
using Entries = std::map<std::string, Entry, std::less<>>;

class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const YAML::Mark& mark, const std::string& path,
                         const std::string& message) const {
    std::string text = source_ + ": ";
    if (!path.empty()) text += path + ": ";
    text += message;
    if (!mark.is_null() && mark.line >= 0) text += " (line " + std::to_string(mark.line + 1) + ")";
    throw InvalidArgument(text);
  }
  [[noreturn]] void fail(const YAML::Node& at, const std::string& path,
                         const std::string& message) const {
    // yaml-cpp marks an empty (null) value at the next token, often the next line: no line then.
    fail(at.IsDefined() && !at.IsNull() ? at.Mark() : YAML::Mark::null_mark(), path, message);
  }

  /// The entries of a map node, rejecting non-map nodes, non-scalar keys, duplicate keys and keys
  /// not in `allowed`.
  template <class Keys>
  Entries entries(const YAML::Node& node, const std::string& path, const Keys& allowed,
                  const std::string& expected) const {
    if (!node.IsMap()) fail(node, path, "expected " + expected + ", got " + describe(node));
    Entries out;
    for (const auto& kv : node) {
      const YAML::Node& key = kv.first;
      if (!key.IsScalar()) fail(key, path, "expected keys to be names, got " + describe(key));
      const std::string& name = key.Scalar();
      if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
        fail(key, path,
             "unknown key '" + name + "'" + suggestion(name, allowed) +
                 " (valid keys: " + key_list(allowed) + ")");
      }
      if (out.count(name) != 0) fail(key, path, "duplicate key '" + name + "'");
      out.emplace(name, Entry{key, kv.second});
    }
    return out;
  }

  double number(const YAML::Node& node, const std::string& path) const {
    double v = 0.0;
    if (!plain_or_numeric(node) || !parse_float_text(node.Scalar(), v))
      fail(node, path, "expected a number, got " + describe(node));
    return v;
  }

  int integer(const YAML::Node& node, const std::string& path) const {
    long long v = 0;
    if (!plain_or_numeric(node) || !parse_int_text(node.Scalar(), v) ||
        v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max())
      fail(node, path, "expected an integer, got " + describe(node));
    return static_cast<int>(v);
  }

  std::string string(const YAML::Node& node, const std::string& path) const {
    if (!node.IsScalar() || node.Scalar().empty())
      fail(node, path, "expected a non-empty string, got " + describe(node));
    return node.Scalar();
  }

  std::array<double, 3> three_numbers(const YAML::Node& node, const std::string& path) const {
    if (!node.IsSequence() || node.size() != 3) {
      fail(node, path,
           "expected 3 numbers, got " +
               (node.IsSequence() ? std::to_string(node.size()) : describe(node)));
    }
    std::array<double, 3> out{};
    for (std::size_t i = 0; i < 3; ++i) out[i] = number(node[i], index(path, i));
    return out;
  }

  Vec3 vec3(const YAML::Node& node, const std::string& path) const {
    const auto a = three_numbers(node, path);
    return Vec3(a[0], a[1], a[2]);
  }

  /// Either 3 numbers (the diagonal) or 3 rows of 3 numbers (the full matrix).
  Mat3 mat3(const YAML::Node& node, const std::string& path) const {
    const std::string expected = "expected 3 numbers (the diagonal) or 3 rows of 3 numbers, got ";
    if (!node.IsSequence()) fail(node, path, expected + describe(node));
    if (node.size() != 3)
      fail(node, path, expected + "a sequence of " + std::to_string(node.size()));
    std::size_t rows = 0;
    for (std::size_t i = 0; i < 3; ++i) rows += node[i].IsSequence() ? 1 : 0;
    Mat3 m = Mat3::Zero();
    if (rows == 0) {
      const auto d = three_numbers(node, path);
      m.diagonal() << d[0], d[1], d[2];
    } else if (rows == 3) {
      for (std::size_t i = 0; i < 3; ++i) {
        const auto r = three_numbers(node[i], index(path, i));
        m.row(static_cast<Eigen::Index>(i)) << r[0], r[1], r[2];
      }
    } else {
      fail(node, path, expected + "a mix of numbers and rows");
    }
    return m;
  }

 private:
  std::string source_;
};

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
    rotor.position_m = rd.vec3(node, path);
  } else if (key == "axis") {
    rotor.axis = rd.vec3(node, path);
  } else if (key == "spin") {
    rotor.spin = rd.integer(node, path);
  } else if (key == "thrust_coefficients") {
    rotor.thrust_coefficients = rd.three_numbers(node, path);
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
  const auto entries = rd.entries(node, path, rotor_keys(false), "a map of rotor keys");
  RotorDefaults out;
  for (std::string_view key : rotor_keys(false)) {
    const auto it = entries.find(key);
    if (it == entries.end()) continue;
    set_rotor_field(rd, key, it->second.value, join(path, key), out.values);
    out.given.push_back(key);
  }
  return out;
}

RotorParams read_rotor(const Reader& rd, const YAML::Node& node, std::size_t i,
                       const RotorDefaults& defaults) {
  const std::string path = index("rotors", i);
  const auto entries = rd.entries(node, path, rotor_keys(true), "a map of rotor keys");
  RotorParams rotor = defaults.values;
  std::string missing;
  std::size_t num_missing = 0;
  for (std::string_view key : rotor_keys(true)) {
    const auto it = entries.find(key);
    if (it != entries.end()) {
      set_rotor_field(rd, key, it->second.value, join(path, key), rotor);
    } else if (key != "axis" && std::find(defaults.given.begin(), defaults.given.end(), key) ==
                                    defaults.given.end()) {
      missing += (missing.empty() ? "'" : ", '") + std::string(key) + "'";
      ++num_missing;
    }
  }
  if (num_missing > 0) {
    rd.fail(node, path,
            std::string(num_missing == 1 ? "missing required key " : "missing required keys ") +
                missing + " (set in neither the rotor nor rotor_defaults)");
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

std::string read_text_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InvalidArgument(path + ": cannot read model file: it is a directory");
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const std::string reason =
        errno != 0 ? std::generic_category().message(errno) : std::string("unknown error");
    throw InvalidArgument(path + ": cannot open model file (" + reason + ")");
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InvalidArgument(path + ": error while reading model file");
  return text.str();
}

}  // namespace

// ---- public API -------------------------------------------------------------------------------

VehicleSpec parse_vehicle_spec(const std::string& yaml_text, const std::string& source_name) {
  const Reader rd(source_name);
  std::vector<YAML::Node> documents;
  try {
    documents = YAML::LoadAll(yaml_text);
  } catch (const YAML::ParserException& e) {
    throw InvalidArgument(source_name + ": line " + std::to_string(e.mark.line + 1) + ", column " +
                          std::to_string(e.mark.column + 1) + ": YAML syntax error: " + e.msg);
  } catch (const YAML::Exception& e) {
    throw InvalidArgument(source_name + ": cannot parse YAML: " + e.what());
  }
  const std::string top_expected = "a map with the keys " + key_list(kTopLevelKeys);
  if (documents.empty())
    rd.fail(YAML::Mark::null_mark(), "", "empty document; expected " + top_expected);
  if (documents.size() > 1) {
    rd.fail(documents[1], "",
            "expected one YAML document, got " + std::to_string(documents.size()));
  }
  const YAML::Node& root = documents.front();
  if (!root.IsMap()) rd.fail(root, "", "expected " + top_expected + ", got " + describe(root));
  const Entries top = rd.entries(root, "", kTopLevelKeys, top_expected);

  std::string missing;
  std::size_t num_missing = 0;
  for (std::string_view k : kRequiredTopLevelKeys) {
    if (top.count(k) != 0) continue;
    missing += (missing.empty() ? "'" : ", '") + std::string(k) + "'";
    ++num_missing;
  }
  if (num_missing > 0) {
    rd.fail(YAML::Mark::null_mark(), "",
            std::string(num_missing == 1 ? "missing required key " : "missing required keys ") +
                missing);
  }

  const auto value = [&top](std::string_view key) -> const YAML::Node& {
    return top.find(key)->second.value;
  };
  VehicleSpec spec;
  spec.source = source_name;
  spec.name = rd.string(value("name"), "name");
  spec.mass_kg = rd.number(value("mass_kg"), "mass_kg");
  spec.inertia_kgm2 = rd.mat3(value("inertia_kgm2"), "inertia_kgm2");
  spec.body_drag_Ns_per_m = rd.mat3(value("body_drag_Ns_per_m"), "body_drag_Ns_per_m");
  if (top.count("ground_effect_min_height_m") != 0) {
    spec.ground_effect_min_height_m =
        rd.number(value("ground_effect_min_height_m"), "ground_effect_min_height_m");
  }
  RotorDefaults defaults;
  if (top.count("rotor_defaults") != 0) defaults = read_rotor_defaults(rd, value("rotor_defaults"));

  const YAML::Node& rotors = value("rotors");
  if (!rotors.IsSequence())
    rd.fail(rotors, "rotors", "expected a sequence of rotor maps, got " + describe(rotors));
  spec.rotors.reserve(rotors.size());
  for (std::size_t i = 0; i < rotors.size(); ++i)
    spec.rotors.push_back(read_rotor(rd, rotors[i], i, defaults));
  return spec;
}

VehicleSpec load_vehicle_spec(const std::string& path) {
  return parse_vehicle_spec(read_text_file(path), path);
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
  out << YAML::EndSeq << YAML::EndMap;
  if (!out.good()) throw InvalidArgument("vehicle_spec_to_yaml: " + out.GetLastError());
  return "# Vehicle model written by dronetwin::save_vehicle_spec (format: "
         "docs/model-format.md).\n# Numbers are the shortest decimals that read back bit for "
         "bit.\n" +
         std::string(out.c_str()) + "\n";
}

void save_vehicle_spec(const VehicleSpec& spec, const std::string& path) {
  const std::string text = vehicle_spec_to_yaml(spec);
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw InvalidArgument(path + ": cannot open for writing");
  file << text;
  file.close();
  if (!file) throw InvalidArgument(path + ": error while writing the model file");
}

}  // namespace dronetwin
