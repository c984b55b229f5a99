#pragma once
// Error reporting. Anything a user, a file or Python can get wrong throws one of these with a
// message that says where (file, field, index) and what was expected versus what was found.

#include <cerrno>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>

namespace dronetwin {

/// Bad input: a malformed or unphysical model/experiment file, a wrong array size, a NaN command.
/// Maps to Python's ValueError.
class InvalidArgument : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// A run that cannot continue: diverged or non-finite state, stepping a failed simulator.
/// Maps to Python's RuntimeError.
class SimulationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

namespace detail {
template <class... Parts>
std::string concat(const Parts&... parts) {
  std::ostringstream out;
  out.precision(17);
  (out << ... << parts);
  return out.str();
}
}  // namespace detail

/// Throws InvalidArgument built from the streamed parts unless `condition` holds.
template <class... Parts>
void require(bool condition, const Parts&... parts) {
  if (!condition) throw InvalidArgument(detail::concat(parts...));
}

/// The system's reason for the last failed call (errno), for messages like
/// "<path>: cannot open log (No such file or directory)". Reads errno: call it right after the
/// failing call; "unknown error" when errno is 0 (a stream that failed without a system error).
inline std::string errno_text(int error = errno) {
  return error != 0 ? std::generic_category().message(error) : std::string("unknown error");
}

/// True when every coefficient of an Eigen expression is finite.
template <class Derived>
bool all_finite(const Derived& m) {
  return m.allFinite();
}

}  // namespace dronetwin
