// The equivalent-circuit pack (power/battery.hpp) against its own equations solved by hand: the
// open-circuit voltage table, a constant current (linear charge, the RC branch's exponential),
// the current that delivers a power (V I = P, the smaller root), the most a pack can give, the
// cut-off and the speed cap K_V V.

#include <gtest/gtest.h>

#include <cmath>

#include "dronetwin/power/battery.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

TEST(Battery, OpenCircuitVoltageFollowsTheTableLinearlyAndClampsOutside) {
  const BatteryPack pack;
  for (int k = 0; k < kOcvPoints; ++k)
    EXPECT_NEAR(open_circuit_voltage_V(pack, 0.1 * k),
                pack.cells_in_series * pack.ocv_cell_V[static_cast<std::size_t>(k)], 1e-12)
        << "SoC " << 0.1 * k;
  // Halfway between two points: the mean of their voltages.
  EXPECT_NEAR(open_circuit_voltage_V(pack, 0.45), 6.0 * 0.5 * (3.80 + 3.84), 1e-12);
  EXPECT_EQ(open_circuit_voltage_V(pack, -0.2), open_circuit_voltage_V(pack, 0.0));
  EXPECT_EQ(open_circuit_voltage_V(pack, 1.3), open_circuit_voltage_V(pack, 1.0));
}

TEST(Battery, ConstantCurrentDrainsLinearlyAndChargesTheRcBranchExponentially) {
  const BatteryPack pack;
  BatteryState b = battery_start(pack);
  const double current_A = 12.0, dt_s = 1e-3;
  const int steps = 45000;  // 45 s, 1.5 RC time constants
  for (int k = 0; k < steps; ++k) advance_battery(pack, dt_s, current_A, b);
  const double t_s = steps * dt_s;
  // dSoC/dt = -I / (3600 Q): 12 A for 45 s out of 2.2 A h.
  EXPECT_NEAR(b.soc, 1.0 - current_A * t_s / (3600.0 * pack.capacity_Ah), 1e-12);
  // V1(t) = R1 I (1 - e^{-t / (R1 C1)}): the per-step update is this exponential's exact sampling.
  const double tau_s = pack.rc_resistance_ohm * pack.rc_capacitance_F;
  EXPECT_NEAR(b.rc_voltage_V, pack.rc_resistance_ohm * current_A * (1.0 - std::exp(-t_s / tau_s)),
              1e-12);
  EXPECT_NEAR(
      b.voltage_V,
      open_circuit_voltage_V(pack, b.soc) - b.rc_voltage_V - pack.series_resistance_ohm * current_A,
      1e-12);
  EXPECT_FALSE(b.depleted);
}

TEST(Battery, CurrentDeliversThePowerAtTheTerminalsOnTheHighVoltageBranch) {
  const BatteryPack pack;
  BatteryState b = battery_start(pack);
  b.soc = 0.37;
  b.rc_voltage_V = 0.2;
  const double e = open_circuit_voltage_V(pack, b.soc) - b.rc_voltage_V;
  for (const double power_W : {1.0, 350.0, 2000.0, 4000.0}) {
    const double i = battery_current_A(pack, b, power_W);
    const double v = e - pack.series_resistance_ohm * i;
    EXPECT_NEAR(v * i, power_W, 1e-9 * power_W) << power_W << " W";
    EXPECT_GT(v, 0.5 * e) << "the smaller current, at the higher voltage";
  }
  // Beyond the most the pack can give, E^2 / (4 R0), it gives that at I = E / (2 R0).
  const double most_W = e * e / (4.0 * pack.series_resistance_ohm);
  EXPECT_DOUBLE_EQ(battery_current_A(pack, b, 2.0 * most_W),
                   e / (2.0 * pack.series_resistance_ohm));
  EXPECT_EQ(battery_current_A(pack, b, 0.0), 0.0);
  EXPECT_EQ(battery_current_A(pack, b, -5.0), 0.0);  // no charging from the rotors
  // However much power is asked, the current stays bounded.
  EXPECT_DOUBLE_EQ(battery_current_A(pack, b, 1e300), e / (2.0 * pack.series_resistance_ohm));
}

TEST(Battery, CutsOffWhenTheChargeIsSpentAndThenGivesNothing) {
  BatteryPack pack;
  pack.capacity_Ah = 0.01;  // 36 C: 10 A empties it in 3.6 s
  BatteryState b = battery_start(pack);
  int steps = 0;
  while (!b.depleted && steps < 10000) {
    advance_battery(pack, 1e-3, 10.0, b);
    ++steps;
  }
  EXPECT_NEAR(steps, 3600, 1);  // 3600 within the rounding of the per-step decrement
  EXPECT_TRUE(b.depleted);
  EXPECT_EQ(b.current_A, 0.0);
  EXPECT_EQ(battery_current_A(pack, b, 100.0), 0.0);
}

TEST(Battery, CutsOffBelowTheCutoffVoltageWithoutTheSeriesDrop) {
  BatteryPack pack;
  pack.cutoff_voltage_V = 6.0 * 3.75;  // reached near SoC 0.25 at rest
  BatteryState b = battery_start(pack);
  b.soc = 0.26;
  // A current whose R0 drop alone would take the terminal below the cut-off does not trip it.
  advance_battery(pack, 1e-3, 100.0, b);
  EXPECT_LT(b.voltage_V, pack.cutoff_voltage_V);
  EXPECT_FALSE(b.depleted);
  // Running on, the falling charge and the charging RC branch take E - V1 below it.
  while (!b.depleted && b.soc > 0.2) advance_battery(pack, 1e-3, 100.0, b);
  EXPECT_TRUE(b.depleted);
  EXPECT_GT(b.soc, 0.24);
}

TEST(Battery, SpeedCapIsTheSpeedWhereItEqualsTheMotorConstantTimesTheSaggedVoltage) {
  const auto model = test::load_model("qdrone2");
  const BatteryPack pack;
  const BatteryState b = battery_start(pack);
  const int n = model->num_rotors();
  // Hover references draw little: no cap below them.
  const RotorVector hover = model->hover_speeds_rad_s();
  EXPECT_EQ(battery_speed_cap_rad_s(*model, pack, b, hover), hover.maxCoeff());
  // Full throttle: the cap c solves c = K_V V(P(c)) (Eq. 2.21), V the terminal voltage while
  // every rotor turns at c.
  const RotorVector full = RotorVector::Constant(n, model->rotor(0).max_speed_rad_s);
  const double c = battery_speed_cap_rad_s(*model, pack, b, full);
  ASSERT_LT(c, full[0]);
  const double power_W =
      n * model->rotor(0).thrust(c) * model->rotor(0).yaw_moment_per_thrust_m * c / pack.efficiency;
  EXPECT_NEAR(c, pack.motor_speed_constant_rad_per_V_s * terminal_voltage_V(pack, b, power_W),
              1e-6 * c);
  // A cut-off pack allows nothing.
  BatteryState empty = b;
  empty.depleted = true;
  EXPECT_EQ(battery_speed_cap_rad_s(*model, pack, empty, full), 0.0);
  EXPECT_EQ(terminal_voltage_V(pack, empty, 10.0), 0.0);
}

}  // namespace
}  // namespace dronetwin
