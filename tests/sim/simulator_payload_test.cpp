// The slung payload in a simulator (SimConfig::payload, payload/slung_payload.hpp), against
// physics: without outside forces the pair keeps its momentum and kinetic energy and the cable
// carries the centripetal tension; a cable jerking taut is a perfectly inelastic collision along
// it; under a constant vertical thrust (m_Q + m_L) g the payload swings as a pendulum of length l
// in the effective gravity g (m_Q + m_L) / m_Q, with the exact large-amplitude period; hanging at
// rest it carries its weight; a large three-dimensional swing follows the thesis's swing-angle
// equations (Eq. 3.32-3.35, two signs corrected) integrated independently; on the ground it waits
// until the cable lifts it; bad settings are named.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/integrators/integrator.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using state_index::kPosition;
using state_index::kVelocity;

/// A still world: no disturbance terms, rotor speeds set at once (no motor lag).
SimConfig still_with_payload(const Vec3& gravity) {
  SimConfig c;
  c.disturbances = DisturbanceSwitches::none();
  c.motor_dynamics = false;
  c.environment.gravity_W_m_s2 = gravity;
  c.ground.enabled = false;
  c.payload.enabled = true;
  return c;
}

/// The rotor speed at which the thrust polynomial is exactly zero (Eq. 2.22 has a negative
/// constant term, so thrust vanishes slightly above rest): with it the vehicle feels no force.
RotorVector zero_thrust_speeds(const VehicleModel& model) {
  RotorVector w(model.num_rotors());
  for (int i = 0; i < model.num_rotors(); ++i) {
    const auto& k = model.rotor(i).thrust_coefficients;
    w[i] = (-k[1] + std::sqrt(k[1] * k[1] - 4.0 * k[0] * k[2])) / (2.0 * k[0]);
  }
  return w;
}

/// Equal rotor speeds giving the collective thrust `thrust_N`: no moment.
RotorVector speeds_for_thrust(const VehicleModel& model, double thrust_N) {
  return allocate(model, GeneralizedForce(thrust_N, 0.0, 0.0, 0.0), AllocationMethod::kExact)
      .speeds_rad_s;
}

/// Restarts `sim` at `x` with every rotor at, and headed for, `w`.
void start_at(Simulator& sim, const StateVector& x, const RotorVector& w) {
  sim.reset(x, w);
  sim.set_rotor_speed_reference(w);
}

Vec3 momentum(const Simulator& sim) {
  return sim.model().mass_kg() * Vec3(sim.state().segment<3>(kVelocity)) +
         sim.config().payload.payload.mass_kg * sim.payload().velocity_W_m_s;
}

double kinetic_energy(const Simulator& sim) {
  return 0.5 * sim.model().mass_kg() * sim.state().segment<3>(kVelocity).squaredNorm() +
         0.5 * sim.config().payload.payload.mass_kg * sim.payload().velocity_W_m_s.squaredNorm();
}

double cable_length(const Simulator& sim) {
  return (sim.payload().position_W_m - Vec3(sim.state().segment<3>(kPosition))).norm();
}

TEST(SimulatorPayload, WithoutOutsideForcesMomentumAndEnergyStayAndTheTensionIsCentripetal) {
  const auto model = test::load_model("qdrone2");
  Simulator sim(model, still_with_payload(Vec3::Zero()));
  const double v = 1.5;  // the vehicle's speed across the cable, m/s
  StateVector x = Simulator::hover_state(Vec3(0.0, 0.0, 5.0));
  x.segment<3>(kVelocity) = Vec3(0.0, v, 0.0);
  start_at(sim, x, zero_thrust_speeds(*model));
  const SlungPayload& p = sim.config().payload.payload;
  const double m_Q = model->mass_kg(), m_L = p.mass_kg, l = p.tether_length_m;
  const double mu = m_Q * m_L / (m_Q + m_L);
  // reset() hangs the payload l below, moving with the vehicle; stopped, its relative speed is v,
  // across the cable.
  sim.set_payload_state(PayloadState{Vec3(0.0, 0.0, 5.0 - l), Vec3::Zero()});
  ASSERT_TRUE(sim.payload().taut);
  ASSERT_NEAR(cable_length(sim), l, 1e-15);
  EXPECT_NEAR(sim.payload_tension_N(), mu * v * v / l, 1e-9 * mu * v * v / l);
  const Vec3 p0 = momentum(sim);
  const double e0 = kinetic_energy(sim);
  ASSERT_TRUE(sim.step(3000).ok());  // 3 s: about 3 turns about the centre of mass
  EXPECT_LT((momentum(sim) - p0).norm(), 1e-12 * p0.norm());
  EXPECT_NEAR(kinetic_energy(sim), e0, 1e-9 * e0);
  EXPECT_NEAR(cable_length(sim), l, 1e-12);
  EXPECT_TRUE(sim.payload().taut);
  EXPECT_NEAR(sim.payload_tension_N(), mu * v * v / l, 1e-6 * mu * v * v / l);
}

