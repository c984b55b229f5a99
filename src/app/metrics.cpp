// Tracking metrics (metrics.hpp).
#include "dronetwin/app/metrics.hpp"

#include <cmath>
#include <limits>
#include <numbers>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

TrackingRmse::TrackingRmse(double dt_s, std::optional<std::array<double, 2>> window_s)
    : last_(std::numeric_limits<std::int64_t>::max()),
      window_{0.0, std::numeric_limits<double>::infinity()} {
  require(std::isfinite(dt_s) && dt_s > 0.0, "tracking RMSE: dt_s: expected > 0, got ", dt_s);
  if (window_s) {
    const auto [t0, t1] = *window_s;
    require(std::isfinite(t0) && t0 >= 0.0 && !(t1 <= t0), "tracking RMSE: window [", t0, ", ", t1,
            "] s: expected 0 <= t0 < t1");
    first_ = static_cast<std::int64_t>(std::ceil(t0 / dt_s - 1e-9));
    const double last = std::floor(t1 / dt_s + 1e-9);
    last_ = last < 9e18 ? static_cast<std::int64_t>(last) : last_;
    window_ = {t0, t1};
  }
}

void TrackingRmse::add(std::int64_t step, const StateVector& x, const ReferencePoint& r) {
  add(step, x, r.position_m, r.yaw_rad);
}

void TrackingRmse::add(std::int64_t step, const StateVector& x, const Vec3& position_m,
                       double yaw_rad) {
  if (step < first_ || step > last_) return;
  const Vec3 e_p = position_m - x.segment<3>(state_index::kPosition);
  const double yaw = math::to_euler(Vec4(x.segment<4>(state_index::kQuaternion)))[2];
  const double e_yaw = std::remainder(yaw_rad - yaw, 2.0 * std::numbers::pi);
  sum_sq_.head<3>() += e_p.cwiseAbs2();
  sum_sq_[3] += e_yaw * e_yaw;
  ++samples_;
}

Vec4 TrackingRmse::rmse() const {
  if (samples_ == 0) return Vec4::Constant(std::numeric_limits<double>::quiet_NaN());
  return (sum_sq_ / static_cast<double>(samples_)).cwiseSqrt();
}

std::array<double, 2> TrackingRmse::window_s(double end_s) const {
  return {window_[0], std::min(window_[1], end_s)};
}

Vec4 tracking_rmse(const double* t_s, const double* states, const double* references,
                   std::int64_t rows, double dt_s, std::optional<std::array<double, 2>> window_s) {
  TrackingRmse m(dt_s, window_s);
  for (std::int64_t i = 0; i < rows; ++i) {
    require(std::isfinite(t_s[i]), "tracking RMSE: t[", i, "] is not finite");
    const StateVector x = Eigen::Map<const StateVector>(states + i * kStateSize);
    const double* r = references + 4 * i;
    m.add(std::llround(t_s[i] / dt_s), x, Vec3(r[0], r[1], r[2]), r[3]);
  }
  return m.rmse();
}

}  // namespace dronetwin
