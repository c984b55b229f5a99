#pragma once
// Input shaping for a slung payload (docs/payload.md): the reference a position controller flies
// is convolved with a train of impulses that cancels the swing it would excite (the zero-vibration
// (ZV) shaper of Singer and Seering, J. Dyn. Sys. Meas. Control 112(1), 1990, used for slung
// loads by Bisgaard, la Cour-Harbo and Bendtsen, Control Eng. Practice 2010).
//
// A lightly damped mode s = -zeta w0 +- i w_d leaves no residual oscillation after the two
// impulses 1 / (1 + K) at 0 and K / (1 + K) at pi / w_d, K = exp(-zeta pi / sqrt(1 - zeta^2)).
// For several modes the shapers are convolved (2^n impulses).
//
// The modes are those of the horizontal motion of a vehicle under a PD position loop with a
// payload on a tether, linearised about hover (one axis; x = vehicle, x_r = payload - vehicle):
//   m_Q x''  = -K_p x - K_d x' + (m_L g / l) x_r        (the cable's pull, tension m_L g)
//   x_r''    = -(g / l) x_r - x''
// Two modes, both oscillatory for the SE(3) gains of se3.yaml with the thesis payload.

#include <array>
#include <cmath>
#include <complex>
#include <numbers>

#include <Eigen/Eigenvalues>

#include "dronetwin/core/types.hpp"

namespace dronetwin {

struct ShaperImpulse {
  double amplitude = 1.0;
  double delay_s = 0.0;
};

/// Up to two convolved ZV shapers: `count` impulses, amplitudes summing to 1.
struct InputShaper {
  std::array<ShaperImpulse, 4> impulses{};
  int count = 1;
};

/// The oscillatory modes (Im > 0) of the linearised vehicle-payload pair under the PD loop; at
/// most two. `count` says how many.
struct SwingModes {
  std::array<std::complex<double>, 2> poles{};
  int count = 0;
};

inline SwingModes slung_payload_swing_modes(double vehicle_mass_kg, double payload_mass_kg,
                                            double tether_length_m, double gravity_m_s2,
                                            double position_p, double position_d) {
  const double m = vehicle_mass_kg, g = gravity_m_s2, l = tether_length_m;
  // Row of the vehicle's acceleration over (x, x', x_r, x_r').
  const Eigen::RowVector4d a(-position_p / m, -position_d / m, payload_mass_kg * g / (l * m), 0.0);
  Eigen::Matrix4d A = Eigen::Matrix4d::Zero();
  A(0, 1) = 1.0;
  A(2, 3) = 1.0;
  A.row(1) = a;
  A.row(3) = -a;
  A(3, 2) -= g / l;
  const Eigen::EigenSolver<Eigen::Matrix4d> solver(A, false);
  SwingModes modes;
  for (int i = 0; i < 4 && modes.count < 2; ++i) {
    const std::complex<double> s = solver.eigenvalues()[i];
    if (s.imag() > 0.0) modes.poles[static_cast<std::size_t>(modes.count++)] = s;
  }
  return modes;
}

/// The ZV shaper of every mode of `modes`, convolved (impulses ordered as built, not by delay).
inline InputShaper zv_shaper(const SwingModes& modes) {
  InputShaper shaper;
  for (int k = 0; k < modes.count; ++k) {
    const std::complex<double> s = modes.poles[static_cast<std::size_t>(k)];
    const double zeta = -s.real() / std::abs(s);
    const double K = std::exp(-zeta * std::numbers::pi / std::sqrt(1.0 - zeta * zeta));
    const double half_period_s = std::numbers::pi / s.imag();
    const int n = shaper.count;
    for (int j = 0; j < n; ++j) {
      ShaperImpulse& first = shaper.impulses[static_cast<std::size_t>(j)];
      ShaperImpulse& second = shaper.impulses[static_cast<std::size_t>(n + j)];
      second = {first.amplitude * K / (1.0 + K), first.delay_s + half_period_s};
      first.amplitude /= 1.0 + K;
    }
    shaper.count = 2 * n;
  }
  return shaper;
}

}  // namespace dronetwin