TEST(SimulatorPayload, ACableJerkingTautIsAnInelasticCollisionAlongIt) {
  const auto model = test::load_model("qdrone2");
  Simulator sim(model, still_with_payload(Vec3::Zero()));
  const double v = 2.0;
  StateVector x = Simulator::hover_state(Vec3(0.0, 0.0, 5.0));
  x.segment<3>(kVelocity) = Vec3(v, 0.0, 0.0);
  start_at(sim, x, zero_thrust_speeds(*model));
  const SlungPayload& p = sim.config().payload.payload;
  const double m_Q = model->mass_kg(), m_L = p.mass_kg, l = p.tether_length_m;
  // The payload at rest behind the vehicle, half a tether away: the cable is slack.
  PayloadState s;
  s.position_W_m = Vec3(-0.5 * l, 0.0, 5.0);
  sim.set_payload_state(s);
  EXPECT_FALSE(sim.payload().taut);
  EXPECT_EQ(sim.payload_tension_N(), 0.0);
  const Vec3 p0 = momentum(sim);
  // Slack, the vehicle coasts for 0.5 l / v, then the cable jerks taut.
  ASSERT_TRUE(sim.step(static_cast<std::int64_t>(std::ceil(0.5 * l / v / 1e-3)) + 10).ok());
  EXPECT_TRUE(sim.payload().taut);
  EXPECT_NEAR(cable_length(sim), l, 1e-12);
  EXPECT_LT((momentum(sim) - p0).norm(), 1e-12 * p0.norm());
  // Perfectly inelastic along the cable (here the line of motion): one common velocity, and the
  // kinetic energy of the relative motion, mu v^2 / 2, gone.
  const double common = m_Q * v / (m_Q + m_L);
  EXPECT_NEAR(sim.state()[kVelocity], common, 1e-12);
  EXPECT_NEAR(sim.payload().velocity_W_m_s.x(), common, 1e-12);
  EXPECT_NEAR(kinetic_energy(sim), 0.5 * m_Q * m_Q * v * v / (m_Q + m_L), 1e-12);
}

/// Complete elliptic integral of the first kind by the arithmetic-geometric mean.
double elliptic_k(double k) {
  double a = 1.0, b = std::sqrt(1.0 - k * k);
  for (int i = 0; i < 30; ++i) {
    const double an = 0.5 * (a + b);
    b = std::sqrt(a * b);
    a = an;
  }
  return std::numbers::pi / (2.0 * a);
}

TEST(SimulatorPayload, UnderAConstantThrustThePayloadSwingsWithTheTwoBodyPendulumPeriod) {
  const auto model = test::load_model("qdrone2");
  const double g = 9.81;
  Simulator sim(model, still_with_payload(Vec3(0.0, 0.0, -g)));
  const SlungPayload& p = sim.config().payload.payload;
  const double m_Q = model->mass_kg(), m_L = p.mass_kg, l = p.tether_length_m;
  // Equal rotor speeds giving the thrust (m_Q + m_L) g: no moment, the vehicle stays level.
  start_at(sim, Simulator::hover_state(Vec3(0.0, 0.0, 5.0)),
           speeds_for_thrust(*model, (m_Q + m_L) * g));
  const double amplitude_rad = 0.3;
  PayloadState s;
  s.position_W_m = Vec3(l * std::sin(amplitude_rad), 0.0, 5.0 - l * std::cos(amplitude_rad));
  sim.set_payload_state(s);
  ASSERT_TRUE(sim.payload().taut);
  EXPECT_NEAR(sim.swing_angles().gamma1_rad, amplitude_rad, 1e-15);
  // The relative motion is a pendulum of length l in the gravity g (m_Q + m_L) / m_Q; its
  // period at amplitude a is 4 K(sin(a / 2)) / w0.
  const double w0 = std::sqrt(g * (m_Q + m_L) / (m_Q * l));
  const double period_s = 4.0 * elliptic_k(std::sin(0.5 * amplitude_rad)) / w0;
  std::vector<double> downward_crossings_s;
  double previous = sim.swing_angles().gamma1_rad;
  while (sim.time_s() < 10.5 * period_s) {
    ASSERT_TRUE(sim.step().ok());
    const double now = sim.swing_angles().gamma1_rad;
    if (previous > 0.0 && now <= 0.0)
      downward_crossings_s.push_back(sim.time_s() - 1e-3 * now / (now - previous));
    previous = now;
  }
  ASSERT_GE(downward_crossings_s.size(), 10u);
  const double measured_s = (downward_crossings_s.back() - downward_crossings_s.front()) /
                            static_cast<double>(downward_crossings_s.size() - 1);
  EXPECT_NEAR(measured_s, period_s, 1e-6 * period_s);
  EXPECT_NEAR(cable_length(sim), l, 1e-12);
  // The vehicle stays level: the cable acts at its centre of mass.
  EXPECT_NEAR(sim.state()[state_index::kQuaternion], 1.0, 1e-12);
}

