// FaultSettings (faults/rotor_fault.hpp): the order in which lost-effectiveness faults compose
// (by start time, ties in list order, other kinds left out), shared by the Simulator and the
// batched engine, and the active-fault mask at the step nearest each start.

#include "dronetwin/faults/rotor_fault.hpp"

#include <gtest/gtest.h>

namespace dronetwin {
namespace {

TEST(RotorFaultOrder, ByStartTimeTiesInListOrderOtherKindsLeftOut) {
  FaultSettings f;
  f.rotor[0] = {RotorFaultKind::kEffectiveness, 0, 3.0, 0.5};
  f.rotor[1] = {RotorFaultKind::kStop, 1, 1.0, 1.0};
  f.rotor[2] = {RotorFaultKind::kEffectiveness, 2, 1.0, 0.8};
  f.rotor[3] = {RotorFaultKind::kEffectiveness, 3, 3.0, 0.9};
  f.rotor[4] = {RotorFaultKind::kEffectiveness, 1, 0.5, 0.7};
  f.rotor[5] = {RotorFaultKind::kStuck, 0, 0.0, 1.0};
  f.num_rotor_faults = 6;
  std::array<int, kMaxRotorFaults> order{};
  ASSERT_EQ(f.effectiveness_order(order), 4);
  EXPECT_EQ(order[0], 4);  // 0.5 s
  EXPECT_EQ(order[1], 2);  // 1.0 s
  EXPECT_EQ(order[2], 0);  // 3.0 s, listed before fault 3
  EXPECT_EQ(order[3], 3);
  EXPECT_EQ(FaultSettings{}.effectiveness_order(order), 0);
}

TEST(RotorFaultOrder, ActiveFromTheStepNearestTheStart) {
  FaultSettings f;
  f.rotor[0] = {RotorFaultKind::kStop, 0, 0.0104, 1.0};
  f.rotor[1] = {RotorFaultKind::kStop, 1, 0.02, 1.0};
  f.num_rotor_faults = 2;
  const double dt = 0.001;
  // 10.4 ms is nearest the step at 10 ms: the fault acts on that step, not on the one before.
  EXPECT_EQ(f.active_at(0.009, dt), 0u);
  EXPECT_EQ(f.active_at(0.010, dt), 1u);
  EXPECT_EQ(f.active_at(0.019, dt), 1u);
  EXPECT_EQ(f.active_at(0.020, dt), 3u);
}

}  // namespace
}  // namespace dronetwin
