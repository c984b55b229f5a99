// Each force/moment term of the QDrone2 model against a hand calculation at one chosen state.
// The expected values are written out component by component from the thesis constants
// (Table 2.1, Eq. 2.22-2.35), not computed with the library's vector code.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "dronetwin/dynamics/vehicle_dynamics.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

// Thesis constants (Table 2.1, Eq. 2.22, 2.25) and the SDF rotor height (notes #7).
constexpr double kK1 = 1.9533e-6, kK2 = 8.594e-4, kK3 = -0.0121;
constexpr double kKtau = 68.9055;
constexpr double kCD = 0.00020673, kCR = 1e-8, kCMD = 1e-7, kCG = 0.0006, kJr = 4.92e-6;
constexpr double kMass = 1.504;
constexpr double kRx[4] = {-0.1016, 0.1016, -0.1016, 0.1016};
constexpr double kRy[4] = {-0.127, -0.127, 0.127, 0.127};
constexpr double kRz = 0.023;
constexpr double kEps[4] = {1, -1, -1, 1};
constexpr double kSpeeds[4] = {1100.0, 1250.0, 1180.0, 1320.0};

double thrust(double w) { return kK1 * w * w + kK2 * w + kK3; }

class RotorTermsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    model = test::load_model("qdrone2");
    speeds = RotorVector(4);
    for (int i = 0; i < 4; ++i) speeds[i] = kSpeeds[i];
    // Level attitude, so body and world axes coincide and the hand calculation stays readable.
    x = StateVector::Zero();
    x.segment<3>(0) << 0.3, -0.2, 0.5;
    x.segment<3>(3) << 2.0, -1.0, 0.5;   // v_W
    x[6] = 1.0;                          // q = identity
    x.segment<3>(10) << 0.3, -0.2, 0.5;  // w_B
    env.wind_W_m_s << 0.5, 0.0, 0.0;
  }
  WrenchBreakdown breakdown(const DisturbanceSwitches& sw = {}) const {
    return wrench_breakdown(*model, sw, env, x, speeds);
  }
  // In-plane hub air velocity of rotor i at the chosen state, by components:
  // v_hub = (v - wind) + w x r, axis = e3 so the in-plane part drops the z component.
  void v_perp(int i, double& vx, double& vy) const {
    const double wx = 0.3, wy = -0.2, wz = 0.5;
    vx = (2.0 - 0.5) + (wy * kRz - wz * kRy[i]);
    vy = (-1.0 - 0.0) + (wz * kRx[i] - wx * kRz);
  }

  std::shared_ptr<const VehicleModel> model;
  RotorVector speeds;
  StateVector x;
  Environment env;
};

TEST_F(RotorTermsTest, ThrustAndItsMoment) {  // Eq. 2.22, 2.24, 2.27
  const auto b = breakdown();
  double fz = 0, mx = 0, my = 0;
  for (int i = 0; i < 4; ++i) {
    const double t = thrust(kSpeeds[i]);
    fz += t;
    mx += kRy[i] * t;   // (r x T e3)_x = r_y T
    my += -kRx[i] * t;  // (r x T e3)_y = -r_x T
  }
  const Wrench<double> w = b[Term::kThrust];
  EXPECT_NEAR(w.force_B.x(), 0.0, 1e-15);
  EXPECT_NEAR(w.force_B.y(), 0.0, 1e-15);
  EXPECT_NEAR(w.force_B.z(), fz, 1e-12);
  EXPECT_NEAR(w.moment_B.x(), mx, 1e-13);
  EXPECT_NEAR(w.moment_B.y(), my, 1e-13);
  EXPECT_NEAR(w.moment_B.z(), 0.0, 1e-15);
}

TEST_F(RotorTermsTest, YawReaction) {  // Eq. 2.24: +eps T / K_tau
  double mz = 0;
  for (int i = 0; i < 4; ++i) mz += kEps[i] * thrust(kSpeeds[i]) / kKtau;
  const Wrench<double> w = breakdown()[Term::kYawReaction];
  EXPECT_NEAR(w.moment_B.z(), mz, 1e-14);
  EXPECT_EQ(w.force_B.norm(), 0.0);
}

