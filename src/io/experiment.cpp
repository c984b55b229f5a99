// Strict YAML binding of Experiment (format: docs/experiment-format.md). yaml-cpp stays in this
// file. Every error starts with the source file and names the field path.
#include "dronetwin/io/experiment.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <system_error>
#include <utility>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

// ---- scalars ----------------------------------------------------------------------------------

bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// YAML 1.2 core-schema float: [-+]?(digits[.digits*]|.digits)([eE][-+]?digits)?, or
/// [-+]?.inf / .nan in the three spellings of the schema. from_chars is locale-independent.
bool parse_double(std::string_view s, double& out) {
  std::string_view body = s;
  const bool negative = !body.empty() && body.front() == '-';
  if (!body.empty() && (body.front() == '-' || body.front() == '+')) body.remove_prefix(1);
  if (body == ".inf" || body == ".Inf" || body == ".INF") {
    out = negative ? -std::numeric_limits<double>::infinity()
                   : std::numeric_limits<double>::infinity();
    return true;
  }
  if (s == ".nan" || s == ".NaN" || s == ".NAN") {
    out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  std::size_t i = 0, digits = 0;
  for (; i < body.size() && is_digit(body[i]); ++i) ++digits;
  if (i < body.size() && body[i] == '.') {
    for (++i; i < body.size() && is_digit(body[i]); ++i) ++digits;
  }
  if (digits == 0) return false;
  if (i < body.size() && (body[i] == 'e' || body[i] == 'E')) {
    ++i;
    if (i < body.size() && (body[i] == '+' || body[i] == '-')) ++i;
    std::size_t exponent_digits = 0;
    for (; i < body.size() && is_digit(body[i]); ++i) ++exponent_digits;
    if (exponent_digits == 0) return false;
  }
  if (i != body.size()) return false;
  double v = 0.0;
  const auto r = std::from_chars(body.data(), body.data() + body.size(), v);
  if (r.ec != std::errc{} || r.ptr != body.data() + body.size()) return false;
  out = negative ? -v : v;
  return true;
}

/// Decimal integer with an optional sign.
template <class Int>
bool parse_integer(std::string_view s, Int& out) {
  std::string_view digits = s;
  if (!digits.empty() && digits.front() == '+') digits.remove_prefix(1);
  const std::string_view unsigned_part =
      !digits.empty() && digits.front() == '-' ? digits.substr(1) : digits;
  if (unsigned_part.empty() || !std::all_of(unsigned_part.begin(), unsigned_part.end(), is_digit))
    return false;
  const auto r = std::from_chars(digits.data(), digits.data() + digits.size(), out);
  return r.ec == std::errc{} && r.ptr == digits.data() + digits.size();
}

std::string format_number(double v) {
  std::ostringstream out;
  out.precision(17);
  out << v;
  return out.str();
}

// ---- key suggestions --------------------------------------------------------------------------

std::size_t edit_distance(std::string_view a, std::string_view b) {
  // Levenshtein distance, one row at a time.
  std::vector<std::size_t> previous(b.size() + 1), current(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) previous[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    current[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t substitute = previous[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      current[j] = std::min({previous[j] + 1, current[j - 1] + 1, substitute});
    }
    std::swap(previous, current);
  }
  return previous[b.size()];
}

using Names = std::vector<std::string_view>;

/// "; did you mean 'x'?" for the closest name, if it is close enough to be a typo.
std::string did_you_mean(std::string_view unknown, const Names& valid) {
  std::string_view best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  for (std::string_view name : valid) {
    const std::size_t d = edit_distance(unknown, name);
    if (d < best_distance) best_distance = d, best = name;
  }
  const std::size_t tolerance = std::max<std::size_t>(2, unknown.size() / 3);
  if (best.empty() || best_distance > tolerance) return {};
  return "; did you mean '" + std::string(best) + "'?";
}

std::string list(const Names& names) {
  std::string out;
  for (std::string_view n : names) out += (out.empty() ? "" : ", ") + std::string(n);
  return out;
}

std::string child(const std::string& parent, std::string_view key) {
  return parent.empty() ? std::string(key) : parent + "." + std::string(key);
}
std::string item(const std::string& parent, std::size_t i) {
  return parent + "[" + std::to_string(i) + "]";
}

// ---- node reader ------------------------------------------------------------------------------

/// Untagged plain scalar (or an explicit !!float / !!int / !!bool tag): something that can be a
/// number or a bool. A quoted "1.5" is a string.
bool plain(const YAML::Node& node) {
  if (!node.IsScalar()) return false;
  const std::string& tag = node.Tag();
  return tag == "?" || tag == "tag:yaml.org,2002:float" || tag == "tag:yaml.org,2002:int" ||
         tag == "tag:yaml.org,2002:bool";
}

std::string describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Undefined:
    case YAML::NodeType::Null:
      return "nothing (null)";
    case YAML::NodeType::Scalar:
      return plain(node) ? "'" + node.Scalar() + "'" : "the string \"" + node.Scalar() + "\"";
    case YAML::NodeType::Sequence:
      return "a sequence of " + std::to_string(node.size()) +
             (node.size() == 1 ? " item" : " items");
    case YAML::NodeType::Map:
      return "a map";
  }
  return "an unknown node";
}

