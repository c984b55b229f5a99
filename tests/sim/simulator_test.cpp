// Simulator behaviour: equilibria and analytic trajectories, determinism, input validation,
// failure detection and ground contact.

#include <gtest/gtest.h>

#include <cmath>
#include <thread>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

constexpr double kMass = 1.504;  // thesis Table 2.1
constexpr double kK3 = -0.0121;  // thrust at w = 0, thesis Eq. 2.22

Simulator hovering(SimConfig cfg, double z) {
  const auto model = test::load_model("qdrone2");
  Simulator sim(model, cfg);
  sim.reset(Simulator::hover_state(Vec3(0.3, -0.2, z), 0.4), model->hover_speeds_rad_s());
  sim.set_rotor_speed_reference(model->hover_speeds_rad_s());
  return sim;
}

TEST(Simulator, AllocationDerivedHoverHoldsPosition) {
  // Noise off, every disturbance on except the ground effect (the allocation hover trim does not
  // include it). At rest the drag terms vanish, so the hover speeds balance gravity exactly.
  SimConfig cfg;
  cfg.disturbances.ground_effect = false;
  Simulator sim = hovering(cfg, 1.0);
  const StateVector x0 = sim.state();
  ASSERT_TRUE(sim.step(10000).ok());  // 10 s
  EXPECT_LT((sim.state().head<3>() - x0.head<3>()).norm(), 1e-6);
}

TEST(Simulator, HoverHoldsHighAboveTheGroundWithEveryTermOn) {
  // At 1 km the ground-effect term is C_G / h^2 = 6e-10 of the thrust: drift < 1e-6 m in 10 s.
  Simulator sim = hovering(SimConfig{}, 1000.0);
  const StateVector x0 = sim.state();
  ASSERT_TRUE(sim.step(10000).ok());
  EXPECT_LT((sim.state().head<3>() - x0.head<3>()).norm(), 1e-6);
}

SimConfig falling_config(bool body_drag) {
  SimConfig cfg;
  cfg.disturbances = DisturbanceSwitches::none();
  cfg.disturbances.body_drag = body_drag;
  cfg.ground.enabled = false;
  return cfg;
}

TEST(Simulator, FreeFallMatchesTheAnalyticParabola) {
  // Rotors stopped: each still gives T(0) = 'K3 (slightly negative, kept as printed, notes #17).
  Simulator sim(test::load_model("qdrone2"), falling_config(false));
  sim.reset(Simulator::hover_state(Vec3(0, 0, 10)));
  const double a = -9.81 + 4 * kK3 / kMass;
  for (int k = 1; k <= 10; ++k) {
    ASSERT_TRUE(sim.step(100).ok());
    const double t = 0.1 * k;
    EXPECT_NEAR(sim.state()[2], 10 + 0.5 * a * t * t, 1e-10);
    EXPECT_NEAR(sim.state()[5], a * t, 1e-10);
  }
}

TEST(Simulator, FallWithBodyDragApproachesTerminalVelocity) {
  // m v' = m a0 - A_zz v  =>  v(t) = (a0/k)(1 - e^{-kt}), z(t) = z0 + (a0/k)(t - (1 - e^{-kt})/k),
  // with k = A_zz / m = 0.25 / 1.504 (thesis Table 2.1).
  Simulator sim(test::load_model("qdrone2"), falling_config(true));
  sim.reset(Simulator::hover_state(Vec3(0, 0, 100)));
  const double a0 = -9.81 + 4 * kK3 / kMass, k = 0.25 / kMass;
  ASSERT_TRUE(sim.step(5000).ok());
  const double t = 5.0;
  EXPECT_NEAR(sim.state()[5], a0 / k * (1 - std::exp(-k * t)), 1e-9);
  EXPECT_NEAR(sim.state()[2], 100 + a0 / k * (t - (1 - std::exp(-k * t)) / k), 1e-9);
}

TEST(Simulator, TimeIsStepCountTimesDt) {
  Simulator sim = hovering(SimConfig{}, 2.0);
  ASSERT_TRUE(sim.step(12345).ok());
  EXPECT_EQ(sim.step_count(), 12345);
  EXPECT_EQ(sim.time_s(), 12345 * 1e-3);
}

// ---- determinism ----------------------------------------------------------------------------

SimConfig noisy(std::uint64_t seed) {
  SimConfig cfg;
  cfg.noise.enabled = true;
  cfg.seed = seed;
  cfg.environment.wind_W_m_s << 1.0, 0.5, 0.0;
  return cfg;
}

