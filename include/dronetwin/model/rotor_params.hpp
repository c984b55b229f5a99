#pragma once
// Parameters of one rotor (propeller + motor), as written in a vehicle model file.
// All quantities SI; the thesis symbols are given for the QDrone2 (thesis Table 2.1).

#include <array>

#include "dronetwin/core/types.hpp"

namespace dronetwin {

struct RotorParams {
  /// Hub position relative to the centre of mass, body frame, m (thesis Eq. 2.25, z from SDF).
  Vec3 position_m = Vec3::Zero();
  /// Thrust direction in the body frame; normalised when the model is loaded. Tilted rotors
  /// allowed.
  Vec3 axis = Vec3::UnitZ();
  /// Turning direction epsilon_i in {+1, -1}. Sign convention of thesis Eq. 2.24: the reaction
  /// (yaw) moment of this rotor is +epsilon_i * T_i / K_tau about its axis.
  int spin = 1;
  /// Thrust polynomial T(w) = c[0] w^2 + c[1] w + c[2]  ('K1 [N s^2/rad^2], 'K2 [N s/rad], 'K3
  /// [N]), thesis Eq. 2.22.
  std::array<double, 3> thrust_coefficients{0.0, 0.0, 0.0};
  /// Reaction moment per unit thrust, 1/K_tau, m (thesis Eq. 2.23).
  double yaw_moment_per_thrust_m = 0.0;
  /// Rotor (blade-flapping) drag C_D: F_D = -|w| C_D v_perp, N s^2/(rad m) (thesis Eq. 2.32).
  double rotor_drag_coefficient = 0.0;
  /// Rolling moment C_R: M_R = |w| C_R v_perp, N s^2/rad (thesis Eq. 2.32).
  double rolling_moment_coefficient = 0.0;
  /// Drag moment C_MD: M_D = -epsilon C_MD T axis, m (thesis Eq. 2.32).
  double drag_moment_coefficient = 0.0;
  /// Ground effect C_G: F_G = C_G T / h^2 along the axis, m^2 (thesis appendix C.2 form).
  double ground_effect_coefficient = 0.0;
  /// Spinning-part inertia about the axis, kg m^2 (gyroscopic moment, thesis Eq. 2.35).
  double inertia_kgm2 = 0.0;
  /// Motor first-order lag constants, s (thesis Eq. 2.43-2.45).
  double time_constant_rise_s = 0.0;
  double time_constant_fall_s = 0.0;
  /// Rotor speed limits, rad/s (speeds are magnitudes; the spin sign is `spin`).
  double min_speed_rad_s = 0.0;
  double max_speed_rad_s = 0.0;

  /// Thrust T(w) in N for speed w in rad/s (thesis Eq. 2.22).
  template <class T>
  T thrust(const T& w) const {
    return (T(thrust_coefficients[0]) * w + T(thrust_coefficients[1])) * w +
           T(thrust_coefficients[2]);
  }

  /// Inverse of the thrust polynomial on [min_speed, max_speed]: the speed that gives
  /// `thrust_N`, clamped to the speed limits. Closed form (positive root of the quadratic).
  double speed_for_thrust(double thrust_N) const;
};

}  // namespace dronetwin
