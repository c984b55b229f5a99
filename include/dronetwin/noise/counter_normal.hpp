#pragma once
// Counter-based normal streams: the n-th draw of a stream is a pure function of (key, n), so
// many vehicles can draw their noise in any grouping, order or thread and get the same numbers.
// The batched simulator's OU noise uses one stream per lane (key from the seed and the lane).
//
//   const std::uint64_t key = counter_stream_key(seed, lane);
//   double xi = counter_normal(key, step * kCounterDrawsPerStep + j);   // any n, any order
//
// Bits: draw n of stream `key` is splitmix64's output at state key + (n + 1) * golden, i.e. the
// splitmix64 sequence started at `key` and read at position n (a Weyl sequence through a
// bijective mixer, which passes BigCrush). Keys are themselves mixed from (seed, stream id), so
// two streams meet only if their starting points fall within a run's draw count of each other on
// a 2^64 cycle.
//
// Normal: the ziggurat of noise/random.hpp, whose first candidate takes those 64 bits. About 97 %
// of draws end there (one multiply, two table reads); the rest continue with a xoshiro256++
// generator seeded from the bits (Random::normal_from), still a function of (key, n) alone.
// counter_normals_pack() is the same for W streams and N draws at once: the common case in SIMD,
// the rest lane by lane, so every lane equals counter_normal() bit for bit.

#include <array>
#include <cmath>
#include <cstdint>

#include "dronetwin/core/simd.hpp"
#include "dronetwin/noise/random.hpp"

namespace dronetwin {

/// Counter slots reserved per physics step of a stream: the state noise draws 0-12, the batch's
/// derivative noise 16-28.
inline constexpr std::uint64_t kCounterDrawsPerStep = 32;

/// Key of stream `stream` under `seed`.
inline std::uint64_t counter_stream_key(std::uint64_t seed, std::uint64_t stream) {
  return Random::mix64(Random::mix64(seed + Random::kGolden) ^ (stream * 0xd1342543de82ef95ULL));
}

/// 64 uniform bits: draw n of stream `key`.
inline std::uint64_t counter_bits(std::uint64_t key, std::uint64_t n) {
  return Random::mix64(key + (n + 1) * Random::kGolden);
}

/// The normal of 64 counter bits: the ziggurat's first candidate from them and, for the rare
/// candidate outside its rectangle, the rest from a generator seeded with them.
inline double normal_of_counter_bits(std::uint64_t bits) {
  Random more(bits ^ 0x6a09e667f3bcc909ULL);
  return Random::normal_from(bits, more);
}

/// Standard normal: draw n of stream `key`.
inline double counter_normal(std::uint64_t key, std::uint64_t n) {
  return normal_of_counter_bits(counter_bits(key, n));
}

/// The lane-draws of counter_normals_pack whose first candidate left the ziggurat's rectangle
/// (2.8 % of them: the top layer always does, the others near their edge), finished lane by lane.
/// Out of line on purpose: the batch's flattened step (DRONETWIN_FLATTEN) would otherwise inline
/// the wedge, the tail and their exp and log into its hot loop.
template <int W, std::size_t N>
[[gnu::noinline]] void finish_outside_draws(
    const std::array<Pack<std::uint64_t, W>, N>& bits,
    const std::array<typename Pack<double, W>::mask_type, N>& inside,
    std::array<Pack<double, W>, N>& out) {
  for (std::size_t j = 0; j < N; ++j) {
    auto outside = !inside[j];
    const int count = stdx::popcount(outside);
    for (int k = 0; k < count; ++k) {
      const int l = stdx::find_first_set(outside);
      outside[l] = false;
      out[j][l] = normal_of_counter_bits(bits[j][l]);
    }
  }
}

/// Draws first[l] + j, j = 0 .. N-1, of W streams at once: out[j] lane l is
/// counter_normal(key[l], first[l] + j), bit for bit. The N candidates are formed together and the
/// rare lanes that leave the ziggurat's rectangle are finished afterwards, lane by lane, so the
/// common path has no branch per draw.
template <int W, std::size_t N>
inline void counter_normals_pack(const Pack<std::uint64_t, W>& key,
                                 const Pack<std::uint64_t, W>& first,
                                 std::array<Pack<double, W>, N>& out) {
  using U = Pack<std::uint64_t, W>;
  using I = Pack<std::int64_t, W>;
  using D = Pack<double, W>;
  const Random::ZigguratTables& t = Random::ziggurat();
  // Weyl state of draw first: key + (first + 1) golden; draw first + j adds j golden.
  const U start = key + (first + U(1)) * U(Random::kGolden);
  std::array<U, N> bits;
  std::array<typename D::mask_type, N> inside;
  bool all_inside = true;
#pragma GCC unroll 16
  for (std::size_t j = 0; j < N; ++j) {
    U z = start + U(static_cast<std::uint64_t>(j) * Random::kGolden);
    z = (z ^ (z >> 30)) * U(0xbf58476d1ce4e5b9ULL);
    z = (z ^ (z >> 27)) * U(0x94d049bb133111ebULL);
    bits[j] = z ^ (z >> 31);
    // The ziggurat's first candidate (Random::normal_from).
    const U layer = bits[j] & U(127);
    const D u = stdx::static_simd_cast<D>(stdx::static_simd_cast<I>(bits[j] >> 11) -
                                          I(std::int64_t{1} << 52)) *
                D(0x1.0p-52);
    const D edge([&](auto l) { return t.x[static_cast<std::size_t>(layer[l])]; });
    const D ratio([&](auto l) { return t.ratio[static_cast<std::size_t>(layer[l])]; });
    out[j] = u * edge;
    inside[j] = stdx::abs(u) < ratio;
    all_inside = all_inside && stdx::all_of(inside[j]);
  }
  if (!all_inside) finish_outside_draws<W, N>(bits, inside, out);
}

}  // namespace dronetwin