class Reader;

/// The checked entries of one YAML map, with the path of the map for messages.
class Map {
 public:
  Map(const Reader& rd, YAML::Node node, std::string path, std::map<std::string, YAML::Node> e)
      : rd_(&rd), node_(std::move(node)), path_(std::move(path)), entries_(std::move(e)) {}

  bool has(std::string_view key) const { return entries_.count(std::string(key)) != 0; }
  /// The value of an optional key, or an undefined node.
  YAML::Node get(std::string_view key) const {
    const auto it = entries_.find(std::string(key));
    return it == entries_.end() ? YAML::Node(YAML::NodeType::Undefined) : it->second;
  }
  /// The value of a required key; fails naming the map and the key when it is absent.
  YAML::Node required(std::string_view key) const;
  std::string path(std::string_view key) const { return child(path_, key); }
  const std::string& path() const { return path_; }
  const YAML::Node& node() const { return node_; }

 private:
  const Reader* rd_;
  YAML::Node node_;
  std::string path_;
  std::map<std::string, YAML::Node> entries_;
};

class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}
  const std::string& source() const { return source_; }

  /// Throws "<source>: <path>: <message> (line n)".
  [[noreturn]] void fail(const YAML::Node& at, const std::string& path,
                         const std::string& message) const {
    std::string text = source_ + ": ";
    if (!path.empty()) text += path + ": ";
    text += message;
    // yaml-cpp marks a null value at the following token, often on the next line: no line then.
    if (at.IsDefined() && !at.IsNull() && at.Mark().line >= 0)
      text += " (line " + std::to_string(at.Mark().line + 1) + ")";
    throw InvalidArgument(text);
  }

  Map map(const YAML::Node& node, const std::string& path, const Names& allowed,
          const std::string& expected) const {
    if (!node.IsMap()) fail(node, path, "expected " + expected + ", got " + describe(node));
    std::map<std::string, YAML::Node> entries;
    for (const auto& kv : node) {
      if (!kv.first.IsScalar())
        fail(kv.first, path, "expected keys to be names, got " + describe(kv.first));
      const std::string& key = kv.first.Scalar();
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
        fail(kv.first, path,
             "unknown key '" + key + "'" + did_you_mean(key, allowed) +
                 " (valid keys: " + list(allowed) + ")");
      }
      if (entries.count(key) != 0) fail(kv.first, path, "duplicate key '" + key + "'");
      entries.emplace(key, kv.second);
    }
    return Map(*this, node, path, std::move(entries));
  }

  /// A finite number.
  double number(const YAML::Node& node, const std::string& path) const {
    double v = 0.0;
    if (!plain(node) || !parse_double(node.Scalar(), v))
      fail(node, path, "expected a number, got " + describe(node));
    if (!std::isfinite(v)) fail(node, path, "expected a finite number, got " + node.Scalar());
    return v;
  }

  double positive(const YAML::Node& node, const std::string& path) const {
    const double v = number(node, path);
    if (!(v > 0.0)) fail(node, path, "expected a number > 0, got " + node.Scalar());
    return v;
  }

  template <class Int>
  Int integer(const YAML::Node& node, const std::string& path, const std::string& what) const {
    Int v{};
    if (!plain(node) || !parse_integer(node.Scalar(), v))
      fail(node, path, "expected " + what + ", got " + describe(node));
    return v;
  }

  bool boolean(const YAML::Node& node, const std::string& path) const {
    if (plain(node)) {
      const std::string& s = node.Scalar();
      if (s == "true" || s == "True" || s == "TRUE") return true;
      if (s == "false" || s == "False" || s == "FALSE") return false;
    }
    fail(node, path, "expected true or false, got " + describe(node));
  }

  std::string string(const YAML::Node& node, const std::string& path) const {
    if (!node.IsScalar() || node.Scalar().empty())
      fail(node, path, "expected a non-empty string, got " + describe(node));
    return node.Scalar();
  }

  /// One of `names` (a plain or quoted string); index into names.
  std::size_t choice(const YAML::Node& node, const std::string& path, const Names& names,
                     const std::string& what) const {
    if (!node.IsScalar())
      fail(node, path, "expected " + what + " (" + list(names) + "), got " + describe(node));
    const std::string& s = node.Scalar();
    for (std::size_t i = 0; i < names.size(); ++i)
      if (names[i] == s) return i;
    fail(node, path,
         "unknown " + what + " '" + s + "'" + did_you_mean(s, names) + " (valid: " + list(names) +
             ")");
  }

  /// A sequence of finite numbers of any length.
  std::vector<double> numbers(const YAML::Node& node, const std::string& path,
                              const std::string& expected) const {
    if (!node.IsSequence()) fail(node, path, "expected " + expected + ", got " + describe(node));
    std::vector<double> out(node.size());
    for (std::size_t i = 0; i < node.size(); ++i) out[i] = number(node[i], item(path, i));
    return out;
  }

  /// Exactly N finite numbers; `meaning` explains them ("x, y, z").
  template <int N>
  Eigen::Matrix<double, N, 1> fixed(const YAML::Node& node, const std::string& path,
                                    const std::string& meaning) const {
    const std::string expected = std::to_string(N) + " numbers (" + meaning + ")";
    if (!node.IsSequence()) fail(node, path, "expected " + expected + ", got " + describe(node));
    if (node.size() != static_cast<std::size_t>(N))
      fail(node, path, "expected " + expected + ", got " + std::to_string(node.size()));
    Eigen::Matrix<double, N, 1> out;
    for (int i = 0; i < N; ++i)
      out[i] = number(node[static_cast<std::size_t>(i)], item(path, static_cast<std::size_t>(i)));
    return out;
  }

 private:
  std::string source_;
};

