#pragma once
// A 3-vector in an error message: "[x, y, z]", each number with 17 significant digits as
// detail::concat streams them ("0.5", "0.10000000000000001").
//
//   require(all_finite(p), "position_m: expected finite numbers, got ", VecText{p});
//
// VecText is streamed, so require() formats it only when it builds a message: checking good input
// costs no string. vec_text() is the same as a string, for messages built by hand.

#include <ostream>
#include <string>

#include "dronetwin/core/error.hpp"
#include "dronetwin/core/types.hpp"

namespace dronetwin {

/// Refers to `v`: use it within the expression that streams it.
struct VecText {
  const Vec3& v;
};

inline std::ostream& operator<<(std::ostream& out, const VecText& t) {
  return out << '[' << t.v.x() << ", " << t.v.y() << ", " << t.v.z() << ']';
}

inline std::string vec_text(const Vec3& v) { return detail::concat(VecText{v}); }

}  // namespace dronetwin
