#pragma once
// Fixed-step integrators for x_dot = f(x). The inputs (rotor speeds, wind) are held constant
// over the step by the caller's f (zero-order hold), as in thesis Alg. 1-2.
//
//   StateVector x1 = rk4_step(x0, dt, [&](const StateVector& x) { return f(x); });
//
// Neither integrator renormalises the quaternion; the simulator does after each step.

#include <string_view>

#include "dronetwin/core/scalar.hpp"
#include "dronetwin/core/types.hpp"

namespace dronetwin {

enum class Integrator { kRk4, kEuler };

constexpr std::string_view integrator_name(Integrator i) {
  return i == Integrator::kRk4 ? "rk4" : "euler";
}

/// Classical fourth-order Runge-Kutta: global error O(dt^4).
/// The state's scalar may be a SIMD pack (one vehicle per lane); the step size is then taken in
/// the pack's lane type (float for a float batch), so double and pack steps do the same arithmetic.
template <class Vector, class F>
DRONETWIN_HOT_INLINE Vector rk4_step(const Vector& x, double dt_s, F&& f) {
  using V = scalar::value_type_t<typename Vector::Scalar>;
  const V dt = static_cast<V>(dt_s);
  const Vector k1 = f(x);
  const Vector k2 = f(Vector(x + (V(0.5) * dt) * k1));
  const Vector k3 = f(Vector(x + (V(0.5) * dt) * k2));
  const Vector k4 = f(Vector(x + dt * k3));
  // Element by element, the same operations in the same order as the vector expression
  // x + (dt / 6) (k1 + 2 (k2 + k3) + k4): written out, GCC keeps it inline in the simulator's
  // step, where the expression's evaluator was sometimes outlined (a call per packet).
  const V sixth = dt / V(6);
  Vector next = x;
  for (Eigen::Index i = 0; i < x.size(); ++i)
    next[i] = x[i] + sixth * (k1[i] + V(2) * (k2[i] + k3[i]) + k4[i]);
  return next;
}

/// Explicit (forward) Euler: global error O(dt).
template <class Vector, class F>
DRONETWIN_HOT_INLINE Vector euler_step(const Vector& x, double dt_s, F&& f) {
  using V = scalar::value_type_t<typename Vector::Scalar>;
  const V dt = static_cast<V>(dt_s);
  const Vector k = f(x);
  // Written out as in rk4_step (the same operations as x + dt * f(x)).
  Vector next = x;
  for (Eigen::Index i = 0; i < x.size(); ++i) next[i] = x[i] + dt * k[i];
  return next;
}

// Always inlined (with rk4_step and euler_step): the batch's flattened pack step relies on it, GCC
// stopped inlining them there once the step grew (a third of its speed lost, docs/batch.md).
template <class Vector, class F>
DRONETWIN_HOT_INLINE Vector integrate_step(Integrator method, const Vector& x, double dt, F&& f) {
  return method == Integrator::kRk4 ? rk4_step(x, dt, f) : euler_step(x, dt, f);
}

}  // namespace dronetwin
