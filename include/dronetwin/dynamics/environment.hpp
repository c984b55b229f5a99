#pragma once
// The world the vehicle flies in: gravity and the air's velocity. Wind is held constant over a
// physics step (a turbulence model can update it between steps).

#include "dronetwin/core/types.hpp"

namespace dronetwin {

struct Environment {
  /// Gravitational acceleration, world frame, m/s^2 (z up, so default points down).
  Vec3 gravity_W_m_s2{0.0, 0.0, -9.81};
  /// Velocity of the air mass, world frame, m/s. Aerodynamic terms use v - wind.
  Vec3 wind_W_m_s{0.0, 0.0, 0.0};
};

}  // namespace dronetwin
