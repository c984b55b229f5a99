// Counter-based normal streams (noise/counter_normal.hpp): the pack path equals the scalar one
// bit for bit (including the ziggurat's rare slow path), the draws are standard normal (moments,
// Kolmogorov-Smirnov against the normal CDF, the tail beyond the ziggurat's base), and neighbouring
// streams and draws are uncorrelated.

#include "dronetwin/noise/counter_normal.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <vector>

namespace dronetwin {
namespace {

std::uint64_t bits_of(double x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

TEST(CounterNormal, PacksEqualTheScalarStreamBitForBitIncludingTheSlowPath) {
  constexpr int W = 8;
  using U = Pack<std::uint64_t, W>;
  int slow = 0;
  for (std::uint64_t round = 0; round < 20000; ++round) {
    // Lanes at unrelated keys and counters, as in a batch whose lanes reset at different times.
    const U key([&](auto l) { return counter_stream_key(round % 7, round * W + l); });
    const U n([&](auto l) { return round * 16 + 3 * static_cast<std::uint64_t>(l); });
    std::array<Pack<double, W>, 1> draw;
    counter_normals_pack<W, 1>(key, n, draw);
    const Pack<double, W>& x = draw[0];
    for (int l = 0; l < W; ++l) {
      const double ref = counter_normal(key[l], n[l]);
      ASSERT_EQ(bits_of(x[l]), bits_of(ref)) << "round " << round << " lane " << l;
      // The slow path ran where the first candidate left the rectangle.
      const std::uint64_t b = counter_bits(key[l], n[l]);
      const int layer = static_cast<int>(b & 127u);
      const double u =
          static_cast<double>(static_cast<std::int64_t>(b >> 11) - (std::int64_t{1} << 52)) *
          0x1.0p-52;
      slow += !(std::abs(u) < Random::ziggurat().ratio[static_cast<std::size_t>(layer)]);
    }
  }
  // 2.8 % of 160 000 draws take it (the top layer always, 1/128 of the draws; the rest near
  // their layer's edge); the comparison above covered them.
  EXPECT_GT(slow, 1000);
}

TEST(CounterNormal, ThirteenDrawsAtOnceEqualTheScalarStream) {
  constexpr int W = 8;
  using U = Pack<std::uint64_t, W>;
  for (std::uint64_t round = 0; round < 3000; ++round) {
    const U key([&](auto l) { return counter_stream_key(round, l); });
    const U first([&](auto l) { return (round + l) * kCounterDrawsPerStep; });
    std::array<Pack<double, W>, 13> x;
    counter_normals_pack<W, 13>(key, first, x);
    for (std::size_t j = 0; j < 13; ++j)
      for (int l = 0; l < W; ++l)
        ASSERT_EQ(bits_of(x[j][l]), bits_of(counter_normal(key[l], first[l] + j)))
            << "round " << round << " draw " << j << " lane " << l;
  }
}

/// Standard normal CDF.
double phi(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

TEST(CounterNormal, DrawsAreStandardNormal) {
  constexpr int kStreams = 64, kDraws = 16000;
  std::vector<double> x;
  x.reserve(static_cast<std::size_t>(kStreams) * kDraws);
  for (int s = 0; s < kStreams; ++s) {
    const std::uint64_t key = counter_stream_key(2024, static_cast<std::uint64_t>(s));
    for (int n = 0; n < kDraws; ++n)
      x.push_back(counter_normal(key, static_cast<std::uint64_t>(n)));
  }
  const double count = static_cast<double>(x.size());
  double m1 = 0, m2 = 0, m4 = 0;
  for (double v : x) {
    m1 += v;
    m2 += v * v;
    m4 += v * v * v * v;
  }
  m1 /= count;
  m2 /= count;
  m4 /= count;
  // Sampling standard deviations: mean 1/sqrt(n), variance sqrt(2/n), fourth moment sqrt(96/n).
  EXPECT_NEAR(m1, 0.0, 5.0 / std::sqrt(count));
  EXPECT_NEAR(m2, 1.0, 5.0 * std::sqrt(2.0 / count));
  EXPECT_NEAR(m4, 3.0, 5.0 * std::sqrt(96.0 / count));

  // Kolmogorov-Smirnov: sup |F_n - Phi| below the 0.1 % critical value 1.95 / sqrt(n).
  std::sort(x.begin(), x.end());
  double d = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double f = phi(x[i]);
    d = std::max({d, static_cast<double>(i + 1) / count - f, f - static_cast<double>(i) / count});
  }
  EXPECT_LT(d, 1.95 / std::sqrt(count));

  // The tail beyond the ziggurat's base edge R = 3.4426 (drawn by its separate tail sampler).
  const double r = 3.442619855899;
  const auto beyond = std::count_if(x.begin(), x.end(), [&](double v) { return std::abs(v) > r; });
  const double expected = count * 2.0 * (1.0 - phi(r));
  EXPECT_NEAR(static_cast<double>(beyond), expected, 5.0 * std::sqrt(expected));
}

TEST(CounterNormal, NeighbouringStreamsAndDrawsAreUncorrelated) {
  constexpr int kDraws = 200000;
  const std::uint64_t a = counter_stream_key(7, 0), b = counter_stream_key(7, 1);
  const std::uint64_t c = counter_stream_key(8, 0);
  double ab = 0, ac = 0, lag1 = 0;
  double prev = counter_normal(a, 0);
  for (int n = 0; n < kDraws; ++n) {
    const auto k = static_cast<std::uint64_t>(n);
    const double xa = counter_normal(a, k);
    ab += xa * counter_normal(b, k);
    ac += xa * counter_normal(c, k);
    if (n > 0) lag1 += xa * prev;
    prev = xa;
  }
  const double tol = 5.0 / std::sqrt(static_cast<double>(kDraws));
  EXPECT_NEAR(ab / kDraws, 0.0, tol) << "lanes 0 and 1 of one seed";
  EXPECT_NEAR(ac / kDraws, 0.0, tol) << "lane 0 of seeds 7 and 8";
  EXPECT_NEAR(lag1 / (kDraws - 1), 0.0, tol) << "consecutive draws of one stream";
  EXPECT_NE(counter_stream_key(7, 1), counter_stream_key(8, 0));
}

TEST(CounterNormal, RandomNormalIsTheZigguratFromItsOwnBits) {
  // Random::normal() is normal_from(next_u64(), itself): the refactoring that lets counter
  // streams share the ziggurat kept its stream.
  Random a(99), b(99);
  for (int i = 0; i < 100000; ++i) {
    const double x = a.normal();
    const double y = Random::normal_from(b.next_u64(), b);
    ASSERT_EQ(bits_of(x), bits_of(y)) << "draw " << i;
  }
}

}  // namespace
}  // namespace dronetwin
