// Conformance suite run over every controller: each file of config/controllers/ (enumerated, so a
// new config is covered without touching this file) and a tiny controller defined here that
// implements only calculate_u. Every controller must give finite, correctly sized outputs at
// arbitrary states, be deterministic after reset(), reject NaN inputs naming the index, and clone
// into an independent controller with identical outputs. At the end, hand-computed outputs of the
// PID and SE(3) equations and of each of their modifications.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/config/controller_config.hpp"
#include "dronetwin/control/controller_base.hpp"
#include "dronetwin/control/pid.hpp"
#include "dronetwin/control/se3.hpp"
#include "dronetwin/core/error.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kRateHz = 1000.0;

/// The smallest useful controller: thrust from a z PD, rate damping. Implements only calculate_u,
/// so the base class allocates.
class TinyHover final : public ControllerBase {
 public:
  using ControllerBase::ControllerBase;
  std::string_view name() const override { return "tiny_hover"; }
  std::unique_ptr<ControllerBase> clone() const override {
    return std::make_unique<TinyHover>(*this);
  }

 protected:
  GeneralizedForce do_calculate_u(const ControlInput& in) override {
    const double m = model().mass_kg();
    const double ez = in.reference.position_m.z() - in.state[2];
    GeneralizedForce u;
    u << m * 9.81 + 10.0 * ez - 4.0 * in.state[5], -0.05 * in.state.segment<3>(10);
    return u;
  }
};

struct ControllerCase {
  std::string name;
  std::function<std::unique_ptr<ControllerBase>(std::shared_ptr<const VehicleModel>)> make;
};

void PrintTo(const ControllerCase& c, std::ostream* os) { *os << c.name; }

std::vector<std::string> config_files() {
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(test::source_path("config/controllers")))
    if (entry.path().extension() == ".yaml") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

std::vector<ControllerCase> all_controllers() {
  std::vector<ControllerCase> cases;
  for (const std::string& path : config_files()) {
    cases.push_back({fs::path(path).stem().string(), [path](auto model) {
                       return load_controller(path, std::move(model), kRateHz);
                     }});
  }
  cases.push_back({"tiny_hover", [](auto model) -> std::unique_ptr<ControllerBase> {
                     return std::make_unique<TinyHover>(std::move(model));
                   }});
  return cases;
}

/// A control input with every field away from zero: random state (test::random_state), random
/// derivative, reference and time.
ControlInput random_input(Random& rng) {
  ControlInput in;
  in.time_s = 100.0 * rng.uniform();
  in.state = test::random_state(rng);
  for (int i = 0; i < kStateSize; ++i) in.state_derivative[i] = 10.0 * rng.uniform() - 5.0;
  ReferencePoint& r = in.reference;
  r.position_m = Vec3(4 * rng.uniform() - 2, 4 * rng.uniform() - 2, 3 * rng.uniform());
  r.velocity_m_s = Vec3(2 * rng.uniform() - 1, 2 * rng.uniform() - 1, rng.uniform() - 0.5);
  r.acceleration_m_s2 = Vec3(2 * rng.uniform() - 1, 2 * rng.uniform() - 1, rng.uniform() - 0.5);
  r.yaw_rad = 6.0 * rng.uniform() - 3.0;
  r.yaw_rate_rad_s = rng.uniform() - 0.5;
  return in;
}

std::vector<ControlInput> random_inputs(std::uint64_t seed, int n) {
  Random rng(seed);
  std::vector<ControlInput> inputs;
  for (int i = 0; i < n; ++i) inputs.push_back(random_input(rng));
  return inputs;
}

/// calculate_actuator_cmd into a NaN-poisoned vector, then calculate_u into a poisoned vector.
struct Output {
  RotorVector w;
  GeneralizedForce u;
};
Output outputs(ControllerBase& c, const ControlInput& in) {
  Output out;
  out.w = RotorVector::Constant(c.model().num_rotors(), kNaN);
  out.w = c.calculate_actuator_cmd(in);
  out.u = GeneralizedForce::Constant(kNaN);
  out.u = c.calculate_u(in);
  return out;
}

bool bitwise_equal(const Output& a, const Output& b) {
  return a.w.size() == b.w.size() &&
         std::memcmp(a.w.data(), b.w.data(),
                     sizeof(double) * static_cast<std::size_t>(a.w.size())) == 0 &&
         std::memcmp(a.u.data(), b.u.data(), sizeof(double) * 4) == 0;
}

