// The battery in the batched engine (BatchSimulator with SimConfig::battery): every lane drains
// its own pack and equals a Simulator with the same pack to round-off, while the sag caps its
// rotors and when it cuts off (also with a lost-effectiveness fault and with a lane's own thrust
// curve, both of which the shaft power follows); a lane reset gives it a full pack; results are
// bitwise independent of threads and batch size.

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <vector>

#include "dronetwin/batch/batch_simulator.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

/// A small 3S pack: K_V times its ~11 V caps the rotors near 1500 rad/s (hover 1174), and 25 mAh
/// last about three seconds at hover, so the cap binds and packs cut off within the test.
SimConfig battery_config() {
  SimConfig c;
  c.battery.enabled = true;
  c.battery.pack.cells_in_series = 3;
  c.battery.pack.cutoff_voltage_V = 9.0;
  c.battery.pack.capacity_Ah = 0.025;
  c.faults.rotor[0] = RotorFault{RotorFaultKind::kEffectiveness, 0, 0.3, 0.7};
  c.faults.num_rotor_faults = 1;
  return c;
}

StateVector start_of(int l) { return Simulator::hover_state(Vec3(0.3 * l, 0.0, 50.0)); }

/// Lane l's references: from below hover to well above what the pack can drive.
RotorVector reference_of(const VehicleModel& model, int l) {
  return model.hover_speeds_rad_s() * (0.9 + 0.25 * l);
}

TEST(BatchBattery, EveryLaneEqualsASimulatorWithTheSamePack) {
  const auto model = test::load_model("qdrone2");
  const SimConfig c = battery_config();
  constexpr int kLanes = 5, kSteps = 3000;
  BatchSimulator<double> batch(model, c, kLanes, 2);
  // Lane 2 has its own thrust curve (K1 8 % up); its Simulator flies the edited model.
  constexpr int kEdited = 2;
  const double k1 = 1.08 * parameter_value(model->parameters(), ModelParameter::kThrustK1);
  batch.set_parameter(ModelParameter::kThrustK1, kEdited, k1);
  VehicleSpec spec = model->spec();
  set_parameter_value(spec, ModelParameter::kThrustK1, k1);
  const auto edited = std::make_shared<const VehicleModel>(spec);
  std::vector<Simulator> sims;
  for (int l = 0; l < kLanes; ++l) {
    sims.emplace_back(l == kEdited ? edited : model, c);
    batch.reset(l, start_of(l), model->hover_speeds_rad_s());
    batch.set_rotor_speed_reference(l, reference_of(*model, l));
    sims.back().reset(start_of(l), model->hover_speeds_rad_s());
    sims.back().set_rotor_speed_reference(reference_of(*model, l));
  }
  bool capped = false;
  for (int k = 1; k <= kSteps; ++k) {
    ASSERT_EQ(batch.step(1), 0) << "step " << k;
    for (int l = 0; l < kLanes; ++l) {
      Simulator& sim = sims[static_cast<std::size_t>(l)];
      ASSERT_TRUE(sim.step().ok()) << sim.failure_message();
      const BatteryState& b = batch.battery(l);
      const BatteryState& s = sim.battery();
      SCOPED_TRACE(testing::Message() << "lane " << l << " step " << k);
      ASSERT_EQ(b.depleted, s.depleted);
      ASSERT_NEAR(b.soc, s.soc, 1e-12);
      ASSERT_NEAR(b.voltage_V, s.voltage_V, 1e-9);
      ASSERT_NEAR(b.current_A, s.current_A, 1e-9);
      if (k % 50 != 0) continue;
      const StateVector gap = batch.state(l) - sim.state();
      ASSERT_LE(gap.cwiseAbs().maxCoeff(), 1e-9 * (1.0 + sim.state().cwiseAbs().maxCoeff()));
      const RotorVector speed_gap = batch.rotor_speeds(l) - sim.rotor_speeds_rad_s();
      ASSERT_LE(speed_gap.cwiseAbs().maxCoeff(), 1e-9 * 3000.0);
      const RotorVector w = sim.rotor_speeds_rad_s();
      if (!s.depleted && w.maxCoeff() < 0.99 * reference_of(*model, l).maxCoeff()) capped = true;
    }
  }
  // What the test covered: the cap bound some lane, the lanes that drew most cut off, and the
  // one below hover still had charge at its end.
  EXPECT_TRUE(capped);
  EXPECT_TRUE(batch.battery(kLanes - 1).depleted);
  EXPECT_FALSE(batch.battery(0).depleted);
  EXPECT_LT(batch.battery(0).soc, 0.5);
  // A cut-off pack stops the rotors (towards their minimum speed).
  EXPECT_LT(batch.rotor_speeds(kLanes - 1).maxCoeff(), 0.2 * model->hover_speeds_rad_s()[0]);
}

TEST(BatchBattery, AResetGivesTheLaneAFullPack) {
  const auto model = test::load_model("qdrone2");
  BatchSimulator<double> batch(model, battery_config(), 2, 1);
  for (int l = 0; l < 2; ++l) {
    batch.reset(l, start_of(l), model->hover_speeds_rad_s());
    batch.set_rotor_speed_reference(l, model->hover_speeds_rad_s());
  }
  batch.step(500);
  const double drawn = batch.battery(1).soc;
  EXPECT_LT(drawn, 0.9);
  batch.reset(0, start_of(0), model->hover_speeds_rad_s());
  EXPECT_EQ(batch.battery(0).soc, battery_config().battery.pack.initial_soc);
  EXPECT_EQ(batch.battery(0).energy_drawn_J, 0.0);
  EXPECT_EQ(batch.battery(1).soc, drawn);
}

std::vector<double> fly(int n, int threads) {
  const auto model = test::load_model("qdrone2");
  BatchSimulator<double> batch(model, battery_config(), n, threads);
  for (int l = 0; l < n; ++l) {
    batch.reset(l, start_of(l % 5), model->hover_speeds_rad_s());
    batch.set_rotor_speed_reference(l, reference_of(*model, l % 5));
  }
  batch.step(700);
  batch.reset(0, start_of(0), model->hover_speeds_rad_s());
  batch.step(900);
  std::vector<double> out;
  for (int l = 0; l < n; ++l) {
    const StateVector x = batch.state(l);
    out.insert(out.end(), x.data(), x.data() + kStateSize);
    const BatteryState& b = batch.battery(l);
    out.insert(out.end(), {b.soc, b.voltage_V, b.current_A, b.rc_voltage_V, b.energy_drawn_J});
  }
  return out;
}

TEST(BatchBattery, BitwiseAcrossThreadsAndBatchSizes) {
  const std::vector<double> one = fly(7, 1);
  EXPECT_EQ(one, fly(7, 2));
  const std::vector<double> single = fly(1, 1);
  EXPECT_TRUE(std::equal(single.begin(), single.end(), one.begin()));
  const std::vector<double> many = fly(40, 2);
  EXPECT_TRUE(std::equal(one.begin(), one.end(), many.begin()));
}

}  // namespace
}  // namespace dronetwin
