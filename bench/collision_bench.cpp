// Scene contact (world/collision.hpp) over one physics step against the racing circuit with 12
// obstacles (bench/bench_scene.hpp: 8 gates, 8 pillars, 4 boxes): a vehicle at a random place in
// the arena moving 1 cm (10 m/s at 1 kHz) and turning 0.01 rad, with the QDrone2's default sphere
// and with a box; and a Simulator step with and without that scene. One thread.
// Run (one line): build/release/bench/collision_bench --benchmark_repetitions=3
//                 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <memory>
#include <vector>

#include "bench_scene.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "dronetwin/world/collision.hpp"

namespace {

using namespace dronetwin;

struct Motion {
  Vec3 p0, p1;
  Vec4 q0, q1;
};

std::vector<Motion> random_motions(const Track& t, int n) {
  Random rng(3);
  std::vector<Motion> m(static_cast<std::size_t>(n));
  for (Motion& x : m) {
    for (int k = 0; k < 3; ++k)
      x.p0[k] = t.arena_min_m[k] + rng.uniform() * (t.arena_max_m[k] - t.arena_min_m[k]);
    const Vec3 d = Vec3(rng.normal(), rng.normal(), rng.normal()).normalized();
    x.p1 = x.p0 + 0.01 * d;
    const double yaw = 6.283 * rng.uniform();
    x.q0 = math::from_euler(0.1, -0.05, yaw);
    x.q1 = math::from_euler(0.1, -0.05, yaw + 0.01);
  }
  return m;
}

void run(benchmark::State& state, const CollisionShape& shape) {
  static const Track t = bench::circuit_with_obstacles();
  const std::vector<Motion> m = random_motions(t, 4096);
  std::size_t i = 0, contacts = 0, tests = 0;
  for (auto _ : state) {
    const Motion& x = m[i];
    const SceneContact c = find_scene_contact(t, shape, x.p0, x.q0, x.p1, x.q1);
    benchmark::DoNotOptimize(c);
    contacts += c ? 1 : 0;
    ++tests;
    i = (i + 1) % m.size();
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["contact_share"] = static_cast<double>(contacts) / static_cast<double>(tests);
}

void BM_SceneContactSphere(benchmark::State& state) { run(state, CollisionShape::sphere(0.264)); }
void BM_SceneContactBox(benchmark::State& state) {
  run(state, CollisionShape::box(Vec3(0.25, 0.25, 0.06)));
}

void step(benchmark::State& state, bool with_scene) {
  auto model = std::make_shared<const VehicleModel>(
      load_vehicle_model(std::string(DRONETWIN_SOURCE_DIR) + "/models/qdrone2.yaml"));
  Simulator sim(model);
  if (with_scene) sim.set_scene(std::make_shared<const Track>(bench::circuit_with_obstacles()));
  // Hovering in the open between the circuit's pillars.
  sim.reset(Simulator::hover_state(Vec3(0.0, 1.5, 3.0)), model->hover_speeds_rad_s());
  sim.set_rotor_speed_reference(model->hover_speeds_rad_s());
  for (auto _ : state) {
    if (!sim.step().ok()) state.SkipWithError("the hover touched something");
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_SimulatorStepNoScene(benchmark::State& state) { step(state, false); }
void BM_SimulatorStepWithScene(benchmark::State& state) { step(state, true); }

}  // namespace

BENCHMARK(BM_SceneContactSphere);
BENCHMARK(BM_SceneContactBox);
BENCHMARK(BM_SimulatorStepNoScene);
BENCHMARK(BM_SimulatorStepWithScene);
BENCHMARK_MAIN();