std::vector<double> trace(Simulator sim, int steps) {
  std::vector<double> out;
  const RotorVector base = sim.model().hover_speeds_rad_s();
  for (int k = 0; k < steps; ++k) {
    RotorVector ref = base;
    ref[k % 4] += 20.0 * std::sin(0.01 * k);
    sim.set_rotor_speed_reference(ref);
    if (!sim.step().ok()) break;
    const StateVector m = sim.measured_state();
    out.insert(out.end(), m.data(), m.data() + kStateSize);
    const StateVector d = sim.measured_state_derivative();
    out.insert(out.end(), d.data(), d.data() + kStateSize);
  }
  return out;
}

TEST(Simulator, SameSeedGivesBitwiseIdenticalRuns) {
  const auto a = trace(hovering(noisy(42), 1.0), 2000);
  const auto b = trace(hovering(noisy(42), 1.0), 2000);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(double)));
  const auto c = trace(hovering(noisy(43), 1.0), 2000);
  EXPECT_NE(0, std::memcmp(a.data(), c.data(), a.size() * sizeof(double)));
}

TEST(Simulator, CopiesRunIndependentlyAndIdenticallyOnThreads) {
  const Simulator prototype = hovering(noisy(9), 1.5);
  const auto serial = trace(prototype, 1500);
  std::vector<std::vector<double>> results(4);
  std::vector<std::thread> threads;
  for (int i = 0; i < 4; ++i)
    threads.emplace_back([&, i] { results[static_cast<std::size_t>(i)] = trace(prototype, 1500); });
  for (auto& t : threads) t.join();
  for (const auto& r : results) {
    ASSERT_EQ(r.size(), serial.size());
    EXPECT_EQ(0, std::memcmp(r.data(), serial.data(), r.size() * sizeof(double)));
  }
}

TEST(Simulator, ResetReplaysTheSameNoise) {
  Simulator sim = hovering(noisy(5), 1.0);
  const StateVector x0 = sim.state();
  const RotorVector w0 = sim.rotor_speeds_rad_s();
  sim.step(300);
  const StateVector first = sim.measured_state();
  sim.reset(x0, w0);
  sim.step(300);
  EXPECT_EQ(first, sim.measured_state());
  EXPECT_NE(sim.measured_state(), sim.state());  // the noise is really there
}

TEST(Simulator, NoiseOffMeansMeasuredEqualsTrue) {
  Simulator sim = hovering(SimConfig{}, 1.0);
  sim.step(100);
  EXPECT_EQ(sim.measured_state(), sim.state());
  EXPECT_EQ(sim.measured_state_derivative(), sim.state_derivative());
}

// ---- bad input ------------------------------------------------------------------------------

using test::error_of;

TEST(Simulator, RejectsNonFiniteAndMisSizedInputs) {
  Simulator sim = hovering(SimConfig{}, 1.0);
  RotorVector ref = sim.model().hover_speeds_rad_s();
  ref[2] = std::nan("");
  EXPECT_NE(error_of([&] { sim.set_rotor_speed_reference(ref); }).find("[2]"), std::string::npos);
  ref[2] = INFINITY;
  EXPECT_NE(error_of([&] { sim.set_rotor_speed_reference(ref); }).find("finite"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              sim.set_rotor_speed_reference(RotorVector::Zero(3));
            }).find("expected 4 values"),
            std::string::npos);
  EXPECT_NE(
      error_of([&] { sim.set_generalized_force(Vec4(14.0, 0.0, -INFINITY, 0.0)); }).find("[2]"),
      std::string::npos);
  StateVector x = sim.state();
  x[4] = std::nan("");
  EXPECT_NE(error_of([&] { sim.set_state(x); }).find("state[4]"), std::string::npos);
  x = sim.state();
  x.segment<4>(6).setZero();
  EXPECT_NE(error_of([&] { sim.set_state(x); }).find("quaternion"), std::string::npos);
  x = sim.state();
  x[2] = -1.0;
  EXPECT_NE(error_of([&] { sim.set_state(x); }).find("below the ground"), std::string::npos);
  EXPECT_NE(error_of([&] { sim.set_wind(Vec3(0, std::nan(""), 0)); }).find("wind"),
            std::string::npos);
  // The simulator is unchanged by the rejected calls and still flies.
  EXPECT_TRUE(sim.step(10).ok());
}

