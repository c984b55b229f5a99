#pragma once
// SIMD packs: W vehicles side by side in one scalar, so the force kernel written for `double`
// steps W vehicles per instruction when instantiated with Pack<double, W>.
//
//   using P = Pack<double, 4>;                       // four vehicles, one AVX register (or two
//   SSE) P mass = pack_from<P>([&](int lane) { return masses[lane]; }); Vector3<P> v = ...; //
//   Eigen works on packs as on doubles double m2 = lane(mass, 2);
//
// The type is GCC 12's std::experimental::simd (Parallelism TS v2, in libstdc++ since GCC 11):
// it is standard C++, needs no extra package, compiles to SSE2 on a portable x86-64 build and to
// AVX2/AVX-512 with -march=native, and supports the per-lane math the model needs (abs, exp, min,
// max, masked selects). Eigen's own packet types are internal API; a hand-written pack would be
// the same code again. The fixed_size ABI is used so a pack's width is the number of lanes asked
// for, independent of the machine.
//
// What this header adds for Eigen: NumTraits (so Matrix<Pack, ...> is a valid matrix type) and
// ScalarBinaryOpTraits with the lane type (so a pack matrix times a shared double constant works
// without first broadcasting the constant), plus scalar::select for a pack mask (core/scalar.hpp).
//
// Trap: comparisons of packs return masks, not bools; code templated on the scalar must use
// scalar::select / scalar::max (core/scalar.hpp) instead of `?:` and std::max.

#include <Eigen/Core>
#include <experimental/simd>
#include <limits>
#include <type_traits>

#include "dronetwin/core/scalar.hpp"

namespace dronetwin {

namespace stdx = std::experimental;

/// W lanes of T (float or double), one vehicle per lane.
template <class T, int W>
using Pack = stdx::fixed_size_simd<T, W>;

/// Lane `i` of a pack.
template <class T, class Abi>
inline T lane(const stdx::simd<T, Abi>& p, int i) {
  return p[static_cast<std::size_t>(i)];
}

/// A pack whose lane i is f(i).
template <class P, class F>
inline P pack_from(F&& f) {
  return P([&](auto i) { return static_cast<typename P::value_type>(f(static_cast<int>(i))); });
}

/// f applied to each lane of x (f(x) for a plain number): for the library functions a pack's
/// own math does not reproduce bit for bit (atan2, asin, sin, cos of glibc), so a lane equals the
/// scalar code that calls them.
template <class S, class F>
inline S lanewise(F&& f, const S& x) {
  if constexpr (std::is_arithmetic_v<S>) {
    return f(x);
  } else {
    return S([&](auto l) { return f(x[l]); });
  }
}
template <class S, class F>
inline S lanewise(F&& f, const S& x, const S& y) {
  if constexpr (std::is_arithmetic_v<S>) {
    return f(x, y);
  } else {
    return S([&](auto l) { return f(x[l], y[l]); });
  }
}

namespace scalar {

/// Per-lane `mask ? a : b`.
template <class T, class Abi>
struct Selector<stdx::simd_mask<T, Abi>> {
  static stdx::simd<T, Abi> pick(const stdx::simd_mask<T, Abi>& mask, const stdx::simd<T, Abi>& a,
                                 const stdx::simd<T, Abi>& b) {
    stdx::simd<T, Abi> out = b;
    stdx::where(mask, out) = a;
    return out;
  }
};

/// A pack is zero when every lane is.
template <class T, class Abi>
struct ZeroTest<stdx::simd<T, Abi>> {
  static bool test(const stdx::simd<T, Abi>& x) { return stdx::all_of(x == T(0)); }
};

}  // namespace scalar
}  // namespace dronetwin

namespace Eigen {

template <class T, class Abi>
struct NumTraits<std::experimental::simd<T, Abi>> : GenericNumTraits<T> {
  using P = std::experimental::simd<T, Abi>;
  using Real = P;
  using NonInteger = P;
  using Literal = P;
  using Nested = P;
  enum {
    IsComplex = 0,
    IsInteger = 0,
    IsSigned = 1,
    RequireInitialization = 1,
    ReadCost = 1,
    AddCost = 1,
    MulCost = 1
  };
  static P epsilon() { return P(std::numeric_limits<T>::epsilon()); }
  static P dummy_precision() { return P(NumTraits<T>::dummy_precision()); }
  static P highest() { return P(std::numeric_limits<T>::max()); }
  static P lowest() { return P(std::numeric_limits<T>::lowest()); }
  static int digits10() { return std::numeric_limits<T>::digits10; }
};

#if defined(__clang__)
namespace internal {
/// clang only: a fixed-size matrix of packs asks for no extra alignment. Its elements already carry
/// theirs (32 or 64 bytes), and Eigen's default request below that (16 bytes with SSE) is an error
/// for clang ("requested alignment is less than minimum alignment"). GCC accepts the request and
/// keeps Eigen's default: with this specialisation GCC 12 compiled the flattened pack step for over
/// 15 minutes and 5 GB (a CI run) instead of half a minute.
template <class T, class Abi, int Size>
struct compute_default_alignment<std::experimental::simd<T, Abi>, Size> {
  enum { value = 0 };
};
// (Dynamic sizes keep Eigen's heap alignment; this one only settles which rule applies.)
template <class T, class Abi>
struct compute_default_alignment<std::experimental::simd<T, Abi>, Dynamic> {
  enum { value = EIGEN_MAX_ALIGN_BYTES };
};
}  // namespace internal
#endif

template <class T, class Abi, class BinaryOp>
struct ScalarBinaryOpTraits<std::experimental::simd<T, Abi>, T, BinaryOp> {
  using ReturnType = std::experimental::simd<T, Abi>;
};
template <class T, class Abi, class BinaryOp>
struct ScalarBinaryOpTraits<T, std::experimental::simd<T, Abi>, BinaryOp> {
  using ReturnType = std::experimental::simd<T, Abi>;
};

}  // namespace Eigen