YAML::Node Map::required(std::string_view key) const {
  const auto it = entries_.find(std::string(key));
  if (it == entries_.end()) {
    // The line of a nested map helps find it; the top level's first line does not.
    rd_->fail(path_.empty() ? YAML::Node(YAML::NodeType::Undefined) : node_, path_,
              "missing required key '" + std::string(key) + "'");
  }
  return it->second;
}

// ---- key tables -------------------------------------------------------------------------------

const Names kTopLevelKeys = {"name",       "description",   "model",        "seed",
                             "duration_s", "physics_dt_s",  "integrator",   "motor_dynamics",
                             "noise",      "wind_m_s",      "gravity_m_s2", "disturbances",
                             "ground",     "initial_state", "log",          "input"};
const Names kRequiredTopLevelKeys = {"name", "model", "duration_s", "input"};
const Names kNoiseKeys = {"enabled", "drift", "theta", "sigma"};
const Names kBlockKeys = {"a", "b"};
const Names kDisturbanceKeys = {"rotor_drag",    "rolling_moment", "drag_moment",
                                "ground_effect", "gyroscopic",     "body_drag"};
const Names kGroundKeys = {"enabled", "crash_speed_m_s", "crash_tilt_rad"};
const Names kInitialStateKeys = {"position_m", "velocity_m_s",           "quaternion_wxyz",
                                 "euler_rad",  "angular_velocity_rad_s", "rotor_speeds_rad_s"};