class ControllerConformance : public ::testing::TestWithParam<ControllerCase> {
 protected:
  std::shared_ptr<const VehicleModel> model_ = test::load_model("qdrone2");
  std::unique_ptr<ControllerBase> make() const { return GetParam().make(model_); }
};

TEST_P(ControllerConformance, OutputsAreFiniteCorrectlySizedAndWithinRotorLimits) {
  auto c = make();
  Random rng(11);
  for (int k = 0; k < 500; ++k) {
    const ControlInput in = random_input(rng);
    const Output out = outputs(*c, in);
    ASSERT_EQ(out.w.size(), model_->num_rotors()) << "input " << k;
    ASSERT_TRUE(out.w.allFinite()) << "input " << k << ": " << out.w.transpose();
    ASSERT_TRUE(out.u.allFinite()) << "input " << k << ": " << out.u.transpose();
    for (int i = 0; i < model_->num_rotors(); ++i) {
      EXPECT_GE(out.w[i], model_->rotor(i).min_speed_rad_s) << "input " << k;
      EXPECT_LE(out.w[i], model_->rotor(i).max_speed_rad_s) << "input " << k;
    }
  }
}

TEST_P(ControllerConformance, DegenerateInputsStayFinite) {
  // A zero quaternion (finite, so accepted), a vehicle upside down or pointing straight up, and a
  // reference that asks for free fall: no NaN may come out.
  auto c = make();
  std::vector<ControlInput> inputs(4);
  inputs[0].state.segment<4>(6).setZero();
  inputs[1].state.segment<4>(6) = math::from_euler(std::numbers::pi, 0, 0);
  inputs[2].state.segment<4>(6) = math::from_euler(0, std::numbers::pi / 2, 0);
  inputs[3].state.segment<4>(6) = Vec4(1, 0, 0, 0);
  inputs[3].reference.acceleration_m_s2 = Vec3(0, 0, -9.81);
  for (const ControlInput& in : inputs) {
    const Output out = outputs(*c, in);
    EXPECT_TRUE(out.w.allFinite() && out.u.allFinite()) << out.u.transpose();
  }
}

TEST_P(ControllerConformance, DeterministicAfterReset) {
  auto c = make();
  const std::vector<ControlInput> inputs = random_inputs(21, 200);
  std::vector<Output> first;
  for (const ControlInput& in : inputs) first.push_back(outputs(*c, in));
  c->reset();
  for (std::size_t k = 0; k < inputs.size(); ++k)
    ASSERT_TRUE(bitwise_equal(outputs(*c, inputs[k]), first[k])) << "input " << k;
}

TEST_P(ControllerConformance, NanInputIsRejectedNamingTheIndex) {
  auto c = make();
  const ControlInput good = random_inputs(31, 1).front();
  for (int i = 0; i < kStateSize; ++i) {
    ControlInput in = good;
    in.state[i] = kNaN;
    try {
      c->calculate_actuator_cmd(in);
      ADD_FAILURE() << "state[" << i << "] = NaN was accepted";
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find("state[" + std::to_string(i) + "]"), std::string::npos)
          << e.what();
    }
    in = good;
    in.state_derivative[i] = kNaN;
    try {
      c->calculate_u(in);
      ADD_FAILURE() << "state_derivative[" << i << "] = NaN was accepted";
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find("state_derivative[" + std::to_string(i) + "]"),
                std::string::npos)
          << e.what();
    }
  }
  ControlInput in = good;
  in.reference.yaw_rad = kNaN;
  EXPECT_THROW(c->calculate_actuator_cmd(in), InvalidArgument);
}

TEST_P(ControllerConformance, CloneIsIndependentWithIdenticalOutputs) {
  auto original = make();
  // Give the original some memory (integrators) first.
  for (const ControlInput& in : random_inputs(41, 50)) outputs(*original, in);
  auto copy = original->clone();
  auto witness = original->clone();
  EXPECT_EQ(copy->name(), original->name());
  EXPECT_EQ(copy->level(), original->level());
  const std::vector<ControlInput> inputs = random_inputs(42, 100);
  std::vector<Output> expected;
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    expected.push_back(outputs(*copy, inputs[k]));
    ASSERT_TRUE(bitwise_equal(expected.back(), outputs(*original, inputs[k]))) << "input " << k;
  }
  // The witness was cloned with the others but never used. Driving and resetting the original
  // must not change what it does: it still gives what the copy gave from the same start.
  for (const ControlInput& in : random_inputs(43, 100)) outputs(*original, in);
  original->reset();
  for (std::size_t k = 0; k < inputs.size(); ++k)
    ASSERT_TRUE(bitwise_equal(outputs(*witness, inputs[k]), expected[k])) << "input " << k;
}