TEST(Simulator, RejectsBadConfigs) {
  const auto model = test::load_model("qdrone2");
  SimConfig cfg;
  cfg.dt_s = 0.0;
  EXPECT_NE(error_of([&] { Simulator s(model, cfg); }).find("dt_s"), std::string::npos);
  cfg = SimConfig{};
  cfg.noise.parameters.theta[2].a = 2.5;  // I - Theta has an eigenvalue beyond -1: unstable
  EXPECT_NE(error_of([&] { Simulator s(model, cfg); }).find("noise.theta.quaternion"),
            std::string::npos);
  cfg = SimConfig{};
  cfg.environment.gravity_W_m_s2.x() = std::nan("");
  EXPECT_NE(error_of([&] { Simulator s(model, cfg); }).find("gravity"), std::string::npos);
}

// ---- failures are detected, not propagated ---------------------------------------------------

TEST(Simulator, DivergenceIsDetectedAndTheRunStops) {
  SimConfig cfg;
  cfg.divergence.max_angular_speed_rad_s = 30.0;
  const auto model = test::load_model("qdrone2");
  Simulator sim(model, cfg);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 50)), model->hover_speeds_rad_s());
  RotorVector ref(4);
  ref << 3400.0, 0.0, 3400.0, 0.0;  // full yaw-and-roll torque: the body spins up
  sim.set_rotor_speed_reference(ref);
  const StepResult r = sim.step(100000);
  EXPECT_EQ(r.status, StepStatus::kDiverged);
  EXPECT_LT(r.steps_taken, 100000);
  EXPECT_TRUE(sim.state().allFinite());  // the bad step was not committed
  EXPECT_LE(sim.state().segment<3>(10).norm(), 30.0);
  EXPECT_NE(sim.failure_message().find("|w|"), std::string::npos);
  EXPECT_THROW(sim.step(), SimulationError);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 50)));
  EXPECT_TRUE(sim.step().ok());
}

TEST(Simulator, ARefusedStepCommitsNothing) {
  // A step that both touches the ground and diverges: the touchdown it would have counted, the
  // rotor speeds, noise, time and state all stay as they were.
  SimConfig cfg;
  cfg.divergence.max_position_m = 1.0;
  cfg.noise.enabled = true;
  const auto model = test::load_model("qdrone2");
  Simulator sim(model, cfg);
  StateVector x = Simulator::hover_state(Vec3(0.9995, 0, 0.0005));
  x[3] = 2.0;   // just inside the position limit, past it after the step
  x[5] = -2.0;  // and falling onto the ground within the step
  RotorVector ref(4);
  ref << 3400.0, 0.0, 3400.0, 0.0;
  sim.reset(x, ref);
  const SimData before = sim.data();
  const StepResult r = sim.step();
  ASSERT_EQ(r.status, StepStatus::kDiverged);
  EXPECT_EQ(r.steps_taken, 0);
  const SimData& after = sim.data();
  EXPECT_EQ(after.contact.touchdowns, before.contact.touchdowns);
  EXPECT_EQ(after.contact.in_contact, before.contact.in_contact);
  EXPECT_EQ(after.contact.max_touchdown_speed_m_s, before.contact.max_touchdown_speed_m_s);
  EXPECT_EQ(after.state, before.state);
  EXPECT_EQ(after.measured_state, before.measured_state);
  EXPECT_EQ(after.rotor_speed_rad_s, before.rotor_speed_rad_s);
  EXPECT_EQ(after.state_noise.value(), before.state_noise.value());
  EXPECT_EQ(after.step_count, before.step_count);
  EXPECT_EQ(after.time_s, before.time_s);
  EXPECT_EQ(after.failure.step, 1);
  EXPECT_GT(after.failure.position_m, 1.0);
}

TEST(Simulator, NonFiniteStateIsDetected) {
  Simulator sim = hovering(SimConfig{}, 1.0);
  sim.mutable_data().state[3] = std::nan("");  // bypasses set_state's checks on purpose
  EXPECT_EQ(sim.step().status, StepStatus::kNonFinite);
  EXPECT_NE(sim.failure_message().find("non-finite"), std::string::npos);
  EXPECT_THROW(sim.step(), SimulationError);
}

// ---- ground ---------------------------------------------------------------------------------