/// Eq. 3.32 in the thesis's coordinates X = (x, y, z, g1, g2), written from the Lagrangian of
/// the parametrisation of Eq. 3.33 (an independent derivation, docs/payload.md): M as printed
/// (with M44 = m_p l^2 cos^2 g2), the Coriolis vector C X_dot with the two signs Eq. 3.34 has
/// wrong (C15, C45) corrected, G with the pair's weight in the z row. Returns X_ddot for the
/// force u on the vehicle (here thrust only).
Eigen::Matrix<double, 10, 1> swing_equations(const Eigen::Matrix<double, 10, 1>& y, double m_q,
                                             double m_p, double l, double g, const Vec3& u) {
  const double s1 = std::sin(y[3]), c1 = std::cos(y[3]), s2 = std::sin(y[4]), c2 = std::cos(y[4]);
  const double d1 = y[8], d2 = y[9];
  Eigen::Matrix<double, 5, 5> M;
  M << m_q + m_p, 0, 0, m_p * l * c1 * c2, -m_p * l * s1 * s2,            //
      0, m_q + m_p, 0, 0, m_p * l * c2,                                   //
      0, 0, m_q + m_p, m_p * l * s1 * c2, m_p * l * c1 * s2,              //
      m_p * l * c1 * c2, 0, m_p * l * s1 * c2, m_p * l * l * c2 * c2, 0,  //
      -m_p * l * s1 * s2, m_p * l * c2, m_p * l * c1 * s2, 0, m_p * l * l;
  Eigen::Matrix<double, 5, 1> coriolis;
  coriolis << -m_p * l * (d1 * d1 * s1 * c2 + 2 * d1 * d2 * c1 * s2 + d2 * d2 * s1 * c2),
      -m_p * l * d2 * d2 * s2,
      m_p * l * (d1 * d1 * c1 * c2 - 2 * d1 * d2 * s1 * s2 + d2 * d2 * c1 * c2),
      -2 * m_p * l * l * d1 * d2 * s2 * c2, m_p * l * l * d1 * d1 * s2 * c2;
  Eigen::Matrix<double, 5, 1> G;
  G << 0, 0, (m_q + m_p) * g, m_p * g * l * s1 * c2, m_p * g * l * c1 * s2;
  Eigen::Matrix<double, 5, 1> force;
  force << u, 0, 0;
  Eigen::Matrix<double, 10, 1> ydot;
  ydot << y.tail<5>(), M.lu().solve(force - coriolis - G);
  return ydot;
}

