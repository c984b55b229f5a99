#pragma once
// What every batched inner loop does with its generalized forces: refuse the lanes whose u is not
// finite (the batch stops them, as ControllerBase refuses a non-finite output), allocate the rest
// through the nominal model's thrust-first allocation (model/allocation.hpp, the scalar
// controllers' own), write their rotor references and flag saturation per lane.
//
//   Mask failed;
//   allocate_lanes(model, u, running, reference, failed, &saturated[pack * W]);

#include <array>
#include <cstdint>
#include <limits>

#include "dronetwin/core/simd.hpp"
#include "dronetwin/model/allocation.hpp"

namespace dronetwin {

/// True in the lanes where x is finite.
template <class P>
DRONETWIN_HOT_INLINE auto finite_lanes(const P& x) {
  using T = typename P::value_type;
  return stdx::abs(x) <= P(std::numeric_limits<T>::max());
}

/// True in the lanes where all four components of u are finite.
template <class P>
auto finite_lanes(const Vector4<P>& u) {
  return finite_lanes(u[0]) && finite_lanes(u[1]) && finite_lanes(u[2]) && finite_lanes(u[3]);
}

/// Rotor references of the `running` lanes whose u is finite; `failed` marks the running lanes
/// whose u is not (their references unchanged). saturated[l] (lane l of the pack) becomes 1 or 0
/// for the lanes allocated.
template <class P, class M>
void allocate_lanes(const VehicleModel& model, const Vector4<P>& u, const M& running,
                    std::array<P, kMaxRotors>& reference, M& failed, std::uint8_t* saturated) {
  const M ok = running && finite_lanes(u);
  failed = running && !ok;
  const ThrustFirstAllocation<P> a = allocate_thrust_first<P>(model, u);
  for (int i = 0; i < model.num_rotors(); ++i)
    stdx::where(ok, reference[static_cast<std::size_t>(i)]) =
        a.speeds_rad_s[static_cast<std::size_t>(i)];
  for (std::size_t l = 0; l < P::size(); ++l)
    if (ok[l]) saturated[l] = a.saturated[l] ? 1 : 0;
}

}  // namespace dronetwin
