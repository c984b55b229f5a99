// 100 000 random states and commands, extremes included (speeds and rates past the divergence
// limits, rotor commands beyond the motors' range, hurricane winds, tumbling attitudes): no NaN
// ever escapes into the simulator's state. Every step either succeeds with a finite state within
// the limits or is refused with a status and leaves the state as it was.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

double spread(Random& rng, double scale) {
  // Mostly moderate values, sometimes extreme ones, sometimes exactly 0.
  const double u = rng.uniform();
  if (u < 0.1) return 0.0;
  const double magnitude = u < 0.8 ? scale : scale * 1e3;
  return magnitude * (2.0 * rng.uniform() - 1.0);
}

TEST(Extremes, NoNaNEscapesAndEveryBadStepIsRefusedWithAStatus) {
  int ok = 0, refused = 0, rejected_inputs = 0;
  for (const char* name : {"qdrone2", "tilted_hexarotor"}) {
    const auto model = test::load_model(name);
    Random rng(2024);
    SimConfig cfg;
    cfg.noise.enabled = true;
    Simulator sim(model, cfg);
    const int n = model->num_rotors();
    for (int trial = 0; trial < 50000; ++trial) {
      StateVector x;
      for (int i = 0; i < 3; ++i) x[i] = spread(rng, 10.0);
      x[2] = std::abs(x[2]);  // above the ground (below it is an input error, tested elsewhere)
      for (int i = 3; i < 6; ++i) x[i] = spread(rng, 50.0);
      x.segment<4>(6) =
          math::from_euler(6.3 * rng.uniform(), 6.3 * rng.uniform(), 6.3 * rng.uniform());
      for (int i = 10; i < 13; ++i) x[i] = spread(rng, 20.0);
      RotorVector w(n), ref(n);
      for (int i = 0; i < n; ++i) {
        w[i] = std::abs(spread(rng, 2000.0));
        ref[i] = spread(rng, 4000.0);  // negative and beyond the limits: the motors clamp
      }
      try {
        sim.set_wind(Vec3(spread(rng, 10.0), spread(rng, 10.0), spread(rng, 2.0)));
        sim.reset(x, w);
        sim.set_rotor_speed_reference(ref);
      } catch (const InvalidArgument&) {
        ++rejected_inputs;
        continue;
      }
      const StateVector before = sim.state();
      const StepResult r = sim.step();
      const StateVector& after = sim.state();
      ASSERT_TRUE(after.allFinite()) << name << " trial " << trial;
      ASSERT_TRUE(sim.measured_state().allFinite()) << name << " trial " << trial;
      if (r.ok()) {
        ++ok;
        const DivergenceLimits& lim = cfg.divergence;
        ASSERT_LE(after.head<3>().norm(), lim.max_position_m);
        ASSERT_LE(after.segment<3>(3).norm(), lim.max_speed_m_s);
        ASSERT_LE(after.segment<3>(10).norm(), lim.max_angular_speed_rad_s);
        ASSERT_NEAR(after.segment<4>(6).norm(), 1.0, 1e-12);
        for (int i = 0; i < n; ++i) {
          ASSERT_GE(sim.rotor_speeds_rad_s()[i], model->rotor(i).min_speed_rad_s);
          ASSERT_LE(sim.rotor_speeds_rad_s()[i], model->rotor(i).max_speed_rad_s);
        }
      } else {
        ++refused;
        ASSERT_NE(r.status, StepStatus::kOk);
        ASSERT_EQ(after, before) << "a refused step changed the state";
        ASSERT_FALSE(sim.failure_message().empty());
        ASSERT_THROW(sim.step(), SimulationError);
      }
    }
  }
  // Both outcomes were exercised (the spread reaches past the limits).
  EXPECT_GT(ok, 10000);
  EXPECT_GT(refused, 100);
  EXPECT_EQ(rejected_inputs, 0);
}

TEST(Extremes, NonFiniteCommandsAreInputErrorsNotFlown) {
  const auto model = test::load_model("qdrone2");
  Simulator sim(model);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  RotorVector bad = model->hover_speeds_rad_s();
  const double inf = std::numeric_limits<double>::infinity();
  for (const double v : {std::nan(""), inf, -inf}) {
    bad[2] = v;
    EXPECT_THROW(sim.set_rotor_speed_reference(bad), InvalidArgument);
    EXPECT_THROW(sim.set_generalized_force(GeneralizedForce(v, 0, 0, 0)), InvalidArgument);
    EXPECT_THROW(sim.set_wind(Vec3(0, v, 0)), InvalidArgument);
  }
  EXPECT_THROW(Simulator::hover_state(Vec3(0, std::nan(""), 1)), InvalidArgument);
  EXPECT_THROW(Simulator::hover_state(Vec3(0, 0, 1), inf), InvalidArgument);
  EXPECT_TRUE(sim.step().ok());
}

TEST(Extremes, AStateWrittenThroughTheDataIsCheckedAtTheNextStep) {
  // What a Python view allows: a NaN, or a zero quaternion, written straight into the state.
  const auto model = test::load_model("qdrone2");
  Simulator sim(model);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  sim.mutable_data().state.segment<4>(6).setZero();
  EXPECT_EQ(sim.step().status, StepStatus::kInvalidState);
  EXPECT_NE(sim.failure_message().find("was not valid"), std::string::npos)
      << sim.failure_message();
  EXPECT_NE(sim.failure_message().find("quaternion norm 0"), std::string::npos);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  sim.mutable_data().state[4] = std::nan("");
  EXPECT_EQ(sim.step().status, StepStatus::kNonFinite);
  EXPECT_NE(sim.failure_message().find("NaN or inf"), std::string::npos) << sim.failure_message();
}

}  // namespace
}  // namespace dronetwin
