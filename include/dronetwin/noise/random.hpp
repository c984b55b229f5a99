#pragma once
// Seeded random numbers whose streams do not depend on the standard library (its distributions
// are not specified bit-for-bit, so we implement our own). next_u64() and uniform() are identical
// on every platform; normal() is too wherever std::exp/log/sqrt round alike (glibc on x86-64 and
// aarch64 do), since the ziggurat tables and its rare wedge/tail branches use them.
//
//   Random rng(42);
//   double n = rng.normal();     // N(0, 1)
//
// Generator: xoshiro256++ (Blackman & Vigna), seeded through splitmix64. Normals: the ziggurat
// method of Marsaglia & Tsang (2000) with 128 layers; the layer tables are computed once (they
// are constants, not shared mutable state). Copying a Random copies its stream.

#include <array>
#include <cmath>
#include <cstdint>

namespace dronetwin {

class Random {
 public:
  explicit Random(std::uint64_t seed = 0) { reseed(seed); }

  void reseed(std::uint64_t seed) {
    std::uint64_t s = seed;
    for (auto& word : state_) word = splitmix64(s);
  }

  /// Next 64 uniformly distributed bits.
  std::uint64_t next_u64() {
    const std::uint64_t result = rotl(state_[0] + state_[3], 23) + state_[0];
    const std::uint64_t t = state_[1] << 17;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= t;
    state_[3] = rotl(state_[3], 45);
    return result;
  }

  /// Uniform on [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }

  /// Standard normal sample.
  double normal() { return normal_from(next_u64(), *this); }

  /// The ziggurat's layer tables (constants): right edges x, densities f = exp(-x^2/2) there,
  /// and ratio[i] = x[i+1]/x[i], the part of layer i wholly inside the density.
  static constexpr int kLayers = 128;
  struct ZigguratTables {
    std::array<double, kLayers + 1> x{};
    std::array<double, kLayers + 1> f{};
    std::array<double, kLayers> ratio{};
  };
  static const ZigguratTables& ziggurat() { return tables(); }

  /// A standard normal whose first candidate comes from `bits` (64 uniform bits: the low 7 pick
  /// the layer, the top 53 the signed uniform) and whose rare second chances (a wedge, the tail,
  /// a rejection) draw from `more`. normal() is normal_from(next_u64(), *this); the counter-based
  /// streams of noise/counter_normal.hpp pass bits of their own and a generator seeded from them.
  static double normal_from(std::uint64_t bits, Random& more) {
    const auto& z = tables();
    for (;;) {
      const int layer = static_cast<int>(bits & 127u);
      // Signed 53-bit uniform in (-1, 1) from the remaining bits.
      const double u =
          static_cast<double>(static_cast<std::int64_t>(bits >> 11) - (std::int64_t{1} << 52)) *
          0x1.0p-52;
      const double x = u * z.x[layer];
      if (std::abs(u) < z.ratio[layer]) return x;  // inside the rectangle: the common case
      if (layer == 0) return more.tail(u < 0);
      // Wedge between two layers: accept with the exact density.
      const double y0 = z.f[layer], y1 = z.f[layer + 1];
      if (y1 + (y0 - y1) * more.uniform() < std::exp(-0.5 * x * x)) return x;
      bits = more.next_u64();
    }
  }

  /// splitmix64's output function (a bijective 64-bit mixer).
  static std::uint64_t mix64(std::uint64_t z) {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  /// splitmix64's increment (the golden-ratio Weyl constant).
  static constexpr std::uint64_t kGolden = 0x9e3779b97f4a7c15ULL;

 private:
  static constexpr double kR = 3.442619855899;          // right edge of the base layer
  static constexpr double kArea = 9.91256303526217e-3;  // area of each layer (unnormalised pdf)

  // x[0] is the base layer's width A/f(R): the base includes the tail as a virtual rectangle.
  using Tables = ZigguratTables;

  static const Tables& tables() {
    static const Tables t = [] {
      Tables b;
      const double fR = std::exp(-0.5 * kR * kR);
      b.x[0] = kArea / fR;  // the base layer includes the tail, as a virtual rectangle
      b.x[1] = kR;
      for (int i = 2; i < kLayers; ++i) {
        b.x[i] = std::sqrt(-2.0 *
                           std::log(kArea / b.x[i - 1] + std::exp(-0.5 * b.x[i - 1] * b.x[i - 1])));
      }
      b.x[kLayers] = 0.0;
      for (int i = 0; i <= kLayers; ++i) b.f[i] = std::exp(-0.5 * b.x[i] * b.x[i]);
      b.f[0] = fR;
      for (int i = 0; i < kLayers; ++i) b.ratio[i] = b.x[i + 1] / b.x[i];
      return b;
    }();
    return t;
  }

  double tail(bool negative) {
    // Marsaglia's exact sampling of the normal tail beyond R.
    for (;;) {
      const double a = -std::log(1.0 - uniform()) / kR;
      const double b = -std::log(1.0 - uniform());
      if (2.0 * b > a * a) return negative ? -(kR + a) : kR + a;
    }
  }

  static std::uint64_t rotl(std::uint64_t v, int k) { return (v << k) | (v >> (64 - k)); }
  static std::uint64_t splitmix64(std::uint64_t& s) { return mix64(s += kGolden); }

  std::array<std::uint64_t, 4> state_{};
};

}  // namespace dronetwin
