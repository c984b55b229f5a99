// libFuzzer harness: PX4 ULog files (adapters/ulog.hpp) and, for a file the reader accepts, the
// import (adapters/ulog_import.hpp) that `dronetwin import ulog` runs on it. Accepted logs have
// columns of equal length per topic.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "dronetwin/adapters/ulog.hpp"
#include "dronetwin/adapters/ulog_import.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dronetwin;
  const std::vector<std::uint8_t> bytes(data, data + size);
  ULog log;
  if (!fuzz::accepted([&] { log = parse_ulog(bytes, "fuzz.ulg"); })) return 0;
  for (const ULogTopic& t : log.topics) {
    fuzz::check(t.num_messages() > 0, "a topic without data is listed");
    fuzz::check(t.values.size() == t.columns.size(), "a topic with more names than columns");
    for (const auto& column : t.values) {
      fuzz::check(column.size() == t.num_messages(), "columns of a topic differ in length");
    }
    fuzz::check(t.timestamp_us.empty() || t.timestamp_us.size() == t.num_messages(),
                "timestamps and values differ in count");
  }
  ULogImport imp;
  if (fuzz::accepted([&] { imp = import_ulog(log); })) {
    fuzz::check(imp.rows() >= 2 && imp.values.size() == imp.rows() * imp.columns.size(),
                "an import with incomplete rows");
  }
  return 0;
}
