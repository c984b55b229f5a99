#pragma once
// Control allocation: generalized forces u = [T, tau_x, tau_y, tau_z] -> rotor speed references.
//
// kExact (default): rotor thrusts from the pseudo-inverse of the allocation matrix (thesis
//   Eq. 2.30 generalised), then each rotor's full thrust polynomial inverted in closed form.
// kThesis: thesis Eq. 2.31, w_i^2 = (A^+ u)_i / 'K1 (drops 'K2 w + 'K3; at hover this commands
//   about 32 % more thrust than asked, notes #38). Negative w^2 gives w = 0.
// Both clamp to the rotor speed limits.

#include <algorithm>
#include <cmath>
#include <string_view>

#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

enum class AllocationMethod { kExact, kThesis };

constexpr std::string_view allocation_name(AllocationMethod m) {
  return m == AllocationMethod::kExact ? "exact" : "thesis";
}

inline RotorVector allocate_speeds(const VehicleModel& model, const GeneralizedForce& u,
                                   AllocationMethod method = AllocationMethod::kExact) {
  const RotorVector thrusts = model.thrusts_for(u);
  RotorVector w(model.num_rotors());
  for (int i = 0; i < model.num_rotors(); ++i) {
    const RotorParams& r = model.rotor(i);
    if (method == AllocationMethod::kExact) {
      w[i] = r.speed_for_thrust(thrusts[i]);
    } else {
      const double w2 = thrusts[i] / r.thrust_coefficients[0];
      w[i] = std::clamp(w2 > 0.0 ? std::sqrt(w2) : 0.0, r.min_speed_rad_s, r.max_speed_rad_s);
    }
  }
  return w;
}

}  // namespace dronetwin
