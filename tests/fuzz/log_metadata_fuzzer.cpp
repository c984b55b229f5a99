// libFuzzer harness: log sidecars (config/log_metadata_reader.hpp). For an accepted sidecar the
// writer (logging/log_metadata.hpp) is checked too: its JSON reads back to metadata that writes
// the same JSON again.
#include <cstddef>
#include <cstdint>
#include <string>

#include "dronetwin/config/log_metadata_reader.hpp"
#include "dronetwin/logging/log_metadata.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dronetwin;
  LogMetadata m;
  if (!fuzz::accepted([&] { m = parse_log_metadata(fuzz::text(data, size), "fuzz.json"); })) {
    return 0;
  }
  const std::string written = log_metadata_to_json(m);
  LogMetadata again;
  fuzz::check(fuzz::accepted([&] { again = parse_log_metadata(written, "written.json"); }),
              "the JSON written for an accepted sidecar does not parse");
  fuzz::check(log_metadata_to_json(again) == written,
              "a sidecar written, read back and written again changes");
  return 0;
}
