#pragma once
// Battery (docs/battery.md): an equivalent-circuit pack drained by the rotors, whose terminal
// voltage caps the rotor speed through the thesis's motor law w = K_V V (Eq. 2.21, V = w / K_V).
//
// Circuit (Thevenin form, as in Chen and Rincon-Mora 2006): n_s cells in series, each an
// open-circuit voltage OCV(SoC), then a series resistance R0 and one R1 || C1 branch:
//   terminal voltage   V     = E(SoC) - V1 - R0 I,        E = n_s OCV_cell(SoC)
//   RC branch          dV1/dt = (R1 I - V1) / (R1 C1)
//   charge             dSoC/dt = -I / (3600 Q_Ah)
// The load is the rotors' shaft power through the motors' and ESCs' efficiency eta:
//   V I = P_shaft / eta,   P_shaft = sum_i Q_i w_i,   Q_i = T_i(w_i) / K_tau   (Eq. 2.23-2.24)
// so I is the smaller root of R0 I^2 - (E - V1) I + P_shaft / eta = 0. When the pack cannot give
// that power (no real root) it gives its most, at I = (E - V1) / (2 R0).
//
// A step holds the rotor speeds, so it holds the current: the RC branch and the charge advance
// exactly over it. The pack is cut off (latched, as an ESC's low-voltage cut-off does) once its
// charge is spent or its load-compensated voltage E - V1 falls below cutoff_voltage_V; from then
// on it gives no current and the rotors get no voltage.
//
//   BatteryPack pack;                                         // 6S 2200 mAh LiPo (assumed)
//   BatteryState b = battery_start(pack);
//   const double P_W = rotor_shaft_power_W(model, speeds_rad_s) / pack.efficiency;
//   advance_battery(pack, dt_s, battery_current_A(pack, b, P_W), b);
//   double cap = battery_speed_cap_rad_s(model, pack, b, reference_rad_s);   // w <= K_V V(w)

#include <algorithm>
#include <array>
#include <cmath>

#include "dronetwin/core/types.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

/// The open-circuit voltage table: one value per cell at SoC 0, 0.1, ..., 1.
inline constexpr int kOcvPoints = 11;

struct BatteryPack {
  int cells_in_series = 6;
  double capacity_Ah = 2.2;
  /// Rest voltage of one LiPo cell at SoC 0, 0.1, ..., 1 (a typical LiPo table; docs/battery.md).
  std::array<double, kOcvPoints> ocv_cell_V = {3.27, 3.69, 3.73, 3.77, 3.80, 3.84,
                                               3.87, 3.95, 4.02, 4.11, 4.20};
  double series_resistance_ohm = 0.030;  ///< R0 > 0 of the pack, wiring and connectors included
  double rc_resistance_ohm = 0.015;      ///< R1
  double rc_capacitance_F = 2000.0;      ///< C1 (R1 C1 = 30 s)
  /// Shaft power over electrical power of the motors and ESCs together.
  double efficiency = 0.75;
  /// K_V: no-load rotor speed per volt, rad/(V s) (thesis Table 2.1: 136.1356 for the QDrone2).
  double motor_speed_constant_rad_per_V_s = 136.1356;
  /// E - V1 (the terminal voltage without the R0 drop) below which the pack is cut off (3.0 V
  /// per cell).
  double cutoff_voltage_V = 18.0;
  /// State of charge at reset, in (0, 1].
  double initial_soc = 1.0;
};

struct BatterySettings {
  bool enabled = false;
  BatteryPack pack{};
};

/// The pack's state: plain data (SimData::battery).
struct BatteryState {
  double soc = 1.0;             ///< state of charge, 1 = full, 0 = empty
  double rc_voltage_V = 0.0;    ///< V1, the voltage across the RC branch
  double current_A = 0.0;       ///< current drawn over the step from time_s
  double voltage_V = 0.0;       ///< terminal voltage under that current (0 once cut off)
  double energy_drawn_J = 0.0;  ///< electrical energy delivered at the terminals so far
  bool depleted = false;        ///< cut off: charge spent or voltage below the cut-off
};

/// E(SoC): the pack's open-circuit voltage, linear between the table's points (SoC clamped to
/// [0, 1]).
inline double open_circuit_voltage_V(const BatteryPack& pack, double soc) {
  const double s = std::clamp(soc, 0.0, 1.0) * (kOcvPoints - 1);
  const int k = std::min(static_cast<int>(s), kOcvPoints - 2);
  const double f = s - k;
  const auto& v = pack.ocv_cell_V;
  return pack.cells_in_series *
         ((1.0 - f) * v[static_cast<std::size_t>(k)] + f * v[static_cast<std::size_t>(k + 1)]);
}

/// A full-rest pack at pack.initial_soc: no current, no RC voltage.
inline BatteryState battery_start(const BatteryPack& pack) {
  BatteryState b;
  b.soc = pack.initial_soc;
  b.voltage_V = open_circuit_voltage_V(pack, b.soc);
  return b;
}

/// Sum of Q_i w_i with Q_i = T_i / K_tau the rotor's drag torque (Eq. 2.23-2.24); a rotor at a
/// speed where the thrust polynomial is negative takes none.
inline double rotor_shaft_power_W(const VehicleModelTpl<double>& model,
                                  const RotorVector& speeds_rad_s) {
  double p = 0.0;
  for (int i = 0; i < model.num_rotors(); ++i) {
    const RotorParamsTpl<double>& r = model.rotor(i);
    const double w = speeds_rad_s[i];
    p += std::max(r.thrust(w), 0.0) * r.yaw_moment_per_thrust_m * std::abs(w);
  }
  return p;
}

