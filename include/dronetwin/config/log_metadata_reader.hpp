#pragma once
// Reading the JSON sidecar of a run log (logging/log_metadata.hpp; docs/log-format.md) and the
// log with it. Parsing goes through yaml-cpp (JSON is YAML 1.2 flow syntax) and is strict: a
// missing or unknown field, a wrong type, a format other than kRunLogFormat or a newer
// format_version is an InvalidArgument "<file>: <field>: <what> (line n)".
//
//   RunLog log = read_run_log("out/hover/log.csv");       // the CSV and, if present, log.json
//   if (log.metadata) {
//     double rate_hz = log.metadata->log_rate_hz;
//     std::string unit = log.metadata->column("vz").unit;  // "m/s"
//     bool same_model = file_hash("models/qdrone2.yaml") == log.metadata->model_hash;
//   }
//
// Trap: the importers' sidecars (adapters/crazypad_import.hpp, adapters/ulog_import.hpp) share
// the core fields but are of format kImportedLogFormat; read_log_metadata() rejects them by name.

#include <optional>
#include <string>

#include "dronetwin/logging/csv_log.hpp"
#include "dronetwin/logging/log_metadata.hpp"

namespace dronetwin {

/// Reads a run log's sidecar. InvalidArgument "<json_path>: <field>: <what>" for a malformed one.
LogMetadata read_log_metadata(const std::string& json_path);

/// The "format" field of a sidecar (kRunLogFormat, kImportedLogFormat, ...; "" when it has
/// none), to choose a reader. InvalidArgument naming the file if it is not JSON.
std::string log_sidecar_format(const std::string& json_path);

/// Same, from JSON text; `source_name` stands for the file in messages.
LogMetadata parse_log_metadata(const std::string& json_text, const std::string& source_name);

/// A run log read back: the CSV and, when its sidecar exists, the metadata.
struct RunLog {
  LogTable table;
  std::optional<LogMetadata> metadata;
};

/// Reads `csv_path` (read_csv_log) and sidecar_path(csv_path) if that file exists. A sidecar
/// whose columns differ from the CSV header is an InvalidArgument naming both files.
RunLog read_run_log(const std::string& csv_path);

}  // namespace dronetwin
