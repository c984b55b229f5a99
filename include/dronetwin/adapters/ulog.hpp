#pragma once
// Reader for PX4 ULog files (format version 1, as specified in the PX4 user guide, "ULog File
// Format"). It reads a whole file into memory and turns every logged topic instance into a table
// of numeric columns, ready for import or identification.
//
//   ULog log = read_ulog("flight.ulg");
//   const ULogTopic& att = log.topic("vehicle_attitude");        // multi_id 0
//   const std::vector<double>& t = att.column("timestamp");      // seconds since boot
//   const std::vector<double>& qw = att.column("q[0]");
//   for (const ULogTopic& esc : log.topics) ...                  // every (name, multi_id)
//   std::string ver = log.info.at("ver_sw");                     // string info values
//
// Column names flatten the message format: arrays become `rpm[0]`, nested messages
// `esc[2].esc_rpm`, and padding fields (`_padding0`) are skipped. `char[n]` fields are text and
// are not columns (they are kept per message only in info values). Every other basic type
// (int8..uint64, float, double, bool, char) becomes a double. `timestamp` (microseconds in the
// file) is converted to seconds; the raw integer microseconds are in `timestamp_us`.
//
// Traps: uint64/int64 values above 2^53 lose precision as doubles (only timestamps get that
// large, and they are kept exactly in `timestamp_us`). A topic that was subscribed but never
// logged has no table. Appended data (incompat flag bit 0): a message of the main stream that
// crosses the first appended offset is dropped and reading resumes at that offset; a file with
// other unknown incompatible flags is rejected, as the format requires.
//
// Errors: InvalidArgument naming the file, the byte offset of the offending message, and what was
// expected (bad magic, truncated message, unknown format or message id, inconsistent sizes).
//
// Hostile files (docs/reliability.md, "Hostile files: bounded memory"): a format may describe at
// most 65535 bytes, the most a message can hold (its size field is uint16); sizes are summed and
// multiplied through nested formats without overflow and checked before anything is allocated,
// so `float[2000000000] x` is refused at its 'F' message naming the format and field. A format
// that contains itself, nests deeper than 32 levels or names an unknown type is refused where it
// is subscribed. The columns of a topic are built at its first data message, and all topics of
// a file together may have at most 2^20 columns with 64 MiB of column names; apart from that the
// memory a file takes is proportional to its size (each logged value becomes one double).

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace dronetwin {

/// One logged topic instance: all its 'D' messages as columns.
struct ULogTopic {
  std::string name;
  int multi_id = 0;
  /// Flattened field names, in format order; "timestamp" (seconds) comes first when present.
  std::vector<std::string> columns;
  /// columns.size() vectors of num_messages() values each.
  std::vector<std::vector<double>> values;
  /// The timestamp field exactly, in microseconds (empty if the format has no timestamp).
  std::vector<std::uint64_t> timestamp_us;

  std::size_t num_messages() const { return values.empty() ? 0 : values.front().size(); }
  bool has_column(std::string_view column) const;
  /// One column; InvalidArgument naming the topic and the missing column otherwise.
  const std::vector<double>& column(std::string_view column) const;
};

/// A logged text message ('L' or tagged 'C').
struct ULogMessage {
  int level = 0;  ///< syslog level, '0' (emergency) .. '7' (debug) as a number 0..7
  std::uint64_t timestamp_us = 0;
  std::string text;
  int tag = -1;  ///< tag of a tagged message, -1 for untagged
};

struct ULog {
  std::string source;
  int version = 0;
  std::uint64_t start_timestamp_us = 0;
  /// 'I' messages: key name -> value. Strings as text, numbers printed in decimal.
  std::map<std::string, std::string> info;
  /// 'M' messages: key name -> values in order (continued entries appended).
  std::map<std::string, std::vector<std::string>> info_multiple;
  /// 'P' parameters (initial values; a later value in the data section overwrites).
  std::map<std::string, double> parameters;
  /// Parameter changes in the data section, in order: (name, value).
  std::vector<std::pair<std::string, double>> parameter_changes;
  std::vector<ULogMessage> messages;
  /// Every topic instance with at least one data message, ordered by (name, multi_id).
  std::vector<ULogTopic> topics;
  /// Dropouts ('O'): total lost time in milliseconds and their count.
  std::uint64_t dropout_total_ms = 0;
  std::size_t dropout_count = 0;

  bool has_topic(std::string_view name, int multi_id = 0) const;
  /// The topic instance; InvalidArgument listing the logged topics otherwise.
  const ULogTopic& topic(std::string_view name, int multi_id = 0) const;
};

/// Reads a ULog file (see the file comment for errors).
ULog read_ulog(const std::string& path);

/// Parses ULog bytes; `source` names them in error messages.
ULog parse_ulog(const std::vector<std::uint8_t>& bytes, const std::string& source);

}  // namespace dronetwin
