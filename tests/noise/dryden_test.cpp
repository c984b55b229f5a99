// Dryden turbulence (noise/dryden.hpp): the MIL-F-8785C scales at the form's reference heights,
// spectra that integrate to the variances, and a long generated record whose variances and
// Welch power spectral densities match the Dryden spectra within their statistical error.

#include "dronetwin/noise/dryden.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <string>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

constexpr double kFoot = 0.3048;

TEST(Dryden, ScalesAtTheFormsReferenceHeights) {
  // At 1000 ft, 0.177 + 0.000823 h = 1: every scale is h and every intensity 0.1 W20.
  const DrydenScales top = dryden_low_altitude(1000.0 * kFoot, 10.0);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(top.length_m[k], 1000.0 * kFoot, 1e-9);
    EXPECT_NEAR(top.sigma_m_s[k], 1.0, 1e-12);
  }
  // Moderate: W20 = 30 kt, sigma_w = 3 kt = 1.5433 m/s at any height.
  EXPECT_NEAR(dryden_low_altitude(50.0, TurbulenceSeverity::kModerate).sigma_m_s[2],
              3.0 * 1852.0 / 3600.0, 1e-12);
  // Below 10 ft the 10 ft values hold: L_w = 10 ft, L_u = 10 / 0.18523^1.2 ft.
  const DrydenScales low = dryden_low_altitude(1.0, 10.0);
  EXPECT_NEAR(low.length_m[2], 10.0 * kFoot, 1e-12);
  EXPECT_NEAR(low.length_m[0], 10.0 / std::pow(0.18523, 1.2) * kFoot, 1e-9);
  EXPECT_NEAR(low.sigma_m_s[0], 1.0 / std::pow(0.18523, 0.4), 1e-12);
  EXPECT_EQ(dryden_low_altitude(-3.0, 10.0).length_m, low.length_m);
  EXPECT_THROW((void)dryden_low_altitude(std::nan(""), 10.0), InvalidArgument);
  EXPECT_THROW((void)dryden_low_altitude(10.0, -1.0), InvalidArgument);
}

TEST(Dryden, SpectraIntegrateToTheVariances) {
  const DrydenScales s = dryden_low_altitude(3.0, TurbulenceSeverity::kSevere);
  const double V = 10.0;
  // Substitute omega = (V / L) tan(theta): the integrand stays smooth on [0, pi/2).
  for (int k = 0; k < 3; ++k) {
    const double scale = V / s.length_m[k];
    double sum = 0.0;
    const int n = 200000;
    for (int i = 0; i < n; ++i) {
      const double theta = (i + 0.5) * (0.5 * std::numbers::pi / n);
      const double omega = scale * std::tan(theta);
      const double d_omega = scale / (std::cos(theta) * std::cos(theta));
      sum += dryden_psd(s, V, omega)[k] * d_omega * (0.5 * std::numbers::pi / n);
    }
    EXPECT_NEAR(sum, s.sigma_m_s[k] * s.sigma_m_s[k], 1e-6 * s.sigma_m_s[k] * s.sigma_m_s[k])
        << "component " << k;
  }
}

// In-place radix-2 FFT.
void fft(std::vector<std::complex<double>>& a) {
  const std::size_t n = a.size();
  for (std::size_t i = 1, j = 0; i < n; ++i) {
    std::size_t bit = n >> 1;
    for (; j & bit; bit >>= 1) j ^= bit;
    j ^= bit;
    if (i < j) std::swap(a[i], a[j]);
  }
  for (std::size_t len = 2; len <= n; len <<= 1) {
    const double angle = -2.0 * std::numbers::pi / static_cast<double>(len);
    const std::complex<double> wl(std::cos(angle), std::sin(angle));
    for (std::size_t i = 0; i < n; i += len) {
      std::complex<double> w(1.0);
      for (std::size_t j = 0; j < len / 2; ++j) {
        const std::complex<double> u = a[i + j], v = a[i + j + len / 2] * w;
        a[i + j] = u + v;
        a[i + j + len / 2] = u - v;
        w *= wl;
      }
    }
  }
}

