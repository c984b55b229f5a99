// JSON output helpers of src/io (json_writer.hpp).
#include "dronetwin/logging/json_writer.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>

#include "dronetwin/core/error.hpp"

namespace dronetwin::json {

std::string json_string(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(c));
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string json_columns(const std::vector<LogColumn>& columns) {
  std::string out = "[";
  for (std::size_t i = 0; i < columns.size(); ++i) {
    const LogColumn& c = columns[i];
    out += (i ? ",\n" : "\n") + std::string("    {\"name\": ") + json_string(c.name) +
           ", \"unit\": " + json_string(c.unit) + ", \"meaning\": " + json_string(c.meaning) + "}";
  }
  return out + "\n  ]";
}

JsonObject& JsonObject::raw(std::string_view key, const std::string& value) {
  text_ += (text_.empty() ? "" : ",\n") + pad_ + "  " + json_string(key) + ": " + value;
  return *this;
}

}  // namespace dronetwin::json
