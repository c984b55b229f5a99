// Cost of minimum-snap planning (planning/min_snap.hpp) for 10 and 100 waypoints: the closed
// form with fixed segment times, and the segment-time allocation (BFGS on log-times, each
// iteration one or more closed-form solves). Single thread. Waypoints: a seeded random walk with
// 1-3 m steps and yaw changes, so the times and the solution are not trivially regular.

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include "dronetwin/planning/min_snap.hpp"

namespace {

using namespace dronetwin;
using namespace dronetwin::planning;

std::vector<Waypoint> walk(int count) {
  std::mt19937_64 gen(42);
  const auto uniform = [&](double lo, double hi) {
    return lo + (hi - lo) * static_cast<double>(gen() >> 11) * 0x1.0p-53;
  };
  std::vector<Waypoint> w(static_cast<std::size_t>(count));
  for (std::size_t j = 1; j < w.size(); ++j) {
    const double heading = uniform(-std::numbers::pi, std::numbers::pi), step_m = uniform(1.0, 3.0);
    w[j].position_m = w[j - 1].position_m + Vec3(step_m * std::cos(heading),
                                                 step_m * std::sin(heading), uniform(-0.3, 0.3));
    w[j].yaw_rad = w[j - 1].yaw_rad + uniform(-0.5, 0.5);
  }
  return w;
}

std::vector<double> nominal_times(const std::vector<Waypoint>& w) {
  std::vector<double> t(w.size() - 1);
  for (std::size_t i = 0; i < t.size(); ++i)
    t[i] = (w[i + 1].position_m - w[i].position_m).norm() / 1.5;
  return t;
}

void PlanFixedTimes(benchmark::State& state) {
  const auto w = walk(static_cast<int>(state.range(0)));
  const auto times = nominal_times(w);
  for (auto _ : state) benchmark::DoNotOptimize(plan_min_snap(w, times));
}
BENCHMARK(PlanFixedTimes)->Arg(10)->Arg(100)->Unit(benchmark::kMicrosecond);

void CostAndGradient(benchmark::State& state) {
  const auto w = walk(static_cast<int>(state.range(0)));
  const auto times = nominal_times(w);
  for (auto _ : state) benchmark::DoNotOptimize(min_snap_cost(w, times));
}
BENCHMARK(CostAndGradient)->Arg(10)->Arg(100)->Unit(benchmark::kMicrosecond);

void AllocateTimes(benchmark::State& state) {
  const auto w = walk(static_cast<int>(state.range(0)));
  TimeAllocation last;
  for (auto _ : state) {
    last = optimize_segment_times(w, 10.0);
    benchmark::DoNotOptimize(last);
  }
  state.counters["iterations"] = last.iterations;
  state.counters["converged"] = last.converged ? 1 : 0;
}
BENCHMARK(AllocateTimes)->Arg(10)->Arg(100)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
