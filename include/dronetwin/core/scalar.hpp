#pragma once
// The few scalar operations the force kernel needs beyond + - * /, written once for every scalar
// it is instantiated with: double and float, ceres::Jet (automatic differentiation for the NMPC
// and the fits) and SIMD packs (lanes of vehicles, core/simd.hpp).
//
//   S h = scalar::max(z + dz, S(h_min));     // per lane for a pack, on the value for a Jet
//   S speed = scalar::abs(w);
//   S tau = scalar::select(ref > w, tau_rise, tau_fall);
//
// A comparison of two doubles (or two Jets, which compare their values) gives a bool; of two
// packs a mask with one bit per lane. select() takes either, so kernel code written with these
// functions has no branches on a pack's value: every lane takes its own side.
//
// Trap: `c ? a : b` and std::max do not compile for packs; use these instead in templated code.

#include <algorithm>
#include <cmath>
#include <type_traits>

namespace dronetwin::scalar {

/// How select() picks for a condition type: `?:` for bool. core/simd.hpp specialises it for pack
/// masks (a class template, so the specialisation is found wherever it is visible at
/// instantiation, unlike an overload declared after the templates below).
template <class Condition>
struct Selector {
  template <class S>
  static S pick(bool condition, const S& a, const S& b) {
    return condition ? a : b;
  }
};

/// `condition ? a : b`: a bool for double, float and Jet; per lane for a pack mask.
template <class Condition, class S>
inline S select(const Condition& condition, const S& a, const S& b) {
  return Selector<Condition>::pick(condition, a, b);
}

/// How is_zero() tests a scalar: the value is 0 (and, for a Jet, every derivative is 0).
/// core/simd.hpp specialises it for packs (every lane 0).
template <class S>
struct ZeroTest {
  static bool test(const S& x) {
    if constexpr (std::is_arithmetic_v<S>) {
      return x == S(0);
    } else {
      return x.a == 0 && x.v.isZero();  // ceres::Jet
    }
  }
};

/// True when x is exactly zero (a structural zero the kernel may skip).
template <class S>
inline bool is_zero(const S& x) {
  return ZeroTest<S>::test(x);
}

/// Absolute value: std::abs for built-in types, found by argument-dependent lookup for the others
/// (ceres::abs for a Jet, std::experimental::abs for a pack).
template <class S>
inline S abs(const S& x) {
  using std::abs;
  return abs(x);
}

/// Larger of two values; equals std::max(a, b) (which returns a when neither is less) for
/// built-in types, per lane for packs.
template <class S>
inline S max(const S& a, const S& b) {
  if constexpr (std::is_arithmetic_v<S>) {
    return std::max(a, b);
  } else {
    return select(a < b, b, a);
  }
}

/// Smaller of two values; std::min(a, b) for built-in types, per lane for packs.
template <class S>
inline S min(const S& a, const S& b) {
  if constexpr (std::is_arithmetic_v<S>) {
    return std::min(a, b);
  } else {
    return select(b < a, b, a);
  }
}

/// Clamps x to [lo, hi] (lo <= hi): std::clamp for built-in types, per lane for packs.
template <class S>
inline S clamp(const S& x, const S& lo, const S& hi) {
  if constexpr (std::is_arithmetic_v<S>) {
    return std::clamp(x, lo, hi);
  } else {
    return select(x < lo, lo, select(hi < x, hi, x));
  }
}

/// e^x: std::exp for built-in types, ceres::exp for a Jet, std::experimental::exp for a pack.
template <class S>
inline S exp(const S& x) {
  using std::exp;
  return exp(x);
}

/// Square root: std::sqrt for built-in types, found by argument-dependent lookup for the others.
template <class S>
inline S sqrt(const S& x) {
  using std::sqrt;
  return sqrt(x);
}

/// The machine number inside a scalar: S itself for double and float, T for a ceres::Jet<T, N>
/// (its `Scalar`) and for a pack of T (its `value_type`). Constants that no fit differentiates and
/// every lane shares (rotor positions and axes) are stored in this type.
/// (Constrained specializations: clang takes two void_t specializations for one, CWG 1980.)
template <class S>
struct value_type {
  using type = S;
};
template <class S>
requires requires { typename S::Scalar; }
struct value_type<S> {
  using type = typename S::Scalar;
};
template <class S>
requires requires {
  typename S::value_type;
  typename S::abi_type;
}
struct value_type<S> {
  using type = typename S::value_type;
};
template <class S>
using value_type_t = typename value_type<S>::type;

/// A plain number as scalar S (through S's value type, so a double becomes a float pack too).
template <class S, class T>
inline S from_value(const T& x) requires std::is_arithmetic_v<T> {
  return S(static_cast<value_type_t<S>>(x));
}

}  // namespace dronetwin::scalar
