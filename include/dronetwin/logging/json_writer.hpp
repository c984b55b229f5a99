#pragma once
// Writing the small JSON files of src/io (summary.json, log sidecars). Private to src/io: not
// installed. Output is deterministic: numbers are "%.17g" (they read back bit for bit), JSON has
// no NaN or infinity so those become null, and objects keep the order the keys were added in.
//
//   json::JsonObject j(0);
//   j.str("format", "dronetwin.run_log").integer("format_version", 1).num("dt_s", 0.001);
//   std::string text = j.done() + "\n";      // {\n  "format": ...,\n  ...\n}
//
// Reading JSON goes through yaml-cpp (JSON is YAML 1.2 flow syntax); see log_metadata.cpp.

#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "dronetwin/logging/csv_log.hpp"

namespace dronetwin::json {

/// A quoted JSON string: ", \ and control characters escaped.
std::string json_string(std::string_view s);

/// "%.17g" of a finite number, "null" otherwise.
std::string json_number(double v);

/// [a, b, c] of an Eigen vector's numbers.
template <class Vector>
std::string json_array(const Vector& v) {
  std::string out = "[";
  for (Eigen::Index i = 0; i < v.size(); ++i) out += (i ? ", " : "") + json_number(v[i]);
  return out + "]";
}

/// The "columns" array of a log sidecar: one {"name", "unit", "meaning"} object per line,
/// indented for a top-level key.
std::string json_columns(const std::vector<LogColumn>& columns);

/// Writes "key": value pairs, one per line, indented by `indent` + 2 spaces.
class JsonObject {
 public:
  explicit JsonObject(int indent) : pad_(static_cast<std::size_t>(indent), ' ') {}
  /// `value` is already JSON (an object, array, number, ...).
  JsonObject& raw(std::string_view key, const std::string& value);
  JsonObject& str(std::string_view key, std::string_view v) { return raw(key, json_string(v)); }
  JsonObject& num(std::string_view key, double v) { return raw(key, json_number(v)); }
  JsonObject& integer(std::string_view key, long long v) { return raw(key, std::to_string(v)); }
  JsonObject& boolean(std::string_view key, bool v) { return raw(key, v ? "true" : "false"); }
  JsonObject& null(std::string_view key) { return raw(key, "null"); }
  /// The value, or null when there is none.
  JsonObject& str_or_null(std::string_view key, const std::optional<std::string>& v) {
    return v ? str(key, *v) : null(key);
  }
  JsonObject& num_or_null(std::string_view key, const std::optional<double>& v) {
    return v ? num(key, *v) : null(key);
  }
  /// The object, "{" to "}" (no trailing newline).
  std::string done() const { return "{\n" + text_ + "\n" + pad_ + "}"; }

 private:
  std::string pad_;
  std::string text_;
};

}  // namespace dronetwin::json