TEST(SimulatorPayload, AThreeDimensionalSwingMatchesTheSwingAngleEquations) {
  const auto model = test::load_model("qdrone2");
  const double g = 9.81;
  Simulator sim(model, still_with_payload(Vec3(0.0, 0.0, -g)));
  const SlungPayload& p = sim.config().payload.payload;
  const double m_Q = model->mass_kg(), m_L = p.mass_kg, l = p.tether_length_m;
  // A level vehicle under a constant thrust 1.1 (m_Q + m_L) g (equal rotor speeds: no moment).
  const double thrust_N = 1.1 * (m_Q + m_L) * g;
  StateVector x = Simulator::hover_state(Vec3(0.2, -0.1, 5.0));
  const Vec3 v0(0.3, -0.2, 0.1);
  x.segment<3>(kVelocity) = v0;
  start_at(sim, x, speeds_for_thrust(*model, thrust_N));
  // Large swings in both angles, with rates.
  const double g1 = 0.5, g2 = 0.3, r1 = 0.8, r2 = -0.6;
  Eigen::Matrix<double, 10, 1> y;
  y << 0.2, -0.1, 5.0, g1, g2, v0, r1, r2;
  const Vec3 relative_velocity =
      l * Vec3(std::cos(g1) * std::cos(g2) * r1 - std::sin(g1) * std::sin(g2) * r2,
               std::cos(g2) * r2,
               std::sin(g1) * std::cos(g2) * r1 + std::cos(g1) * std::sin(g2) * r2);
  sim.set_payload_state(
      PayloadState{payload_position_at(Vec3(0.2, -0.1, 5.0), l, g1, g2), v0 + relative_velocity});
  const Vec3 u(0.0, 0.0, thrust_N);
  const double dt = sim.config().dt_s;
  for (int k = 0; k < 3000; ++k) {
    ASSERT_TRUE(sim.step().ok());
    ASSERT_GT(sim.payload_tension_N(), 0.0);
    const auto f = [&](const Eigen::Matrix<double, 10, 1>& z) {
      return swing_equations(z, m_Q, m_L, l, g, u);
    };
    y = rk4_step(y, dt, f);
  }
  const SwingAngles a = sim.swing_angles();
  // Two fourth-order integrations of the same motion in different coordinates.
  EXPECT_LT((Vec3(sim.state().segment<3>(kPosition)) - Vec3(y.head<3>())).norm(), 1e-8);
  EXPECT_NEAR(a.gamma1_rad, y[3], 1e-8);
  EXPECT_NEAR(a.gamma2_rad, y[4], 1e-8);
  EXPECT_NEAR(a.gamma1_rate_rad_s, y[8], 1e-7);
  EXPECT_NEAR(a.gamma2_rate_rad_s, y[9], 1e-7);
}

TEST(SimulatorPayload, HangingAtRestItCarriesItsWeightAndAHoverForBothHolds) {
  const auto model = test::load_model("qdrone2");
  const double g = 9.81;
  SimConfig c = still_with_payload(Vec3(0.0, 0.0, -g));
  c.ground.enabled = true;
  Simulator sim(model, c);
  const double m_L = c.payload.payload.mass_kg;
  start_at(sim, Simulator::hover_state(Vec3(1.0, 2.0, 2.0)),
           speeds_for_thrust(*model, (model->mass_kg() + m_L) * g));
  EXPECT_NEAR(sim.payload_tension_N(), m_L * g, 1e-12 * m_L * g);
  EXPECT_NEAR(sim.state_derivative()[kVelocity + 2], 0.0, 1e-12);
  ASSERT_TRUE(sim.step(5000).ok());
  EXPECT_NEAR(sim.state()[kPosition + 2], 2.0, 1e-9);
  EXPECT_NEAR(sim.payload().position_W_m.z(), 2.0 - c.payload.payload.tether_length_m, 1e-9);
  EXPECT_NEAR(sim.swing_angles().gamma1_rad, 0.0, 1e-12);
}

TEST(SimulatorPayload, FromTheGroundTheCableLiftsThePayloadOnceItPullsMoreThanItsWeight) {
  const auto model = test::load_model("qdrone2");
  const double g = 9.81;
  SimConfig c = still_with_payload(Vec3(0.0, 0.0, -g));
  c.ground.enabled = true;
  Simulator sim(model, c);
  const double m_L = c.payload.payload.mass_kg, l = c.payload.payload.tether_length_m;
  // On the ground: the payload rests beside the vehicle's feet, the cable slack.
  sim.reset(Simulator::hover_state(Vec3::Zero()));
  EXPECT_TRUE(sim.payload().on_ground);
  EXPECT_FALSE(sim.payload().taut);
  const double climb_thrust_N = 1.2 * (model->mass_kg() + m_L) * g;
  sim.set_rotor_speed_reference(speeds_for_thrust(*model, climb_thrust_N));
  bool lifted = false;
  double z_at_lift_off = 0.0;
  for (int k = 0; k < 3000 && !lifted; ++k) {
    ASSERT_TRUE(sim.step().ok());
    EXPECT_GE(sim.payload().position_W_m.z(), 0.0);
    if (!sim.payload().on_ground) {
      lifted = true;
      z_at_lift_off = sim.state()[kPosition + 2];
    }
  }
  ASSERT_TRUE(lifted);
  // It leaves the ground only once the cable is taut, with the vehicle l above it.
  EXPECT_NEAR(z_at_lift_off, l, 1e-6);
  ASSERT_TRUE(sim.step(1000).ok());
  EXPECT_GT(sim.payload().position_W_m.z(), 0.1);
  EXPECT_NEAR(cable_length(sim), l, 1e-12);
  EXPECT_TRUE(sim.payload().taut);
}

