#pragma once
// Motor dynamics: first-order lag from the speed reference to the rotor speed, with separate
// rise and fall time constants (thesis Eq. 2.43-2.44), discretised exactly for a fixed step
// (Eq. 2.45):  w(t + dt) = e^{-dt/tau} w(t) + (1 - e^{-dt/tau}) w_ref,
// tau = tau_rise when w_ref > w, tau_fall otherwise. References are clamped to the rotor's speed
// limits first. The decay factors depend only on dt, so they are computed once per simulator.
//
//   MotorDiscretization d = discretize_motors(model, 1e-3);
//   advance_motors(model, d, reference_rad_s, speed_rad_s);       // one step, every rotor
//   S w1 = motor_speed_after(decay_rise, decay_fall, ref, w0);    // one rotor, any scalar
//
// Templated on the scalar: a fit differentiates with respect to the time constants (Jet), a batch
// steps one motor per lane (packs).

#include "dronetwin/core/scalar.hpp"
#include "dronetwin/core/types.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

/// e^{-dt/tau}, the per-step decay of Eq. 2.45; 0 for tau = 0 (no lag: the speed jumps).
template <class S>
S motor_decay(const S& tau_s, double dt_s) {
  using V = scalar::value_type_t<S>;
  const S safe_tau = scalar::select(V(0) < tau_s, tau_s, S(V(1)));
  return scalar::select(V(0) < tau_s, scalar::exp(S(V(-dt_s)) / safe_tau), S(V(0)));
}

/// Eq. 2.45 for one rotor: the speed after one step from `speed` toward the (already clamped)
/// `reference`, rising with `decay_rise` and falling with `decay_fall`.
template <class S, class W>
S motor_speed_after(const S& decay_rise, const S& decay_fall, const W& reference, const W& speed) {
  using V = scalar::value_type_t<S>;
  const S a = scalar::select(reference > speed, decay_rise, decay_fall);
  return a * speed + (V(1) - a) * reference;
}

/// The reference a rotor can actually follow: clamped to [min_speed, max_speed].
template <class S, class W>
W clamp_speed(const RotorParamsTpl<S>& r, const W& w_ref) {
  return scalar::clamp(w_ref, W(r.min_speed_rad_s), W(r.max_speed_rad_s));
}

struct MotorDiscretization {
  RotorVector decay_rise;  ///< e^{-dt/tau_rise} per rotor (0 for tau = 0: no lag)
  RotorVector decay_fall;  ///< e^{-dt/tau_fall} per rotor
};

inline MotorDiscretization discretize_motors(const VehicleModel& model, double dt_s) {
  const int n = model.num_rotors();
  MotorDiscretization d{RotorVector(n), RotorVector(n)};
  for (int i = 0; i < n; ++i) {
    const RotorParams& r = model.rotor(i);
    d.decay_rise[i] = motor_decay(r.time_constant_rise_s, dt_s);
    d.decay_fall[i] = motor_decay(r.time_constant_fall_s, dt_s);
  }
  return d;
}

/// Advances every rotor speed by one step toward its (clamped) reference (Eq. 2.45).
inline void advance_motors(const VehicleModel& model, const MotorDiscretization& d,
                           const RotorVector& reference_rad_s, RotorVector& speed_rad_s) {
  for (int i = 0; i < model.num_rotors(); ++i) {
    const double ref = clamp_speed(model.rotor(i), reference_rad_s[i]);
    speed_rad_s[i] = motor_speed_after(d.decay_rise[i], d.decay_fall[i], ref, speed_rad_s[i]);
  }
}

}  // namespace dronetwin
