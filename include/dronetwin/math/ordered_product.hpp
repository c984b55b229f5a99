#pragma once
// y = M x with every y_i summed left to right, ((M_i0 x_0 + M_i1 x_1) + M_i2 x_2) + ...
//
// Eigen sums a small product in an order that depends on the scalar: vectorised doubles go column
// by column, a scalar it cannot vectorise (a SIMD pack of vehicles, a Jet) goes through a pairwise
// tree. Each order is fine alone, but a batch lane would then differ from the Simulator by a
// rounding step that a tumbling flight amplifies. The force kernel's products use this instead,
// so a double and every lane of a pack do the same operations in the same order (bitwise equal,
// since the build forbids the compiler to fuse either into multiply-adds: CMakeLists.txt).
//
//   Vector3<P> v_B = ordered_product(R.transpose(), v_W);    // any scalars Eigen can multiply

#include <Eigen/Core>

#include "dronetwin/core/types.hpp"

namespace dronetwin::math {

template <class M, class V>
DRONETWIN_HOT_INLINE auto ordered_product(const Eigen::MatrixBase<M>& m,
                                          const Eigen::MatrixBase<V>& x) {
  using S =
      typename Eigen::ScalarBinaryOpTraits<typename M::Scalar, typename V::Scalar>::ReturnType;
  constexpr int kRows = M::RowsAtCompileTime, kCols = M::ColsAtCompileTime;
  static_assert(kRows > 0 && kCols > 0, "ordered_product: fixed sizes only");
  Eigen::Matrix<S, kRows, 1> y;
  for (int i = 0; i < kRows; ++i) {
    S acc = m(i, 0) * x(0);
    for (int j = 1; j < kCols; ++j) acc = acc + m(i, j) * x(j);
    y(i) = acc;
  }
  return y;
}

}  // namespace dronetwin::math
