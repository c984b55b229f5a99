#pragma once
// Control allocation: generalized forces u = [T, tau_x, tau_y, tau_z] -> rotor speed references.
//
// kExact (default): rotor thrusts from the pseudo-inverse of the allocation matrix (thesis
//   Eq. 2.30 generalised) with thrust-first saturation handling (allocate_with_saturation), then
//   each rotor's full thrust polynomial inverted in closed form.
// kThesis: thesis Eq. 2.31, w_i^2 = (A^+ u)_i / 'K1 (drops 'K2 w + 'K3; at hover this commands
//   about 32 % more thrust than asked, notes #38). Negative w^2 gives w = 0.
// Both clamp to the rotor speed limits.

#include <algorithm>
#include <array>
#include <cmath>
#include <string_view>
#include <utility>

#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

enum class AllocationMethod { kExact, kThesis };

constexpr std::string_view allocation_name(AllocationMethod m) {
  return m == AllocationMethod::kExact ? "exact" : "thesis";
}

/// Result of an allocation with saturation handling.
struct AllocationResult {
  RotorVector speeds_rad_s;
  /// Rotor thrusts the speeds produce (N), i.e. what the allocation actually asks for.
  RotorVector thrusts_N;
  /// Generalized forces those thrusts give (A * thrusts): equals the request when unsaturated.
  GeneralizedForce achieved = GeneralizedForce::Zero();
  /// Factor (0..1) applied to the requested moments to stay within the rotor limits.
  double moment_scale = 1.0;
  /// True when the request could not be met exactly (moments scaled or thrust clipped).
  bool saturated = false;
};

/// The thrust-first allocation (exact method) for any lane scalar: a pack allocates W vehicles'
/// requests at once, each lane as the double would, bit for bit.
template <class S>
struct ThrustFirstAllocation {
  std::array<S, kMaxRotors> speeds_rad_s{};
  /// Factor (0..1) applied to the requested moments.
  S moment_scale{};
  /// Moments scaled or thrust clipped (a bool, or a mask for a pack).
  decltype(std::declval<S>() < std::declval<S>()) saturated{};
};

/// Thrust-first allocation (exact method): rotor thrusts t = A^+ [T, 0] + s A^+ [0, tau] with the
/// largest s in [0, 1] that keeps every rotor within its thrust range [T(w_min), T(w_max)]; if the
/// collective thrust alone is out of range it is clipped per rotor. Thrust is kept first because
/// losing altitude control is worse than a slower attitude response. Rotor speeds by the closed
/// form inverse of each rotor's thrust polynomial.
template <class S>
ThrustFirstAllocation<S> allocate_thrust_first(const VehicleModel& model, const Vector4<S>& u) {
  const int n = model.num_rotors();
  const AllocationInverse& pinv = model.allocation_pseudo_inverse();
  const auto c = [](double v) { return scalar::from_value<S>(v); };
  const S zero = c(0.0);
  std::array<S, kMaxRotors> t_thrust{}, t_moment{}, lo{}, hi{};
  ThrustFirstAllocation<S> r;  // saturated{}: false (a mask: false in every lane)
  S s = c(1.0);
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const RotorParams& rp = model.rotor(i);
    t_thrust[k] = c(pinv(i, 0)) * u[0];
    t_moment[k] = (c(pinv(i, 1)) * u[1] + c(pinv(i, 2)) * u[2]) + c(pinv(i, 3)) * u[3];
    lo[k] = c(rp.thrust(rp.min_speed_rad_s));
    hi[k] = c(rp.thrust(rp.max_speed_rad_s));
    const S base = scalar::clamp(t_thrust[k], lo[k], hi[k]);
    r.saturated = r.saturated || base != t_thrust[k];
    // Largest s with lo <= base + s m <= hi for this rotor.
    const S m = t_moment[k];
    s = scalar::select(m > zero && base + s * m > hi[k], scalar::max(zero, (hi[k] - base) / m), s);
    s = scalar::select(m < zero && base + s * m < lo[k], scalar::max(zero, (lo[k] - base) / m), s);
  }
  r.saturated = r.saturated || s < c(1.0);
  r.moment_scale = s;
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const RotorParams& rp = model.rotor(i);
    const S t =
        scalar::clamp(scalar::clamp(t_thrust[k], lo[k], hi[k]) + s * t_moment[k], lo[k], hi[k]);
    r.speeds_rad_s[k] = inverse_thrust_polynomial(rp.thrust_coefficients, rp.min_speed_rad_s,
                                                  rp.max_speed_rad_s, t);
  }
  return r;
}