TEST_F(RotorTermsTest, RotorDragActsAtTheHub) {  // Eq. 2.32 with per-rotor hub velocity
  double fx = 0, fy = 0, mx = 0, my = 0, mz = 0;
  for (int i = 0; i < 4; ++i) {
    double vx, vy;
    v_perp(i, vx, vy);
    const double dfx = -kSpeeds[i] * kCD * vx, dfy = -kSpeeds[i] * kCD * vy;
    fx += dfx;
    fy += dfy;
    // r x F with F = (dfx, dfy, 0)
    mx += -kRz * dfy;
    my += kRz * dfx;
    mz += kRx[i] * dfy - kRy[i] * dfx;
  }
  const Wrench<double> w = breakdown()[Term::kRotorDrag];
  EXPECT_NEAR(w.force_B.x(), fx, 1e-13);
  EXPECT_NEAR(w.force_B.y(), fy, 1e-13);
  EXPECT_NEAR(w.force_B.z(), 0.0, 1e-15);
  EXPECT_NEAR(w.moment_B.x(), mx, 1e-14);
  EXPECT_NEAR(w.moment_B.y(), my, 1e-14);
  EXPECT_NEAR(w.moment_B.z(), mz, 1e-14);
  // The yaw-rate part is a damping: about 4 C_D w r^2 w_z (notes #14), so the yaw moment
  // opposes w_z = 0.5 rad/s here.
  EXPECT_LT(w.moment_B.z(), 0.0);
}

TEST_F(RotorTermsTest, RollingMoment) {  // Eq. 2.32: +|w| C_R v_perp
  double mx = 0, my = 0;
  for (int i = 0; i < 4; ++i) {
    double vx, vy;
    v_perp(i, vx, vy);
    mx += kSpeeds[i] * kCR * vx;
    my += kSpeeds[i] * kCR * vy;
  }
  const Wrench<double> w = breakdown()[Term::kRollingMoment];
  EXPECT_NEAR(w.moment_B.x(), mx, 1e-18);
  EXPECT_NEAR(w.moment_B.y(), my, 1e-18);
  EXPECT_EQ(w.moment_B.z(), 0.0);
}

TEST_F(RotorTermsTest, DragMoment) {  // Eq. 2.32: -eps C_MD T e3
  double mz = 0;
  for (int i = 0; i < 4; ++i) mz += -kEps[i] * kCMD * thrust(kSpeeds[i]);
  EXPECT_NEAR(breakdown()[Term::kDragMoment].moment_B.z(), mz, 1e-20);
}

TEST_F(RotorTermsTest, GroundEffect) {  // appendix C.2 form: C_G T / h^2, h = hub height
  double fz = 0, mx = 0, my = 0;
  for (int i = 0; i < 4; ++i) {
    const double h = 0.5 + kRz;  // level: every hub is r_z above the body origin
    const double f = kCG * thrust(kSpeeds[i]) / (h * h);
    fz += f;
    mx += kRy[i] * f;
    my += -kRx[i] * f;
  }
  const Wrench<double> w = breakdown()[Term::kGroundEffect];
  EXPECT_NEAR(w.force_B.z(), fz, 1e-13);
  EXPECT_NEAR(w.moment_B.x(), mx, 1e-14);
  EXPECT_NEAR(w.moment_B.y(), my, 1e-14);
}

TEST_F(RotorTermsTest, GroundEffectHeightIsFlooredAtTheHubClearance) {
  x[2] = 0.0;  // body origin on the ground: hubs at 0.023 m, the floor
  const double at_floor = breakdown()[Term::kGroundEffect].force_B.z();
  double expected = 0;
  for (int i = 0; i < 4; ++i) expected += kCG * thrust(kSpeeds[i]) / (0.023 * 0.023);
  EXPECT_NEAR(at_floor, expected, 1e-10);
  // Rolled by 30 deg, the lower hubs would be below 0.023 m: the force stays finite, floored.
  x.segment<4>(6) = math::from_euler(0.5, 0.0, 0.0);
  const auto tilted = breakdown()[Term::kGroundEffect];
  EXPECT_TRUE(tilted.force_B.allFinite());
  EXPECT_LE(tilted.force_B.norm(), expected * (1 + 1e-12));
}

TEST_F(RotorTermsTest, Gyroscopic) {  // Eq. 2.35 with the minus of Eq. 2.37
  double hz = 0;
  for (int i = 0; i < 4; ++i) hz += kEps[i] * kJr * kSpeeds[i];
  // -w x (0, 0, hz) = -(w_y hz, -w_x hz, 0)
  const Wrench<double> w = breakdown()[Term::kGyroscopic];
  EXPECT_NEAR(w.moment_B.x(), -(-0.2 * hz), 1e-18);
  EXPECT_NEAR(w.moment_B.y(), -(-0.3 * hz), 1e-18);
  EXPECT_EQ(w.moment_B.z(), 0.0);
}

