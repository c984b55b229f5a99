// Sensors and estimation: one SensorSuite update with every sensor type at its default rate (the
// cost a run pays per physics step), a depth-camera frame (64 x 48, 90 deg) of the racing circuit
// with 12 obstacles for 1 and 64 vehicles, and the error-state EKF's IMU propagation and motion-
// capture update. One thread.
// Run (one line): build/release/bench/sensors_bench --benchmark_repetitions=3
//                 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "bench_scene.hpp"
#include "dronetwin/estimation/error_state_ekf.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/sensors/depth_camera.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"

namespace {

using namespace dronetwin;

Track scene() { return bench::circuit_with_obstacles(); }

SensorTruth flying() {
  SensorTruth t;
  t.state << 0.3, -0.2, 1.5, 1.0, 0.5, 0.1, 1, 0, 0, 0, 0.2, -0.1, 0.3;
  t.state.segment<4>(6) = math::from_euler(0.1, -0.05, 0.4);
  t.acceleration_W_m_s2 = Vec3(0.5, -0.2, 0.1);
  t.rotor_speed_rad_s = RotorVector::Constant(4, 1200.0);
  return t;
}

void BM_SensorSuiteUpdateAllTypes(benchmark::State& state) {
  std::vector<SensorSpec> specs;
  for (const std::string_view type : kSensorTypeNames)
    specs.push_back(SensorSpec::defaults(type, std::string(type)));
  SensorSuite suite(specs, 1e-3, 4, 1);
  SensorTruth t = flying();
  std::int64_t k = 0;
  for (auto _ : state) {
    t.time_s = static_cast<double>(k) * 1e-3;
    suite.update(k++, t);
    benchmark::DoNotOptimize(suite.latest(0).values.data());
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["sensors"] = static_cast<double>(specs.size());
}

void BM_DepthCameraFrame64x48(benchmark::State& state) {
  static const Track t = scene();
  const DepthCamera cam(DepthCameraParameters{});
  const auto n = static_cast<std::size_t>(state.range(0));
  std::vector<double> states;
  for (std::size_t i = 0; i < n; ++i) {
    StateVector x = Simulator::hover_state(
        t.start_position_m + Vec3(0.05 * static_cast<double>(i), 0.0, 0.1), t.start_yaw_rad);
    states.insert(states.end(), x.data(), x.data() + kStateSize);
  }
  std::vector<float> frames(n * cam.pixels());
  for (auto _ : state) {
    cam.render_batch(states.data(), n, &t, frames.data());
    benchmark::DoNotOptimize(frames.data());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * n));
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations() * n), benchmark::Counter::kIsRate);
}

void BM_EkfImuPropagation(benchmark::State& state) {
  ErrorStateEkf ekf(EkfParameters{});
  ekf.reset(Simulator::hover_state(Vec3(0, 0, 1)), 0.0);
  const Vec3 f(0.1, -0.05, 9.8), w(0.01, 0.02, -0.01);
  for (auto _ : state) {
    ekf.propagate(f, w, 1e-3);
    benchmark::DoNotOptimize(ekf.covariance().data());
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_EkfMotionCaptureUpdate(benchmark::State& state) {
  ErrorStateEkf ekf(EkfParameters{});
  ekf.reset(Simulator::hover_state(Vec3(0, 0, 1)), 0.0);
  for (auto _ : state) {
    ekf.update_position(Vec3(0.0, 0.0, 1.0), 5e-4);
    ekf.update_attitude(Vec4(1, 0, 0, 0), 1.75e-3);
    benchmark::DoNotOptimize(ekf.covariance().data());
  }
  state.SetItemsProcessed(state.iterations());
}

}  // namespace

BENCHMARK(BM_SensorSuiteUpdateAllTypes);
BENCHMARK(BM_DepthCameraFrame64x48)->Arg(1)->Arg(64)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EkfImuPropagation);
BENCHMARK(BM_EkfMotionCaptureUpdate);
BENCHMARK_MAIN();
