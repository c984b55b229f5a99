// Run-log sidecars (include/dronetwin/logging/log_metadata.hpp, docs/log-format.md): the writer
// and FNV-1a. The reader is config/log_metadata_reader.hpp (it parses JSON with yaml-cpp).
#include "dronetwin/logging/log_metadata.hpp"

#include <array>
#include <cstdio>
#include <filesystem>
#include <system_error>

#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/json_writer.hpp"
#include "dronetwin/logging/text_file.hpp"

namespace dronetwin {

namespace {
using json::json_array;
using json::JsonObject;
}  // namespace

// ---- hash -------------------------------------------------------------------------------------

std::uint64_t fnv1a64(std::string_view bytes) {
  std::uint64_t h = 0xcbf29ce484222325ULL;  // offset basis
  for (const char c : bytes) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;  // FNV prime 2^40 + 2^8 + 0xb3
  }
  return h;
}

std::string content_hash(std::string_view bytes) {
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(fnv1a64(bytes)));
  return std::string(kContentHashPrefix) + hex;
}

std::string file_hash(const std::string& path) {
  return content_hash(read_text_file(path, "file to hash"));
}

// ---- LogMetadata ------------------------------------------------------------------------------

const LogColumn& LogMetadata::column(std::string_view name) const {
  for (const LogColumn& c : columns)
    if (c.name == name) return c;
  throw InvalidArgument((source.empty() ? std::string("log metadata") : source) +
                        ": columns: no column '" + std::string(name) + "'");
}

std::vector<std::string> LogMetadata::column_names() const {
  std::vector<std::string> names;
  names.reserve(columns.size());
  for (const LogColumn& c : columns) names.push_back(c.name);
  return names;
}

std::string sidecar_path(const std::string& csv_path) {
  return std::filesystem::path(csv_path).replace_extension(".json").string();
}

// ---- writer -----------------------------------------------------------------------------------

std::string log_metadata_to_json(const LogMetadata& m) {
  JsonObject disturbances(2);
  for (std::size_t i = 0; i < kDisturbanceSwitchNames.size(); ++i)
    disturbances.boolean(kDisturbanceSwitchNames[i], m.disturbances.*kDisturbanceSwitchMembers[i]);

  JsonObject j(0);
  j.str("format", m.format)
      .integer("format_version", m.format_version)
      .str("dronetwin_version", m.dronetwin_version)
      .str("experiment", m.experiment)
      .str("experiment_path", m.experiment_path)
      .str("input_type", m.input_type)
      .str("model", m.model)
      .str("model_path", m.model_path)
      .str_or_null("model_hash", m.model_hash)
      .raw("seed", std::to_string(m.seed))
      .num("dt_s", m.dt_s)
      .str("integrator", integrator_name(m.integrator))
      .boolean("motor_dynamics", m.motor_dynamics)
      .integer("log_every_n_steps", m.log_every_n_steps)
      .num("log_rate_hz", m.log_rate_hz)
      .str_or_null("controller_path", m.controller_path)
      .num_or_null("control_rate_hz", m.control_rate_hz)
      .boolean("noise", m.noise)
      .raw("disturbances", disturbances.done())
      .boolean("ground", m.ground)
      .raw("wind_m_s", json_array(m.wind_m_s))
      .raw("gravity_m_s2", json_array(m.gravity_m_s2))
      .integer("num_rotors", m.num_rotors)
      .raw("columns", json::json_columns(m.columns));
  return j.done() + "\n";
}

void write_log_metadata(const LogMetadata& metadata, const std::string& json_path) {
  write_text_file(json_path, log_metadata_to_json(metadata));
}

}  // namespace dronetwin