/// allocate_thrust_first() in double, with the thrusts and the generalized force it achieves.
inline AllocationResult allocate_with_saturation(const VehicleModel& model,
                                                 const GeneralizedForce& u) {
  const int n = model.num_rotors();
  const ThrustFirstAllocation<double> a = allocate_thrust_first<double>(model, u);
  AllocationResult r;
  r.thrusts_N.resize(n);
  r.speeds_rad_s.resize(n);
  for (int i = 0; i < n; ++i) {
    r.speeds_rad_s[i] = a.speeds_rad_s[static_cast<std::size_t>(i)];
    r.thrusts_N[i] = model.rotor(i).thrust(r.speeds_rad_s[i]);
  }
  r.moment_scale = a.moment_scale;
  r.saturated = a.saturated;
  r.achieved = model.allocation_matrix() * r.thrusts_N;
  return r;
}

/// Rotor speed references for generalized forces u with `method`, and what they achieve. kExact
/// is allocate_with_saturation(); kThesis is Eq. 2.31 as printed, clipped per rotor, `saturated`
/// when the achieved force differs from u (by more than 1e-6 relative).
inline AllocationResult allocate(const VehicleModel& model, const GeneralizedForce& u,
                                 AllocationMethod method = AllocationMethod::kExact) {
  if (method == AllocationMethod::kExact) return allocate_with_saturation(model, u);
  const int n = model.num_rotors();
  const RotorVector thrusts = model.thrusts_for(u);
  AllocationResult r;
  r.speeds_rad_s.resize(n);
  r.thrusts_N.resize(n);
  for (int i = 0; i < n; ++i) {
    const RotorParams& rp = model.rotor(i);
    const double w2 = thrusts[i] / rp.thrust_coefficients[0];
    r.speeds_rad_s[i] =
        std::clamp(w2 > 0.0 ? std::sqrt(w2) : 0.0, rp.min_speed_rad_s, rp.max_speed_rad_s);
    r.thrusts_N[i] = rp.thrust(r.speeds_rad_s[i]);
  }
  r.achieved = model.allocation_matrix() * r.thrusts_N;
  r.moment_scale = 1.0;
  r.saturated = (r.achieved - u).norm() > 1e-6 * (1 + u.norm());
  return r;
}

/// The speed references alone (allocate(model, u, method).speeds_rad_s).
inline RotorVector allocate_speeds(const VehicleModel& model, const GeneralizedForce& u,
                                   AllocationMethod method = AllocationMethod::kExact) {
  return allocate(model, u, method).speeds_rad_s;
}

/// The generalized force [T, tau] that rotor speed commands produce once the motors clamp them to
/// their limits: A * T_i(clamp(w_i)).
inline GeneralizedForce generalized_force_of(const VehicleModel& model,
                                             const RotorVector& speeds_rad_s) {
  RotorVector thrusts(model.num_rotors());
  for (int i = 0; i < model.num_rotors(); ++i) {
    const RotorParams& r = model.rotor(i);
    thrusts[i] = r.thrust(std::clamp(speeds_rad_s[i], r.min_speed_rad_s, r.max_speed_rad_s));
  }
  return model.allocation_matrix() * thrusts;
}

}  // namespace dronetwin
