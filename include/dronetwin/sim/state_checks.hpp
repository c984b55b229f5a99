#pragma once
// The two checks on a state that the Simulator and the batch share, so that a lane and a
// Simulator agree on what they accept and on why a step failed.

#include <cmath>

#include "dronetwin/core/error.hpp"
#include "dronetwin/sim/simulator.hpp"

namespace dronetwin {

/// Ok, or why `x` cannot be flown on: non-finite, a quaternion whose squared norm left
/// [0.25, 4] (a zero one stays zero after normalisation), or beyond the divergence limits.
/// Squared norms against squared limits (the limits are positive): no square roots on the path
/// taken every step; a NaN or inf fails its block's comparison too, and which failure it was is
/// sorted out only then.
inline StepStatus classify_state(const StateVector& x, const DivergenceLimits& lim) {
  using namespace state_index;
  const double p2 = x.segment<3>(kPosition).squaredNorm(),
               v2 = x.segment<3>(kVelocity).squaredNorm(),
               q2 = x.segment<4>(kQuaternion).squaredNorm(),
               w2 = x.segment<3>(kAngularVelocity).squaredNorm();
  if (p2 <= lim.max_position_m * lim.max_position_m &&
      v2 <= lim.max_speed_m_s * lim.max_speed_m_s &&
      w2 <= lim.max_angular_speed_rad_s * lim.max_angular_speed_rad_s && q2 <= 4.0 && q2 >= 0.25) {
    return StepStatus::kOk;
  }
  if (!x.allFinite()) return StepStatus::kNonFinite;
  if (!(q2 >= 0.25 && q2 <= 4.0)) return StepStatus::kInvalidState;
  return StepStatus::kDiverged;
}

/// Throws InvalidArgument unless `state` can be started from: every element finite, a non-zero
/// quaternion (it is normalised), and not below the ground when ground contact is on. The
/// message starts with `where` and, for lane >= 0, "lane <lane>: ". Allocates nothing unless it
/// throws (the batch's resets run inside an RL env's step).
inline void require_start_state(const StateVector& state, bool ground_enabled, const char* where,
                                int lane = -1) {
  const auto check = [&](bool ok, const auto&... parts) {
    if (ok) return;
    if (lane >= 0) require(false, where, "lane ", lane, ": ", parts...);
    require(false, where, parts...);
  };
  for (int i = 0; i < kStateSize; ++i)
    check(std::isfinite(state[i]), "state[", i, "]: expected a finite number, got ", state[i]);
  const double qn = state.segment<4>(state_index::kQuaternion).norm();
  check(qn > 1e-9, "state[6:10]: the quaternion must be non-zero (it is normalised), got norm ",
        qn);
  check(!(ground_enabled && state[state_index::kPosition + 2] < 0.0), "state[2]: z = ", state[2],
        " m is below the ground (z = 0); disable ground contact to start below it");
}

}  // namespace dronetwin
