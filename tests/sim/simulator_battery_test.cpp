// The battery in a simulator (SimConfig::battery, power/battery.hpp): energy is conserved (the
// charge's chemical energy, the integral of the open-circuit voltage over the charge spent, equals
// the shaft power over the efficiency plus the resistive losses plus the RC branch's stored
// energy); a hover empties the pack within the bounds energy over power gives; the voltage sag
// caps full throttle at the speed where w = K_V V; a pack that does not cap changes nothing; bad
// settings are named.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "dronetwin/core/error.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using test::hovering;

SimConfig calm_with_battery() {
  SimConfig c;
  c.disturbances = DisturbanceSwitches::none();
  c.battery.enabled = true;
  return c;
}

/// Shaft power by hand: sum of (T_i / K_tau) w_i with T_i the thrust polynomial (Eq. 2.22-2.24).
double shaft_power_W(const VehicleModel& model, const RotorVector& w) {
  double p = 0.0;
  for (int i = 0; i < model.num_rotors(); ++i) {
    const auto& k = model.rotor(i).thrust_coefficients;
    const double thrust_N = (k[0] * w[i] + k[1]) * w[i] + k[2];
    p += std::max(thrust_N, 0.0) * model.rotor(i).yaw_moment_per_thrust_m * w[i];
  }
  return p;
}

/// 3600 Q n_s times the integral of the (piecewise-linear) cell voltage from soc_end to soc_start:
/// the chemical energy the charge spent carried, J.
double chemical_energy_J(const BatteryPack& pack, double soc_end, double soc_start) {
  const int pieces = 100000;  // a piecewise-linear integrand: the midpoint rule converges fast
  const double h = (soc_start - soc_end) / pieces;
  double sum = 0.0;
  for (int k = 0; k < pieces; ++k) sum += open_circuit_voltage_V(pack, soc_end + (k + 0.5) * h);
  return 3600.0 * pack.capacity_Ah * sum * h;
}

TEST(SimulatorBattery, ChemicalEnergyEqualsShaftWorkOverEfficiencyPlusLossesPlusStoredEnergy) {
  const auto model = test::load_model("qdrone2");
  const SimConfig c = calm_with_battery();
  const BatteryPack& pack = c.battery.pack;
  Simulator sim = hovering(model, c);
  const double dt_s = c.dt_s;
  double shaft_J = 0.0, r0_loss_J = 0.0, r1_loss_J = 0.0;
  const int steps = test::full_or_sanitized(120000, 20000);
  for (int k = 0; k < steps; ++k) {
    const double p_W = shaft_power_W(*model, sim.rotor_speeds_rad_s());
    const double v1_before = sim.battery().rc_voltage_V;
    ASSERT_TRUE(sim.step().ok());
    const BatteryState& b = sim.battery();
    shaft_J += p_W * dt_s;
    r0_loss_J += b.current_A * b.current_A * pack.series_resistance_ohm * dt_s;
    r1_loss_J += 0.5 * (v1_before * v1_before + b.rc_voltage_V * b.rc_voltage_V) /
                 pack.rc_resistance_ohm * dt_s;
  }
  const BatteryState& b = sim.battery();
  ASSERT_FALSE(b.depleted);
  // What reached the terminals is exactly the shaft work over the efficiency.
  EXPECT_NEAR(b.energy_drawn_J, shaft_J / pack.efficiency, 1e-9 * b.energy_drawn_J);
  const double stored_J = 0.5 * pack.rc_capacitance_F * b.rc_voltage_V * b.rc_voltage_V;
  const double chemical_J = chemical_energy_J(pack, b.soc, pack.initial_soc);
  const double accounted_J = shaft_J / pack.efficiency + r0_loss_J + r1_loss_J + stored_J;
  // The discrete update holds the current and the open-circuit voltage over a step: the balance
  // is off by O(dt) terms of order 1e-7 of the whole (docs/battery.md); the losses themselves are
  // 3 % of it.
  EXPECT_NEAR(accounted_J, chemical_J, 1e-5 * chemical_J)
      << "r0 loss " << r0_loss_J << " J, r1 loss " << r1_loss_J << " J, stored " << stored_J
      << " J";
  EXPECT_GT(r0_loss_J + r1_loss_J, 1e-3 * chemical_J);  // the loss terms matter to the balance
}

TEST(SimulatorBattery, HoverEmptiesThePackWithinTheTimeEnergyOverPowerBrackets) {
  const auto model = test::load_model("qdrone2");
  SimConfig c = calm_with_battery();
  c.battery.pack.initial_soc = test::kSanitized ? 0.01 : 0.1;
  const BatteryPack& pack = c.battery.pack;
  Simulator sim = hovering(model, c);
  const double electrical_W = shaft_power_W(*model, model->hover_speeds_rad_s()) / pack.efficiency;
  double max_current_A = 0.0;
  while (!sim.battery().depleted) {
    ASSERT_TRUE(sim.step().ok());
    max_current_A = std::max(max_current_A, sim.battery().current_A);
    ASSERT_LT(sim.time_s(), 1000.0);
  }
  const double t_s = sim.time_s();
  const double chemical_J = chemical_energy_J(pack, 0.0, pack.initial_soc);
  // Losses are >= 0, so the pack lasts at most chemical / electrical; they are at most
  // (R0 + R1) I_max^2 (V1 <= R1 I_max), so it lasts at least chemical / (electrical + that).
  const double loss_max_W =
      (pack.series_resistance_ohm + pack.rc_resistance_ohm) * max_current_A * max_current_A;
  EXPECT_LE(t_s, chemical_J / electrical_W);
  EXPECT_GE(t_s, chemical_J / (electrical_W + loss_max_W) - c.dt_s);
  // Cut off: the motors get no voltage, spin down, and the vehicle falls.
  ASSERT_TRUE(sim.step(300).ok());
  for (int i = 0; i < model->num_rotors(); ++i) EXPECT_LT(sim.rotor_speeds_rad_s()[i], 1.0);
  EXPECT_LT(sim.state()[state_index::kVelocity + 2], -2.0);
}