TEST(SimulatorPayload, SwingAnglesInvertEq333AndTheirRatesMatchTheMotion) {
  const auto model = test::load_model("qdrone2");
  Simulator sim(model, still_with_payload(Vec3(0.0, 0.0, -9.81)));
  const double l = sim.config().payload.payload.tether_length_m;
  const double g1 = 0.4, g2 = -0.25;
  PayloadState s;
  const Vec3 vehicle(0.0, 0.0, 5.0);
  sim.reset(Simulator::hover_state(vehicle));
  s.position_W_m =
      vehicle + l * Vec3(std::sin(g1) * std::cos(g2), std::sin(g2), -std::cos(g1) * std::cos(g2));
  // Rates of 0.7 and -1.1 rad/s through the derivative of the Eq. 3.33 parametrisation.
  const double r1 = 0.7, r2 = -1.1;
  s.velocity_W_m_s = l * Vec3(std::cos(g1) * std::cos(g2) * r1 - std::sin(g1) * std::sin(g2) * r2,
                              std::cos(g2) * r2,
                              std::sin(g1) * std::cos(g2) * r1 + std::cos(g1) * std::sin(g2) * r2);
  sim.set_payload_state(s);
  const SwingAngles a = sim.swing_angles();
  EXPECT_NEAR(a.gamma1_rad, g1, 1e-14);
  EXPECT_NEAR(a.gamma2_rad, g2, 1e-14);
  EXPECT_NEAR(a.gamma1_rate_rad_s, r1, 1e-13);
  EXPECT_NEAR(a.gamma2_rate_rad_s, r2, 1e-13);
}

TEST(SimulatorPayload, BadSettingsAndPlacementsAreNamed) {
  const auto model = test::load_model("qdrone2");
  SimConfig c;
  c.payload.enabled = true;
  c.payload.payload.mass_kg = 0.0;
  EXPECT_EQ(test::error_of([&] { Simulator s(model, c); }),
            "simulation config: payload.mass_kg: expected > 0, got 0");
  c.payload.payload.mass_kg = 0.5;
  c.payload.payload.tether_length_m = -1.0;
  EXPECT_EQ(test::error_of([&] { Simulator s(model, c); }),
            "simulation config: payload.tether_length_m: expected > 0, got -1");
  c.payload.payload.tether_length_m = 0.5;
  c.payload.payload.drag_area_m2 = std::nan("");
  EXPECT_EQ(test::error_of([&] { Simulator s(model, c); }),
            "simulation config: payload.drag_area_m2: expected >= 0, got nan");
  c.payload.payload.drag_area_m2 = 0.0;
  c.payload.payload.air_density_kg_m3 = -1.0;
  EXPECT_EQ(test::error_of([&] { Simulator s(model, c); }),
            "simulation config: payload.air_density_kg_m3: expected >= 0, got -1");
  c.payload.payload.air_density_kg_m3 = 1.225;
  c.payload.initial_swing2_rad = std::numeric_limits<double>::infinity();
  EXPECT_EQ(test::error_of([&] { Simulator s(model, c); }),
            "simulation config: payload.initial_swing_rad: expected finite angles, got [0, inf]");
  c.payload.initial_swing2_rad = 0.0;
  Simulator sim(model, c);
  sim.reset(Simulator::hover_state(Vec3(0.0, 0.0, 2.0)));
  PayloadState s;
  s.position_W_m = Vec3(0.0, 0.0, 1.0);
  EXPECT_EQ(test::error_of([&] { sim.set_payload_state(s); }),
            "payload position: 1 m from the vehicle, beyond the tether length 0.5 m");
  SimConfig off;
  Simulator plain(model, off);
  EXPECT_NE(test::error_of([&] { plain.set_payload_state(s); }).find("has no payload"),
            std::string::npos);
}

}  // namespace
}  // namespace dronetwin