const Names kLogKeys = {"every_n_steps", "wrench_breakdown", "measured"};
// In the order of the ExperimentInput alternatives (input_type_name() indexes it).
const Names kInputTypes = {"constant_rotor_speeds", "piecewise_rotor_speeds",
                           "constant_generalized_force", "hover"};
static_assert(std::variant_size_v<ExperimentInput> == 4,
              "a new input kind needs a name in kInputTypes and a branch in read_input(), "
              "check_against_model() and run_experiment's InputDriver");
const Names kSegmentKeys = {"start_s", "rotor_speeds_rad_s"};
const Names kIntegrators = {"rk4", "euler"};
const Names kDrifts = {"per_sample", "continuous"};
const Names kAllocations = {"exact", "thesis"};

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
      rd.fail(node[i], item(path, i),
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
  const std::array<bool DisturbanceSwitches::*, 6> members = {
      &DisturbanceSwitches::rotor_drag,  &DisturbanceSwitches::rolling_moment,
      &DisturbanceSwitches::drag_moment, &DisturbanceSwitches::ground_effect,
      &DisturbanceSwitches::gyroscopic,  &DisturbanceSwitches::body_drag};
  for (std::size_t i = 0; i < members.size(); ++i) {
    const std::string_view key = kDisturbanceKeys[i];
    if (m.has(key)) s.*members[i] = rd.boolean(m.get(key), m.path(key));
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
  return g;
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
  return s;
}

LogSettings read_log(const Reader& rd, const YAML::Node& node, const std::string& path) {
  const Map m = rd.map(node, path, kLogKeys, "a map of log settings");
  LogSettings s;
  if (m.has("every_n_steps")) {
    const YAML::Node n = m.get("every_n_steps");
    const long long v = rd.integer<long long>(n, m.path("every_n_steps"), "an integer >= 1");
    if (v < 1 || v > std::numeric_limits<int>::max())
      rd.fail(n, m.path("every_n_steps"), "expected an integer >= 1, got " + n.Scalar());
    s.every_n_steps = static_cast<int>(v);
  }
  if (m.has("wrench_breakdown"))
    s.wrench_breakdown = rd.boolean(m.get("wrench_breakdown"), m.path("wrench_breakdown"));
  if (m.has("measured")) s.measured = rd.boolean(m.get("measured"), m.path("measured"));
  return s;
}

ExperimentInput read_input(const Reader& rd, const YAML::Node& node, const std::string& path) {
  const std::string expected = "a map with a 'type' (" + list(kInputTypes) + ")";
  if (!node.IsMap()) rd.fail(node, path, "expected " + expected + ", got " + describe(node));
  YAML::Node type_node(YAML::NodeType::Undefined);
  for (const auto& kv : node)
    if (kv.first.IsScalar() && kv.first.Scalar() == "type") type_node = kv.second;
  if (!type_node.IsDefined())
    rd.fail(node, path, "missing required key 'type' (" + list(kInputTypes) + ")");
  const std::size_t type = rd.choice(type_node, child(path, "type"), kInputTypes, "input type");

  switch (type) {
    case 0: {
      const Map m = rd.map(node, path, {"type", "rotor_speeds_rad_s"}, expected);
      return ConstantRotorSpeedsInput{
          read_rotor_speeds(rd, m.required("rotor_speeds_rad_s"), m.path("rotor_speeds_rad_s"))};
    }
    case 1: {
      const Map m = rd.map(node, path, {"type", "segments"}, expected);
      const YAML::Node segs = m.required("segments");
      const std::string segs_path = m.path("segments");
      if (!segs.IsSequence() || segs.size() == 0)
        rd.fail(
            segs, segs_path,
            "expected a non-empty list of {start_s, rotor_speeds_rad_s}, got " + describe(segs));
      PiecewiseRotorSpeedsInput in;
      for (std::size_t i = 0; i < segs.size(); ++i) {
        const Map s = rd.map(segs[i], item(segs_path, i), kSegmentKeys,
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
                      " s (the start of " + item(segs_path, i - 1) +
                      "; starts must strictly increase), got " + start.Scalar());
        seg.rotor_speeds =
            read_rotor_speeds(rd, s.required("rotor_speeds_rad_s"), s.path("rotor_speeds_rad_s"));
        in.segments.push_back(std::move(seg));
      }
      return in;
    }
    case 2: {
      const Map m = rd.map(node, path, {"type", "u", "allocation"}, expected);
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
    default:
      rd.map(node, path, {"type"}, expected);
      return HoverInput{};
  }
}

/// The model file: relative to the experiment's directory if it exists there, else relative to
/// the current directory (or absolute).
std::string resolve_model_path(const Reader& rd, const YAML::Node& node, const std::string& model) {
  const fs::path given(model);
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
  rd.fail(node, "model", "model file '" + model + "' not found (looked for " + tried + ")");
}

void check_experiment(const Experiment& e, const std::string& source) {
  const auto fail = [&](const std::string& field, const std::string& message) {
    throw InvalidArgument(source + ": " + field + ": " + message);
  };
  if (!(std::isfinite(e.duration_s) && e.duration_s > 0.0))
    fail("duration_s", "expected a number > 0, got " + format_number(e.duration_s));
  if (!(std::isfinite(e.physics_dt_s) && e.physics_dt_s > 0.0 && e.physics_dt_s <= 0.1))
    fail("physics_dt_s", "expected a step in (0, 0.1] s, got " + format_number(e.physics_dt_s));
  if (!(e.duration_s / e.physics_dt_s <= 1e12))
    fail("duration_s", "expected at most 1e12 physics steps, got duration_s / physics_dt_s = " +
                           format_number(e.duration_s / e.physics_dt_s));
  if (e.ground.enabled && e.initial_state.position_m.z() < 0.0)
    fail("initial_state.position_m[2]",
         "expected z >= 0 (the ground is at z = 0; set ground.enabled: false to start below it), "
         "got " +
             format_number(e.initial_state.position_m.z()));
  // OU stability (as in validate(SimConfig), but naming the experiment's field): the per-step map
  // of a block is I - s Theta, with eigenvalues 1 - s a and 1 - s (a + N b), N = 3 or 4.
  const double s = e.noise.parameters.drift == OuDrift::kPerSample ? 1.0 : e.physics_dt_s;
  const BlockCoefficients th = e.noise.parameters.theta[0];
  for (const double n : {3.0, 4.0}) {
    const double e1 = 1.0 - s * th.a, e2 = 1.0 - s * (th.a + n * th.b);
    if (!(std::abs(e1) < 1.0 && std::abs(e2) < 1.0))
      fail("noise.theta",
           "the OU process is unstable: the per-step decay factors 1 - s a = " + format_number(e1) +
               " and 1 - s (a + " + format_number(n) + " b) = " + format_number(e2) +
               " must lie in (-1, 1) (s = " + format_number(s) + ", from the drift setting)");
  }
  // The remaining run settings with the simulator's own check.
  (void)e.sim_config();
}

std::string read_file(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec))
    throw InvalidArgument(path + ": cannot read experiment file: it is a directory");
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const std::string reason =
        errno != 0 ? std::generic_category().message(errno) : std::string("unknown error");
    throw InvalidArgument(path + ": cannot open experiment file (" + reason + ")");
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InvalidArgument(path + ": error while reading experiment file");
  return text.str();
}

