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
// BM_*Split: the threads:2 row's lanes as one batch per thread, no memory in common (split()).
//
// "steps per call" 1 is an RL loop that acts every physics step; 10 is a 100 Hz policy over a
// 1 kHz physics (the pack stays in registers for the 10 steps).

#include <benchmark/benchmark.h>
#include <pthread.h>
#include <sched.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <thread>
#include <vector>

#include "dronetwin/batch/batch_se3.hpp"
#include "dronetwin/batch/batch_simulator.hpp"
#include "dronetwin/batch/thread_pool.hpp"
#include "dronetwin/config/model_loader.hpp"

namespace {

using namespace dronetwin;

enum class Mode { kOpenLoop, kNoise, kSe3, kWindField, kFaults, kBattery };

// One benchmark's batch, its inner loop and its restarts.
template <class T>
class Rig {
 public:
  Rig(int n, int threads, Mode mode)
      : model_(std::make_shared<const VehicleModel>(
            load_vehicle_model(std::string(DRONETWIN_SOURCE_DIR) + "/models/qdrone2.yaml"))),
        n_(n),
        mode_(mode),
        batch_(model_, config(mode), n, threads),
        se3_(model_, Se3Gains::thesis(), se3_options(), n) {
    for (int l = 0; l < n; ++l) {
      ReferencePoint r;
      r.position_m = Vec3(0.5, -0.3, 1.0 + 1e-3 * l);
      r.yaw_rad = 0.3;
      se3_.set_reference(l, r);
    }
    hover_ = model_->hover_speeds_rad_s();
    ref_ = hover_;
    ref_[0] *= 1.001;  // a little asymmetry so the body moves and rotates
    for (int l = 0; l < n; ++l) {
      batch_.set_parameter(ModelParameter::kMass, l, model_->mass_kg() * (1.0 + 1e-4 * (l % 100)));
      batch_.set_parameter(ModelParameter::kThrustK1, l,
                           parameter_value(model_->parameters(), ModelParameter::kThrustK1) *
                               (1.0 + 1e-4 * (l % 37)));
    }
    restart();
  }

  /// Open loop drifts: true when the lanes should be restarted (every 2 s of simulated time).
  bool due() const { return simulated_ >= 2000 && mode_ != Mode::kSe3; }

  void restart() {
    for (int l = 0; l < n_; ++l) {
      batch_.reset(l, Simulator::hover_state(Vec3(0, 0, 1.0 + 1e-3 * l)), hover_);
      batch_.set_rotor_speed_reference(l, ref_);
    }
    simulated_ = 0;
  }

  int step(int steps) {
    simulated_ += steps;
    return mode_ == Mode::kSe3 ? batch_.step(steps, se3_) : batch_.step(steps);
  }

 private:
  static SimConfig config(Mode mode) {
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
    return cfg;
  }
  static Se3Options se3_options() {
    Se3Options options;
    options.gravity_compensation = true;
    options.max_tilt_rad = 0.6;
    return options;
  }

