// libFuzzer harness: experiment files (config/experiment.hpp). The input is parsed as if it were
// config/experiments/fuzz_input.yaml, so the seeds' relative model and controller paths resolve
// (and their controller files are parsed too). For an accepted experiment: the run settings and
// the step count are valid (validate() agrees with the parser), and the model it names loads and
// is checked against the experiment's rotor-speed vectors.
#include <cstddef>
#include <cstdint>
#include <string>

#include "dronetwin/config/experiment.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dronetwin;
  static const std::string source =
      std::string(DRONETWIN_SOURCE_DIR) + "/config/experiments/fuzz_input.yaml";
  Experiment e;
  if (!fuzz::accepted([&] { e = parse_experiment(fuzz::text(data, size), source); })) return 0;
  fuzz::check(fuzz::accepted([&] { validate(e); }), "validate() refuses a parsed experiment");
  fuzz::check(fuzz::accepted([&] { (void)e.sim_config(); }),
              "sim_config() refuses a parsed experiment");
  fuzz::check(e.num_steps() >= 1, "a parsed experiment has no physics step");
  (void)fuzz::accepted([&] { check_against_model(e, load_vehicle_model(e.model_path)); });
  return 0;
}