template <class... Fs>
struct Overloaded : Fs... {
  using Fs::operator()...;
};
template <class... Fs>
Overloaded(Fs...) -> Overloaded<Fs...>;

}  // namespace

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
  SimConfig c;
  c.dt_s = physics_dt_s;
  c.integrator = integrator;
  c.motor_dynamics = motor_dynamics;
  if (const auto* u = std::get_if<ConstantGeneralizedForceInput>(&input))
    c.allocation = u->allocation;
  c.disturbances = disturbances;
  c.environment.gravity_W_m_s2 = gravity_m_s2;
  c.environment.wind_W_m_s = wind_m_s;
  c.noise = noise;
  c.ground = ground;
  c.seed = seed;
  try {
    dronetwin::validate(c);
  } catch (const InvalidArgument& e) {
    throw InvalidArgument(source + ": " + e.what());
  }
  return c;
}

std::int64_t Experiment::num_steps() const {
  return static_cast<std::int64_t>(std::ceil(duration_s / physics_dt_s - 1e-9));
}

std::int64_t segment_start_step(double start_s, double dt_s) {
  const double k = std::ceil(start_s / dt_s - 1e-9);
  return k > 0.0 ? static_cast<std::int64_t>(k) : 0;
}

Experiment parse_experiment(const std::string& yaml_text, const std::string& source_name) {
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
  const std::string expected = "a map of experiment settings";
  if (documents.empty())
    throw InvalidArgument(source_name + ": empty document; expected " + expected);
  if (documents.size() > 1)
    rd.fail(documents[1], "",
            "expected one YAML document, got " + std::to_string(documents.size()));
  const Map top = rd.map(documents.front(), "", kTopLevelKeys, expected);
  for (std::string_view key : kRequiredTopLevelKeys) (void)top.required(key);

  Experiment e;
  e.source = source_name;
  e.name = rd.string(top.get("name"), "name");
  if (top.has("description")) e.description = rd.string(top.get("description"), "description");
  e.model_path = resolve_model_path(rd, top.get("model"), rd.string(top.get("model"), "model"));
  if (top.has("seed")) {
    e.seed = rd.integer<std::uint64_t>(top.get("seed"), "seed",
                                       "an integer in [0, 18446744073709551615]");
  }
  e.duration_s = rd.positive(top.get("duration_s"), "duration_s");
  if (top.has("physics_dt_s"))
    e.physics_dt_s = rd.positive(top.get("physics_dt_s"), "physics_dt_s");
  if (top.has("integrator")) {
    e.integrator = rd.choice(top.get("integrator"), "integrator", kIntegrators, "integrator") == 0
                       ? Integrator::kRk4
                       : Integrator::kEuler;
  }
  if (top.has("motor_dynamics"))
    e.motor_dynamics = rd.boolean(top.get("motor_dynamics"), "motor_dynamics");
  if (top.has("noise")) e.noise = read_noise(rd, top.get("noise"), "noise");
  if (top.has("wind_m_s"))
    e.wind_m_s = rd.fixed<3>(top.get("wind_m_s"), "wind_m_s", "x, y, z in m/s");
  if (top.has("gravity_m_s2"))
    e.gravity_m_s2 = rd.fixed<3>(top.get("gravity_m_s2"), "gravity_m_s2", "x, y, z in m/s^2");
  if (top.has("disturbances"))
    e.disturbances = read_disturbances(rd, top.get("disturbances"), "disturbances");
  if (top.has("ground")) e.ground = read_ground(rd, top.get("ground"), "ground");
  if (top.has("initial_state"))
    e.initial_state = read_initial_state(rd, top.get("initial_state"), "initial_state");
  if (top.has("log")) e.log = read_log(rd, top.get("log"), "log");
  e.input = read_input(rd, top.get("input"), "input");
  check_experiment(e, source_name);
  return e;
}

Experiment load_experiment(const std::string& path) {
  return parse_experiment(read_file(path), path);
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
             },
             e.input);
}

}  // namespace dronetwin