TEST(Simulator, RestsOnTheGroundWithoutSinkingOrDrifting) {
  Simulator sim(test::load_model("qdrone2"));
  sim.reset(Simulator::hover_state(Vec3(1, 2, 0)));
  ASSERT_TRUE(sim.step(5000).ok());
  EXPECT_EQ(sim.state()[2], 0.0);
  EXPECT_EQ(sim.state().segment<3>(3).norm(), 0.0);
  EXPECT_EQ(sim.state()[0], 1.0);
  EXPECT_TRUE(sim.contact().in_contact);
  EXPECT_FALSE(sim.contact().crashed);
  // Idle rotors below hover speed: still resting, still finite (ground effect floor 0.023 m).
  sim.set_rotor_speed_reference(RotorVector::Constant(4, 700.0));
  ASSERT_TRUE(sim.step(5000).ok());
  EXPECT_EQ(sim.state()[2], 0.0);
  EXPECT_TRUE(sim.wrench_breakdown()[Term::kGroundEffect].force_B.allFinite());
}

TEST(Simulator, DropLandsWithTheFreeFallSpeedAndDoesNotBounce) {
  // From rest at h with rotors stopped: touchdown speed sqrt(2 |a| h), a = -g + 4 'K3 / m.
  for (const double h : {0.05, 0.5}) {
    SimConfig cfg;
    cfg.disturbances = DisturbanceSwitches::none();
    Simulator sim(test::load_model("qdrone2"), cfg);
    sim.reset(Simulator::hover_state(Vec3(0, 0, h)));
    ASSERT_TRUE(sim.step(2000).ok());
    const double a = 9.81 - 4 * kK3 / kMass;
    // The touchdown is seen at the end of the step that crosses z = 0: speed error < a dt.
    EXPECT_NEAR(sim.contact().last_touchdown_speed_m_s, std::sqrt(2 * a * h), a * 1e-3);
    EXPECT_EQ(sim.contact().touchdowns, 1);  // no bounce
    EXPECT_EQ(sim.state()[2], 0.0);
    EXPECT_EQ(sim.contact().crashed, std::sqrt(2 * a * h) > cfg.ground.crash_speed_m_s);
  }
}

TEST(Simulator, TakesOffAndLandsAgain) {
  const auto model = test::load_model("qdrone2");
  Simulator sim(model);
  sim.reset(Simulator::hover_state(Vec3::Zero()));
  sim.set_rotor_speed_reference(1.05 * model->hover_speeds_rad_s());
  ASSERT_TRUE(sim.step(1500).ok());
  EXPECT_GT(sim.state()[2], 0.3);
  EXPECT_FALSE(sim.contact().in_contact);
  // Descend with too little thrust. Note the ground effect (C_G T / h^2, floored at 0.023 m) more
  // than doubles the thrust near the ground: at 800 rad/s (52 % of the hover thrust) the vehicle
  // would float on that cushion a few mm up. 500 rad/s gives 25 %, x 2.13 < 100 %: it lands.
  sim.set_rotor_speed_reference(RotorVector::Constant(4, 500.0));
  ASSERT_TRUE(sim.step(4000).ok());
  EXPECT_TRUE(sim.contact().in_contact);
  EXPECT_EQ(sim.state()[2], 0.0);
  EXPECT_TRUE(sim.state().allFinite());
}

TEST(Simulator, TiltedContactIsACrash) {
  SimConfig cfg;
  cfg.disturbances = DisturbanceSwitches::none();
  Simulator sim(test::load_model("qdrone2"), cfg);
  StateVector x = Simulator::hover_state(Vec3(0, 0, 0.02));
  x.segment<4>(6) = math::from_euler(1.3, 0.0, 0.0);  // beyond the 1 rad crash tilt
  sim.reset(x);
  ASSERT_TRUE(sim.step(200).ok());
  EXPECT_TRUE(sim.contact().crashed);
}

TEST(Simulator, WrenchBreakdownMatchesTheStateDerivative) {
  Simulator sim = hovering(noisy(1), 0.3);
  sim.set_wind(Vec3(2.0, -1.0, 0.0));
  sim.step(200);
  const auto b = sim.wrench_breakdown();
  const Mat3 R = math::rotation_matrix<double>(sim.state().segment<4>(6));
  const Vec3 a = R * b.total().force_B / kMass;
  EXPECT_LT((a - sim.state_derivative().segment<3>(3)).norm(), 1e-12);
}

}  // namespace
}  // namespace dronetwin