INSTANTIATE_TEST_SUITE_P(AllControllers, ControllerConformance,
                         ::testing::ValuesIn(all_controllers()),
                         [](const ::testing::TestParamInfo<ControllerCase>& p) {
                           std::string name = p.param.name;
                           for (char& ch : name)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return name;
                         });

TEST(ControllerConformanceSuite, CoversEveryShippedConfig) {
  // The suite enumerates the directory; this guards against an empty or unreadable one.
  const std::vector<std::string> files = config_files();
  EXPECT_GE(files.size(), 5u);
  std::vector<std::string> names;
  for (const auto& f : files) names.push_back(fs::path(f).stem().string());
  for (const char* expected : {"pid", "pid_thesis", "pid_hardware", "se3", "se3_thesis"})
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
}

// ---- the equations at one instant, by hand ----------------------------------------------------
// Independent transcriptions of thesis Eq. 3.15-3.20 (PID) and Eq. 3.27-3.28 (SE(3)) at one
// input, and the effect of each modification.

ControlInput sample_input() {
  ControlInput in;
  in.state.segment<3>(0) = Vec3(0.1, -0.2, 0.9);
  in.state.segment<3>(3) = Vec3(0.3, 0.1, -0.2);
  in.state.segment<4>(6) = math::from_euler(0.05, -0.03, 0.2);
  in.state.segment<3>(10) = Vec3(0.1, -0.2, 0.3);
  in.state_derivative.segment<3>(10) = Vec3(1.0, 2.0, 3.0);
  in.reference.position_m = Vec3(0.5, 0.4, 1.0);
  in.reference.velocity_m_s = Vec3(1.0, -1.0, 0.5);
  in.reference.yaw_rad = 0.1;
  in.reference.yaw_rate_rad_s = 0.2;
  return in;
}

/// Eq. 3.15-3.20 as printed for the numbers of sample_input(), first call (integral = e_p dt),
/// optionally with the reference velocity fed forward.
GeneralizedForce printed_pid(const PidGains& g, double dt, bool feedforward) {
  const double phi = 0.05, theta = -0.03, psi = 0.2;
  const Vec3 w(0.1, -0.2, 0.3), alpha(1, 2, 3);
  const double psi_dot =
      (std::sin(phi) * w[1] + std::cos(phi) * w[2]) / std::cos(theta);  // Eq. 2.8
  const Vec4 e_p(0.5 - 0.1, 0.4 + 0.2, 1.0 - 0.9, 0.1 - psi);
  Vec4 e_v(-0.3, -0.1, 0.2, -psi_dot);
  if (feedforward) e_v += Vec4(1.0, -1.0, 0.5, 0.2);
  const Vec4 u_outer =
      g.outer_p.cwiseProduct(e_p) + g.outer_d.cwiseProduct(e_v) + g.outer_i.cwiseProduct(e_p * dt);
  const double T = u_outer[2] + 1.504 * 9.81;
  const Vec3 e_att(-u_outer[1] - phi, u_outer[0] - theta, u_outer[3]);
  GeneralizedForce u;
  u << T,
      g.inner_p.cwiseProduct(e_att) - g.inner_d1.cwiseProduct(w) - g.inner_d2.cwiseProduct(alpha);
  return u;
}

TEST(PidEquations, AsPrintedMatchesEquations315To320) {
  const auto model = test::load_model("qdrone2");
  for (const PidGains& g : {PidGains::thesis_simulation(), PidGains::thesis_hardware()}) {
    CascadedPid pid(model, g, PidOptions{}, 1e-3);
    const GeneralizedForce u = pid.calculate_u(sample_input());
    EXPECT_LT((u - printed_pid(g, 1e-3, false)).norm(), 1e-12) << u.transpose();
    // The sum includes the current sample (notes #33): the second identical call adds K_I e_p dt
    // once more, e.g. 6 * 0.1 * 1e-3 N of thrust.
    const GeneralizedForce u2 = pid.calculate_u(sample_input());
    EXPECT_NEAR(u2[0] - u[0], g.outer_i[2] * 0.1 * 1e-3, 1e-12);
    EXPECT_LT((pid.integral() - Vec4(0.4, 0.6, 0.1, 0.1 - 0.2) * 2e-3).norm(), 1e-15);
  }
}

TEST(PidEquations, VelocityFeedforwardUsesTheReferenceDerivatives) {
  const auto model = test::load_model("qdrone2");
  PidOptions o;
  o.velocity_feedforward = true;
  CascadedPid pid(model, PidGains::thesis_simulation(), o, 1e-3);
  const GeneralizedForce expected = printed_pid(PidGains::thesis_simulation(), 1e-3, true);
  EXPECT_LT((pid.calculate_u(sample_input()) - expected).norm(), 1e-12);
}

