#pragma once
// Tracking metrics of a closed-loop flight: the one RMSE of dronetwin, used by the experiment
// runner's summary.json and by Python's dronetwin.rmse(), so the two cannot disagree.
//
// RMSE [x, y, z, yaw] of the TRUE state against the reference at the same instant, over the
// physics steps k (t = k dt, t = 0 included) in the window [t0, t1]: a step is in it when
// ceil(t0 / dt - 1e-9) <= k <= floor(t1 / dt + 1e-9) (the tolerance of segment starts). The yaw is
// the atan2-based ZYX yaw of q_WB and its error is wrapped into [-pi, pi].
//
//   TrackingRmse m(sim.config().dt_s, window);       // window: std::nullopt = the whole run
//   m.add(sim.step_count(), sim.state(), reference.at(sim.time_s()));   // after every step
//   Vec4 e = m.rmse();                               // NaN when no step was in the window
//
//   Vec4 e = tracking_rmse(t, states, references, dt, window);  // over recorded rows

#include <array>
#include <cstdint>
#include <optional>

#include "dronetwin/control/reference.hpp"
#include "dronetwin/core/types.hpp"

namespace dronetwin {

class TrackingRmse {
 public:
  /// `window_s` = [t0, t1] with 0 <= t0 < t1 (checked by the experiment parser), or none.
  TrackingRmse(double dt_s, std::optional<std::array<double, 2>> window_s);

  /// Adds step `step` (t = step dt) when it is in the window.
  void add(std::int64_t step, const StateVector& state, const ReferencePoint& reference);
  /// Same with the reference's position and yaw given directly.
  void add(std::int64_t step, const StateVector& state, const Vec3& reference_position_m,
           double reference_yaw_rad);

  /// [x, y, z, yaw] (m, m, m, rad); NaN when no step was in the window.
  Vec4 rmse() const;
  std::int64_t samples() const { return samples_; }
  /// The window asked for ([0, inf) without one), clipped to `end_s`.
  std::array<double, 2> window_s(double end_s) const;

 private:
  std::int64_t first_ = 0;
  std::int64_t last_;
  std::array<double, 2> window_;
  Vec4 sum_sq_ = Vec4::Zero();
  std::int64_t samples_ = 0;
};

/// TrackingRmse over recorded rows: times `t_s` (each a whole number of steps dt_s), true states
/// (rows x 13, row-major) and reference [x, y, z, yaw] (rows x 4, row-major).
Vec4 tracking_rmse(const double* t_s, const double* states, const double* references,
                   std::int64_t rows, double dt_s, std::optional<std::array<double, 2>> window_s);

}  // namespace dronetwin
