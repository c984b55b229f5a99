// Env-steps per second of the RL vector env (rl/vec_env.hpp) on the racing task as the thesis
// trains it (Sec. 4.4): relative-position actions, the SE(3) inner loop at every physics step,
// 10 physics steps of 1 ms per env step, the Eq. 4.18 observation, Eq. 4.20 reward, gate and
// collision checks, auto-resets (random actions crash often, so resets are part of the cost).
// Arguments: N envs, threads. Run: build/release-native/bench/rl_bench (docs/performance.md).

#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

#include "dronetwin/config/env_config_loader.hpp"
#include "dronetwin/rl/vec_env.hpp"

namespace {

using namespace dronetwin;

template <class T>
void racing(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  const EnvFile f = load_env_config(std::string(DRONETWIN_SOURCE_DIR) + "/config/rl/racing.yaml");
  rl::VecEnv<T> env(f.model, f.config, n, threads);
  // A fixed set of actions per env (what the policy outputs is not the env's cost): a push
  // forward along +x with a per-env wobble.
  std::vector<double> actions(static_cast<std::size_t>(3 * n));
  for (int e = 0; e < n; ++e) {
    actions[static_cast<std::size_t>(3 * e)] = 0.6;
    actions[static_cast<std::size_t>(3 * e + 1)] = 0.3 * std::sin(e);
    actions[static_cast<std::size_t>(3 * e + 2)] = 0.2 * std::cos(e);
  }
  for (auto _ : state) {
    env.step(actions.data());
    benchmark::DoNotOptimize(env.reward_data());
  }
  const double env_steps = static_cast<double>(state.iterations()) * n;
  state.counters["env_steps/s"] = benchmark::Counter(env_steps, benchmark::Counter::kIsRate);
  state.counters["physics_steps/s"] =
      benchmark::Counter(env_steps * env.substeps(), benchmark::Counter::kIsRate);
}

void BM_RacingDouble(benchmark::State& s) { racing<double>(s); }
void BM_RacingFloat(benchmark::State& s) { racing<float>(s); }

void sizes(benchmark::internal::Benchmark* b) {
  b->ArgNames({"N", "threads"});
  for (int n : {1, 16, 256, 1024, 4096}) b->Args({n, 1});
  for (int n : {256, 1024, 4096}) b->Args({n, 2});
  b->UseRealTime();
}

BENCHMARK(BM_RacingDouble)->Apply(sizes);
BENCHMARK(BM_RacingFloat)->Apply(sizes);

}  // namespace

BENCHMARK_MAIN();