TEST(PidEquations, TiltLimitClipsTheAttitudeCommand) {
  const auto model = test::load_model("qdrone2");
  ControlInput in;                                 // level, at rest at the origin
  in.reference.position_m = Vec3(5.0, -5.0, 0.0);  // asks for theta_des = phi_des = 0.471 * 5
  PidGains g = PidGains::thesis_simulation();
  g.outer_i.setZero();
  PidOptions o;
  o.max_tilt_rad = 0.2;
  CascadedPid pid(model, g, o, 1e-3);
  const GeneralizedForce u = pid.calculate_u(in);
  // phi_des = -u_y = -0.471 * (-5) -> +0.2; theta_des = u_x -> +0.2; inner P 12 N m/rad.
  EXPECT_NEAR(u[1], 12.0 * 0.2, 1e-12);
  EXPECT_NEAR(u[2], 12.0 * 0.2, 1e-12);
  CascadedPid printed(model, g, PidOptions{}, 1e-3);
  EXPECT_NEAR(printed.calculate_u(in)[2], 12.0 * 0.471 * 5.0, 1e-9);
}

TEST(PidEquations, AntiWindupClampsAndFreezesTheIntegral) {
  const auto model = test::load_model("qdrone2");
  ControlInput in;
  in.reference.position_m = Vec3(5.0, 0.0, 1.0);  // x command clipped by the tilt limit
  PidOptions o;
  o.max_tilt_rad = 0.2;
  o.conditional_integration = true;
  o.integral_limit = Vec4(0.5, 0.5, 0.05, 1.0);
  CascadedPid pid(model, PidGains::thesis_simulation(), o, 1e-2);
  for (int k = 0; k < 200; ++k) pid.calculate_u(in);
  EXPECT_EQ(pid.integral()[0], 0.0);   // x saturated and pushing further: frozen
  EXPECT_EQ(pid.integral()[2], 0.05);  // z: 1 m * 2 s would be 2 m s, clamped at 0.05
  pid.reset();
  EXPECT_EQ(pid.integral(), Vec4::Zero());
}

TEST(PidEquations, YawErrorWrapAndYawLoops) {
  const auto model = test::load_model("qdrone2");
  ControlInput in;
  in.state.segment<4>(6) = math::from_euler(0, 0, -3.0);
  in.reference.yaw_rad = 3.0;  // 6 rad apart, or -0.283 rad the short way
  PidGains g = PidGains::thesis_hardware();
  g.outer_i.setZero();
  g.inner_d2.setZero();
  CascadedPid printed(model, g, PidOptions{}, 1e-3);
  PidOptions wrap;
  wrap.yaw_error_wrap = true;
  CascadedPid wrapped(model, g, wrap, 1e-3);
  EXPECT_NEAR(printed.calculate_u(in)[3], 2.0 * 1.5 * 6.0, 1e-9);
  EXPECT_NEAR(wrapped.calculate_u(in)[3], 2.0 * 1.5 * (6.0 - 2.0 * std::numbers::pi), 1e-9);
  // Rate loop: the inner yaw error is psi_des - w_z.
  in.state.segment<4>(6) = Vec4(1, 0, 0, 0);
  in.reference.yaw_rad = 0.0;
  in.state[12] = 0.5;
  PidOptions rate;
  rate.yaw_loop = PidYawLoop::kRate;
  CascadedPid rate_loop(model, g, rate, 1e-3);
  const double psi_des = -0.4 * 0.5;  // K_D,psi * (-psi_dot), psi_dot = w_z when level
  EXPECT_NEAR(printed.calculate_u(in)[3], 2.0 * psi_des - 0.01 * 0.5, 1e-12);
  EXPECT_NEAR(rate_loop.calculate_u(in)[3], 2.0 * (psi_des - 0.5) - 0.01 * 0.5, 1e-12);
}

TEST(PidEquations, YawFrameMappingRotatesTheHorizontalCommand) {
  // Facing +y (psi = pi/2), an x error must become a roll command: the body y axis points along
  // world -x, and a positive roll tilts the thrust toward body -y, i.e. toward world +x.
  const auto model = test::load_model("qdrone2");
  ControlInput in;
  in.state.segment<4>(6) = math::from_euler(0, 0, std::numbers::pi / 2);
  in.reference.position_m = Vec3(0.1, 0, 0);
  in.reference.yaw_rad = std::numbers::pi / 2;
  PidGains g = PidGains::thesis_simulation();
  g.outer_i.setZero();
  PidOptions o;
  o.yaw_frame_mapping = true;
  CascadedPid pid(model, g, o, 1e-3);
  const GeneralizedForce u = pid.calculate_u(in);
  EXPECT_NEAR(u[1], 12.0 * 0.471 * 0.1, 1e-12);  // roll
  EXPECT_NEAR(u[2], 0.0, 1e-12);                 // pitch
}

