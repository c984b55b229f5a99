// libFuzzer harness: vehicle model files (config/model_loader.hpp). Parses the input as a model
// file, validates it into a VehicleModel, and for an accepted model checks the writer: the YAML
// of the spec reads back to a spec that writes the same YAML again.
#include <cstddef>
#include <cstdint>
#include <string>

#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/model/vehicle_model.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dronetwin;
  const std::string yaml = fuzz::text(data, size);
  VehicleSpec spec;
  if (!fuzz::accepted([&] { spec = parse_vehicle_spec(yaml, "fuzz.yaml"); })) return 0;
  if (!fuzz::accepted([&] { (void)VehicleModel(spec); })) return 0;
  const std::string written = vehicle_spec_to_yaml(spec);
  VehicleSpec again;
  fuzz::check(fuzz::accepted([&] { again = parse_vehicle_spec(written, "written.yaml"); }),
              "the YAML written for an accepted model does not parse");
  fuzz::check(fuzz::accepted([&] { (void)VehicleModel(again); }),
              "the YAML written for an accepted model does not validate");
  fuzz::check(vehicle_spec_to_yaml(again) == written,
              "a model written, read back and written again changes");
  return 0;
}