TEST(SimulatorBattery, VoltageSagCapsFullThrottleWhereSpeedEqualsMotorConstantTimesVoltage) {
  const auto model = test::load_model("qdrone2");
  SimConfig c = calm_with_battery();
  c.ground.enabled = false;
  Simulator sim = hovering(model, c);
  const double max_rad_s = model->rotor(0).max_speed_rad_s;
  sim.set_rotor_speed_reference(RotorVector::Constant(model->num_rotors(), max_rad_s));
  ASSERT_TRUE(sim.step(50).ok());  // 100 motor time constants
  const BatteryPack& pack = c.battery.pack;
  const BatteryState& b = sim.battery();
  const double w = sim.rotor_speeds_rad_s()[0];
  // The fixed point of w = K_V V(w) (Eq. 2.21 with the sag of the current w draws) ...
  EXPECT_NEAR(w, pack.motor_speed_constant_rad_per_V_s * b.voltage_V, 1e-3 * w);
  // ... well below the rotor's own limit, and with V I = P_shaft(w) / eta at the terminals.
  EXPECT_LT(w, 0.9 * max_rad_s);
  EXPECT_GT(w, 1.5 * model->hover_speeds_rad_s()[0]);
  EXPECT_NEAR(b.voltage_V * b.current_A,
              shaft_power_W(*model, sim.rotor_speeds_rad_s()) / pack.efficiency,
              2e-3 * b.voltage_V * b.current_A);
  EXPECT_FALSE(b.depleted);  // a punch does not trip the (load-compensated) cut-off
  // Without the battery the rotors reach their limit.
  SimConfig ideal = c;
  ideal.battery.enabled = false;
  Simulator free_sim = hovering(model, ideal);
  free_sim.set_rotor_speed_reference(RotorVector::Constant(model->num_rotors(), max_rad_s));
  ASSERT_TRUE(free_sim.step(50).ok());
  EXPECT_NEAR(free_sim.rotor_speeds_rad_s()[0], max_rad_s, 1e-6 * max_rad_s);
}

TEST(SimulatorBattery, APackThatDoesNotCapLeavesTheFlightBitwiseUnchanged) {
  const auto model = test::load_model("qdrone2");
  SimConfig with = calm_with_battery(), without = with;
  without.battery.enabled = false;
  Simulator a = hovering(model, with), b = hovering(model, without);
  ASSERT_TRUE(a.step(2000).ok());
  ASSERT_TRUE(b.step(2000).ok());
  EXPECT_EQ(a.state(), b.state());
  EXPECT_LT(a.battery().soc, 1.0);
  EXPECT_EQ(b.battery().soc, 1.0);
  // reset() restarts the pack; set_battery() swaps it.
  a.reset(Simulator::hover_state(Vec3(0.0, 0.0, 1.0)));
  EXPECT_EQ(a.battery().soc, 1.0);
  EXPECT_EQ(a.battery().current_A, 0.0);
  BatterySettings half = with.battery;
  half.pack.initial_soc = 0.5;
  a.set_battery(half);
  EXPECT_EQ(a.battery().soc, 0.5);
}

TEST(SimulatorBattery, BadSettingsAreNamed) {
  const auto model = test::load_model("qdrone2");
  const auto message = [&](auto&& edit) {
    SimConfig c = calm_with_battery();
    edit(c.battery.pack);
    return test::error_of([&] { Simulator sim(model, c); });
  };
  EXPECT_NE(message([](BatteryPack& p) {
              p.efficiency = 1.5;
            }).find("battery.efficiency: expected a fraction in (0, 1], got 1.5"),
            std::string::npos);
  EXPECT_NE(message([](BatteryPack& p) { p.ocv_cell_V[4] = 3.0; }).find("battery.ocv_cell_V[4]"),
            std::string::npos);
  EXPECT_NE(message([](BatteryPack& p) { p.initial_soc = 0.0; }).find("battery.initial_soc"),
            std::string::npos);
  EXPECT_NE(message([](BatteryPack& p) { p.capacity_Ah = -1.0; }).find("battery.capacity_Ah"),
            std::string::npos);
  EXPECT_NE(message([](BatteryPack& p) {
              p.series_resistance_ohm = 0.0;
            }).find("battery.series_resistance_ohm: expected > 0 ohm"),
            std::string::npos);
  EXPECT_NE(message([](BatteryPack& p) { p.cells_in_series = 0; }).find("battery.cells_in_series"),
            std::string::npos);
  Simulator sim(model, calm_with_battery());
  BatterySettings bad;
  bad.pack.rc_capacitance_F = std::nan("");
  EXPECT_NE(test::error_of([&] { sim.set_battery(bad); }).find("battery.rc_capacitance_F"),
            std::string::npos);
}

}  // namespace
}  // namespace dronetwin
