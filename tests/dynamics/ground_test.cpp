// Ground contact (dynamics/ground.hpp): a vehicle resting on its landing gear does not creep while
// friction holds it, and when it slides, its logged velocity is how it moves. Expected values come
// from Coulomb friction against the frame drag: F = A (wind - v) against mu m g.

#include "dronetwin/dynamics/ground.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

Simulator resting(const std::shared_ptr<const VehicleModel>& model, const Vec3& wind) {
  SimConfig cfg;
  cfg.environment.wind_W_m_s = wind;
  Simulator sim(model, cfg);
  sim.reset(Simulator::hover_state(Vec3(1.0, 2.0, 0.0), 0.3));  // on the ground, rotors stopped
  return sim;
}

TEST(Ground, FrictionHoldsAVehicleInWindWithoutCreep) {
  // 5 m/s of wind on the frame: 0.3 N s/m x 5 m/s = 1.5 N, below mu m g = 8.9 N.
  const auto model = test::load_model("qdrone2");
  Simulator sim = resting(model, Vec3(5.0, 0.0, 0.0));
  const StateVector start = sim.state();
  for (int k = 0; k < 10000; ++k) {
    ASSERT_TRUE(sim.step().ok());
    ASSERT_EQ(sim.state(), start) << "moved at step " << k;  // not a micrometre: held
  }
  EXPECT_TRUE(sim.contact().in_contact);
  EXPECT_FALSE(sim.contact().sliding);
  EXPECT_FALSE(sim.contact().crashed);
}

TEST(Ground, ASlidingVehicleMovesAsItsVelocitySaysAndReachesTheFrictionBalance) {
  // 40 m/s: drag 0.3 x 40 = 12 N > mu N = 8.9 N, so it slides; it accelerates until the drag
  // on the relative wind equals the kinetic friction: A_xx (w - v) = mu N. The normal force N is
  // what the gear carries: the weight plus the small downward thrust of stopped rotors
  // ('K3 < 0) and its ground effect, read from the wrench breakdown.
  const auto model = test::load_model("qdrone2");
  const double wind = 40.0;
  Simulator sim = resting(model, Vec3(wind, 0.0, 0.0));
  const double mu = sim.config().ground.friction_coefficient;
  const double normal_N = -sim.wrench_breakdown().total().force_B.z();  // level: body z = world z
  const double a_xx = model->body_drag_Ns_per_m()(0, 0);
  ASSERT_EQ(model->body_drag_Ns_per_m()(0, 1), 0.0);
  ASSERT_GT(normal_N, model->mass_kg() * 9.81);
  const double v_balance = wind - mu * normal_N / a_xx;
  const double dt = sim.config().dt_s;
  const StateVector start = sim.state();
  double travelled = 0.0;  // the trapezoid of the logged velocities
  const double x0 = sim.state()[0];
  for (int k = 0; k < 60000; ++k) {  // 60 s: 12 time constants m / A_xx
    const double v_before = sim.state()[3];
    ASSERT_TRUE(sim.step().ok());
    travelled += 0.5 * (v_before + sim.state()[3]) * dt;
    ASSERT_EQ(sim.state()[2], 0.0);
    ASSERT_NEAR(sim.state()[4], 0.0, 1e-15);  // no sideways motion in a wind along x
  }
  EXPECT_TRUE(sim.contact().sliding);
  EXPECT_NEAR(sim.state()[0] - x0, travelled, 1e-9 * travelled);
  EXPECT_NEAR(sim.state()[3], v_balance, 1e-3 * v_balance);
  // Attitude held upright by the gear, no rotation.
  EXPECT_EQ(sim.state().segment<4>(6), start.segment<4>(6));
  EXPECT_EQ(sim.state().segment<3>(10), Vec3::Zero());

  // The wind drops: kinetic friction stops it, within v / (mu g) seconds, and then it holds.
  sim.set_wind(Vec3::Zero());
  const double v = sim.state()[3];
  const double g = -sim.config().environment.gravity_W_m_s2.z();
  const auto stop_steps = static_cast<int>(std::ceil(v / (mu * g) / dt)) + 50;
  for (int k = 0; k < stop_steps; ++k) ASSERT_TRUE(sim.step().ok());
  EXPECT_EQ(sim.state()[3], 0.0);
  EXPECT_FALSE(sim.contact().sliding);
  const StateVector stopped = sim.state();
  for (int k = 0; k < 1000; ++k) ASSERT_TRUE(sim.step().ok());
  EXPECT_EQ(sim.state(), stopped);
}

TEST(Ground, AWreckOnItsSideStaysWhereItLiesWhateverItsRotorsDo) {
  // Rolled 90 degrees, all rotors at full speed: the thrust pushes along the floor with several
  // times the weight. The gear does not carry a vehicle on its side, so it is held (and crashed)
  // instead of skidding away on its propellers.
  const auto model = test::load_model("qdrone2");
  SimConfig cfg;
  Simulator sim(model, cfg);
  StateVector x = Simulator::hover_state(Vec3(1.0, 2.0, 0.0));
  const double half = 0.25 * M_PI;  // quaternion of a 90-degree roll: (cos 45, sin 45, 0, 0)
  x.segment<4>(6) << std::cos(half), std::sin(half), 0.0, 0.0;
  sim.reset(x);
  RotorVector full = RotorVector::Zero(model->num_rotors());
  for (int i = 0; i < model->num_rotors(); ++i) full[i] = model->rotor(i).max_speed_rad_s;
  sim.set_rotor_speeds(full);
  sim.set_rotor_speed_reference(full);
  ASSERT_TRUE(sim.step(5000).ok());
  EXPECT_EQ(sim.state().segment<3>(0), Vec3(1.0, 2.0, 0.0));
  EXPECT_EQ(sim.state().segment<3>(3), Vec3::Zero());
  EXPECT_EQ(sim.state().segment<4>(6), x.segment<4>(6));
  EXPECT_TRUE(sim.contact().in_contact);
  EXPECT_TRUE(sim.contact().crashed);
}

TEST(Ground, FrictionOffLetsTheWindPushItFreely) {
  const auto model = test::load_model("qdrone2");
  SimConfig cfg;
  cfg.environment.wind_W_m_s = Vec3(5.0, 0.0, 0.0);
  cfg.ground.friction_coefficient = 0.0;
  Simulator sim(model, cfg);
  sim.reset(Simulator::hover_state(Vec3::Zero()));
  ASSERT_TRUE(sim.step(1000).ok());
  // Only the frame drag acts horizontally: a = A (w - v) / m, v(t) = w (1 - e^{-A t / m}).
  const double k = model->body_drag_Ns_per_m()(0, 0) / model->mass_kg();
  EXPECT_NEAR(sim.state()[3], 5.0 * (1.0 - std::exp(-k * 1.0)), 1e-3);
  EXPECT_TRUE(sim.contact().sliding);
}

}  // namespace
}  // namespace dronetwin
