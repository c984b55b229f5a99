// Cost of minimum-snap planning (planning/min_snap.hpp) for 10 and 100 waypoints: the closed
// form with fixed segment times, and the segment-time allocation (BFGS on log-times, each
// iteration one or more closed-form solves). Single thread. Waypoints: a seeded random walk with
// 1-3 m steps and yaw changes, so the times and the solution are not trivially regular.
// TimeOptimalLap: the time-optimal flying lap of the shipped circuit (time_optimal/), with the
// default options (every warm start) and with one warm start; one solve per iteration.

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/config/track_loader.hpp"
#include "dronetwin/planning/min_snap.hpp"
#include "dronetwin/time_optimal/time_optimal_lap.hpp"

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

/// Argument 0: the default options (every warm-start factor); otherwise one warm start, the plan
/// flown at arg / 100 of its feasible segment times.
void TimeOptimalLapOfTheCircuit(benchmark::State& state) {
  const std::string root = DRONETWIN_SOURCE_DIR;
  const VehicleModel model = load_vehicle_model(root + "/models/qdrone2.yaml");
  const Track track = load_track(root + "/config/tracks/circuit.yaml");
  TimeOptimalOptions options;
  if (state.range(0) > 0)
    options.warm_start_time_factors = {static_cast<double>(state.range(0)) / 100.0};
  TimeOptimalLap lap(min_snap_lap(track, model, options));
  for (auto _ : state) {
    lap = solve_time_optimal_lap(track, model, options);
    benchmark::DoNotOptimize(lap.lap_time_s);
  }
  state.counters["lap_s"] = lap.lap_time_s;
  state.counters["solves"] = lap.outer_iterations;
  state.counters["lm_iterations"] = lap.inner_iterations;
}
BENCHMARK(TimeOptimalLapOfTheCircuit)
    ->Arg(0)
    ->Arg(100)
    ->Arg(80)
    ->Arg(60)
    ->Arg(50)
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

BENCHMARK_MAIN();
