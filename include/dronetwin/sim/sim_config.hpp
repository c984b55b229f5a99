#pragma once
// Run settings of a Simulator (everything that is not the airframe): step size, integrator,
// which disturbance terms apply, environment, wind field, noise, ground and divergence limits,
// seed.

#include <cstdint>
#include <string_view>

#include "dronetwin/dynamics/environment.hpp"
#include "dronetwin/dynamics/ground.hpp"
#include "dronetwin/dynamics/wind_field.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/faults/rotor_fault.hpp"
#include "dronetwin/integrators/integrator.hpp"
#include "dronetwin/noise/ornstein_uhlenbeck.hpp"
#include "dronetwin/payload/slung_payload.hpp"
#include "dronetwin/power/battery.hpp"

namespace dronetwin {

struct NoiseConfig {
  /// Adds OU noise to the measured state and state derivative (thesis Sec. 3.4).
  bool enabled = false;
  OuParameters parameters = OuParameters::thesis();
};

/// A state beyond these bounds is reported as diverged (the run stops) instead of integrated on.
struct DivergenceLimits {
  double max_position_m = 1.0e5;
  double max_speed_m_s = 500.0;
  double max_angular_speed_rad_s = 1.0e4;
};

struct SimConfig {
  /// Physics step, s (thesis: 1 ms).
  double dt_s = 1.0e-3;
  Integrator integrator = Integrator::kRk4;
  /// First-order motor lag (Eq. 2.43-2.45). Off: rotor speed = clamped reference at once.
  bool motor_dynamics = true;
  DisturbanceSwitches disturbances{};
  Environment environment{};
  /// Shear, gusts and turbulence around environment.wind_W_m_s (default: none, constant wind).
  WindSettings wind{};
  /// Rotor faults (lost effectiveness, a stop, a stuck motor) from given times on (default none).
  FaultSettings faults{};
  /// An equivalent-circuit pack that drains and caps the rotor speed (default off: ideal supply).
  BatterySettings battery{};
  /// A payload on a tether under the vehicle (default off).
  PayloadSettings payload{};
  NoiseConfig noise{};
  GroundConfig ground{};
  DivergenceLimits divergence{};
  /// Seed of the simulator's own random stream (noise). Same seed + same config = same run.
  std::uint64_t seed = 0;
};

/// Throws InvalidArgument naming the field when a setting is out of range or not finite.
void validate(const SimConfig& config);

/// Throws InvalidArgument "<prefix>faults[j].rotor: expected 0 .. n-1 (rotors of '<vehicle>'),
/// got r" for a fault on a rotor the vehicle does not have (validate() knows only kMaxRotors).
void validate_fault_rotors(const FaultSettings& faults, int num_rotors, std::string_view vehicle,
                           std::string_view prefix = "");

}  // namespace dronetwin
