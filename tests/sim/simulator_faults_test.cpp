// Rotor faults in a simulator (SimConfig::faults, faults/rotor_fault.hpp): before its start a
// faulted run is the nominal run bit for bit; at the step nearest the start a lost-effectiveness
// fault changes the acceleration by exactly the lost thrust's force and moment (a hand
// calculation from the rotor's parameters); a stopped rotor spins down along its motor lag's
// exponential; a stuck rotor ignores its reference; reset() clears them; bad settings are named.

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "dronetwin/batch/batch_simulator.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using test::hovering;

using namespace state_index;

SimConfig calm() {
  SimConfig c;
  c.disturbances = DisturbanceSwitches::none();  // thrust and yaw reaction only
  return c;
}

FaultSettings one(RotorFaultKind kind, int rotor, double start_s, double effectiveness = 1.0) {
  FaultSettings f;
  f.rotor[0] = RotorFault{kind, rotor, start_s, effectiveness};
  f.num_rotor_faults = 1;
  return f;
}

TEST(SimulatorFaults, LostEffectivenessTakesAwayThatThrustFromTheStepNearestItsStart) {
  const auto model = test::load_model("qdrone2");
  SimConfig c = calm();
  c.faults = one(RotorFaultKind::kEffectiveness, 1, 0.1004, 0.5);  // nearest step: t = 0.100
  Simulator faulted = hovering(model, c), nominal = hovering(model, calm());
  ASSERT_TRUE(faulted.step(100).ok());  // t = 0.1 s: the fault acts from this step on
  ASSERT_TRUE(nominal.step(100).ok());
  EXPECT_EQ(faulted.state(), nominal.state());  // untouched before
  EXPECT_EQ(faulted.rotor_speeds_rad_s(), nominal.rotor_speeds_rad_s());
  // The derivative now differs by the lost half of rotor 1's thrust: force -T/2 a and moment
  // r x (-T/2 a) plus the yaw reaction spin k T/2 (-a) about the axis.
  const RotorParams& r = model->rotor(1);
  const double w = nominal.rotor_speeds_rad_s()[1];
  const double thrust_N =
      (r.thrust_coefficients[0] * w + r.thrust_coefficients[1]) * w + r.thrust_coefficients[2];
  const Vec3 lost_force_B = -0.5 * thrust_N * r.axis;
  const Vec3 lost_moment_B = r.position_m.cross(lost_force_B) +
                             r.spin * r.yaw_moment_per_thrust_m * lost_force_B.dot(r.axis) * r.axis;
  const StateVector delta = faulted.state_derivative() - nominal.state_derivative();
  const Mat3 R = math::rotation_matrix<double>(nominal.state().segment<4>(kQuaternion));
  EXPECT_LE((delta.segment<3>(kVelocity) - R * lost_force_B / model->mass_kg()).norm(), 1e-12);
  EXPECT_LE((delta.segment<3>(kAngularVelocity) - model->inertia_inverse() * lost_moment_B).norm(),
            1e-9);
  // The breakdown's thrust term lost the same force.
  const Vec3 thrust_gap = faulted.wrench_breakdown()[Term::kThrust].force_B -
                          nominal.wrench_breakdown()[Term::kThrust].force_B;
  EXPECT_LE((thrust_gap - lost_force_B).norm(), 1e-12);
  // Left alone the vehicle now rolls and drops; reset() brings back the nominal vehicle.
  ASSERT_TRUE(faulted.step(200).ok());
  EXPECT_GT(faulted.state().segment<3>(kAngularVelocity).norm(), 0.1);
  faulted.reset(Simulator::hover_state(Vec3(0.0, 0.0, 2.0)), model->hover_speeds_rad_s());
  EXPECT_EQ(faulted.state_derivative(), hovering(model, calm()).state_derivative());
}

