// PolicyController (policy/policy_controller.hpp): a policy flown by the controller through
// ClosedLoop sees the observations the VecEnv shows it and flies the same path, for the position,
// CTBR and generalized-force modes; mismatched policies and rotor-speed or sensor observations are
// refused.

#include "dronetwin/policy/policy_controller.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "dronetwin/config/env_config_loader.hpp"
#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/control/reference.hpp"
#include "dronetwin/rl/vec_env.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

EnvFile hover_env(const std::string& overrides) {
  return load_env_config(test::source_path("config/rl/hover.yaml"), overrides);
}

// A linear "policy" on the hover default's observation (target_relative, velocity, rotation,
// body_rates, previous_action): positions a = K (target - p) - D v; thrust and rates (or torques)
// from the height error and the tilt (below). Squashed by tanh for the normalised modes.
std::shared_ptr<const PolicyFile> pd_policy(const rl::VecEnv<double>& env, double kp, double kd,
                                            bool squash,
                                            const Eigen::VectorXd& bias = Eigen::VectorXd()) {
  PolicyFile p;
  const int n = env.observation_size(), m = env.action_size();
  p.observation_size = n;
  p.action_size = m;
  for (const rl::PieceSlice& s : env.observation_layout())
    p.observation.push_back(
        {std::string(rl::kObservationPieceNames[static_cast<std::size_t>(s.piece)]), s.size});
  p.action_mode = std::string(rl::kActionModeNames[static_cast<std::size_t>(env.config().action)]);
  p.normalized_actions = env.config().normalized_actions;
  Mlp& mlp = p.mlp;
  mlp.observation_mean = Eigen::VectorXd::Zero(n);
  mlp.observation_std = Eigen::VectorXd::Ones(n);
  mlp.observation_clip = 1e6;
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(m, n);
  const rl::ActionMode mode = env.config().action;
  if (mode == rl::ActionMode::kCtbr || mode == rl::ActionMode::kGeneralizedForce) {
    // [T, roll, pitch, yaw]: thrust from the height error and vertical speed; roll and pitch
    // levelled from the body z axis in the world (R(1,2) = -roll, R(0,2) = pitch: rotation
    // piece entries 6 + 3 * 2 + 1 and 6 + 3 * 2 + 0), damped by the body rates (15, 16).
    W(0, 2) = kp;
    W(0, 5) = -kd;
    W(1, 13) = 2.0 * kp;
    W(2, 12) = -2.0 * kp;
    W(1, 15) = -kd;
    W(2, 16) = -kd;
  } else {
    for (int k = 0; k < std::min(3, m); ++k) {
      W(k, k) = kp;
      W(k, 3 + k) = -kd;
    }
  }
  mlp.weights = {W};
  mlp.biases = {bias.size() == m ? bias : Eigen::VectorXd::Zero(m)};
  mlp.output = squash ? Mlp::OutputSquash::kTanh : Mlp::OutputSquash::kIdentity;
  mlp.action_scale = Eigen::VectorXd::Ones(m);
  p.source = "pd.dtpolicy";
  return std::make_shared<const PolicyFile>(std::move(p));
}

// The same policy, once in the VecEnv (one env, its own stepping) and once as a controller in a
// ClosedLoop at the physics rate from the env's start state: same observations, same path.
void expect_same_flight(const std::string& overrides, double kp, double kd, bool squash,
                        const Eigen::VectorXd& bias = Eigen::VectorXd()) {
  EnvFile f = hover_env(overrides);
  rl::VecEnv<double> env(f.model, f.config, 1, 1);
  const auto policy = pd_policy(env, kp, kd, squash, bias);
  MlpEvaluator network(std::shared_ptr<const Mlp>(policy, &policy->mlp));

  Simulator sim(f.model, f.config.sim);
  sim.set_state(env.batch().state(0));
  sim.set_rotor_speeds(env.batch().rotor_speeds(0));  // the env starts them at hover
  PolicyController controller(f.model, policy, f.config);
  const SetpointReference target(env.target(0));
  ClosedLoop loop(sim, controller, target, 1.0 / f.config.sim.dt_s);

  std::vector<double> obs(static_cast<std::size_t>(env.observation_size()));
  std::vector<double> action(static_cast<std::size_t>(env.action_size()));
  for (int t = 0; t < 150; ++t) {  // 1.5 s
    const double* o = env.observation<double>();
    network.evaluate(o, action.data());
    for (int s = 0; s < env.substeps(); ++s) {
      loop.step();
      if (s == 0) {
        // The controller's observation at its policy step is the env's at this env step.
        for (int i = 0; i < env.observation_size(); ++i)
          ASSERT_NEAR(controller.observation()[static_cast<std::size_t>(i)], o[i], 1e-9)
              << "step " << t << ", observation " << i;
      }
    }
    env.step(action.data());
    ASSERT_FALSE(env.done_data()[0]) << rl::kEndCauseNames[env.end_cause_data()[0]];
    const StateVector a = env.batch().state(0), b = sim.state();
    for (int k = 0; k < 13; ++k)
      ASSERT_NEAR(a[k], b[k], 1e-9) << "step " << t << ", x[" << k << "]";
  }
  EXPECT_EQ(controller.policy_steps(), 150);
}

TEST(PolicyController, RelativePositionFliesAsTheEnv) {
  expect_same_flight("{action: relative_position}", 1.0, 0.3, false);
}