// Welch's estimate of the one-sided PSD in omega (rad/s): Hann-windowed segments of m samples.
std::vector<double> welch(const std::vector<double>& x, std::size_t m, double dt) {
  std::vector<double> window(m), psd(m / 2 + 1, 0.0);
  double w2 = 0.0;
  for (std::size_t n = 0; n < m; ++n) {
    window[n] = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * static_cast<double>(n) /
                                     static_cast<double>(m));
    w2 += window[n] * window[n];
  }
  const std::size_t segments = x.size() / m;
  std::vector<std::complex<double>> a(m);
  for (std::size_t s = 0; s < segments; ++s) {
    for (std::size_t n = 0; n < m; ++n) a[n] = window[n] * x[s * m + n];
    fft(a);
    for (std::size_t k = 0; k <= m / 2; ++k)
      psd[k] += dt * std::norm(a[k]) / (std::numbers::pi * w2) / static_cast<double>(segments);
  }
  return psd;
}

TEST(Dryden, GeneratedGustsHaveTheDrydenVariancesAndSpectra) {
  // 3 m above the ground (the 10 ft scales), severe, 10 m/s through the air, 50 Hz, 2^21 samples
  // (11.6 h): per component about 9 000 correlation times.
  const DrydenScales s = dryden_low_altitude(3.0, TurbulenceSeverity::kSevere);
  const double V = 10.0, dt = 0.02;
  const std::size_t n = std::size_t{1} << 21, m = 4096;
  Random rng(20261204);
  DrydenState state = dryden_start(rng);
  std::vector<std::vector<double>> g(3, std::vector<double>(n));
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 gust = dryden_step(state, s, V, dt, rng);
    for (int k = 0; k < 3; ++k) g[static_cast<std::size_t>(k)][i] = gust[k];
  }
  for (int k = 0; k < 3; ++k) {
    const std::vector<double>& x = g[static_cast<std::size_t>(k)];
    double mean = 0.0, var = 0.0;
    for (double v : x) mean += v / static_cast<double>(n);
    for (double v : x) var += (v - mean) * (v - mean) / static_cast<double>(n);
    const double sigma2 = s.sigma_m_s[k] * s.sigma_m_s[k];
    // Relative error of a variance over N / (2 T / dt) independent stretches: sqrt(2 / N_eff).
    const double tau = s.length_m[k] / V;
    const double rel = std::sqrt(2.0 / (static_cast<double>(n) * dt / (2.0 * tau)));
    EXPECT_NEAR(var / sigma2, 1.0, 4.0 * rel) << "component " << k;
    RecordProperty("variance_ratio_" + std::to_string(k), std::to_string(var / sigma2));

    // Bands of +50 % in omega from 0.5 to 20 rad/s (Nyquist 157 rad/s: aliasing below 1 %).
    const std::vector<double> psd = welch(x, m, dt);
    const double d_omega = 2.0 * std::numbers::pi / (static_cast<double>(m) * dt);
    const double segments = static_cast<double>(n / m);
    double worst = 0.0;
    for (double lo = 0.5; lo < 20.0; lo *= 1.5) {
      double measured = 0.0, expected = 0.0;
      int bins = 0;
      for (std::size_t b = 1; b < psd.size(); ++b) {
        const double omega = static_cast<double>(b) * d_omega;
        if (omega < lo || omega >= 1.5 * lo) continue;
        measured += psd[b];
        expected += dryden_psd(s, V, omega)[k];
        ++bins;
      }
      ASSERT_GT(bins, 0);
      // A band's mean of bins x segments periodogram values: relative error 1 / sqrt of that
      // (Hann-windowed bins overlap: counted as half as many), plus 2 % for the window's bias.
      const double sigma = std::sqrt(2.0 / (bins * segments));
      const double ratio = measured / expected;
      EXPECT_NEAR(ratio, 1.0, 4.0 * sigma + 0.02) << "component " << k << ", band " << lo;
      worst = std::max(worst, std::abs(ratio - 1.0));
    }
    RecordProperty("psd_worst_band_error_" + std::to_string(k), std::to_string(worst));
  }
}

TEST(Dryden, TheSameSeedGivesTheSameGusts) {
  const DrydenScales s = dryden_low_altitude(2.0, TurbulenceSeverity::kLight);
  Random a(5), b(5);
  DrydenState sa, sb;
  for (int i = 0; i < 1000; ++i)
    ASSERT_EQ(dryden_step(sa, s, 3.0, 0.001, a), dryden_step(sb, s, 3.0, 0.001, b));
  // Hovering (airspeed 0): advected at kDrydenMinAirspeed_m_s, never NaN.
  for (int i = 0; i < 1000; ++i) ASSERT_TRUE(dryden_step(sa, s, 0.0, 0.001, a).allFinite());
}

}  // namespace
}  // namespace dronetwin
