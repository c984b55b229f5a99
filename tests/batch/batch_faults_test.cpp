// Rotor faults in the batched engine (BatchSimulator with SimConfig::faults): every lane carries
// the faults on its own clock, from its own reset, and equals a Simulator with the same faults to
// round-off (lost effectiveness in a rebuilt pack kernel, a stopped rotor, a stuck motor); a lane
// reset after its faults began flies the nominal vehicle again until they begin anew; results are
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

/// Four faults, listed out of start order: the kernels must scale them in the Simulator's order.
SimConfig faulty_config() {
  SimConfig c;
  c.faults.rotor[0] = RotorFault{RotorFaultKind::kEffectiveness, 0, 0.20, 0.6};
  c.faults.rotor[1] = RotorFault{RotorFaultKind::kStuck, 1, 0.35, 1.0};
  c.faults.rotor[2] = RotorFault{RotorFaultKind::kStop, 2, 0.50, 1.0};
  c.faults.rotor[3] = RotorFault{RotorFaultKind::kEffectiveness, 3, 0.10, 0.8};
  c.faults.num_rotor_faults = 4;
  return c;
}

StateVector start_of(int l) { return Simulator::hover_state(Vec3(0.2 * l, 0.0, 10.0)); }

/// Lane l's references: hover with a lane-dependent offset, so that the lanes differ.
RotorVector reference_of(const VehicleModel& model, int l) {
  RotorVector w = model.hover_speeds_rad_s();
  w[0] += 5.0 * l;
  w[1] -= 3.0 * l;
  return w;
}

TEST(BatchFaults, EveryLaneOnItsOwnClockEqualsASimulatorWithTheSameFaults) {
  const auto model = test::load_model("qdrone2");
  const SimConfig c = faulty_config();
  constexpr int kLanes = 5, kSteps = 900;
  BatchSimulator<double> batch(model, c, kLanes, 2);
  std::vector<Simulator> sims;
  const auto restart = [&](int l) {
    batch.reset(l, start_of(l), model->hover_speeds_rad_s());
    batch.set_rotor_speed_reference(l, reference_of(*model, l));
    Simulator& sim = sims[static_cast<std::size_t>(l)];
    sim.reset(start_of(l), model->hover_speeds_rad_s());
    sim.set_rotor_speed_reference(reference_of(*model, l));
  };
  for (int l = 0; l < kLanes; ++l) sims.emplace_back(model, c);
  for (int l = 0; l < kLanes; ++l) restart(l);
  const RotorVector hover = model->hover_speeds_rad_s();
  for (int k = 1; k <= kSteps; ++k) {
    // Lane l starts again at step 120 l: after some of its faults began (they end with the
    // reset and begin again on its new clock).
    for (int l = 1; l < kLanes; ++l)
      if (k == 120 * l + 1) restart(l);
    ASSERT_EQ(batch.step(1), 0) << "step " << k;
    for (int l = 0; l < kLanes; ++l) {
      Simulator& sim = sims[static_cast<std::size_t>(l)];
      ASSERT_TRUE(sim.step().ok()) << sim.failure_message();
      if (k % 50 != 0 && k != 121) continue;
      SCOPED_TRACE(testing::Message() << "lane " << l << " step " << k);
      const StateVector gap = batch.state(l) - sim.state();
      ASSERT_LE(gap.cwiseAbs().maxCoeff(), 1e-9 * (1.0 + sim.state().cwiseAbs().maxCoeff()));
      const RotorVector speed_gap = batch.rotor_speeds(l) - sim.rotor_speeds_rad_s();
      ASSERT_LE(speed_gap.cwiseAbs().maxCoeff(), 1e-9 * hover.maxCoeff());
    }
  }
  // Lost effectiveness is felt: lane 0 tilted and sank, against a fault-free lane.
  BatchSimulator<double> nominal(model, SimConfig{}, 1, 1);
  nominal.reset(0, start_of(0), hover);
  nominal.set_rotor_speed_reference(0, reference_of(*model, 0));
  nominal.step(kSteps);
  EXPECT_GT((batch.state(0) - nominal.state(0)).head<3>().norm(), 0.1);
  // Lane 0 ran all 0.9 s: its rotor 2 stopped (spun down towards its minimum); rotor 1 is stuck
  // and ignores a new reference that rotor 3 follows.
  EXPECT_LT(batch.rotor_speeds(0)[2], 0.2 * hover[2]);
  const RotorVector before = batch.rotor_speeds(0);
  batch.set_rotor_speed_reference(0, hover + RotorVector::Constant(hover.size(), 80.0));
  batch.step(50);
  EXPECT_EQ(batch.rotor_speeds(0)[1], before[1]);
  EXPECT_GT(batch.rotor_speeds(0)[3], before[3] + 40.0);
}

std::vector<double> fly(int n, int threads) {
  const auto model = test::load_model("qdrone2");
  BatchSimulator<double> batch(model, faulty_config(), n, threads);
  for (int l = 0; l < n; ++l) {
    batch.reset(l, start_of(l % 5), model->hover_speeds_rad_s());
    batch.set_rotor_speed_reference(l, reference_of(*model, l % 5));
  }
  batch.step(300);
  batch.reset(0, start_of(0), model->hover_speeds_rad_s());  // lane 0 on a later clock
  batch.step(400);
  std::vector<double> out;
  for (int l = 0; l < n; ++l) {
    const StateVector x = batch.state(l);
    out.insert(out.end(), x.data(), x.data() + kStateSize);
    const RotorVector w = batch.rotor_speeds(l);
    out.insert(out.end(), w.data(), w.data() + w.size());
  }
  return out;
}

TEST(BatchFaults, BitwiseAcrossThreadsAndBatchSizes) {
  const std::vector<double> one = fly(7, 1);
  EXPECT_EQ(one, fly(7, 2));
  const std::vector<double> single = fly(1, 1);
  EXPECT_TRUE(std::equal(single.begin(), single.end(), one.begin()));
  const std::vector<double> many = fly(64, 2);
  EXPECT_TRUE(std::equal(one.begin(), one.end(), many.begin()));
}

TEST(BatchFaults, AFaultOnARotorTheModelLacksIsNamed) {
  const auto model = test::load_model("qdrone2");
  SimConfig c;
  c.faults.rotor[0] = RotorFault{RotorFaultKind::kStop, 5, 1.0, 1.0};
  c.faults.num_rotor_faults = 1;
  EXPECT_NE(test::error_of([&] {
              BatchSimulator<double> b(model, c, 4);
            }).find("faults[0].rotor: expected 0 .. 3"),
            std::string::npos);
}

}  // namespace
}  // namespace dronetwin
