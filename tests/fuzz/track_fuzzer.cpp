// libFuzzer harness: racing-track files (config/track_loader.hpp). Parses the input as a track;
// for an accepted one (gates are optional), every gate's geometry is usable: finite corners inside
// the arena, and the passage and frame tests on a segment through it return without trouble and
// finite numbers, and a ray straight down from the start meets the ground (or something nearer)
// within its height.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "dronetwin/config/track_loader.hpp"
#include "dronetwin/world/gate.hpp"
#include "dronetwin/world/ray_cast.hpp"
#include "fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dronetwin;
  const std::string yaml = fuzz::text(data, size);
  Track t;
  if (!fuzz::accepted([&] { t = parse_track(yaml, "fuzz.yaml"); })) return 0;
  // A track may have no gates (a scene of obstacles); racing checks for gates itself.
  fuzz::check(std::isfinite(t.length_m()), "an accepted track has a non-finite length");
  fuzz::check(!t.gates.empty() || t.length_m() == 0.0, "a track without gates has a length");
  for (const Gate& g : t.gates) {
    for (const Vec3& c : g.corners()) {
      fuzz::check(c.allFinite(), "a gate corner is not finite");
      fuzz::check(
          (c.array() > t.arena_min_m.array()).all() && (c.array() < t.arena_max_m.array()).all(),
          "a gate corner is outside the arena");
    }
    // At everyday coordinates (beyond ~1e15 m a unit step is lost to rounding).
    if (!(g.center_m.norm() < 1e6)) continue;
    const Vec3 before = g.center_m - g.normal(), after = g.center_m + g.normal();
    fuzz::check(cross_gate(g, before, after) == GateCrossing::kThrough,
                "a segment through a gate's centre along its normal does not pass it");
    fuzz::check(std::isfinite(frame_distance_m(g, before, after)),
                "the frame distance is not finite");
  }
  // Straight down from the start, the ground is at most the start's height away; obstacles and
  // frames can only be nearer (world/ray_cast.hpp).
  const RayHit down = cast_ray(t, t.start_position_m, -Vec3::UnitZ(), kNoHit);  // unlimited range
  fuzz::check(down.distance_m >= 0.0 &&
                  down.distance_m <= std::max(t.start_position_m.z(), 0.0) * (1.0 + 1e-12),
              "a ray straight down from the start does not meet the ground within its height");
  return 0;
}
