// Thrust-stand fit (include/dronetwin/adapters/thrust_stand_fit.hpp).
#include "dronetwin/adapters/thrust_stand_fit.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

double SpeedMap::speed_rad_s(double pwm, double vbat_V) const {
  if (!(pwm > 0.0)) return 0.0;
  return std::max(0.0, a_rad_s_per_V * (pwm / 65535.0 * vbat_V) + b_rad_s);
}

ThrustStandFit fit_thrust_stand(const ThrustStandData& d, const ThrustStandOptions& options) {
  const std::size_t n = d.rows();
  require(d.weight_g.size() == n && d.vbat_V.size() == n && d.rpm[0].size() == n &&
              d.rpm[1].size() == n && d.rpm[2].size() == n && d.rpm[3].size() == n,
          d.source, ": thrust-stand columns have different lengths");
  ThrustStandFit fit;
  fit.source = d.source;
  constexpr double kRpmToRadS = 2.0 * std::numbers::pi / 60.0;

  std::vector<std::size_t> used;
  double tare_sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const bool all_stopped =
        d.rpm[0][i] == 0 && d.rpm[1][i] == 0 && d.rpm[2][i] == 0 && d.rpm[3][i] == 0;
    const bool all_running =
        d.rpm[0][i] > 0 && d.rpm[1][i] > 0 && d.rpm[2][i] > 0 && d.rpm[3][i] > 0;
    if (d.pwm[i] == 0.0 && all_stopped) {
      tare_sum += d.weight_g[i];
      ++fit.tare_rows;
    } else if (d.pwm[i] > 0.0 && all_running) {
      used.push_back(i);
    }
  }
  require(used.size() >= 10, d.source, ": only ", used.size(),
          " rows with pwm > 0 and all four motors spinning; need at least 10");
  if (options.subtract_tare) {
    require(fit.tare_rows > 0, d.source,
            ": no rest rows (pwm = 0, all rpm = 0) to take the tare from");
    fit.tare_g = tare_sum / static_cast<double>(fit.tare_rows);
  }

  const auto m = static_cast<Eigen::Index>(used.size());
  Eigen::VectorXd w(m), thrust(m), u(m);
  std::array<double, 4> motor_sum{};
  for (Eigen::Index k = 0; k < m; ++k) {
    const std::size_t i = used[static_cast<std::size_t>(k)];
    const double rpm_mean = (d.rpm[0][i] + d.rpm[1][i] + d.rpm[2][i] + d.rpm[3][i]) / 4.0;
    for (std::size_t j = 0; j < 4; ++j) motor_sum[j] += d.rpm[j][i];
    w[k] = rpm_mean * kRpmToRadS;
    thrust[k] = (d.weight_g[i] - fit.tare_g) * options.gravity_m_s2 / 1000.0 / 4.0;
    u[k] = d.pwm[i] / 65535.0 * d.vbat_V[i];
  }
  const double all = motor_sum[0] + motor_sum[1] + motor_sum[2] + motor_sum[3];
  for (std::size_t j = 0; j < 4; ++j) fit.motor_speed_ratio[j] = 4.0 * motor_sum[j] / all;
  fit.min_speed_rad_s = w.minCoeff();
  fit.max_speed_rad_s = w.maxCoeff();
  fit.max_thrust_N = thrust.maxCoeff();

  Eigen::MatrixXd a(m, 3);
  a.col(0) = w.array().square();
  a.col(1) = w;
  a.col(2).setOnes();
  fit.thrust = fit_linear(a, thrust, {"K1", "K2", "K3"}, d.source + ": thrust curve T(w)");

  Eigen::MatrixXd b(m, 2);
  b.col(0) = u;
  b.col(1).setOnes();
  fit.speed_map_fit = fit_linear(b, w, {"a", "b"}, d.source + ": speed map w(u)");
  fit.speed_map = {fit.speed_map_fit.coefficients[0], fit.speed_map_fit.coefficients[1]};

  Eigen::MatrixXd c(m, 3);
  c.col(0) = u.array().square();
  c.col(1) = u;
  c.col(2).setOnes();
  fit.speed_map_quadratic = fit_linear(c, w, {"c2", "c1", "c0"}, d.source + ": speed map w(u^2)");
  return fit;
}

}  // namespace dronetwin