TEST(PolicyController, GlobalPositionFliesAsTheEnv) {
  // The point [0, 0, 1.5] moved by K (target - p) - D v, yaw 0.
  Eigen::VectorXd bias(4);
  bias << 0.0, 0.0, 1.5, 0.0;
  expect_same_flight("{action: global_position}", 0.5, 0.2, false, bias);
}

TEST(PolicyController, NormalisedCtbrFliesAsTheEnv) {
  expect_same_flight("{action: ctbr, normalized_actions: true, max_thrust_to_weight: 2}", 0.3, 0.3,
                     true);
}

TEST(PolicyController, GeneralizedForceFliesAsTheEnv) {
  expect_same_flight(
      "{action: generalized_force, normalized_actions: true, max_thrust_to_weight: 2}", 0.2, 0.2,
      true);
}

TEST(PolicyController, RotorSpeedModeIsARotorSpeedController) {
  EnvFile f = hover_env("{action: rotor_speeds, normalized_actions: true}");
  rl::VecEnv<double> env(f.model, f.config, 1, 1);
  PolicyController c(f.model, pd_policy(env, 0.0, 0.0, true), f.config);
  EXPECT_EQ(c.level(), ControlLevel::kRotorSpeed);
  ControlInput in;
  in.state = env.batch().state(0);
  // A zero network output is the middle of every rotor's speed range.
  const RotorVector w = c.calculate_actuator_cmd(in);
  for (int i = 0; i < f.model->num_rotors(); ++i) {
    const auto& r = f.model->rotor(i);
    EXPECT_DOUBLE_EQ(w[i], 0.5 * (r.min_speed_rad_s + r.max_speed_rad_s));
  }
  EXPECT_THROW((void)c.calculate_u(in), InvalidArgument);
}

TEST(PolicyController, MismatchedPoliciesAreRefusedNamingWhatDiffers) {
  EnvFile f = hover_env("{action: relative_position}");
  rl::VecEnv<double> env(f.model, f.config, 1, 1);
  const auto policy = pd_policy(env, 1.0, 0.0, false);
  const auto message = [&](const EnvFile& other) {
    try {
      PolicyController c(other.model, policy, other.config);
    } catch (const InvalidArgument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string obs = message(hover_env("{observation: [velocity, target_relative]}"));
  EXPECT_NE(obs.find("pd.dtpolicy"), std::string::npos) << obs;
  EXPECT_NE(obs.find("observation"), std::string::npos) << obs;
  const std::string act = message(hover_env("{action: ctbr}"));
  EXPECT_NE(act.find("action"), std::string::npos) << act;
  // Rotor speeds are not in a ControlInput: a policy that observes them cannot be flown here.
  EnvFile rs = hover_env("{observation: [target_relative, velocity, rotor_speeds]}");
  rl::VecEnv<double> env_rs(rs.model, rs.config, 1, 1);
  try {
    PolicyController c(rs.model, pd_policy(env_rs, 1.0, 0.0, false), rs.config);
    ADD_FAILURE() << "no error";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("observes rotor_speeds"), std::string::npos) << e.what();
  }
}

// Sensor readings and depth frames come from a VecEnv's sensor suites, which a controller does not
// simulate: a policy trained on them is refused with the way out.
TEST(PolicyController, APolicyThatObservesSensorsIsRefused) {
  for (const std::string sensors :
       {"{sensors: [{type: imu, rate_hz: 100}]}",
        "{sensors: [{type: depth_camera, rate_hz: 10, width_px: 4, height_px: 3}]}"}) {
    EnvFile f = hover_env(sensors);
    rl::VecEnv<double> env(f.model, f.config, 1, 1);
    try {
      PolicyController c(f.model, pd_policy(env, 1.0, 0.0, false), f.config);
      ADD_FAILURE() << "no error for " << sensors;
    } catch (const InvalidArgument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("pd.dtpolicy"), std::string::npos) << what;
      EXPECT_NE(what.find("observes sensors or depth cameras"), std::string::npos) << what;
      EXPECT_NE(what.find("evaluate it in a VecEnv instead"), std::string::npos) << what;
    }
  }
}

TEST(PolicyController, ResetStartsANewEpisodeAndACloneCarriesTheEpisodeOn) {
  EnvFile f = hover_env("{action: relative_position}");
  rl::VecEnv<double> env(f.model, f.config, 1, 1);
  PolicyController a(f.model, pd_policy(env, 1.0, 0.3, false), f.config);
  ControlInput in;
  in.state = env.batch().state(0);
  in.reference.position_m = Vec3(0, 0, 2);
  (void)a.calculate_u(in);
  EXPECT_EQ(a.policy_steps(), 1);
  const std::unique_ptr<ControllerBase> b = a.clone();  // the same memory
  EXPECT_EQ(static_cast<PolicyController&>(*b).policy_steps(), 1);
  in.time_s = 0.001;  // not yet due (100 Hz)
  (void)a.calculate_u(in);
  EXPECT_EQ(a.policy_steps(), 1);
  a.reset();
  (void)a.calculate_u(in);
  EXPECT_EQ(a.policy_steps(), 1);
  EXPECT_EQ(a.diagnostic_names(),
            (std::vector<std::string>{"gates_passed", "laps", "action_0", "action_1", "action_2"}));
}

}  // namespace
}  // namespace dronetwin
