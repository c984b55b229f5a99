#pragma once
// Thrust-stand identification for a quadrotor whose four motors are driven with one PWM value
// (the Bitcraze 2021 Crazyflie 2.1 sweep; io/crazyflie_csv.hpp reads it).
//
// Per-motor thrust T = (weight_g - tare_g) g / 1000 / 4 N against the mean rotor speed
// w = mean(rpm1..4) 2 pi / 60 rad/s, fitted to thesis Eq. 2.22:
//
//   T(w) = K1 w^2 + K2 w + K3                                       (Eq. 2.22)
//
// and the speed map from the command to the rotor speed, with u = pwm / 65535 * vbat the mean
// motor voltage (V):
//
//   w(pwm, vbat) = a u + b      (pwm > 0; w = 0 for pwm = 0)
//
// A quadratic in u is also fitted and reported so that the choice is visible (the linear map is
// kept: the quadratic term lowers the residual by < 1 %, see docs/identification.md).
//
//   ThrustStandFit f = fit_thrust_stand(read_thrust_stand_csv(path));
//   f.thrust.coefficients  -> K1, K2, K3 (std_errors beside them)
//   double w = f.speed_map.speed_rad_s(40000, 3.7);
//
// Rows used: every motor spinning (all rpm > 0) and pwm > 0; rows at pwm = 0 with every rpm = 0
// give the tare (the load cell reads about -1.1 g at rest, which would otherwise become K3).
// Trap: the rig measures the sum of four motors, so per-motor thrust assumes equal motors; the
// motor-to-motor speed spread (motor_speed_ratio) says how good that is.

#include <array>
#include <string>

#include "dronetwin/adapters/crazyflie_csv.hpp"
#include "dronetwin/identification/linear_fit.hpp"

namespace dronetwin {

/// Rotor speed from PWM duty and battery voltage (see the file comment).
struct SpeedMap {
  double a_rad_s_per_V = 0.0;
  double b_rad_s = 0.0;
  /// 0 for pwm <= 0 (motor off); otherwise max(0, a u + b), u = pwm / 65535 * vbat.
  double speed_rad_s(double pwm, double vbat_V) const;
};

struct ThrustStandOptions {
  /// Converts grams of load-cell reading to newtons. 9.81 is the project's gravity, so a hover
  /// computed with the model (m g) and with the stand (grams) agree exactly.
  double gravity_m_s2 = 9.81;
  /// Subtract the mean reading at rest (pwm = 0, all rpm = 0) from every weight.
  bool subtract_tare = true;
};

struct ThrustStandFit {
  std::string source;
  double tare_g = 0.0;  ///< mean load-cell reading at rest (0 if not subtracted)
  std::size_t tare_rows = 0;
  LinearFit thrust;               ///< K1, K2, K3 of Eq. 2.22, per motor (N, rad/s)
  LinearFit speed_map_fit;        ///< a, b of w = a u + b
  LinearFit speed_map_quadratic;  ///< c2, c1, c0 of w = c2 u^2 + c1 u + c0 (for comparison)
  SpeedMap speed_map;
  /// Mean speed of each motor over the rows used, divided by the mean of all four.
  std::array<double, 4> motor_speed_ratio{};
  double min_speed_rad_s = 0.0;  ///< lowest / highest mean rotor speed in the rows used
  double max_speed_rad_s = 0.0;
  double max_thrust_N = 0.0;  ///< per motor, highest tare-corrected thrust in the rows used
};

ThrustStandFit fit_thrust_stand(const ThrustStandData& data,
                                const ThrustStandOptions& options = {});

}  // namespace dronetwin
