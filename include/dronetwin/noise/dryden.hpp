#pragma once
// Dryden turbulence, the low-altitude form of MIL-F-8785C (sec. 3.7.3): three gust velocities
// (u along the mean wind, v across it, w vertical) as coloured noise whose spectra are the Dryden
// spectra, for a vehicle flying at airspeed V through turbulence frozen in the air (Taylor's
// hypothesis: a spatial frequency Omega is seen at omega = Omega V).
//
//   const DrydenScales s = dryden_low_altitude(2.0, TurbulenceSeverity::kModerate);
//   DrydenState state;                                    // plain data: zero gusts
//   Vec3 gust = dryden_step(state, s, airspeed_m_s, dt_s, rng);   // u, v, w in m/s
//
// Scales (h in ft, 10 <= h <= 1000; W20 the mean wind 20 ft above the ground):
//   L_w = h,  L_u = L_v = h / (0.177 + 0.000823 h)^1.2
//   sigma_w = 0.1 W20,  sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4
// with W20 = 15, 30, 45 kt for light, moderate and severe turbulence. Below 10 ft (3.05 m), where
// the form gives no values and a multirotor mostly flies, the 10 ft values hold.
//
// Spectra, one-sided in omega (rad/s), each integrating to sigma^2 over [0, inf):
//   Phi_u(omega) = sigma_u^2 (2 L_u / (pi V)) / (1 + (L_u omega / V)^2)
//   Phi_v(omega) = sigma_v^2 (L_v / (pi V)) (1 + 3 (L_v omega / V)^2) / (1 + (L_v omega / V)^2)^2
// and Phi_w as Phi_v with L_w, sigma_w.
//
// Each step is exact for the forming filters with V held over it: u is a first-order Gauss-Markov
// process (correlation exp(-V tau / L_u)); v and w are the second-order filter
// (1 + sqrt(3) T s) / (1 + T s)^2, T = L / V, whose state moves by its transition matrix and
// whose step noise has the covariance P - Phi P Phi^T of the stationary covariance P. Started at
// zero, the gusts build up over a few T; dryden_start() draws a stationary start instead.
// tests/noise/dryden_test.cpp checks the variances and the spectra against these formulas.

#include <array>

#include "dronetwin/core/types.hpp"
#include "dronetwin/noise/random.hpp"

namespace dronetwin {

enum class TurbulenceSeverity { kLight, kModerate, kSevere };

/// W20 of MIL-F-8785C: 15, 30, 45 kt in m/s.
double dryden_wind_at_20ft_m_s(TurbulenceSeverity severity);

/// Intensities and scale lengths of u, v, w.
struct DrydenScales {
  Vec3 sigma_m_s = Vec3::Zero();
  Vec3 length_m = Vec3::Ones();
};

/// The low-altitude scales at height `height_m` above the ground (clamped to 10 .. 1000 ft) for
/// the mean wind `wind_at_20ft_m_s` at 20 ft. InvalidArgument for a non-finite height or a
/// negative or non-finite wind.
DrydenScales dryden_low_altitude(double height_m, double wind_at_20ft_m_s);
DrydenScales dryden_low_altitude(double height_m, TurbulenceSeverity severity);

/// One-sided spectra of u, v, w at `omega_rad_s` for airspeed `airspeed_m_s` (> 0).
Vec3 dryden_psd(const DrydenScales& scales, double airspeed_m_s, double omega_rad_s);

/// The filters' state, each part scaled to unit stationary variance (so that a change of height
/// or airspeed between steps rescales the gusts instead of disturbing the filters): u, and the
/// two states of each of v and w. Plain data.
struct DrydenState {
  double u = 0.0;
  std::array<double, 2> v{0.0, 0.0};
  std::array<double, 2> w{0.0, 0.0};
};

/// Gust velocities (u, v, w) of `state`, m/s: sigma_u u and sigma (z1 + sqrt(3) z2) / 2.
Vec3 dryden_gust(const DrydenState& state, const DrydenScales& scales);

/// Advances `state` by `dt_s` at airspeed `airspeed_m_s` (held over the step; clamped below to
/// kDrydenMinAirspeed_m_s) and returns the new gusts. Five normal draws from `rng`.
Vec3 dryden_step(DrydenState& state, const DrydenScales& scales, double airspeed_m_s, double dt_s,
                 Random& rng);

/// A state drawn from the stationary distribution (gusts already developed), for any scales.
DrydenState dryden_start(Random& rng);

/// Below this airspeed the turbulence is advected at this speed: a hovering vehicle in calm air
/// still sees the eddies drift by (and the filters keep a finite time constant).
inline constexpr double kDrydenMinAirspeed_m_s = 0.5;

}  // namespace dronetwin