TEST_F(RotorTermsTest, BodyDragAtLevelAttitude) {  // Eq. 2.32: -A v_air
  const Wrench<double> w = breakdown()[Term::kBodyDrag];
  EXPECT_NEAR(w.force_B.x(), -0.3 * (2.0 - 0.5), 1e-15);
  EXPECT_NEAR(w.force_B.y(), -0.3 * (-1.0), 1e-15);
  EXPECT_NEAR(w.force_B.z(), -0.25 * 0.5, 1e-15);
  EXPECT_EQ(w.moment_B.norm(), 0.0);
}

TEST_F(RotorTermsTest, BodyDragTurnsWithTheAirframe) {
  // Rolled 90 deg about x: body z points along world -y... (R e3 = (0, -1, 0)). A purely world-y
  // airflow then meets the airframe along its z axis, the 0.25 N s/m direction (our body-frame
  // reading, docs/conventions.md), not the 0.3 of the world-frame reading.
  x.segment<4>(6) = math::from_euler(std::numbers::pi / 2, 0.0, 0.0);
  x.segment<3>(3) << 0.0, 2.0, 0.0;
  env.wind_W_m_s.setZero();
  const Wrench<double> w = breakdown()[Term::kBodyDrag];
  const Vec3 force_W = math::rotation_matrix<double>(x.segment<4>(6)) * w.force_B;
  EXPECT_NEAR(force_W.y(), -0.25 * 2.0, 1e-14);
  EXPECT_NEAR(force_W.x(), 0.0, 1e-14);
  EXPECT_NEAR(force_W.z(), 0.0, 1e-14);
}

TEST_F(RotorTermsTest, GravityExpressedInTheBodyFrame) {
  const Wrench<double> w = breakdown()[Term::kGravity];
  EXPECT_NEAR(w.force_B.z(), -kMass * 9.81, 1e-12);
}

TEST_F(RotorTermsTest, EachSwitchRemovesOnlyItsTerm) {
  const auto all = breakdown();
  const std::pair<bool DisturbanceSwitches::*, Term> switches[] = {
      {&DisturbanceSwitches::rotor_drag, Term::kRotorDrag},
      {&DisturbanceSwitches::rolling_moment, Term::kRollingMoment},
      {&DisturbanceSwitches::drag_moment, Term::kDragMoment},
      {&DisturbanceSwitches::ground_effect, Term::kGroundEffect},
      {&DisturbanceSwitches::gyroscopic, Term::kGyroscopic},
      {&DisturbanceSwitches::body_drag, Term::kBodyDrag}};
  for (const auto& [member, term] : switches) {
    DisturbanceSwitches sw;
    sw.*member = false;
    const auto b = breakdown(sw);
    for (int t = 0; t < kNumTerms; ++t) {
      const Term other = static_cast<Term>(t);
      if (other == term) {
        EXPECT_EQ(b[other].force_B.norm() + b[other].moment_B.norm(), 0.0) << term_name(term);
        EXPECT_GT(all[other].force_B.norm() + all[other].moment_B.norm(), 0.0) << term_name(term);
      } else {
        EXPECT_EQ(b[other].force_B, all[other].force_B) << term_name(term);
        EXPECT_EQ(b[other].moment_B, all[other].moment_B) << term_name(term);
      }
    }
  }
}

TEST_F(RotorTermsTest, BreakdownDrivesTheNewtonEulerEquations) {
  // a_W = R F_total / m and J w_dot = M_total - w x J w, with F_total including gravity.
  const auto total = breakdown().total();
  const StateVector xdot = state_derivative<double>(*model, {}, env, x, speeds);
  const Vec3 a_expected = total.force_B / kMass;  // level attitude: R = I
  EXPECT_LT((xdot.segment<3>(3) - a_expected).norm(), 1e-12);
  const Vec3 w = x.segment<3>(10);
  const Mat3 J = model->inertia_kgm2();
  const Vec3 wdot_expected = J.inverse() * (total.moment_B - w.cross(J * w));
  EXPECT_LT((xdot.segment<3>(10) - wdot_expected).norm(), 1e-10);
}

}  // namespace
}  // namespace dronetwin
