#pragma once
// One-off evaluations of the force kernel (force_kernel.hpp) at a single state: the state
// derivative, and the wrench of every term separately. A simulator keeps its kernel and calls
// prepare() once per step instead; these build one for the call.
//
//   StateVector xdot = state_derivative(model, switches, env, x, rotor_speeds);
//   WrenchBreakdown b = wrench_breakdown(model, switches, env, x, rotor_speeds);
//
// The breakdown evaluates the same kernel with one term switched on at a time, so its terms sum
// to the kernel's total wrench (up to the order of the additions) and can never describe another
// model. Rotor speeds are magnitudes in rad/s, held constant over a physics step.

#include "dronetwin/core/types.hpp"
#include "dronetwin/dynamics/environment.hpp"
#include "dronetwin/dynamics/force_kernel.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

/// x_dot = f(x, w) for the full model (thesis Eq. 2.41-2.42 with the resolutions of
/// docs/conventions.md). The quaternion in x need not be exactly unit (RK4 stages are not).
template <class S, class X>
StateVectorT<S> state_derivative(const VehicleModelTpl<S>& model, const DisturbanceSwitches& sw,
                                 const Environment& env, const StateVectorT<X>& x,
                                 const RotorVector& speeds_rad_s) {
  const ForceKernel<S> kernel(model, ForceTerms::of(sw));
  HeldRotorTerms<S> held;
  kernel.prepare(speeds_rad_s, held);
  return kernel.derivative(held, x, env);
}

/// Every term's force and moment at one state, gravity included (expressed in the body frame);
/// terms the switches turn off are zero.
inline WrenchBreakdown wrench_breakdown(const VehicleModelTpl<double>& model,
                                        const DisturbanceSwitches& sw, const Environment& env,
                                        const StateVector& x, const RotorVector& speeds_rad_s) {
  WrenchBreakdown out;
  const Mat3 R = math::rotation_matrix<double>(x.segment<4>(state_index::kQuaternion));
  const ForceTerms enabled = ForceTerms::of(sw);
  for (int t = 0; t < kNumTerms; ++t) {
    const Term term = static_cast<Term>(t);
    if (!enabled.includes(term)) continue;  // switched off, or gravity (added below)
    const ForceTerms one = ForceTerms::only(term);
    const ForceKernel<double> kernel(model, one);
    HeldRotorTerms<double> held;
    kernel.prepare(speeds_rad_s, held);
    const Vector6<double> w = kernel.wrench(held, x, R, env.wind_W_m_s);
    out[term].force_B = w.head<3>();
    out[term].moment_B = w.tail<3>();
  }
  out[Term::kGravity].force_B = R.transpose() * (model.mass_kg() * env.gravity_W_m_s2);
  return out;
}

}  // namespace dronetwin