  std::shared_ptr<const VehicleModel> model_;
  int n_;
  Mode mode_;
  BatchSimulator<T> batch_;
  BatchSe3Controller<T> se3_;
  RotorVector hover_, ref_;
  std::int64_t simulated_ = 0;
};

// Vehicle-steps per second and nanoseconds per vehicle-step (time / (vehicle steps / 1e9)).
void report_rates(benchmark::State& state, double vehicle_steps) {
  state.counters["vehicle_steps/s"] =
      benchmark::Counter(vehicle_steps, benchmark::Counter::kIsRate);
  state.counters["ns/vehicle_step"] = benchmark::Counter(
      vehicle_steps / 1e9, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

template <class T>
void run(benchmark::State& state, Mode mode = Mode::kOpenLoop) {
  const int n = static_cast<int>(state.range(0));
  const int steps = static_cast<int>(state.range(1));
  Rig<T> rig(n, static_cast<int>(state.range(2)), mode);
  for (auto _ : state) {
    if (rig.due()) {
      state.PauseTiming();
      rig.restart();
      state.ResumeTiming();
    }
    benchmark::DoNotOptimize(rig.step(steps));
  }
  report_rates(state, static_cast<double>(state.iterations()) * n * steps);
}

// The threads:2 row's work with no memory in common between the threads: N lanes as `threads`
// batches of N / threads lanes (one thread each), stepped together by one ThreadPool, so the
// same hand-over and the same wait as the threads:2 row. It tells what two threads of this machine
// give at the moment: where this row is as slow as the threads:2 row, the machine is the limit;
// where it is faster, the difference is what sharing one batch's arrays costs
// (bench/two_thread_scaling.sh, docs/performance.md).
template <class T>
void split(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int steps = static_cast<int>(state.range(1));
  const int threads = static_cast<int>(state.range(2));
  if (n % threads != 0) {
    state.SkipWithError("N must be a multiple of the number of threads");
    return;
  }
  std::vector<std::unique_ptr<Rig<T>>> rigs;
  for (int t = 0; t < threads; ++t)
    rigs.push_back(std::make_unique<Rig<T>>(n / threads, 1, Mode::kOpenLoop));
  ThreadPool pool(threads);
  for (auto _ : state) {
    if (rigs.front()->due()) {
      state.PauseTiming();
      for (auto& rig : rigs) rig->restart();
      state.ResumeTiming();
    }
    pool.run(threads, [&](int t) {
      benchmark::DoNotOptimize(rigs[static_cast<std::size_t>(t)]->step(steps));
    });
  }
  report_rates(state, static_cast<double>(state.iterations()) * n * steps);
}

// The machine, not the engine: one cache line passed back and forth between a thread pinned to
// CPU 0 and one pinned to CPU 1, the time of a round trip. Every hand-over of the pool and every
// line the two threads of a batch both touch pays this; on a shared VM it changes when the host
// moves the vCPUs (about 110 ns and then 360-515 ns on the same VM within minutes:
// docs/performance.md).
void BM_CoreRoundTrip(benchmark::State& state) {
  const auto pin = [](int cpu) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(cpu, &set);
    return pthread_setaffinity_np(pthread_self(), sizeof(set), &set) == 0;
  };
  cpu_set_t before;
  pthread_getaffinity_np(pthread_self(), sizeof(before), &before);
  alignas(64) std::atomic<std::int64_t> ball{0};
  std::atomic<int> partner_pinned{-1};  // -1 not yet known, 0 failed, 1 pinned
  std::atomic<bool> stop{false};
  std::thread partner([&] {
    partner_pinned = pin(1) ? 1 : 0;
    // Answers each odd value with the next even one until told to stop.
    while (!stop.load(std::memory_order_relaxed)) {
      const std::int64_t v = ball.load(std::memory_order_acquire);
      if ((v & 1) == 1) ball.store(v + 1, std::memory_order_release);
    }
  });
  while (partner_pinned.load() < 0) {
  }
  if (partner_pinned.load() == 1 && pin(0)) {
    std::int64_t v = 0;
    for (auto _ : state) {
      ball.store(++v, std::memory_order_release);
      ++v;
      while (ball.load(std::memory_order_acquire) != v) {
      }
    }
  } else {
    state.SkipWithError("cannot pin one thread to CPU 0 and one to CPU 1");
  }
  stop = true;
  partner.join();
  pthread_setaffinity_np(pthread_self(), sizeof(before), &before);
}
BENCHMARK(BM_CoreRoundTrip)->UseRealTime();

// The layout question behind batch_stride(), without the engine: 1024 float lanes in rows of
// `stride` floats, walked pack by pack, each pack reading the 24 rows a pack step reads (state,
// rotor speeds and references, wind) and rewriting the 17 it writes, with a little arithmetic.
// 1024 floats are 4096 bytes, the period of the L1 set index, so every row of a pack falls in one
// set; batch_stride<float>(1024), 1040 (65 lines), spreads them (docs/batch.md, "Layout"). Far less
// arithmetic per pack than the kernel's, so it shows the cache effect larger than a step does.
void BM_PackRows(benchmark::State& state) {
  constexpr int kLanes = 1024, kRead = 24, kWritten = 17;
  constexpr int kWidth = kBatchLanes<float>;
  using P = Pack<float, kWidth>;
  const auto stride = static_cast<std::size_t>(state.range(0));
  AlignedArray<float> rows(stride * kRead, 1.0f);
  for (auto _ : state) {
    for (std::size_t base = 0; base < kLanes; base += kWidth) {
      P sum(0.0f);
      for (std::size_t k = 0; k < kRead; ++k)
        sum += P(&rows[k * stride + base], stdx::vector_aligned);
      for (std::size_t k = 0; k < kWritten; ++k) {
        float* row = &rows[k * stride + base];
        const P x = P(row, stdx::vector_aligned) * P(0.999f) + sum * P(1e-6f);
        x.copy_to(row, stdx::vector_aligned);
      }
    }
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * kLanes);
}
// The unpadded row, then the batch's own stride for 1024 floats (1040 on a 64-byte line).
BENCHMARK(BM_PackRows)->ArgName("stride")->Arg(1024)->Arg(batch_stride<float>(1024, "BM_PackRows"));

// Two-thread scaling measured so that the machine's speed cancels out: a 1-thread and a 2-thread
// batch of the same lanes take turns (the order alternating), each call timed on its own, and
// `scaling` is the 1-thread time over the 2-thread time. On a shared virtual machine the clock
// rate drifts by tens of percent within seconds, so the ratio of two separate benchmark runs
// mixes that drift into the figure; interleaving the calls does not. `in_a_row` calls of one
// batch go before the other's turn: 1 puts the other batch's call between two calls (the caller
// busy elsewhere between steps, longer than the pool's polling window at N = 1024), 16 measures
// calls back to back (a stepping loop), still alternating every ~16 calls so the drift cancels.
template <class T>
void scaling(benchmark::State& state, Mode mode = Mode::kOpenLoop) {
  const int n = static_cast<int>(state.range(0));
  const int steps = static_cast<int>(state.range(1));
  const int in_a_row = static_cast<int>(state.range(2));
  Rig<T> one(n, 1, mode), two(n, 2, mode);
  using Clock = std::chrono::steady_clock;
  Clock::duration time_one{}, time_two{};
  bool one_first = true;
  for (auto _ : state) {
    const auto timed = [&](Rig<T>& rig) {
      Clock::duration total{};
      for (int call = 0; call < in_a_row; ++call) {
        if (rig.due()) rig.restart();
        const auto start = Clock::now();
        benchmark::DoNotOptimize(rig.step(steps));
        total += Clock::now() - start;
      }
      return total;
    };
    if (one_first) {
      time_one += timed(one);
      time_two += timed(two);
    } else {
      time_two += timed(two);
      time_one += timed(one);
    }
    one_first = !one_first;
  }
  const double vehicle_steps = static_cast<double>(state.iterations()) * n * steps * in_a_row;
  const auto seconds = [](Clock::duration d) { return std::chrono::duration<double>(d).count(); };
  state.counters["scaling"] = seconds(time_one) / seconds(time_two);
  state.counters["M_steps/s_1thread"] = vehicle_steps / seconds(time_one) / 1e6;
  state.counters["M_steps/s_2threads"] = vehicle_steps / seconds(time_two) / 1e6;
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

void BM_BatchDoubleSplit(benchmark::State& s) { split<double>(s); }
void BM_BatchFloatSplit(benchmark::State& s) { split<float>(s); }

void BM_ScalingDouble(benchmark::State& s) { scaling<double>(s); }
void BM_ScalingFloat(benchmark::State& s) { scaling<float>(s); }
void BM_ScalingDoubleSe3(benchmark::State& s) { scaling<double>(s, Mode::kSe3); }

void sizes(benchmark::internal::Benchmark* b) {
  b->ArgNames({"N", "steps", "threads"});
  for (int n : {1, 64, 1024, 16384}) b->Args({n, 1, 1});
  for (int n : {1024, 16384}) b->Args({n, 10, 1});
  for (int n : {1024, 16384}) b->Args({n, 10, 2});
  b->Args({1024, 1, 2});  // a stepping loop on two threads, without interleaving (performance.md)
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

void split_sizes(benchmark::internal::Benchmark* b) {
  b->ArgNames({"N", "steps", "threads"});
  b->Args({1024, 1, 2});
  b->Args({1024, 10, 2});
  b->UseRealTime();
}
BENCHMARK(BM_BatchDoubleSplit)->Apply(split_sizes);
BENCHMARK(BM_BatchFloatSplit)->Apply(split_sizes);

void scaling_sizes(benchmark::internal::Benchmark* b) {
  b->ArgNames({"N", "steps", "in_a_row"});
  for (int in_a_row : {1, 16})
    for (int n : {1024, 16384})
      for (int steps : {1, 10}) b->Args({n, steps, in_a_row});
}
BENCHMARK(BM_ScalingDouble)->Apply(scaling_sizes);
BENCHMARK(BM_ScalingFloat)->Apply(scaling_sizes);
BENCHMARK(BM_ScalingDoubleSe3)->Apply(scaling_sizes);

}  // namespace

BENCHMARK_MAIN();
