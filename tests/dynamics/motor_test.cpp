// Motor lag (thesis Eq. 2.43-2.45): the exact discretisation must reproduce the continuous
// first-order step response w(t) = w_ref + (w0 - w_ref) e^{-t/tau} at every sample, with the rise
// constant going up and the fall constant going down.

#include <gtest/gtest.h>

#include <cmath>

#include "dronetwin/dynamics/motor.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

std::shared_ptr<const VehicleModel> model_with_time_constants(double rise_s, double fall_s) {
  VehicleSpec spec = test::load_model("qdrone2")->spec();
  for (auto& r : spec.rotors) {
    r.time_constant_rise_s = rise_s;
    r.time_constant_fall_s = fall_s;
  }
  return std::make_shared<const VehicleModel>(spec);
}

TEST(Motor, StepResponseFollowsTheExponentialLawRisingAndFalling) {
  const double tau_rise = 5e-4, tau_fall = 2e-3, dt = 1e-4;
  const auto model = model_with_time_constants(tau_rise, tau_fall);
  const MotorDiscretization d = discretize_motors(*model, dt);
  RotorVector w = RotorVector::Zero(4), ref = RotorVector::Constant(4, 1500.0);
  for (int k = 1; k <= 50; ++k) {
    advance_motors(*model, d, ref, w);
    const double expected = 1500.0 * (1.0 - std::exp(-k * dt / tau_rise));
    EXPECT_NEAR(w[0], expected, 1e-9 * 1500.0) << "rising, step " << k;
  }
  const double w_top = w[0];
  ref.setConstant(300.0);
  for (int k = 1; k <= 50; ++k) {
    advance_motors(*model, d, ref, w);
    const double expected = 300.0 + (w_top - 300.0) * std::exp(-k * dt / tau_fall);
    EXPECT_NEAR(w[3], expected, 1e-9 * 1500.0) << "falling, step " << k;
  }
}

TEST(Motor, TimeConstantIsTheTimeTo63Percent) {
  // After exactly one time constant the response has covered 1 - 1/e of the step.
  const double tau = 5e-4;
  const auto model = model_with_time_constants(tau, tau);
  const MotorDiscretization d = discretize_motors(*model, tau / 10);
  RotorVector w = RotorVector::Zero(4), ref = RotorVector::Constant(4, 1000.0);
  for (int k = 0; k < 10; ++k) advance_motors(*model, d, ref, w);
  EXPECT_NEAR(w[1] / 1000.0, 1.0 - std::exp(-1.0), 1e-12);
}

TEST(Motor, ReferenceIsClampedToTheSpeedLimits) {
  const auto model = test::load_model("qdrone2");  // [0, 3400] rad/s
  const MotorDiscretization d = discretize_motors(*model, 1e-3);
  RotorVector w = RotorVector::Zero(4), ref(4);
  ref << 5000.0, -200.0, 3400.0, 1000.0;
  for (int k = 0; k < 200; ++k) advance_motors(*model, d, ref, w);
  EXPECT_NEAR(w[0], 3400.0, 1e-9);
  EXPECT_NEAR(w[1], 0.0, 1e-9);
  EXPECT_NEAR(w[2], 3400.0, 1e-9);
  EXPECT_NEAR(w[3], 1000.0, 1e-9);
}

TEST(Motor, SimulatorAppliesTheLagAfterTheForces) {
  // Notes #25: forces use the current speed; the filter then advances. After n steps from rest
  // with tau = 0.5 ms and dt = 1 ms the speed is ref (1 - e^{-2n}).
  const auto model = test::load_model("qdrone2");
  Simulator sim(model);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 5)));
  sim.set_rotor_speed_reference(RotorVector::Constant(4, 1200.0));
  sim.step();
  EXPECT_NEAR(sim.rotor_speeds_rad_s()[0], 1200.0 * (1 - std::exp(-2.0)), 1e-9);
  sim.step();
  EXPECT_NEAR(sim.rotor_speeds_rad_s()[0], 1200.0 * (1 - std::exp(-4.0)), 1e-9);
}

TEST(Motor, DisabledMotorDynamicsFollowTheReferenceAtOnce) {
  SimConfig cfg;
  cfg.motor_dynamics = false;
  Simulator sim(test::load_model("qdrone2"), cfg);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 5)));
  sim.set_rotor_speed_reference(RotorVector::Constant(4, 4000.0));
  sim.step();
  EXPECT_EQ(sim.rotor_speeds_rad_s()[2], 3400.0);  // clamped
}

}  // namespace
}  // namespace dronetwin
