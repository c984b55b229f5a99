// Cost of one physics step of the full QDrone2 model: RK4, every disturbance term, motor lag,
// ground check; single thread. *WindField: shear, a gust and moderate Dryden turbulence.
// *Battery: the equivalent-circuit pack (at hover: the speed cap is checked, never binds).
// *Payload: a 0.5 kg slung payload, swinging (integrated with the vehicle, cable settled). Run:
// build/bench/step_bench (see docs/performance.md).

#include <benchmark/benchmark.h>

#include <memory>

#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/sim/simulator.hpp"

namespace {

using namespace dronetwin;

std::shared_ptr<const VehicleModel> model(const char* name) {
  return std::make_shared<const VehicleModel>(
      load_vehicle_model(std::string(DRONETWIN_SOURCE_DIR) + "/models/" + name + ".yaml"));
}

void run(benchmark::State& state, const char* name, Integrator integrator, bool noise,
         bool wind_field = false, bool battery = false, bool payload = false) {
  const auto m = model(name);
  SimConfig cfg;
  cfg.integrator = integrator;
  cfg.noise.enabled = noise;
  cfg.environment.wind_W_m_s << 1.0, -0.5, 0.0;  // non-zero air velocity: drag terms do work
  if (wind_field) {  // shear, a gust that lasts the whole run, moderate Dryden turbulence
    cfg.wind.shear.enabled = true;
    cfg.wind.gusts[0] = {0.0, 10.0, Vec3(0.0, 1.0, 0.0)};
    cfg.wind.num_gusts = 1;
    cfg.wind.turbulence = TurbulenceSettings::of(TurbulenceSeverity::kModerate);
  }
  cfg.battery.enabled = battery;
  cfg.payload.enabled = payload;
  cfg.payload.initial_swing1_rad = 0.2;
  Simulator sim(m, cfg);
  RotorVector ref = m->hover_speeds_rad_s();
  ref[0] *= 1.001;  // a little asymmetry so the body moves and rotates
  const StateVector start = Simulator::hover_state(Vec3(0, 0, 1.0));
  sim.reset(start, m->hover_speeds_rad_s());
  sim.set_rotor_speed_reference(ref);
  std::int64_t since_reset = 0;
  for (auto _ : state) {
    // Open loop drifts: restart every 2 s of simulated time, outside the hot path's cost.
    if (++since_reset == 2000) {
      state.PauseTiming();
      sim.reset(start, m->hover_speeds_rad_s());
      sim.set_rotor_speed_reference(ref);
      since_reset = 0;
      state.ResumeTiming();
    }
    benchmark::DoNotOptimize(sim.step());
  }
  state.counters["steps/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_StepQDrone2Rk4(benchmark::State& s) { run(s, "qdrone2", Integrator::kRk4, false); }
void BM_StepQDrone2Rk4Noise(benchmark::State& s) { run(s, "qdrone2", Integrator::kRk4, true); }
void BM_StepQDrone2Euler(benchmark::State& s) { run(s, "qdrone2", Integrator::kEuler, false); }
void BM_StepQDrone2Rk4WindField(benchmark::State& s) {
  run(s, "qdrone2", Integrator::kRk4, false, true);
}
void BM_StepQDrone2Rk4Battery(benchmark::State& s) {
  run(s, "qdrone2", Integrator::kRk4, false, false, true);
}
void BM_StepQDrone2Rk4Payload(benchmark::State& s) {
  run(s, "qdrone2", Integrator::kRk4, false, false, false, true);
}
void BM_StepHexarotorRk4(benchmark::State& s) { run(s, "hexarotor", Integrator::kRk4, false); }

BENCHMARK(BM_StepQDrone2Rk4);
BENCHMARK(BM_StepQDrone2Rk4Noise);
BENCHMARK(BM_StepQDrone2Rk4WindField);
BENCHMARK(BM_StepQDrone2Rk4Battery);
BENCHMARK(BM_StepQDrone2Rk4Payload);
BENCHMARK(BM_StepQDrone2Euler);
BENCHMARK(BM_StepHexarotorRk4);

}  // namespace

BENCHMARK_MAIN();
