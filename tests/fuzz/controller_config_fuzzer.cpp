// libFuzzer harness: controller files (config/controller_config.hpp), every controller type.
#include <cstddef>
#include <cstdint>

#include "dronetwin/config/controller_config.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dronetwin;
  ControllerConfig c;
  if (!fuzz::accepted([&] { c = parse_controller_config(fuzz::text(data, size), "fuzz.yaml"); })) {
    return 0;
  }
  fuzz::check(c.source == "fuzz.yaml", "the parsed controller does not name its source");
  fuzz::check(c.type() == ControllerType::kPid || c.type() == ControllerType::kSe3 ||
                  c.type() == ControllerType::kNmpc,
              "a parsed controller of no known type");
  return 0;
}
