// core/scalar.hpp and core/simd.hpp: the few operations the force kernel needs beyond arithmetic,
// for plain numbers (the standard functions' results), ceres::Jet (on the value, derivatives
// carried through the chosen branch) and SIMD packs (each lane on its own).

#include "dronetwin/core/scalar.hpp"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "dronetwin/core/simd.hpp"
#include "dronetwin/core/types.hpp"

namespace dronetwin {
namespace {

TEST(Scalar, PlainNumbersGetTheStandardFunctions) {
  for (const double a : {-2.5, -0.0, 0.0, 1.0, 3.25}) {
    for (const double b : {-1.0, 0.0, 2.0}) {
      EXPECT_EQ(scalar::max(a, b), std::max(a, b));
      EXPECT_EQ(scalar::min(a, b), std::min(a, b));
      EXPECT_EQ(scalar::select(a < b, a, b), a < b ? a : b);
    }
    EXPECT_EQ(scalar::abs(a), std::abs(a));
    EXPECT_EQ(scalar::clamp(a, -1.0, 2.0), std::clamp(a, -1.0, 2.0));
    EXPECT_EQ(scalar::exp(a), std::exp(a));
  }
  EXPECT_TRUE(scalar::is_zero(0.0));
  EXPECT_TRUE(scalar::is_zero(-0.0));
  EXPECT_FALSE(scalar::is_zero(1e-300));
  EXPECT_EQ(scalar::from_value<float>(0.1), 0.1f);
}

TEST(Scalar, JetsCompareOnTheValueAndKeepTheDerivativesOfTheBranchTaken) {
  using J = ceres::Jet<double, 2>;
  const J a(1.5, 0), b(-2.0, 1);
  EXPECT_EQ(scalar::max(a, b).a, 1.5);
  EXPECT_EQ(scalar::max(a, b).v[0], 1.0);  // d max / d a = 1 where a is larger
  EXPECT_EQ(scalar::max(a, b).v[1], 0.0);
  EXPECT_EQ(scalar::min(a, b).v[1], 1.0);
  EXPECT_EQ(scalar::abs(b).a, 2.0);
  EXPECT_EQ(scalar::abs(b).v[1], -1.0);  // d|b|/db = sign(b)
  EXPECT_NEAR(scalar::exp(a).v[0], std::exp(1.5), 1e-15);
  EXPECT_TRUE(scalar::is_zero(J(0.0)));
  EXPECT_FALSE(scalar::is_zero(J(0.0, 1)));  // zero value, non-zero derivative: not a zero
  static_assert(std::is_same_v<scalar::value_type_t<J>, double>);
  static_assert(std::is_same_v<scalar::value_type_t<float>, float>);
}

TEST(Scalar, EachLaneOfAPackChoosesForItself) {
  using P = Pack<double, 4>;
  const P a = pack_from<P>([](int l) { return l - 1.5; });  // -1.5 -0.5 0.5 1.5
  const P b = pack_from<P>([](int l) { return l % 2 == 0 ? 1.0 : -1.0; });
  const P mx = scalar::max(a, b), mn = scalar::min(a, b), ab = scalar::abs(a);
  const P cl = scalar::clamp(a, P(-1.0), P(1.0));
  const P ex = scalar::exp(a);
  for (int l = 0; l < 4; ++l) {
    EXPECT_EQ(lane(mx, l), std::max(lane(a, l), lane(b, l))) << l;
    EXPECT_EQ(lane(mn, l), std::min(lane(a, l), lane(b, l))) << l;
    EXPECT_EQ(lane(ab, l), std::abs(lane(a, l))) << l;
    EXPECT_EQ(lane(cl, l), std::clamp(lane(a, l), -1.0, 1.0)) << l;
    EXPECT_NEAR(lane(ex, l), std::exp(lane(a, l)), 1e-15 * std::exp(lane(a, l))) << l;
  }
  EXPECT_TRUE(scalar::is_zero(P(0.0)));
  EXPECT_FALSE(scalar::is_zero(pack_from<P>([](int l) { return l == 3 ? 1.0 : 0.0; })));
  static_assert(std::is_same_v<scalar::value_type_t<P>, double>);
  static_assert(std::is_same_v<scalar::value_type_t<Pack<float, 8>>, float>);
}

TEST(Scalar, EigenMatricesOfPacksMultiplyLaneByLane) {
  using P = Pack<double, 4>;
  Matrix3<P> R;
  Vector3<P> v;
  for (int r = 0; r < 3; ++r) {
    v[r] = pack_from<P>([r](int l) { return r + 0.5 * l; });
    for (int c = 0; c < 3; ++c) R(r, c) = pack_from<P>([r, c](int l) { return r - c + l; });
  }
  const Vector3<P> Rv = R * v;
  const Vector3<P> Rd = R * Vec3(1, 2, 3);  // a pack matrix times a shared double vector
  for (int l = 0; l < 4; ++l) {
    Mat3 Rl;
    Vec3 vl;
    for (int r = 0; r < 3; ++r) {
      vl[r] = lane(v[r], l);
      for (int c = 0; c < 3; ++c) Rl(r, c) = lane(R(r, c), l);
    }
    const Vec3 expected = Rl * vl, expected_d = Rl * Vec3(1, 2, 3);
    for (int r = 0; r < 3; ++r) {
      EXPECT_NEAR(lane(Rv[r], l), expected[r], 1e-14 * (1 + std::abs(expected[r])));
      EXPECT_NEAR(lane(Rd[r], l), expected_d[r], 1e-14 * (1 + std::abs(expected_d[r])));
    }
  }
}

}  // namespace
}  // namespace dronetwin
