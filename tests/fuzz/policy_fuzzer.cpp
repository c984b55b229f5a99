// libFuzzer harness: trained-policy files (config/policy_io.hpp). For an accepted file: its sizes
// agree with its network, the network evaluates (to finite actions, or an InvalidArgument that
// says it overflows), and the writer writes it, reads it back and writes the same bytes again
// (the header is canonical after one write; the tensors are float32 already).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "dronetwin/config/policy_io.hpp"
#include "dronetwin/policy/mlp.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dronetwin;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  PolicyFile p;
  if (!fuzz::accepted([&] { p = parse_policy(bytes, "fuzz.dtpolicy"); })) return 0;
  fuzz::check(p.observation_size == p.mlp.input_size() && p.action_size == p.mlp.output_size(),
              "the sizes of an accepted policy disagree with its network");

  // The network is small enough to evaluate: the file holds every weight.
  MlpEvaluator e(std::make_shared<const Mlp>(p.mlp));
  std::vector<double> obs(static_cast<std::size_t>(p.observation_size));
  std::vector<double> action(static_cast<std::size_t>(p.action_size));
  for (std::size_t i = 0; i < obs.size(); ++i) obs[i] = 0.5 * static_cast<double>(i % 7) - 1.5;
  // Extreme but finite numbers may overflow; then the evaluator says so, and otherwise every
  // action is finite.
  if (fuzz::accepted([&] { e.evaluate(obs.data(), action.data()); })) {
    for (const double a : action) fuzz::check(std::isfinite(a), "an action is not finite");
  }

  std::string written;
  fuzz::check(fuzz::accepted([&] { written = policy_file_bytes(p); }),
              "an accepted policy cannot be written");
  PolicyFile again;
  fuzz::check(fuzz::accepted([&] { again = parse_policy(written, "written.dtpolicy"); }),
              "the bytes written for an accepted policy do not read");
  fuzz::check(policy_file_bytes(again) == written,
              "a policy written, read back and written again changes");
  return 0;
}
