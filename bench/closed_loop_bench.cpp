// Closed-loop throughput: physics steps per second of the full QDrone2 model flown by the PID and
// the SE(3) controller at 1 kHz control (a controller evaluation and an allocation every step),
// tracking the thesis references, noise on. Run: build/release/bench/closed_loop_bench.

#include <benchmark/benchmark.h>

#include <memory>
#include <string>

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/config/controller_config.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/control/closed_loop.hpp"

namespace {

using namespace dronetwin;

void run(benchmark::State& state, const char* controller_file, const Reference& reference,
         double rate_hz, const Vec3& start) {
  const std::string root = DRONETWIN_SOURCE_DIR;
  const auto model =
      std::make_shared<const VehicleModel>(load_vehicle_model(root + "/models/qdrone2.yaml"));
  SimConfig cfg;
  cfg.noise.enabled = true;
  Simulator sim(model, cfg);
  auto controller =
      load_controller(root + "/config/controllers/" + controller_file, model, rate_hz);
  const auto restart = [&] {
    sim.reset(Simulator::hover_state(start), model->hover_speeds_rad_s());
    controller->reset();
  };
  restart();
  auto loop = std::make_unique<ClosedLoop>(sim, *controller, reference, rate_hz);
  std::int64_t since_reset = 0;
  for (auto _ : state) {
    if (++since_reset == 20000) {  // 20 s of flight, then start over (outside the timing)
      state.PauseTiming();
      restart();
      loop = std::make_unique<ClosedLoop>(sim, *controller, reference, rate_hz);
      since_reset = 0;
      state.ResumeTiming();
    }
    benchmark::DoNotOptimize(loop->step());
  }
  state.counters["steps/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_ClosedLoopPid1kHz(benchmark::State& s) {
  const SetpointReference hover(Vec3(0.5, -0.3, 1.0));
  run(s, "pid.yaml", hover, 1000.0, Vec3(0, 0, 1));
}
void BM_ClosedLoopSe3Circle1kHz(benchmark::State& s) {
  const CircleReference circle;  // thesis Eq. 3.28
  run(s, "se3.yaml", circle, 1000.0, circle.at(0.0).position_m);
}
void BM_ClosedLoopPid100Hz(benchmark::State& s) {
  const SetpointReference hover(Vec3(0.5, -0.3, 1.0));
  run(s, "pid.yaml", hover, 100.0, Vec3(0, 0, 1));
}

BENCHMARK(BM_ClosedLoopPid1kHz);
BENCHMARK(BM_ClosedLoopSe3Circle1kHz);
BENCHMARK(BM_ClosedLoopPid100Hz);

}  // namespace

BENCHMARK_MAIN();