TEST(Se3Equations, HoverOnTheReferenceIsWeightAndNoMoment) {
  const auto model = test::load_model("qdrone2");
  ControlInput in;
  in.state.segment<3>(0) = Vec3(0, 0, 1);
  in.state.segment<4>(6) = Vec4(1, 0, 0, 0);
  in.reference.position_m = Vec3(0, 0, 1);
  Se3Options o;
  o.gravity_compensation = true;
  Se3Controller se3(model, Se3Gains::thesis(), o);
  const GeneralizedForce u = se3.calculate_u(in);
  EXPECT_NEAR(u[0], 1.504 * 9.81, 1e-12);
  EXPECT_LT(u.tail<3>().norm(), 1e-12);
  // As printed (no m g e3) the same point gives F = 0: no direction, no thrust, and no NaN.
  Se3Controller printed(model, Se3Gains::thesis(), Se3Options{});
  EXPECT_EQ(printed.calculate_u(in), GeneralizedForce::Zero());
}

TEST(Se3Equations, TiltedForceGivesTheGeometricMoment) {
  // Level vehicle, desired force tilted by a about +y: R_des = Ry(a), e_R = 1/2 vee(R_des^T -
  // R_des) = (0, -sin a, 0), so M = (0, K_R,y sin a, 0) (Eq. 3.27) and f = F . e3 = F_z.
  const auto model = test::load_model("qdrone2");
  const double m = 1.504, g = 9.81;
  ControlInput in;
  in.state.segment<4>(6) = Vec4(1, 0, 0, 0);
  in.reference.acceleration_m_s2 = Vec3(3.0, 0, 0);  // F = m (3, 0, g)
  Se3Options o;
  o.gravity_compensation = true;
  Se3Controller se3(model, Se3Gains::thesis(), o);
  GeneralizedForce u = se3.calculate_u(in);
  const double a = std::atan2(3.0, g);
  EXPECT_NEAR(u[0], m * g, 1e-12);
  EXPECT_NEAR(u[2], 20.75 * std::sin(a), 1e-12);
  EXPECT_NEAR(u[1], 0.0, 1e-12);
  EXPECT_NEAR(u[3], 0.0, 1e-12);
  // With a 0.2 rad cone the direction is clipped to the cone and the vertical part kept.
  o.max_tilt_rad = 0.2;
  Se3Controller limited(model, Se3Gains::thesis(), o);
  u = limited.calculate_u(in);
  EXPECT_NEAR(u[0], m * g, 1e-12);
  EXPECT_NEAR(u[2], 20.75 * std::sin(0.2), 1e-12);
}

TEST(Se3Equations, NonnegativeThrustAndGyroscopicTerm) {
  const auto model = test::load_model("qdrone2");
  ControlInput in;
  in.state.segment<4>(6) = math::from_euler(std::numbers::pi, 0, 0);  // upside down
  in.state.segment<3>(10) = Vec3(1.0, 2.0, 0.0);
  Se3Options o;
  o.gravity_compensation = true;
  Se3Controller printed_thrust(model, Se3Gains::thesis(), o);
  EXPECT_NEAR(printed_thrust.calculate_u(in)[0], -1.504 * 9.81, 1e-9);  // F . R e3 < 0
  o.nonnegative_thrust = true;
  Se3Controller clamped(model, Se3Gains::thesis(), o);
  const GeneralizedForce u = clamped.calculate_u(in);
  EXPECT_EQ(u[0], 0.0);
  // Upside down exactly, R = Rx(pi) is symmetric, so e_R = 1/2 vee(R - R^T) = 0 (the geometric
  // controller's antipodal blind spot): M = -K_w w + w x J w, whose z part is the gyroscopic
  // (J_yy - J_xx) w_x w_y.
  EXPECT_NEAR(u[1], -4.5 * 1.0, 1e-12);
  EXPECT_NEAR(u[2], -4.5 * 2.0, 1e-12);
  EXPECT_NEAR(u[3], (0.0169101 - 0.0147209) * 1.0 * 2.0, 1e-12);
}

}  // namespace
}  // namespace dronetwin
