// Simulator::set_interaction (what other vehicles do to this one): a body wrench held over the
// steps accelerates the vehicle exactly as Newton says, a flow is air moving like wind, reset()
// clears both, non-finite values are refused by name.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "dronetwin/core/error.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using state_index::kPosition;
using state_index::kVelocity;

SimConfig still() {
  SimConfig c;
  c.disturbances = DisturbanceSwitches::none();
  c.motor_dynamics = false;
  c.ground.enabled = false;
  return c;
}

TEST(SimulatorInteraction, ABodyForceAcceleratesByForceOverMass) {
  const auto model = test::load_model("qdrone2");
  Simulator free = test::hovering(model, still());
  Simulator pushed = test::hovering(model, still());
  Vector6<double> wrench = Vector6<double>::Zero();
  wrench[2] = -3.0;  // a thrust loss of 3 N, level vehicle: straight down
  pushed.set_interaction(Vec3::Zero(), wrench);
  const double t_s = 0.5;
  const auto n = static_cast<std::int64_t>(std::llround(t_s / still().dt_s));
  ASSERT_TRUE(free.step(n).ok());
  ASSERT_TRUE(pushed.step(n).ok());
  const double a = wrench[2] / model->mass_kg();
  // Level, no rates, no drag terms: the added acceleration is exactly F / m, and RK4 integrates
  // the constant exactly.
  EXPECT_NEAR(pushed.state()[kVelocity + 2] - free.state()[kVelocity + 2], a * t_s, 1e-12);
  EXPECT_NEAR(pushed.state()[kPosition + 2] - free.state()[kPosition + 2], 0.5 * a * t_s * t_s,
              1e-12);
  // A moment turns it: w_x' = M_x / J_xx from rest.
  Simulator turned = test::hovering(model, still());
  Vector6<double> moment = Vector6<double>::Zero();
  moment[3] = 0.01;
  turned.set_interaction(Vec3::Zero(), moment);
  ASSERT_TRUE(turned.step().ok());
  const Vec3 w_dot = model->inertia_kgm2().inverse() * Vec3(moment.tail<3>());
  EXPECT_NEAR(turned.state()[state_index::kAngularVelocity], w_dot[0] * still().dt_s, 1e-12);
}

TEST(SimulatorInteraction, AFlowIsAirMovingLikeWind) {
  const auto model = test::load_model("qdrone2");
  SimConfig c = still();
  c.disturbances = DisturbanceSwitches{};  // every term: drag sees the flow
  Simulator in_flow = test::hovering(model, c);
  Simulator in_wind = test::hovering(model, c);
  const Vec3 flow(0.5, -1.0, -4.0);
  in_flow.set_interaction(flow, Vector6<double>::Zero());
  in_wind.set_wind(flow);
  EXPECT_EQ(in_flow.wind_W_m_s(), flow);
  EXPECT_EQ(in_flow.state_derivative(), in_wind.state_derivative());
  ASSERT_TRUE(in_flow.step(200).ok());
  ASSERT_TRUE(in_wind.step(200).ok());
  EXPECT_EQ(in_flow.state(), in_wind.state());
  // Held until set again; reset() clears it.
  in_flow.reset(Simulator::hover_state(Vec3(0, 0, 2)), model->hover_speeds_rad_s());
  EXPECT_EQ(in_flow.wind_W_m_s(), Vec3::Zero());
  EXPECT_EQ(in_flow.data().interaction_wrench_B, Vector6<double>::Zero());
}

TEST(SimulatorInteraction, NonFiniteValuesAreRefused) {
  const auto model = test::load_model("qdrone2");
  Simulator sim = test::hovering(model, still());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(test::error_of([&] {
              sim.set_interaction(Vec3(0, nan, 0), Vector6<double>::Zero());
            }).find("set_interaction: flow: expected finite numbers"),
            std::string::npos);
  Vector6<double> w = Vector6<double>::Zero();
  w[4] = std::numeric_limits<double>::infinity();
  EXPECT_NE(test::error_of([&] {
              sim.set_interaction(Vec3::Zero(), w);
            }).find("set_interaction: wrench: expected finite numbers"),
            std::string::npos);
  EXPECT_EQ(sim.wind_W_m_s(), Vec3::Zero());  // nothing was set
}

}  // namespace
}  // namespace dronetwin
