#include "dronetwin/noise/dryden.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "dronetwin/core/error.hpp"

namespace dronetwin {

namespace {

constexpr double kFoot_m = 0.3048;
constexpr double kKnot_m_s = 1852.0 / 3600.0;

// One step of a second-order Dryden filter in unit-variance states z (see the header): the
// transition e^{-h} [[1 + h, h], [-h, 1 - h]], h = dt / T, and noise of covariance I - Phi Phi^T.
void second_order_step(std::array<double, 2>& z, double h, Random& rng) {
  const double e = std::exp(-h);
  const double z1 = e * ((1.0 + h) * z[0] + h * z[1]);
  const double z2 = e * (-h * z[0] + (1.0 - h) * z[1]);
  const double e2 = e * e;
  const double q11 = std::max(0.0, 1.0 - e2 * (1.0 + 2.0 * h + 2.0 * h * h));
  const double q22 = std::max(0.0, 1.0 - e2 * (1.0 - 2.0 * h + 2.0 * h * h));
  const double q12 = 2.0 * h * h * e2;
  const double l11 = std::sqrt(q11);
  const double l21 = l11 > 0.0 ? q12 / l11 : 0.0;
  const double l22 = std::sqrt(std::max(0.0, q22 - l21 * l21));
  const double n1 = rng.normal(), n2 = rng.normal();
  z[0] = z1 + l11 * n1;
  z[1] = z2 + l21 * n1 + l22 * n2;
}

double second_order_gust(const std::array<double, 2>& z, double sigma) {
  return 0.5 * sigma * (z[0] + std::sqrt(3.0) * z[1]);
}

}  // namespace

double dryden_wind_at_20ft_m_s(TurbulenceSeverity severity) {
  switch (severity) {
    case TurbulenceSeverity::kLight:
      return 15.0 * kKnot_m_s;
    case TurbulenceSeverity::kModerate:
      return 30.0 * kKnot_m_s;
    case TurbulenceSeverity::kSevere:
      return 45.0 * kKnot_m_s;
  }
  return 0.0;
}

DrydenScales dryden_low_altitude(double height_m, double wind_at_20ft_m_s) {
  require(std::isfinite(height_m), "Dryden turbulence: height_m: expected a finite number, got ",
          height_m);
  require(std::isfinite(wind_at_20ft_m_s) && wind_at_20ft_m_s >= 0.0,
          "Dryden turbulence: wind_at_20ft_m_s: expected a finite number >= 0, got ",
          wind_at_20ft_m_s);
  // MIL-F-8785C 3.7.3.4, in feet.
  const double h_ft = std::clamp(height_m / kFoot_m, 10.0, 1000.0);
  const double k = 0.177 + 0.000823 * h_ft;
  DrydenScales s;
  const double L_uv = h_ft / std::pow(k, 1.2) * kFoot_m;
  s.length_m = Vec3(L_uv, L_uv, h_ft * kFoot_m);
  const double sigma_w = 0.1 * wind_at_20ft_m_s;
  const double sigma_uv = sigma_w / std::pow(k, 0.4);
  s.sigma_m_s = Vec3(sigma_uv, sigma_uv, sigma_w);
  return s;
}

DrydenScales dryden_low_altitude(double height_m, TurbulenceSeverity severity) {
  return dryden_low_altitude(height_m, dryden_wind_at_20ft_m_s(severity));
}

Vec3 dryden_psd(const DrydenScales& s, double airspeed_m_s, double omega_rad_s) {
  require(airspeed_m_s > 0.0, "dryden_psd: airspeed_m_s: expected > 0, got ", airspeed_m_s);
  const double V = airspeed_m_s;
  Vec3 phi;
  const double xu = s.length_m[0] * omega_rad_s / V;
  phi[0] = s.sigma_m_s[0] * s.sigma_m_s[0] * 2.0 * s.length_m[0] / (std::numbers::pi * V) /
           (1.0 + xu * xu);
  for (int k = 1; k < 3; ++k) {
    const double x = s.length_m[k] * omega_rad_s / V;
    phi[k] = s.sigma_m_s[k] * s.sigma_m_s[k] * s.length_m[k] / (std::numbers::pi * V) *
             (1.0 + 3.0 * x * x) / ((1.0 + x * x) * (1.0 + x * x));
  }
  return phi;
}

Vec3 dryden_gust(const DrydenState& state, const DrydenScales& s) {
  return Vec3(s.sigma_m_s[0] * state.u, second_order_gust(state.v, s.sigma_m_s[1]),
              second_order_gust(state.w, s.sigma_m_s[2]));
}

Vec3 dryden_step(DrydenState& state, const DrydenScales& s, double airspeed_m_s, double dt_s,
                 Random& rng) {
  const double V = std::max(airspeed_m_s, kDrydenMinAirspeed_m_s);
  // u: first-order Gauss-Markov with correlation time L_u / V.
  const double a = std::exp(-V * dt_s / s.length_m[0]);
  state.u = a * state.u + std::sqrt(-std::expm1(-2.0 * V * dt_s / s.length_m[0])) * rng.normal();
  second_order_step(state.v, V * dt_s / s.length_m[1], rng);
  second_order_step(state.w, V * dt_s / s.length_m[2], rng);
  return dryden_gust(state, s);
}

DrydenState dryden_start(Random& rng) {
  DrydenState state;
  state.u = rng.normal();
  state.v = {rng.normal(), rng.normal()};
  state.w = {rng.normal(), rng.normal()};
  return state;
}

}  // namespace dronetwin
