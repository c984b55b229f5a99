// Vehicle-steps per second of the batched engine (batch/batch_simulator.hpp): the full QDrone2
// model (every disturbance term), RK4, motor lag, ground check, per-lane parameters (every lane a
// different mass and thrust curve), wind. Arguments: N vehicles, steps per call, threads.
// Run: build/release/bench/batch_bench (docs/performance.md, "Batched engine").
// BM_*Noise: the same with OU state noise on (13 counter-based normals per vehicle-step).
// BM_*Se3: the SE(3) controller and the thrust-first allocation before every physics step
// (BatchSe3Controller), each lane holding its own setpoint, no restarts needed.
// BM_*WindField: shear, a gust and moderate Dryden turbulence (a per-lane scalar pass per step).
// BM_*Faults: a rotor at 90 % thrust from 0.5 s and a stuck rotor from 1 s after each lane's
// reset (the per-lane fault clock, a kernel rebuild when a lane's fault begins).
//
// "steps per call" 1 is an RL loop that acts every physics step; 10 is a 100 Hz policy over a
// 1 kHz physics (the pack stays in registers for the 10 steps).

#include <benchmark/benchmark.h>

#include <memory>

#include "dronetwin/batch/batch_se3.hpp"
#include "dronetwin/batch/batch_simulator.hpp"
#include "dronetwin/config/model_loader.hpp"

namespace {

using namespace dronetwin;

enum class Mode { kOpenLoop, kNoise, kSe3, kWindField, kFaults, kBattery };

template <class T>
void run(benchmark::State& state, Mode mode = Mode::kOpenLoop) {
  const auto model = std::make_shared<const VehicleModel>(
      load_vehicle_model(std::string(DRONETWIN_SOURCE_DIR) + "/models/qdrone2.yaml"));
  const int n = static_cast<int>(state.range(0));
  const int steps = static_cast<int>(state.range(1));
  const int threads = static_cast<int>(state.range(2));
  SimConfig cfg;
  cfg.environment.wind_W_m_s << 1.0, -0.5, 0.0;  // non-zero air velocity: drag terms do work
  cfg.noise.enabled = mode == Mode::kNoise;
  if (mode == Mode::kWindField) {  // shear, a gust over the whole run, moderate turbulence
    cfg.wind.shear.enabled = true;
    cfg.wind.gusts[0] = {0.0, 10.0, Vec3(0.0, 1.0, 0.0)};
    cfg.wind.num_gusts = 1;
    cfg.wind.turbulence = TurbulenceSettings::of(TurbulenceSeverity::kModerate);
  }
  if (mode == Mode::kFaults) {
    cfg.faults.rotor[0] = RotorFault{RotorFaultKind::kEffectiveness, 0, 0.5, 0.9};
    cfg.faults.rotor[1] = RotorFault{RotorFaultKind::kStuck, 1, 1.0, 1.0};
    cfg.faults.num_rotor_faults = 2;
  }
  if (mode == Mode::kBattery) cfg.battery.enabled = true;  // the 6S default, hover: no cap binds
  BatchSimulator<T> batch(model, cfg, n, threads);
  Se3Options options;
  options.gravity_compensation = true;
  options.max_tilt_rad = 0.6;
  BatchSe3Controller<T> se3(model, Se3Gains::thesis(), options, n);
  for (int l = 0; l < n; ++l) {
    ReferencePoint r;
    r.position_m = Vec3(0.5, -0.3, 1.0 + 1e-3 * l);
    r.yaw_rad = 0.3;
    se3.set_reference(l, r);
  }
  const RotorVector hover = model->hover_speeds_rad_s();
  RotorVector ref = hover;
  ref[0] *= 1.001;  // a little asymmetry so the body moves and rotates
  const auto start_all = [&] {
    for (int l = 0; l < n; ++l) {
      batch.reset(l, Simulator::hover_state(Vec3(0, 0, 1.0 + 1e-3 * l)), hover);
      batch.set_rotor_speed_reference(l, ref);
    }
  };
  for (int l = 0; l < n; ++l) {
    batch.set_parameter(ModelParameter::kMass, l, model->mass_kg() * (1.0 + 1e-4 * (l % 100)));
    batch.set_parameter(
        ModelParameter::kThrustK1, l,
        parameter_value(model->parameters(), ModelParameter::kThrustK1) * (1.0 + 1e-4 * (l % 37)));
  }
  start_all();
  std::int64_t simulated = 0;
  for (auto _ : state) {
    // Open loop drifts: restart every 2 s of simulated time, outside the measured time.
    if (simulated >= 2000 && mode != Mode::kSe3) {
      state.PauseTiming();
      start_all();
      simulated = 0;
      state.ResumeTiming();
    }
    benchmark::DoNotOptimize(mode == Mode::kSe3 ? batch.step(steps, se3) : batch.step(steps));
    simulated += steps;
  }
  const double vehicle_steps = static_cast<double>(state.iterations()) * n * steps;
  state.counters["vehicle_steps/s"] =
      benchmark::Counter(vehicle_steps, benchmark::Counter::kIsRate);
  // time / (vehicle steps / 1e9): nanoseconds per vehicle-step.
  state.counters["ns/vehicle_step"] = benchmark::Counter(
      vehicle_steps / 1e9, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_BatchDouble(benchmark::State& s) { run<double>(s); }
void BM_BatchFloat(benchmark::State& s) { run<float>(s); }
void BM_BatchDoubleNoise(benchmark::State& s) { run<double>(s, Mode::kNoise); }
void BM_BatchFloatNoise(benchmark::State& s) { run<float>(s, Mode::kNoise); }
void BM_BatchDoubleSe3(benchmark::State& s) { run<double>(s, Mode::kSe3); }
void BM_BatchDoubleWindField(benchmark::State& s) { run<double>(s, Mode::kWindField); }
void BM_BatchFloatSe3(benchmark::State& s) { run<float>(s, Mode::kSe3); }
void BM_BatchDoubleFaults(benchmark::State& s) { run<double>(s, Mode::kFaults); }
void BM_BatchDoubleBattery(benchmark::State& s) { run<double>(s, Mode::kBattery); }

void sizes(benchmark::internal::Benchmark* b) {
  b->ArgNames({"N", "steps", "threads"});
  for (int n : {1, 64, 1024, 16384}) b->Args({n, 1, 1});
  for (int n : {1024, 16384}) b->Args({n, 10, 1});
  for (int n : {1024, 16384}) b->Args({n, 10, 2});
  b->UseRealTime();
}

BENCHMARK(BM_BatchDouble)->Apply(sizes);
BENCHMARK(BM_BatchFloat)->Apply(sizes);
BENCHMARK(BM_BatchDoubleNoise)->Apply(sizes);
BENCHMARK(BM_BatchFloatNoise)->Apply(sizes);
BENCHMARK(BM_BatchDoubleSe3)->Apply(sizes);
BENCHMARK(BM_BatchFloatSe3)->Apply(sizes);
BENCHMARK(BM_BatchDoubleWindField)->Apply(sizes);
BENCHMARK(BM_BatchDoubleFaults)->Apply(sizes);
BENCHMARK(BM_BatchDoubleBattery)->Apply(sizes);

}  // namespace

BENCHMARK_MAIN();