TEST(SimulatorFaults, AStoppedRotorSpinsDownAlongItsMotorLag) {
  const auto model = test::load_model("qdrone2");
  SimConfig c = calm();
  c.faults = one(RotorFaultKind::kStop, 2, 0.05);
  Simulator sim = hovering(model, c);
  ASSERT_TRUE(sim.step(50).ok());
  const double w0 = sim.rotor_speeds_rad_s()[2];
  const double tau = model->rotor(2).time_constant_fall_s;
  ASSERT_GT(tau, 0.0);
  for (int k = 1; k <= 5; ++k) {
    ASSERT_TRUE(sim.step().ok());
    // Eq. 2.45 with a zero reference: w_k = w_0 e^{-k dt / tau}.
    EXPECT_NEAR(sim.rotor_speeds_rad_s()[2], w0 * std::exp(-k * c.dt_s / tau), 1e-9 * w0);
    EXPECT_EQ(sim.rotor_speeds_rad_s()[0], model->hover_speeds_rad_s()[0]);  // the others hold
  }
  // Whatever the reference asks.
  sim.set_rotor_speed_reference(RotorVector::Constant(4, 2000.0));
  ASSERT_TRUE(sim.step(50).ok());
  EXPECT_LT(sim.rotor_speeds_rad_s()[2], 1.0);
  EXPECT_GT(sim.rotor_speeds_rad_s()[0], 1900.0);
}

TEST(SimulatorFaults, AStuckRotorKeepsItsSpeedWhateverTheReference) {
  const auto model = test::load_model("qdrone2");
  SimConfig c = calm();
  c.faults = one(RotorFaultKind::kStuck, 0, 0.02);
  Simulator sim = hovering(model, c);
  ASSERT_TRUE(sim.step(20).ok());
  const double stuck = sim.rotor_speeds_rad_s()[0];
  sim.set_rotor_speed_reference(RotorVector::Constant(4, 1500.0));
  ASSERT_TRUE(sim.step(100).ok());
  EXPECT_EQ(sim.rotor_speeds_rad_s()[0], stuck);
  EXPECT_NEAR(sim.rotor_speeds_rad_s()[1], 1500.0, 1e-6);
  EXPECT_EQ(sim.data().active_faults, 1u);
}

TEST(SimulatorFaults, SetFaultsMidRunActsFromTheNextStep) {
  const auto model = test::load_model("qdrone2");
  Simulator sim = hovering(model, calm()), reference = hovering(model, calm());
  ASSERT_TRUE(sim.step(30).ok());
  ASSERT_TRUE(reference.step(30).ok());
  sim.set_faults(one(RotorFaultKind::kEffectiveness, 3, 0.0, 0.0));  // started long ago: at once
  EXPECT_NE(sim.state_derivative(), reference.state_derivative());
  sim.set_faults(FaultSettings{});
  EXPECT_EQ(sim.state_derivative(), reference.state_derivative());
}

std::string error_of(const SimConfig& c, const std::shared_ptr<const VehicleModel>& model) {
  try {
    Simulator sim(model, c);
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  return "no error";
}

TEST(SimulatorFaults, BadSettingsAreNamed) {
  const auto model = test::load_model("qdrone2");
  SimConfig c;
  c.faults = one(RotorFaultKind::kStop, 4, 1.0);
  EXPECT_NE(
      error_of(c, model).find("faults[0].rotor: expected 0 .. 3 (rotors of 'qdrone2'), got 4"),
      std::string::npos)
      << error_of(c, model);
  c.faults = one(RotorFaultKind::kEffectiveness, 0, 1.0, 1.5);
  EXPECT_NE(error_of(c, model).find("faults[0].effectiveness: expected a fraction in [0, 1]"),
            std::string::npos);
  c.faults = one(RotorFaultKind::kStuck, 0, std::nan(""));
  EXPECT_NE(error_of(c, model).find("faults[0].start_s: expected a finite time"),
            std::string::npos);
  // The batched engine names a rotor the model lacks as well (tests/batch/batch_faults_test.cpp
  // flies the faults it takes).
  c.faults = one(RotorFaultKind::kStuck, 5, 1.0);
  try {
    BatchSimulator<double> batch(model, c, 2, 1);
    ADD_FAILURE() << "no error";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("faults[0].rotor: expected 0 .. 3"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace dronetwin
