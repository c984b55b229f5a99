#pragma once
// The JSON sidecar of a run log: DIR/log.json next to DIR/log.csv, written by run_experiment().
// It says what the numbers in the CSV are (every column's unit and meaning) and how they were
// made (dronetwin version, experiment and model files, a content hash of the model file, seed,
// physics step, integrator, log rate, control rate, noise and disturbance switches), so a log
// can be read, plotted or checked on its own. Format, field by field: docs/log-format.md.
//
//   LogMetadata m;                                  // filled by the run (app/run_experiment)
//   m.columns = log_columns(layout);
//   write_log_metadata(m, sidecar_path("out/hover/log.csv"));   // out/hover/log.json
//   bool same_model = file_hash("models/qdrone2.yaml") == m.model_hash;
//
// The hash is 64-bit FNV-1a (Fowler, Noll, Vo; offset basis 0xcbf29ce484222325, prime
// 0x100000001b3) over the file's bytes, written "fnv1a64:" + 16 lower-case hex digits. It detects
// an edited or different model file; it is not a cryptographic hash.
//
// The sidecar is deterministic (no wall-clock time, no host name): two runs of the same
// experiment, seed and model give byte-identical sidecars, like their CSV logs.
//
// Reading a sidecar back is config/log_metadata_reader.hpp (it parses JSON with yaml-cpp, which
// only the config layer uses).
//
// Trap: the importers' sidecars (adapters/crazypad_import.hpp, adapters/ulog_import.hpp) share the
// core fields (format, format_version, dronetwin_version, num_rotors, columns) but are of format
// kImportedLogFormat, without seed or physics step; read_log_metadata() rejects them by name.
// Read imported logs with read_csv_log() and their sidecar with any JSON reader.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "dronetwin/core/types.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/integrators/integrator.hpp"
#include "dronetwin/logging/csv_log.hpp"

namespace dronetwin {

/// `format` of a run log's sidecar and the version this library writes and reads.
inline constexpr std::string_view kRunLogFormat = "dronetwin.run_log";
inline constexpr int kRunLogFormatVersion = 1;
/// `format` of the sidecars written by the CrazyPAD and ULog importers.
inline constexpr std::string_view kImportedLogFormat = "dronetwin.imported_log";
inline constexpr int kImportedLogFormatVersion = 1;

/// What a run log's sidecar holds (docs/log-format.md lists every field).
struct LogMetadata {
  /// The sidecar file it was read from (empty when built in memory), for messages.
  std::string source;
  std::string format = std::string(kRunLogFormat);
  int format_version = kRunLogFormatVersion;
  /// The dronetwin version that wrote the log (version()).
  std::string dronetwin_version;
  /// Experiment name, file and input type ("hover", "controller", ...).
  std::string experiment;
  std::string experiment_path;
  std::string input_type;
  /// Model name and file (as resolved by the experiment).
  std::string model;
  std::string model_path;
  /// file_hash(model_path) when the run flew the model of that file; empty when it flew a model
  /// given in memory that differs from the file (run_experiment with a model argument).
  std::optional<std::string> model_hash;
  std::uint64_t seed = 0;
  /// Physics step, s.
  double dt_s = 0.0;
  Integrator integrator = Integrator::kRk4;
  bool motor_dynamics = true;
  /// A row at t = 0 and after every n-th step: rows come at log_rate_hz = 1 / (n dt_s) (a failed
  /// run adds its last good state, possibly between two regular rows).
  std::int64_t log_every_n_steps = 1;
  double log_rate_hz = 0.0;
  /// Closed loop only (input type controller): the controller file and its rate, Hz.
  std::optional<std::string> controller_path;
  std::optional<double> control_rate_hz;
  /// OU measurement noise on (it changes the meas_* columns only).
  bool noise = false;
  DisturbanceSwitches disturbances{};
  /// Ground contact enabled.
  bool ground = true;
  Vec3 wind_m_s = Vec3::Zero();
  Vec3 gravity_m_s2 = Vec3(0.0, 0.0, -9.81);
  int num_rotors = 0;
  /// The CSV's columns in order, each with unit and meaning (log_columns()).
  std::vector<LogColumn> columns;

  /// A column by name; InvalidArgument naming the sidecar and the column otherwise.
  const LogColumn& column(std::string_view name) const;
  /// The column names in order (what the CSV header holds).
  std::vector<std::string> column_names() const;
};

/// What content_hash() values start with.
inline constexpr std::string_view kContentHashPrefix = "fnv1a64:";

/// 64-bit FNV-1a of `bytes` (see the file comment).
std::uint64_t fnv1a64(std::string_view bytes);

/// "fnv1a64:" + 16 lower-case hex digits of fnv1a64(bytes).
std::string content_hash(std::string_view bytes);

/// content_hash() of a file's bytes, to compare with LogMetadata::model_hash. InvalidArgument
/// naming the file if it cannot be read.
std::string file_hash(const std::string& path);

/// The sidecar path of a log: the same stem with ".json" ("out/log.csv" -> "out/log.json").
std::string sidecar_path(const std::string& csv_path);

/// The sidecar's JSON text (deterministic; numbers "%.17g").
std::string log_metadata_to_json(const LogMetadata& metadata);

/// Writes log_metadata_to_json() to `json_path`; InvalidArgument naming the file on failure.
void write_log_metadata(const LogMetadata& metadata, const std::string& json_path);

}  // namespace dronetwin
