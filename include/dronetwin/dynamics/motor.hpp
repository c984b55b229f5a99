#pragma once
// Motor dynamics: first-order lag from the speed reference to the rotor speed, with separate
// rise and fall time constants (thesis Eq. 2.43-2.44), discretised exactly for a fixed step
// (Eq. 2.45):  w(t + dt) = e^{-dt/tau} w(t) + (1 - e^{-dt/tau}) w_ref,
// tau = tau_rise when w_ref > w, tau_fall otherwise. References are clamped to the rotor's speed
// limits first. The decay factors depend only on dt, so they are computed once per simulator.

#include <algorithm>
#include <cmath>

#include "dronetwin/core/types.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

struct MotorDiscretization {
  RotorVector decay_rise;  ///< e^{-dt/tau_rise} per rotor (0 for tau = 0: no lag)
  RotorVector decay_fall;  ///< e^{-dt/tau_fall} per rotor
};

inline MotorDiscretization discretize_motors(const VehicleModel& model, double dt_s) {
  const int n = model.num_rotors();
  MotorDiscretization d{RotorVector(n), RotorVector(n)};
  for (int i = 0; i < n; ++i) {
    const RotorParams& r = model.rotor(i);
    d.decay_rise[i] = r.time_constant_rise_s > 0 ? std::exp(-dt_s / r.time_constant_rise_s) : 0.0;
    d.decay_fall[i] = r.time_constant_fall_s > 0 ? std::exp(-dt_s / r.time_constant_fall_s) : 0.0;
  }
  return d;
}

/// The reference a rotor can actually follow: clamped to [min_speed, max_speed].
inline double clamp_speed(const RotorParams& r, double w_ref) {
  return std::clamp(w_ref, r.min_speed_rad_s, r.max_speed_rad_s);
}

/// Advances every rotor speed by one step toward its (clamped) reference (Eq. 2.45).
inline void advance_motors(const VehicleModel& model, const MotorDiscretization& d,
                           const RotorVector& reference_rad_s, RotorVector& speed_rad_s) {
  for (int i = 0; i < model.num_rotors(); ++i) {
    const double ref = clamp_speed(model.rotor(i), reference_rad_s[i]);
    const double a = ref > speed_rad_s[i] ? d.decay_rise[i] : d.decay_fall[i];
    speed_rad_s[i] = a * speed_rad_s[i] + (1.0 - a) * ref;
  }
}

}  // namespace dronetwin
