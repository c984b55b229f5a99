#pragma once
// The wind a vehicle flies in (docs/wind.md): the mean wind (Environment::wind_W_m_s), optionally
// sheared with height by the logarithmic law of MIL-F-8785C, plus discrete 1 - cos gusts at given
// times, plus Dryden turbulence (noise/dryden.hpp) along the mean wind's axes. The settings are
// plain data; the turbulence's state and random stream belong to whoever steps it (SimData).
//
//   WindSettings w;  w.shear.enabled = true;
//   w.turbulence = TurbulenceSettings::of(TurbulenceSeverity::kModerate);
//   const Vec3 mean = mean_wind_at(env.wind_W_m_s, w.shear, height_m);   // sheared
//   const Vec3 total = mean + gust_at(w, t_s) + turbulence_axes(mean) * dryden_gust;
//
// Shear: W(h) = W_ref ln(h / z0) / ln(h_ref / z0), h_ref = 20 ft (6.096 m) where the mean wind
// is given, z0 = 0.15 ft (0.04572 m, MIL-F-8785C's value for category C flight), and heights below
// 2 z0 held at 2 z0 (the law has no meaning in the roughness layer).
// Gust: the full-wave 1 - cos shape, (A / 2) (1 - cos(2 pi (t - t0) / D)) for t0 <= t <= t0 + D.

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "dronetwin/core/types.hpp"
#include "dronetwin/noise/dryden.hpp"

namespace dronetwin {

struct WindShear {
  bool enabled = false;
  double reference_height_m = 6.096;    ///< where the mean wind holds (20 ft)
  double roughness_length_m = 0.04572;  ///< z0 (0.15 ft)
};

struct Gust {
  double start_s = 0.0;
  double duration_s = 1.0;
  Vec3 amplitude_W_m_s = Vec3::Zero();  ///< the peak, reached at start_s + duration_s / 2
};

struct TurbulenceSettings {
  bool enabled = false;
  /// W20 of the Dryden scales (noise/dryden.hpp): 15, 30, 45 kt for light, moderate, severe.
  double wind_at_20ft_m_s = 0.0;

  static TurbulenceSettings of(TurbulenceSeverity severity) {
    return {true, dryden_wind_at_20ft_m_s(severity)};
  }
};

/// Gusts live in a fixed array so that the settings stay plain data (copyable as bytes).
inline constexpr int kMaxGusts = 8;

/// What varies the wind around the mean: shear, gusts, turbulence. Default: nothing (constant
/// wind, as before the wind field existed). validate(SimConfig) checks the values.
struct WindSettings {
  WindShear shear;
  TurbulenceSettings turbulence;
  std::array<Gust, kMaxGusts> gusts{};
  int num_gusts = 0;

  /// True when the wind at the vehicle can differ from the mean wind.
  bool varies() const { return shear.enabled || turbulence.enabled || num_gusts > 0; }
};

/// The mean wind at `height_m` above the ground, `mean_W_m_s` holding at the shear's reference
/// height.
inline Vec3 mean_wind_at(const Vec3& mean_W_m_s, const WindShear& shear, double height_m) {
  if (!shear.enabled) return mean_W_m_s;
  const double z0 = shear.roughness_length_m;
  const double h = std::max(height_m, 2.0 * z0);
  return mean_W_m_s * (std::log(h / z0) / std::log(shear.reference_height_m / z0));
}

/// The sum of the gusts at time `t_s`.
inline Vec3 gust_at(const WindSettings& w, double t_s) {
  Vec3 sum = Vec3::Zero();
  for (int i = 0; i < w.num_gusts; ++i) {
    const Gust& g = w.gusts[static_cast<std::size_t>(i)];
    const double x = (t_s - g.start_s) / g.duration_s;
    if (x >= 0.0 && x <= 1.0)
      sum += 0.5 * (1.0 - std::cos(2.0 * std::numbers::pi * x)) * g.amplitude_W_m_s;
  }
  return sum;
}

/// Columns: the turbulence's u (along the mean wind's horizontal direction; world x in calm
/// air), v (to its left) and w (up) axes in the world frame.
inline Mat3 turbulence_axes(const Vec3& mean_W_m_s) {
  Vec3 u(mean_W_m_s.x(), mean_W_m_s.y(), 0.0);
  const double n = u.norm();
  u = n > 1e-9 ? Vec3(u / n) : Vec3(Vec3::UnitX());
  Mat3 axes;
  axes.col(0) = u;
  axes.col(1) = Vec3::UnitZ().cross(u);
  axes.col(2) = Vec3::UnitZ();
  return axes;
}

}  // namespace dronetwin
