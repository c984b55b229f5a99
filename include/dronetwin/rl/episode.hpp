#pragma once
// Why an episode ended, and what it achieved: per-env episode statistics reported when an env
// auto-resets (VecEnv::finished_*).

#include <array>
#include <cstdint>
#include <string_view>

namespace dronetwin::rl {

/// Why an env's episode ended this step; kNone while it runs. Everything from kGround to
/// kInvalidAction is `terminated`; kTimeLimit is `truncated`; kFinished (all laps flown) is
/// `terminated` without a crash.
enum class EndCause : std::uint8_t {
  kNone = 0,
  kGround,            ///< hit the ground (below min_height_m, or a touchdown)
  kGateFrame,         ///< touched a gate's frame
  kObstacle,          ///< touched a scene obstacle
  kFlip,              ///< tilt beyond max_tilt_rad
  kOutOfBounds,       ///< left the arena
  kSimulationFailed,  ///< the physics stopped the lane (non-finite, diverged, controller failed)
  kInvalidAction,     ///< the action had a NaN or an infinity
  kFinished,          ///< racing: all laps flown
  kTimeLimit,         ///< episode_time_s reached (truncated)
};
inline constexpr int kNumEndCauses = 10;
inline constexpr std::array<std::string_view, kNumEndCauses> kEndCauseNames = {
    "none",     "ground",        "gate_frame",        "obstacle",
    "flip",     "out_of_bounds", "simulation_failed", "invalid_action",
    "finished", "time_limit"};

/// True for the causes that earn the crash penalty (Eq. 4.21: collided or flipped, and the
/// failures that end an episode the same way).
constexpr bool is_crash(EndCause c) {
  return c != EndCause::kNone && c != EndCause::kFinished && c != EndCause::kTimeLimit;
}

}  // namespace dronetwin::rl