/// The current that delivers `electrical_power_W` at the terminals (the smaller root of the
/// quadratic in the file comment), or the pack's most-power current when it cannot; 0 once cut
/// off.
inline double battery_current_A(const BatteryPack& pack, const BatteryState& b,
                                double electrical_power_W) {
  if (b.depleted || !(electrical_power_W > 0.0)) return 0.0;
  const double e = open_circuit_voltage_V(pack, b.soc) - b.rc_voltage_V;
  if (!(e > 0.0)) return 0.0;
  const double r0 = pack.series_resistance_ohm;  // > 0 (validated): the current is bounded
  const double disc = e * e - 4.0 * r0 * electrical_power_W;
  if (disc <= 0.0) return e / (2.0 * r0);
  // 2 P / (e + sqrt(disc)) is the smaller root without the cancellation of e - sqrt(disc).
  return 2.0 * electrical_power_W / (e + std::sqrt(disc));
}

/// One step of length dt_s at the held current `current_A`: the RC branch and the charge advance
/// exactly, then the terminal voltage and the cut-off are updated.
inline void advance_battery(const BatteryPack& pack, double dt_s, double current_A,
                            BatteryState& b) {
  const double r1 = pack.rc_resistance_ohm;
  const double tau_s = r1 * pack.rc_capacitance_F;
  const double decay = tau_s > 0.0 ? std::exp(-dt_s / tau_s) : 0.0;
  b.current_A = current_A;
  b.energy_drawn_J += (open_circuit_voltage_V(pack, b.soc) - b.rc_voltage_V -
                       pack.series_resistance_ohm * current_A) *
                      current_A * dt_s;
  b.rc_voltage_V = decay * b.rc_voltage_V + (1.0 - decay) * r1 * current_A;
  b.soc -= current_A * dt_s / (3600.0 * pack.capacity_Ah);
  b.voltage_V =
      open_circuit_voltage_V(pack, b.soc) - b.rc_voltage_V - pack.series_resistance_ohm * current_A;
  // The cut-off watches the voltage without the instantaneous R0 drop (as an autopilot's
  // load-compensated estimate does), so a short full-throttle punch does not trip it.
  if (b.soc <= 0.0 || b.voltage_V + pack.series_resistance_ohm * current_A < pack.cutoff_voltage_V)
    b.depleted = true;
  if (b.depleted) {
    b.current_A = 0.0;
    b.voltage_V = 0.0;  // the cut-off disconnects the motors
  }
}

/// The terminal voltage while the pack delivers `electrical_power_W` (E / 2 beyond the most it
/// can give); 0 once cut off.
inline double terminal_voltage_V(const BatteryPack& pack, const BatteryState& b,
                                 double electrical_power_W) {
  if (b.depleted) return 0.0;
  return open_circuit_voltage_V(pack, b.soc) - b.rc_voltage_V -
         pack.series_resistance_ohm * battery_current_A(pack, b, electrical_power_W);
}

/// The speed cap the pack puts on the rotor speed references: the largest c up to the highest
/// (clamped) reference with c <= K_V V(c), where V(c) is the terminal voltage while the rotors
/// turn at min(reference, c) (Eq. 2.21 with the sag of the current they draw). The cap is the
/// fixed point of the voltage loop, found by bisection (the right side falls as c rises), rather
/// than the last step's K_V V, whose one-step delay can oscillate when the motors are fast.
/// 0 once cut off; the highest reference when the pack does not limit them.
inline double battery_speed_cap_rad_s(const VehicleModelTpl<double>& model, const BatteryPack& pack,
                                      const BatteryState& b, const RotorVector& reference_rad_s) {
  if (b.depleted) return 0.0;
  const auto clamped = [](const RotorParamsTpl<double>& r, double w) {
    return std::clamp(w, r.min_speed_rad_s, r.max_speed_rad_s);  // as the motors clamp it
  };
  const int n = model.num_rotors();
  double highest = 0.0;
  for (int i = 0; i < n; ++i)
    highest = std::max(highest, clamped(model.rotor(i), reference_rad_s[i]));
  // slack(c) = K_V V(c) - c: positive at 0, falling in c.
  const auto slack = [&](double cap) {
    double power_W = 0.0;
    for (int i = 0; i < n; ++i) {
      const RotorParamsTpl<double>& r = model.rotor(i);
      const double w = std::min(clamped(r, reference_rad_s[i]), cap);
      power_W += std::max(r.thrust(w), 0.0) * r.yaw_moment_per_thrust_m * w;
    }
    return pack.motor_speed_constant_rad_per_V_s *
               terminal_voltage_V(pack, b, power_W / pack.efficiency) -
           cap;
  };
  if (slack(highest) >= 0.0) return highest;
  double lo = 0.0, hi = highest;
  for (int k = 0; k < 60 && hi - lo > 1e-9 * highest; ++k) {
    const double mid = 0.5 * (lo + hi);
    (slack(mid) >= 0.0 ? lo : hi) = mid;
  }
  return lo;
}

}  // namespace dronetwin
