// Ray casting (world/ray_cast.hpp) against the racing circuit (config/tracks/circuit.yaml: 8
// gates, 32 bars) with 12 obstacles added (8 pillars, 4 boxes) and the ground: one frame of a
// 64 x 48 pinhole camera with a 90 degree horizontal field of view, looking along the first leg
// from the start, and random rays from random points of the arena. One thread.
// Run (one line): build/release/bench/ray_bench --benchmark_repetitions=3
//                 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>
#include <vector>

#include "bench_scene.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/world/ray_cast.hpp"

namespace {

using namespace dronetwin;

Track scene() { return bench::circuit_with_obstacles(); }

struct Rays {
  std::vector<double> origins, directions, distance;
  std::size_t count() const { return distance.size(); }
};

// A 64 x 48 pinhole frame from the start, looking at the first gate.
Rays camera_frame(const Track& t) {
  const int w = 64, h = 48;
  const double focal = 0.5 * w / std::tan(0.25 * M_PI);  // 90 degrees across
  const Vec3 eye = t.start_position_m + Vec3(0, 0, 0.1);
  const Vec3 fwd = (t.gates.front().center_m - eye).normalized();
  const Vec3 left = Vec3::UnitZ().cross(fwd).normalized(), up = fwd.cross(left);
  Rays r;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const Vec3 d =
          (focal * fwd + (0.5 * w - u - 0.5) * left + (0.5 * h - v - 0.5) * up).normalized();
      for (int k = 0; k < 3; ++k) {
        r.origins.push_back(eye[k]);
        r.directions.push_back(d[k]);
      }
    }
  }
  r.distance.resize(static_cast<std::size_t>(w * h));
  return r;
}

Rays random_rays(const Track& t, std::size_t n) {
  Random rng(1);
  Rays r;
  for (std::size_t i = 0; i < n; ++i) {
    Vec3 o, d(rng.normal(), rng.normal(), rng.normal());
    for (int k = 0; k < 3; ++k)
      o[k] = t.arena_min_m[k] + rng.uniform() * (t.arena_max_m[k] - t.arena_min_m[k]);
    o[2] = std::max(o[2], 0.05);
    d.normalize();
    for (int k = 0; k < 3; ++k) {
      r.origins.push_back(o[k]);
      r.directions.push_back(d[k]);
    }
  }
  r.distance.resize(n);
  return r;
}

void run(benchmark::State& state, const Track& t, Rays& r) {
  for (auto _ : state) {
    cast_rays(t, r.origins.data(), r.directions.data(), r.count(), 20.0, r.distance.data());
    benchmark::DoNotOptimize(r.distance.data());
  }
  std::size_t hits = 0;
  for (double d : r.distance) hits += d != kNoHit;
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * r.count()));
  state.counters["rays"] = static_cast<double>(r.count());
  state.counters["hit_share"] = static_cast<double>(hits) / static_cast<double>(r.count());
  state.counters["objects"] = static_cast<double>(t.gates.size() + t.obstacles.size() + 1);
}

void BM_RayCastCameraFrame64x48(benchmark::State& state) {
  static const Track t = scene();
  Rays r = camera_frame(t);
  run(state, t, r);
}
void BM_RayCastRandom(benchmark::State& state) {
  static const Track t = scene();
  Rays r = random_rays(t, 4096);
  run(state, t, r);
}

}  // namespace

BENCHMARK(BM_RayCastCameraFrame64x48)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_RayCastRandom)->Unit(benchmark::kMicrosecond);
BENCHMARK_MAIN();
