// Torque-free rigid body: with no forces and moments the Newton-Euler equations conserve the
// rotational kinetic energy 1/2 w.J w and the world-frame angular momentum R J w, and a spin
// about the intermediate principal axis is unstable (the tennis-racket / Dzhanibekov flip).

#include <gtest/gtest.h>

#include <algorithm>

#include "dronetwin/dynamics/rigid_body.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

// A QDrone2 airframe whose rotors produce nothing at rest (T(0) = 0), flown with all
// disturbances off, gravity off and no ground: a free rigid body.
Simulator free_body(double dt_s) {
  VehicleSpec spec = test::load_model("qdrone2")->spec();
  for (auto& r : spec.rotors) r.thrust_coefficients = {1.9533e-6, 0.0, 0.0};
  SimConfig cfg;
  cfg.dt_s = dt_s;
  cfg.disturbances = DisturbanceSwitches::none();
  cfg.environment.gravity_W_m_s2.setZero();
  cfg.ground.enabled = false;
  return Simulator(std::make_shared<const VehicleModel>(spec), cfg);
}

Vec3 angular_momentum_W(const StateVector& x, const Mat3& J) {
  const Mat3 R = math::rotation_matrix<double>(x.segment<4>(6));
  return R * (J * x.segment<3>(10));
}

TEST(RigidBody, TorqueFreeMotionConservesEnergyAndAngularMomentum) {
  Simulator sim = free_body(1e-3);
  StateVector x0 = Simulator::hover_state(Vec3::Zero());
  x0.segment<3>(10) << 1.5, -2.0, 3.0;  // a general tumble, all three axes
  sim.reset(x0);
  const Mat3 J = sim.model().inertia_kgm2();
  const double e0 = rotational_energy(x0, J);
  const Vec3 h0 = angular_momentum_W(x0, J);
  double worst_e = 0, worst_h = 0;
  for (int k = 0; k < 100; ++k) {  // 100 s at 1 ms
    ASSERT_TRUE(sim.step(1000).ok());
    worst_e = std::max(worst_e, std::abs(rotational_energy(sim.state(), J) - e0) / e0);
    worst_h = std::max(worst_h, (angular_momentum_W(sim.state(), J) - h0).norm() / h0.norm());
  }
  EXPECT_LT(worst_e, 1e-8);
  EXPECT_LT(worst_h, 1e-8);
}

TEST(RigidBody, IntermediateAxisSpinFlips) {
  // J = diag(0.01472, 0.01691, 0.02945): y is the intermediate axis. A spin about y with a tiny
  // perturbation periodically reverses (w_y changes sign) while energy stays put.
  Simulator sim = free_body(1e-3);
  StateVector x0 = Simulator::hover_state(Vec3::Zero());
  x0.segment<3>(10) << 1e-3, 5.0, 1e-3;
  sim.reset(x0);
  double min_wy = 5.0;
  for (int k = 0; k < 60000; ++k) {
    ASSERT_TRUE(sim.step().ok());
    min_wy = std::min(min_wy, sim.state()[11]);
  }
  EXPECT_LT(min_wy, -4.9);  // essentially fully reversed

  // A spin about the major (z) or minor (x) axis with the same perturbation stays put.
  for (int axis : {10, 12}) {
    StateVector xs = Simulator::hover_state(Vec3::Zero());
    xs.segment<3>(10) << 1e-3, 1e-3, 1e-3;
    xs[axis] = 5.0;
    sim.reset(xs);
    double min_w = 5.0;
    for (int k = 0; k < 60000; ++k) {
      ASSERT_TRUE(sim.step().ok());
      min_w = std::min(min_w, sim.state()[axis]);
    }
    EXPECT_GT(min_w, 4.99) << "axis index " << axis;
  }
}

TEST(RigidBody, FullInertiaTensorIsUsed) {
  // With off-diagonal products of inertia, a spin about body z is not a principal spin: w_dot
  // is non-zero even without moments, and the energy is still conserved.
  VehicleSpec spec = test::load_model("qdrone2")->spec();
  spec.inertia_kgm2(0, 2) = spec.inertia_kgm2(2, 0) = 0.002;
  for (auto& r : spec.rotors) r.thrust_coefficients = {1.9533e-6, 0.0, 0.0};
  SimConfig cfg;
  cfg.disturbances = DisturbanceSwitches::none();
  cfg.environment.gravity_W_m_s2.setZero();
  cfg.ground.enabled = false;
  Simulator sim(std::make_shared<const VehicleModel>(spec), cfg);
  StateVector x0 = Simulator::hover_state(Vec3::Zero());
  x0[12] = 3.0;
  sim.reset(x0);
  // Euler's equations by hand at t = 0: J w_dot = -w x J w with w = (0, 0, 3):
  // J w = (0.002*3, 0, Jzz*3); w x Jw = (0*Jzz3 - 3*0, 3*0.006 - 0, 0) = (0, 0.018, 0).
  const StateVector xdot = sim.state_derivative();
  const Vec3 wdot_expected = spec.inertia_kgm2.inverse() * Vec3(0.0, -0.018, 0.0);
  EXPECT_LT((xdot.segment<3>(10) - wdot_expected).norm(), 1e-12);
  const double e0 = rotational_energy(x0, spec.inertia_kgm2);
  ASSERT_TRUE(sim.step(10000).ok());
  EXPECT_NEAR(rotational_energy(sim.state(), spec.inertia_kgm2), e0, 1e-9 * e0);
}

}  // namespace
}  // namespace dronetwin
