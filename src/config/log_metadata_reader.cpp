// Reading run-log sidecars (log_metadata_reader.hpp): strict JSON through yaml-cpp and the
// helpers of yaml_strict.hpp; the writer is logging/log_metadata.cpp.
#include "dronetwin/config/log_metadata_reader.hpp"

#include <array>
#include <cstdio>
#include <filesystem>
#include <set>
#include <system_error>

#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "yaml_strict.hpp"

namespace dronetwin {

namespace {

using io_detail::load_json;
using io_detail::Map;
using io_detail::Reader;

constexpr std::array<std::string_view, 24> kKeys = {"format",
                                                    "format_version",
                                                    "dronetwin_version",
                                                    "experiment",
                                                    "experiment_path",
                                                    "input_type",
                                                    "model",
                                                    "model_path",
                                                    "model_hash",
                                                    "seed",
                                                    "dt_s",
                                                    "integrator",
                                                    "motor_dynamics",
                                                    "log_every_n_steps",
                                                    "log_rate_hz",
                                                    "controller_path",
                                                    "control_rate_hz",
                                                    "noise",
                                                    "disturbances",
                                                    "ground",
                                                    "wind_m_s",
                                                    "gravity_m_s2",
                                                    "num_rotors",
                                                    "columns"};
constexpr std::array<std::string_view, 3> kColumnKeys = {"name", "unit", "meaning"};
constexpr std::array<std::string_view, 2> kIntegrators = {integrator_name(Integrator::kRk4),
                                                          integrator_name(Integrator::kEuler)};

/// A JSON string (quoted in the file: a bare 5 or true is not one).
std::string text(const Reader& rd, const YAML::Node& node, const std::string& path,
                 bool allow_empty = false) {
  if (!node.IsScalar() || io_detail::is_plain(node) || (!allow_empty && node.Scalar().empty())) {
    rd.fail(node, path,
            std::string("expected a ") + (allow_empty ? "" : "non-empty ") + "string, got " +
                io_detail::describe(node));
  }
  if (!io_detail::is_utf8(node.Scalar())) rd.fail(node, path, io_detail::kNotUtf8AfterEscapes);
  return node.Scalar();
}

/// kContentHashPrefix + 16 lower-case hex digits, as content_hash() writes it.
bool is_hash(std::string_view s) {
  const std::string_view prefix = kContentHashPrefix;
  if (s.size() != prefix.size() + 16 || s.substr(0, prefix.size()) != prefix) return false;
  for (const char c : s.substr(prefix.size()))
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  return true;
}

}  // namespace

// ---- reader -----------------------------------------------------------------------------------

std::string log_sidecar_format(const std::string& json_path) {
  const YAML::Node root = load_json(read_text_file(json_path, "log metadata"), json_path);
  const YAML::Node format = root.IsMap() ? root["format"] : YAML::Node();
  return format && format.IsScalar() ? format.Scalar() : std::string();
}

LogMetadata parse_log_metadata(const std::string& json_text, const std::string& source_name) {
  const Reader rd(source_name);
  const std::string expected = "a JSON object with the fields " + io_detail::name_list(kKeys);
  const YAML::Node root = load_json(json_text, source_name);
  if (root.IsNull()) rd.fail("", "empty document; expected " + expected);
  if (!root.IsMap())
    rd.fail(root, "", "expected " + expected + ", got " + io_detail::describe(root));

  // The format first: another kind of sidecar has other fields, and saying so beats listing them
  // as unknown keys.
  const YAML::Node format_node = root["format"];
  if (!format_node) rd.fail(root, "", "missing required key 'format'");
  LogMetadata m;
  m.source = source_name;
  m.format = text(rd, format_node, "format");
  if (m.format != kRunLogFormat) {
    rd.fail(format_node, "format",
            "expected \"" + std::string(kRunLogFormat) + "\", got \"" + m.format + "\"" +
                (m.format == kImportedLogFormat
                     ? " (an importer's sidecar: read its CSV with read_csv_log)"
                     : ""));
  }

  const Map top = rd.map(root, "", kKeys, expected);
  for (const std::string_view key : kKeys) top.required(key);  // every field is required

  const auto field = [&](std::string_view key) { return top.get(key); };
  const auto path = [&](std::string_view key) { return top.path(key); };

  m.format_version =
      rd.integer<int>(field("format_version"), path("format_version"), "an integer >= 1");
  if (m.format_version < 1 || m.format_version > kRunLogFormatVersion) {
    rd.fail(field("format_version"), path("format_version"),
            "this dronetwin reads format version " + std::to_string(kRunLogFormatVersion) +
                ", got " + std::to_string(m.format_version));
  }
  m.dronetwin_version = text(rd, field("dronetwin_version"), path("dronetwin_version"));
  m.experiment = text(rd, field("experiment"), path("experiment"));
  m.experiment_path = text(rd, field("experiment_path"), path("experiment_path"), true);
  m.input_type = text(rd, field("input_type"), path("input_type"));
  m.model = text(rd, field("model"), path("model"));
  m.model_path = text(rd, field("model_path"), path("model_path"));
  if (!field("model_hash").IsNull()) {
    m.model_hash = text(rd, field("model_hash"), path("model_hash"));
    if (!is_hash(*m.model_hash)) {
      rd.fail(field("model_hash"), path("model_hash"),
              "expected \"fnv1a64:\" and 16 lower-case hex digits, got \"" + *m.model_hash + "\"");
    }
  }
  m.seed = rd.integer<std::uint64_t>(field("seed"), path("seed"), "an integer in [0, 2^64 - 1]");
  m.dt_s = rd.positive(field("dt_s"), path("dt_s"));
  m.integrator = static_cast<Integrator>(
      rd.choice(field("integrator"), path("integrator"), kIntegrators, "integrator"));
  m.motor_dynamics = rd.boolean(field("motor_dynamics"), path("motor_dynamics"));
  m.log_every_n_steps = rd.integer<std::int64_t>(field("log_every_n_steps"),
                                                 path("log_every_n_steps"), "an integer >= 1");
  if (m.log_every_n_steps < 1) {
    rd.fail(field("log_every_n_steps"), path("log_every_n_steps"),
            "expected an integer >= 1, got " + std::to_string(m.log_every_n_steps));
  }
  m.log_rate_hz = rd.positive(field("log_rate_hz"), path("log_rate_hz"));
  if (!field("controller_path").IsNull())
    m.controller_path = text(rd, field("controller_path"), path("controller_path"));
  if (!field("control_rate_hz").IsNull())
    m.control_rate_hz = rd.positive(field("control_rate_hz"), path("control_rate_hz"));
  if (m.controller_path.has_value() != m.control_rate_hz.has_value()) {
    rd.fail(field("control_rate_hz"), path("control_rate_hz"),
            m.controller_path ? "expected a rate in Hz with a controller_path, got null"
                              : "expected null without a controller_path");
  }
  m.noise = rd.boolean(field("noise"), path("noise"));
  {
    const std::string p = path("disturbances");
    const std::string what =
        "an object with the fields " + io_detail::name_list(kDisturbanceSwitchNames);
    const Map dist = rd.map(field("disturbances"), p, kDisturbanceSwitchNames, what);
    for (std::size_t i = 0; i < kDisturbanceSwitchNames.size(); ++i) {
      const std::string_view key = kDisturbanceSwitchNames[i];
      m.disturbances.*kDisturbanceSwitchMembers[i] = rd.boolean(dist.required(key), dist.path(key));
    }
  }
  m.ground = rd.boolean(field("ground"), path("ground"));
  m.wind_m_s = rd.fixed<3>(field("wind_m_s"), path("wind_m_s"), "x, y, z in m/s");
  m.gravity_m_s2 = rd.fixed<3>(field("gravity_m_s2"), path("gravity_m_s2"), "x, y, z in m/s^2");
  m.num_rotors = rd.integer<int>(field("num_rotors"), path("num_rotors"),
                                 "an integer in [1, " + std::to_string(kMaxRotors) + "]");
  if (m.num_rotors < 1 || m.num_rotors > kMaxRotors) {
    rd.fail(field("num_rotors"), path("num_rotors"),
            "expected an integer in [1, " + std::to_string(kMaxRotors) + "], got " +
                std::to_string(m.num_rotors));
  }

  const YAML::Node columns = field("columns");
  const std::string cpath = path("columns");
  if (!columns.IsSequence() || columns.size() == 0) {
    rd.fail(columns, cpath,
            "expected a non-empty array of {name, unit, meaning} objects, got " +
                io_detail::describe(columns));
  }
  std::set<std::string, std::less<>> seen;
  for (std::size_t i = 0; i < columns.size(); ++i) {
    const std::string ip = io_detail::item_path(cpath, i);
    const Map c =
        rd.map(columns[i], ip, kColumnKeys, "an object with the fields name, unit, meaning");
    LogColumn col;
    col.name = text(rd, c.required("name"), c.path("name"));
    col.unit = text(rd, c.required("unit"), c.path("unit"));
    col.meaning = text(rd, c.required("meaning"), c.path("meaning"));
    if (!seen.insert(col.name).second)
      rd.fail(c.get("name"), c.path("name"), "duplicate column '" + col.name + "'");
    m.columns.push_back(std::move(col));
  }
  return m;
}

LogMetadata read_log_metadata(const std::string& json_path) {
  return parse_log_metadata(read_text_file(json_path, "log metadata"), json_path);
}

RunLog read_run_log(const std::string& csv_path) {
  RunLog log;
  log.table = read_csv_log(csv_path);
  const std::string json = sidecar_path(csv_path);
  std::error_code ec;
  if (!std::filesystem::exists(json, ec)) return log;
  log.metadata = read_log_metadata(json);
  const std::vector<std::string> names = log.metadata->column_names();
  if (names != log.table.columns) {
    std::size_t i = 0;
    while (i < names.size() && i < log.table.columns.size() && names[i] == log.table.columns[i])
      ++i;
    const auto at = [i](const std::vector<std::string>& v) {
      return i < v.size() ? "'" + v[i] + "'" : std::string("nothing");
    };
    throw InvalidArgument(json + ": columns: do not match the header of " + csv_path + " (column " +
                          std::to_string(i + 1) + ": " + at(names) + " here, " +
                          at(log.table.columns) + " in the CSV)");
  }
  return log;
}

}  // namespace dronetwin
