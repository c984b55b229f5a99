// Closed-loop throughput: physics steps per second of the full QDrone2 model flown by the PID and
// the SE(3) controller at 1 kHz control (a controller evaluation and an allocation every step),
// tracking the thesis references, noise on; and two vehicles in a Fleet (fleet/fleet.hpp) against
// the same two flown one after the other. Run: build/release/bench/closed_loop_bench.

#include <benchmark/benchmark.h>

#include <memory>
#include <string>

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/config/controller_config.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/fleet/fleet.hpp"

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

/// Two SE(3) vehicles hovering 1.2 m apart vertically, one second of flight per iteration: in a
/// Fleet (with or without the wake) or each flown alone one after the other.
void two_vehicles(benchmark::State& state, int mode) {
  const std::string root = DRONETWIN_SOURCE_DIR;
  const auto model =
      std::make_shared<const VehicleModel>(load_vehicle_model(root + "/models/qdrone2.yaml"));
  const SetpointReference above(Vec3(0, 0, 2.2)), below(Vec3(0, 0, 1.0));
  for (auto _ : state) {
    state.PauseTiming();
    Simulator upper(model, SimConfig{}), lower(model, SimConfig{});
    upper.reset(Simulator::hover_state(Vec3(0, 0, 2.2)), model->hover_speeds_rad_s());
    lower.reset(Simulator::hover_state(Vec3(0, 0, 1.0)), model->hover_speeds_rad_s());
    auto cu = load_controller(root + "/config/controllers/se3.yaml", model, 1000.0);
    auto cl = load_controller(root + "/config/controllers/se3.yaml", model, 1000.0);
    ClosedLoop lu(upper, *cu, above, 1000.0), ll(lower, *cl, below, 1000.0);
    DownwashSettings d;
    d.enabled = mode == 1;
    Fleet fleet(d);
    fleet.add("upper", upper, lu);
    fleet.add("lower", lower, ll);
    state.ResumeTiming();
    if (mode == 2) {
      benchmark::DoNotOptimize(lu.run(1.0));
      benchmark::DoNotOptimize(ll.run(1.0));
    } else {
      benchmark::DoNotOptimize(fleet.run(1.0));
    }
  }
  state.counters["vehicle steps/s"] = benchmark::Counter(
      2000.0 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
void BM_FleetTwoSe3Downwash(benchmark::State& s) { two_vehicles(s, 1); }
void BM_FleetTwoSe3NoDownwash(benchmark::State& s) { two_vehicles(s, 0); }
void BM_TwoSe3Alone(benchmark::State& s) { two_vehicles(s, 2); }

BENCHMARK(BM_ClosedLoopPid1kHz);
BENCHMARK(BM_FleetTwoSe3Downwash)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FleetTwoSe3NoDownwash)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TwoSe3Alone)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ClosedLoopSe3Circle1kHz);
BENCHMARK(BM_ClosedLoopPid100Hz);

}  // namespace

BENCHMARK_MAIN();
