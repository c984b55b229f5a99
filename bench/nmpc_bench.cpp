// NMPC solve time per control step (issue "NMPC with Ceres", item 4): the QDrone2 flown on the
// figure eight of thesis Eq. 3.25 by config/controllers/nmpc.yaml (N = 100, 10 ms) and by the
// same file with N = 20, noise on, one thread. One benchmark iteration = one NMPC interval: 10
// physics steps and 10 inner-loop calls, one of which solves. Counters: median and p99 (nearest
// rank) of the wall-clock time of ceres::Solve per control step, mean iterations, failures.
// Run: build/release/bench/nmpc_bench --benchmark_repetitions=3
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/config/controller_config.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/nmpc/nmpc.hpp"

namespace {

using namespace dronetwin;

void run(benchmark::State& state, int horizon_steps) {
  const std::string root = DRONETWIN_SOURCE_DIR;
  const auto model =
      std::make_shared<const VehicleModel>(load_vehicle_model(root + "/models/qdrone2.yaml"));
  SimConfig cfg;
  cfg.noise.enabled = true;
  Simulator sim(model, cfg);
  ControllerConfig c = load_controller_config(root + "/config/controllers/nmpc.yaml");
  if (horizon_steps != std::get<NmpcSettings>(c.settings).options.horizon_steps) {
    std::get<NmpcSettings>(c.settings).options.horizon_steps = horizon_steps;
    std::get<NmpcSettings>(c.settings).options.input_blocks = {1, 1, 2,
                                                               4, 4, 8};  // 20 steps in 6 blocks
  }
  auto controller = make_controller(c, model, 1000.0);
  auto& nmpc = dynamic_cast<NmpcController&>(*controller);
  const FigureEightReference reference;  // Eq. 3.25
  const auto restart = [&] {
    StateVector x0 = Simulator::hover_state(reference.at(0.0).position_m);
    x0.segment<3>(state_index::kVelocity) = reference.at(0.0).velocity_m_s;
    sim.reset(x0, model->hover_speeds_rad_s());
    controller->reset();
  };
  restart();
  auto loop = std::make_unique<ClosedLoop>(sim, *controller, reference, 1000.0);
  std::vector<double> solve_ms;
  double iterations = 0.0;
  std::int64_t failures = 0, since_reset = 0;
  for (auto _ : state) {
    if (++since_reset == 6000) {  // one 60 s lap, then start over (outside the timing)
      state.PauseTiming();
      restart();
      loop = std::make_unique<ClosedLoop>(sim, *controller, reference, 1000.0);
      since_reset = 0;
      state.ResumeTiming();
    }
    for (int i = 0; i < 10; ++i) benchmark::DoNotOptimize(loop->step());
    const NmpcSolveStats& s = nmpc.last_solve();
    solve_ms.push_back(1e3 * s.solve_time_s);
    iterations += s.iterations;
    failures += s.termination == NmpcTermination::kFailure ? 1 : 0;
  }
  std::sort(solve_ms.begin(), solve_ms.end());
  const std::size_t n = solve_ms.size();
  if (n > 0) {
    const auto rank = static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(n)));
    state.counters["solve_median_ms"] = solve_ms[n / 2];
    state.counters["solve_p99_ms"] = solve_ms[std::max<std::size_t>(rank, 1) - 1];
    state.counters["solve_max_ms"] = solve_ms.back();
    state.counters["iterations_mean"] = iterations / static_cast<double>(n);
    state.counters["failures"] = static_cast<double>(failures);
  }
}

void BM_NmpcFigureEightN100(benchmark::State& s) { run(s, 100); }
void BM_NmpcFigureEightN20(benchmark::State& s) { run(s, 20); }

}  // namespace

BENCHMARK(BM_NmpcFigureEightN100)->Unit(benchmark::kMillisecond)->MinTime(4.0);
BENCHMARK(BM_NmpcFigureEightN20)->Unit(benchmark::kMillisecond)->MinTime(2.0);

BENCHMARK_MAIN();
