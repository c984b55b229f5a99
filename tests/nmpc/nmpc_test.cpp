// NmpcController (control/nmpc.hpp) and its prediction model (control/nmpc_model.hpp):
// - the autodiff Jacobians of the RK4 step of Eq. 3.23 and of the whole horizon (the chained
//   single-shooting sensitivities Ceres sees) against central differences;
// - the model's physics (hover is an equilibrium, free fall, torque-free spin);
// - closed-loop figure eight (Eq. 3.25) against thesis Table 3.4, through the experiment runner
//   (which also checks the solve statistics in summary.json);
// - fallback on failed solves (previous plan, then SE(3) position control, then recovery);
// - determinism, and configuration errors naming the field.
#include "dronetwin/nmpc/nmpc.hpp"

#include <gtest/gtest.h>

#include <ceres/jet.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/app/run_experiment.hpp"
#include "dronetwin/config/controller_config.hpp"
#include "dronetwin/config/experiment.hpp"
#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/control/reference.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/csv_log.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/nmpc/nmpc_model.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;
using State13 = Eigen::Matrix<double, 13, 1>;
using Input6 = Eigen::Matrix<double, 6, 1>;

NmpcModel qdrone_model() {
  const auto vm = test::load_model("qdrone2");
  NmpcModel m;
  m.mass_kg = vm->mass_kg();
  m.gravity_m_s2 = 9.81;
  m.inertia_kgm2 = vm->inertia_kgm2();
  m.inertia_inverse = vm->inertia_inverse();
  return m;
}

/// A state away from hover: tilted, spinning, moving.
State13 generic_state() {
  State13 x;
  x.segment<3>(0) = Vec3(0.3, -0.2, 1.1);
  x.segment<3>(3) = Vec3(0.4, -0.3, 0.2);
  x.segment<4>(6) = math::from_euler(0.2, -0.15, 0.7);
  x.segment<3>(10) = Vec3(0.8, -0.5, 0.3);
  return x;
}

Input6 generic_input() { return (Input6() << 1.5, -2.0, 16.0, 0.05, -0.03, 0.01).finished(); }

State13 step(const NmpcModel& m, const State13& x, const Input6& u, double dt) {
  State13 out;
  nmpc_rk4_step<double>(m, x.data(), u.data(), dt, out.data());
  return out;
}

// ---- model ------------------------------------------------------------------------------------

TEST(NmpcModel, Rk4StepJacobianMatchesCentralDifferences) {
  const NmpcModel m = qdrone_model();
  const State13 x = generic_state();
  const Input6 u = generic_input();
  const double dt = 0.01;
  using Jet = ceres::Jet<double, 19>;
  Jet xj[13], uj[6], xn[13];
  for (int i = 0; i < 13; ++i) xj[i] = Jet(x[i], i);
  for (int i = 0; i < 6; ++i) uj[i] = Jet(u[i], 13 + i);
  nmpc_rk4_step<Jet>(m, xj, uj, dt, xn);
  // Central differences with a step ~ cbrt(eps) scaled: truncation O(h^2), rounding O(eps / h).
  const double h = 1e-6;
  double worst = 0.0;
  for (int j = 0; j < 19; ++j) {
    State13 xp = x, xm = x;
    Input6 up = u, um = u;
    if (j < 13) {
      xp[j] += h;
      xm[j] -= h;
    } else {
      up[j - 13] += h;
      um[j - 13] -= h;
    }
    const State13 fd = (step(m, xp, up, dt) - step(m, xm, um, dt)) / (2 * h);
    for (int i = 0; i < 13; ++i) {
      EXPECT_NEAR(xn[i].v[j], fd[i], 1e-7 * (1 + std::abs(fd[i]))) << "d x" << i << " / d z" << j;
      worst = std::max(worst, std::abs(xn[i].v[j] - fd[i]));
    }
  }
  EXPECT_LT(worst, 1e-7);
}

TEST(NmpcModel, HoverIsAnEquilibriumAndZeroForceIsFreeFall) {
  const NmpcModel m = qdrone_model();
  State13 x = State13::Zero();
  x.segment<3>(0) = Vec3(0.5, -1, 1.2);
  x.segment<4>(6) = math::from_euler(0, 0, 0.4);  // any heading
  Input6 u = Input6::Zero();
  u[2] = m.mass_kg * m.gravity_m_s2;  // Eq. 3.23: T = (R e3 . F) R e3 - m g e3 = 0 at level
  State13 y = x;
  for (int k = 0; k < 100; ++k) y = step(m, y, u, 0.01);
  EXPECT_LT((y - x).norm(), 1e-12);
  // F = 0: free fall, z(t) = z0 - g t^2 / 2 (RK4 is exact for constant acceleration).
  u.setZero();
  y = x;
  for (int k = 0; k < 100; ++k) y = step(m, y, u, 0.01);
  EXPECT_NEAR(y[2], 1.2 - 0.5 * 9.81, 1e-12);
  EXPECT_NEAR(y[5], -9.81, 1e-12);
}

TEST(NmpcModel, ThrustIsTheForceProjectedOnTheBodyAxis) {
  // Eq. 3.23 read as T = ((R e3) . F) R e3 - m g e3: with the body tilted by a about +y and F
  // vertical, the acceleration is (F cos a / m) (sin a, 0, cos a) - g e3.
  const NmpcModel m = qdrone_model();
  const double a = 0.3, F = 20.0;
  State13 x = State13::Zero();
  x.segment<4>(6) = math::from_euler(0, a, 0);
  Input6 u = Input6::Zero();
  u[2] = F;
  State13 xd;
  nmpc_derivative<double>(m, x.data(), u.data(), xd.data());
  const double f = F * std::cos(a) / m.mass_kg;
  EXPECT_NEAR(xd[3], f * std::sin(a), 1e-12);
  EXPECT_NEAR(xd[4], 0.0, 1e-12);
  EXPECT_NEAR(xd[5], f * std::cos(a) - 9.81, 1e-12);
}

// ---- the horizon Jacobian ---------------------------------------------------------------------

std::shared_ptr<const VehicleModel> qdrone() { return test::load_model("qdrone2"); }

NmpcOptions small_options() {
  NmpcOptions o;
  o.horizon_steps = 20;
  o.input_blocks = {1, 1, 2, 4, 4, 8};
  o.se3.attitude_d = Vec3(0.8, 0.8, 0.05);
  return o;
}

ControlInput tilted_input(double t_s) {
  ControlInput in;
  in.time_s = t_s;
  in.state.head<13>() = generic_state();
  in.reference.position_m = Vec3(0.1, 0.1, 1.2);
  in.reference.velocity_m_s = Vec3(0.05, 0.1, 0);
  in.reference.acceleration_m_s2 = Vec3(0.01, -0.02, 0);
  return in;
}

TEST(NmpcHorizon, ChainedJacobianMatchesCentralDifferences) {
  // The Jacobian Ceres uses (per-step Jets chained through the horizon, move blocks and the
  // bound-friendly parametrisation) against central differences of the residuals.
  NmpcController c(qdrone(), small_options(), 1000.0);
  c.calculate_u(tilted_input(0.0));  // sets x_0 and the references of the problem
  std::vector<double> z = c.last_parameters();
  // Move away from the optimum so every residual has slope.
  for (std::size_t i = 0; i < z.size(); ++i)
    z[i] += (i % 6 == 0 ? 0.3 : 0.02) * std::sin(1.0 + static_cast<double>(i));
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  ASSERT_TRUE(c.evaluate_horizon(z, &r, &J));
  ASSERT_EQ(J.rows(), c.num_residuals());
  ASSERT_EQ(J.cols(), c.num_parameters());
  const double h = 1e-6;
  for (int j = 0; j < c.num_parameters(); ++j) {
    std::vector<double> zp = z, zm = z;
    zp[static_cast<std::size_t>(j)] += h;
    zm[static_cast<std::size_t>(j)] -= h;
    Eigen::VectorXd rp, rm;
    ASSERT_TRUE(c.evaluate_horizon(zp, &rp, nullptr));
    ASSERT_TRUE(c.evaluate_horizon(zm, &rm, nullptr));
    const Eigen::VectorXd fd = (rp - rm) / (2 * h);
    const double scale = 1.0 + fd.cwiseAbs().maxCoeff();
    EXPECT_LT((J.col(j) - fd).cwiseAbs().maxCoeff(), 1e-6 * scale) << "parameter " << j;
  }
  // Causality: inputs of the last block do not move the states before it starts (step 12).
  const int last_block_col = c.num_parameters() - 6;
  EXPECT_EQ(J.block(0, last_block_col, 13 * 12, 6).cwiseAbs().maxCoeff(), 0.0);
}

// ---- closed loop ------------------------------------------------------------------------------

std::string out_dir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("dronetwin_nmpc_test_" + name);
  fs::remove_all(p);
  return p.string();
}

const DiagnosticSummary& diag(const ClosedLoopSummary& c, const std::string& name) {
  for (const DiagnosticSummary& d : c.diagnostics)
    if (d.name == name) return d;
  throw std::runtime_error("no diagnostic " + name);
}

TEST(NmpcClosedLoop, FigureEightMeetsThesisTable34WithNoiseOn) {
  // The shipped experiment (noise on), shortened to 8 s to keep the suite fast: the NMPC must
  // track at or below thesis Table 3.4 (x 0.080, y 0.060, z 0.0355 m, psi 0.012 rad), every
  // solve must succeed, and the statistics must be in the summary. The full 60 s numbers are in
  // docs/validation.md.
  Experiment e = load_experiment(test::source_path("config/experiments/nmpc_figure8.yaml"));
  e.duration_s = 8.0;
  validate(e);
  const RunSummary s = run_experiment(e, out_dir("figure8"));
  ASSERT_TRUE(s.ok()) << s.failure_message;
  ASSERT_TRUE(s.closed_loop.has_value());
  const ClosedLoopSummary& c = *s.closed_loop;
  EXPECT_EQ(c.controller_name, "nmpc");
  EXPECT_LT(c.rmse[0], 0.080);
  EXPECT_LT(c.rmse[1], 0.060);
  EXPECT_LT(c.rmse[2], 0.0355);
  EXPECT_LT(c.rmse[3], 0.012);
  EXPECT_FALSE(s.crashed);
  // One solve per 10 ms: 801 solves in 8 s (t = 0 and t = 8 s included), none failed.
  EXPECT_EQ(diag(c, "solved").sum, 801.0);
  EXPECT_EQ(diag(c, "iterations").count, 801);
  EXPECT_EQ(diag(c, "failed").sum, 0.0);
  EXPECT_EQ(diag(c, "mode").max, 0.0);
  EXPECT_GE(diag(c, "iterations").median, 1.0);
  EXPECT_GT(diag(c, "solve_time_ms").median, 0.0);
  // The log carries the statistics per row (every 10th step = every solve).
  const LogTable log = read_csv_log(s.log_path);
  const auto& cols = log.columns;
  EXPECT_NE(std::find(cols.begin(), cols.end(), "ctrl_solve_time_ms"), cols.end());
  EXPECT_EQ(cols.back(), "ctrl_consecutive_failures");
  // summary.json has the statistics section.
  std::ifstream js(s.summary_path);
  std::stringstream text;
  text << js.rdbuf();
  EXPECT_NE(text.str().find("\"diagnostics\": {"), std::string::npos);
  EXPECT_NE(text.str().find("\"solve_time_ms\": {"), std::string::npos);
}

/// Flies `c` on the figure eight for `duration_s` from the reference, noise off; returns the
/// largest position error and the rotor commands of every step.
struct Flight {
  double max_error_m = 0.0;
  std::vector<RotorVector> commands;
  std::vector<NmpcMode> modes;
};
Flight fly(NmpcController& c, double duration_s) {
  const auto model = qdrone();
  SimConfig cfg;
  cfg.noise.enabled = false;
  Simulator sim(model, cfg);
  const FigureEightReference ref;
  const ReferencePoint r0 = ref.at(0.0);
  StateVector x0 = Simulator::hover_state(r0.position_m);
  x0.segment<3>(3) = r0.velocity_m_s;
  sim.reset(x0, model->hover_speeds_rad_s());
  ClosedLoop loop(sim, c, ref, 1000.0);
  Flight f;
  const auto n = static_cast<std::int64_t>(std::llround(duration_s * 1000.0));
  for (std::int64_t k = 0; k < n; ++k) {
    if (!loop.step().ok()) break;
    f.commands.push_back(loop.last_rotor_command());
    f.modes.push_back(c.mode());
    const Vec3 e = ref.at(sim.time_s()).position_m - sim.state().head<3>();
    f.max_error_m = std::max(f.max_error_m, e.norm());
  }
  return f;
}

TEST(NmpcClosedLoop, TwoRunsAreBitwiseIdentical) {
  NmpcController a(qdrone(), small_options(), 1000.0), b(qdrone(), small_options(), 1000.0);
  const Flight fa = fly(a, 1.0), fb = fly(b, 1.0);
  ASSERT_EQ(fa.commands.size(), 1000u);
  ASSERT_EQ(fb.commands.size(), 1000u);
  for (std::size_t k = 0; k < fa.commands.size(); ++k)
    ASSERT_EQ(fa.commands[k], fb.commands[k]) << "step " << k;
}

// ---- moment observer --------------------------------------------------------------------------

/// Rotor 0 of the QDrone2 at half thrust from 0.5 s while the shipped NMPC (observer time constant
/// `tau_s`, 0 = off) holds a hover 1.5 m up, noise off, 4 s.
struct WeakRotorFlight {
  double max_tilt_rad = 0.0;
  double max_error_m = 0.0;
  double final_error_m = 0.0;
  Vec3 estimate = Vec3::Zero();    ///< the observer's M_d at the end
  Vec3 lost = Vec3::Zero();        ///< the moment the fault takes then, from the physics
  Vec3 d_estimate = Vec3::Zero();  ///< the velocity estimate d at the end
  Vec3 lost_accel = Vec3::Zero();  ///< the acceleration the fault takes then
};
WeakRotorFlight fly_with_weak_rotor(double tau_s) {
  const auto model = qdrone();
  NmpcOptions o =
      std::get<NmpcSettings>(
          load_controller_config(test::source_path("config/controllers/nmpc.yaml")).settings)
          .options;
  o.moment_observer_time_constant_s = tau_s;
  NmpcController c(model, o, 1000.0);
  SimConfig cfg;
  cfg.noise.enabled = false;
  SimConfig faulty = cfg;
  faulty.faults.rotor[0] = RotorFault{RotorFaultKind::kEffectiveness, 0, 0.5, 0.5};
  faulty.faults.num_rotor_faults = 1;
  Simulator sim(model, faulty);
  const Vec3 target(0.0, 0.0, 1.5);
  sim.reset(Simulator::hover_state(target), model->hover_speeds_rad_s());
  const SetpointReference ref(target, 0.0);
  ClosedLoop loop(sim, c, ref, 1000.0);
  WeakRotorFlight f;
  for (int k = 0; k < 4000; ++k) {
    if (!loop.step().ok()) break;
    const Vec4 q = sim.state().segment<4>(state_index::kQuaternion);
    f.max_tilt_rad = std::max(
        f.max_tilt_rad, std::acos(std::clamp(math::rotation_matrix<double>(q)(2, 2), -1.0, 1.0)));
    f.final_error_m = (sim.state().head<3>() - target).norm();
    f.max_error_m = std::max(f.max_error_m, f.final_error_m);
  }
  f.estimate = c.moment_disturbance_estimate();
  f.d_estimate = c.disturbance_estimate();
  // The lost moment: J (w_dot with the fault - w_dot without it) at the same state and rotor
  // speeds, from the simulator's own force model.
  Simulator healthy(model, cfg);
  healthy.reset(sim.state(), sim.rotor_speeds_rad_s());
  const StateVector gap = sim.state_derivative() - healthy.state_derivative();
  f.lost = model->inertia_kgm2() * gap.segment<3>(state_index::kAngularVelocity);
  f.lost_accel = gap.segment<3>(state_index::kVelocity);
  return f;
}

TEST(NmpcMomentObserver, AWeakRotorTurnsTheVehicleAwayWithoutIt) {
  // Without the observer the attitude law only damps the rates against the lost moment: the
  // vehicle turns until the command's tilt cone (0.5 rad) and flies off.
  const WeakRotorFlight f = fly_with_weak_rotor(0.0);
  EXPECT_GT(f.max_tilt_rad, 0.45);
  EXPECT_GT(f.max_error_m, 1.0);
}

TEST(NmpcMomentObserver, EstimatesTheMomentTheFaultTakesAndHolds) {
  const WeakRotorFlight f = fly_with_weak_rotor(0.05);
  // Half of rotor 0's thrust at its hub: about 0.6 N m about x and y at ~3.7 N lost.
  EXPECT_GT(f.lost.head<2>().norm(), 0.4);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(f.estimate[i], f.lost[i], 0.02) << "axis " << i;
  // The velocity estimate takes up the lost thrust (rotor 0 is driven harder to make the moment,
  // so more than a quarter of the hover thrust is lost: ~2.5 m/s^2).
  EXPECT_LT(f.lost_accel.z(), -2.0);
  EXPECT_NEAR(f.d_estimate.z(), f.lost_accel.z(), 0.1);
  // It stays level, sags while d builds up and climbs back (the no-observer flight: > 1 m off).
  EXPECT_LT(f.max_tilt_rad, 0.1);
  EXPECT_LT(f.max_error_m, 0.5);
  EXPECT_LT(f.final_error_m, 0.8 * f.max_error_m);
}

// ---- fallback ---------------------------------------------------------------------------------

TEST(NmpcFallback, FailedSolvesFlyThePreviousPlanThenSe3ThenRecover) {
  // Solves 50..59 fail: the controller flies the last good plan (solve 49) shifted. Solves
  // 100..229 fail too: after N = 20 failed solves the plan is used up and SE(3) position control
  // takes over. From solve 230 the NMPC flies again. Throughout, no NaN and the vehicle stays on
  // the figure eight (SE(3) alone tracks it to centimetres).
  NmpcController c(qdrone(), small_options(), 1000.0);
  NmpcController probe(qdrone(), small_options(), 1000.0);
  c.inject_solve_failures(50, 10);
  Flight f1 = fly(c, 0.505);  // through solve 50 (t = 0.5 s) and 5 more calls
  EXPECT_EQ(c.mode(), NmpcMode::kPreviousPlan);
  EXPECT_EQ(c.last_solve().termination, NmpcTermination::kFailure);
  EXPECT_EQ(c.last_solve().consecutive_failures, 1);
  // What is flown is the last good plan one interval later: thrust direction = its predicted
  // body axis at the end of interval 1, thrust = that axis . F_1 (Eq. 3.23).
  EXPECT_EQ(c.plan_start_time_s(), 0.49);
  const Vec4 q2 = c.predicted_states().row(2).segment<4>(6).transpose();
  const Vec3 b3 = math::rotation_matrix<double>(Vec4(q2.normalized())).col(2);
  const Vec3 F1 = c.predicted_inputs().row(1).head<3>().transpose();
  EXPECT_LT((c.commanded_force() - b3.dot(F1) * b3).norm(), 1e-12);
  double out[9];
  c.diagnostics(out);
  EXPECT_EQ(out[7], 1.0);  // mode
  EXPECT_EQ(out[8], 1.0);  // consecutive failures

  NmpcController d(qdrone(), small_options(), 1000.0);
  d.inject_solve_failures(100, 130);
  const Flight f2 = fly(d, 3.0);
  ASSERT_EQ(f2.commands.size(), 3000u);
  int plan = 0, previous = 0, se3 = 0;
  for (std::size_t k = 0; k < f2.modes.size(); ++k) {
    ASSERT_TRUE(f2.commands[k].allFinite()) << k;
    const NmpcMode m = f2.modes[k];
    (m == NmpcMode::kPlan ? plan : m == NmpcMode::kPreviousPlan ? previous : se3)++;
  }
  // Solves 100..118 (19 solves x 10 calls) on the previous plan (solve 99): interval j needs
  // the predicted state j + 1, so rows 1..19 of a 20-step plan are usable; solves 119..229 on
  // SE(3); the rest on fresh plans.
  EXPECT_EQ(previous, 19 * 10);
  EXPECT_EQ(se3, 111 * 10);
  EXPECT_EQ(plan, 3000 - 1300);
  EXPECT_EQ(d.mode(), NmpcMode::kPlan);
  EXPECT_EQ(d.last_solve().total_failures, 130);
  // Safe, not tight: the switches (open-loop plan, then SE(3), then back) cost a few cm; a
  // stale or unsafe command would leave the 0.6-0.8 m figure eight by far more than 0.1 m.
  EXPECT_LT(f2.max_error_m, 0.1);
}

TEST(NmpcFallback, ZeroIterationsStillFliesAFeasiblePlan) {
  // max_iterations = 0 returns the warm start (the shifted plan, or the feed-forward input at
  // the first solve): reported as an iteration cap, never as a failure, output finite.
  NmpcOptions o = small_options();
  o.max_iterations = 0;
  NmpcController c(qdrone(), o, 1000.0);
  const GeneralizedForce u = c.calculate_u(tilted_input(0.0));
  EXPECT_TRUE(u.allFinite());
  EXPECT_EQ(c.last_solve().termination, NmpcTermination::kIterationCap);
  EXPECT_EQ(c.last_solve().iterations, 0);
  EXPECT_EQ(c.mode(), NmpcMode::kPlan);
}

TEST(NmpcFallback, BoundsHoldInThePlanAndTheCommand) {
  // Far from the reference and tilted 0.5 rad, beyond a 0.3 rad limit: every planned force is
  // inside the thrust and tilt bounds (by the parametrisation), and the command flown is clipped
  // to the tilt cone and the thrust bound however the prediction tilts.
  NmpcOptions o = small_options();
  o.max_tilt_rad = 0.3;
  o.max_thrust_N = 25.0;
  NmpcController c(qdrone(), o, 1000.0);
  ControlInput in = tilted_input(0.0);
  in.state.segment<4>(6) = math::from_euler(0.5, 0.0, 0.0);
  in.state.segment<3>(10).setZero();
  in.reference.position_m = Vec3(5, -4, 3);
  c.calculate_u(in);
  ASSERT_EQ(c.predicted_inputs().rows(), 20);
  for (int k = 0; k < 20; ++k) {
    const Vec3 F = c.predicted_inputs().row(k).head<3>().transpose();
    EXPECT_LE(std::acos(F.z() / F.norm()), 0.3 + 1e-12) << k;
    EXPECT_LE(F.norm(), 25.0 + 1e-9) << k;
  }
  const Vec3 cmd = c.commanded_force();
  EXPECT_NEAR(std::acos(cmd.z() / cmd.norm()), 0.3, 1e-9);  // clipped: the plan starts at 0.5
  EXPECT_LE(cmd.norm(), 25.0);
}

// ---- configuration ----------------------------------------------------------------------------

TEST(NmpcConfig, ShippedFileIsTheThesisProblem) {
  const ControllerConfig cfg =
      load_controller_config(test::source_path("config/controllers/nmpc.yaml"));
  ASSERT_EQ(cfg.type(), ControllerType::kNmpc);
  const NmpcOptions& o = std::get<NmpcSettings>(cfg.settings).options;
  EXPECT_EQ(o.horizon_steps, 100);  // thesis N = 100 at 10 ms
  EXPECT_EQ(o.step_s, 0.01);
  const NmpcOptions thesis;  // defaults = Eq. 3.24
  EXPECT_EQ(o.state_weights, thesis.state_weights);
  EXPECT_EQ(o.input_weights, thesis.input_weights);
  EXPECT_EQ(o.state_weights[6], 0.1);
  EXPECT_EQ(o.input_weights[0], 0.3);
  EXPECT_EQ(o.input_weights[3], 0.03);
  const auto c =
      load_controller(test::source_path("config/controllers/nmpc.yaml"), qdrone(), 1000.0);
  EXPECT_EQ(c->name(), "nmpc");
  EXPECT_EQ(dynamic_cast<const NmpcController&>(*c).calls_per_solve(), 10);
}

// nmpc_feed_forward.yaml is nmpc.yaml with the inner loop's feed-forward and nothing else.
TEST(NmpcConfig, TheFeedForwardFileIsTheShippedOneWithTheFeedForward) {
  const auto options = [](const char* file) {
    return std::get<NmpcSettings>(
               load_controller_config(test::source_path(std::string("config/controllers/") + file))
                   .settings)
        .options;
  };
  const NmpcOptions plain = options("nmpc.yaml");
  NmpcOptions ff = options("nmpc_feed_forward.yaml");
  EXPECT_FALSE(plain.inner_feed_forward);
  EXPECT_TRUE(ff.inner_feed_forward);
  EXPECT_EQ(ff.horizon_steps, plain.horizon_steps);
  EXPECT_EQ(ff.step_s, plain.step_s);
  EXPECT_EQ(ff.input_blocks, plain.input_blocks);
  EXPECT_EQ(ff.state_weights, plain.state_weights);
  EXPECT_EQ(ff.input_weights, plain.input_weights);
  EXPECT_EQ(ff.terminal_weight_scale, plain.terminal_weight_scale);
  EXPECT_EQ(ff.tilt_penalty_weight, plain.tilt_penalty_weight);
  EXPECT_EQ(ff.min_thrust_N, plain.min_thrust_N);
  EXPECT_EQ(ff.max_thrust_N, plain.max_thrust_N);
  EXPECT_EQ(ff.max_tilt_rad, plain.max_tilt_rad);
  EXPECT_EQ(ff.max_moment_Nm, plain.max_moment_Nm);
  EXPECT_EQ(ff.disturbance_gain, plain.disturbance_gain);
  EXPECT_EQ(ff.max_disturbance_m_s2, plain.max_disturbance_m_s2);
  EXPECT_EQ(ff.moment_observer_time_constant_s, plain.moment_observer_time_constant_s);
  EXPECT_EQ(ff.max_moment_disturbance_Nm, plain.max_moment_disturbance_Nm);
  EXPECT_EQ(ff.max_iterations, plain.max_iterations);
  EXPECT_EQ(ff.function_tolerance, plain.function_tolerance);
  EXPECT_EQ(ff.linear_solver, plain.linear_solver);
  EXPECT_EQ(ff.se3.attitude_p, plain.se3.attitude_p);
  EXPECT_EQ(ff.se3.attitude_d, plain.se3.attitude_d);
  EXPECT_EQ(ff.se3.position_p, plain.se3.position_p);
  EXPECT_EQ(ff.se3.position_d, plain.se3.position_d);
  std::ifstream in(test::source_path("config/controllers/nmpc_feed_forward.yaml"));
  std::stringstream text;
  text << in.rdbuf();
  std::string bad = text.str();
  const std::size_t at = bad.find("feed_forward: true");
  ASSERT_NE(at, std::string::npos);
  bad.replace(at, std::string("feed_forward: true").size(), "feed_forward: 1.5");
  const std::string e = test::error_of([&] { parse_controller_config(bad, "mem.yaml"); });
  EXPECT_NE(e.find("inner_loop.feed_forward"), std::string::npos) << e;
  // The section belongs to the NMPC: in a PID file it is named as misplaced.
  std::ifstream pid_in(test::source_path("config/controllers/pid.yaml"));
  std::stringstream pid_text;
  pid_text << pid_in.rdbuf();
  const std::string misplaced = test::error_of([&] {
    parse_controller_config(pid_text.str() + "inner_loop: {feed_forward: true}\n", "mem.yaml");
  });
  EXPECT_NE(misplaced.find("inner_loop: only for type nmpc"), std::string::npos) << misplaced;
}

// Without feed-forward the attitude law damps the body rates the plan turns at (w_d = 0, Eq.
// 3.28), so the attitude lags the plan's through every turn of the figure eight; with the plan's
// rates and angular acceleration fed forward that lag is gone. The shipped experiment without
// noise, shortened to 8 s (the full 60 s with noise: docs/controllers.md, section 8.7).
TEST(NmpcInnerFeedForward, LowersTheFigureEightErrorOfThePlainInnerLoop) {
  const auto fly = [](const char* controller) {
    Experiment e =
        load_experiment(test::source_path("config/experiments/nmpc_figure8_noise_off.yaml"));
    e.duration_s = 8.0;
    std::get<ControllerLoopInput>(e.input).controller_path =
        test::source_path(std::string("config/controllers/") + controller);
    validate(e);
    const RunSummary s = run_experiment(e, out_dir(std::string("ff_") + controller));
    EXPECT_TRUE(s.ok()) << s.failure_message;
    return s.closed_loop->rmse;
  };
  const auto plain = fly("nmpc.yaml");
  const auto ff = fly("nmpc_feed_forward.yaml");
  std::printf(
      "[ nmpc ff  ] figure eight, 8 s, noise off: RMSE x %.4f / %.4f m, y %.4f / %.4f m "
      "(plain / feed-forward)\n",
      plain[0], ff[0], plain[1], ff[1]);
  EXPECT_LT(ff[0], plain[0]);
  EXPECT_LT(ff[1], plain[1]);
}

TEST(NmpcConfig, BadOptionsAreNamed) {
  const auto model = qdrone();
  const auto error = [&](const NmpcOptions& o, double rate) {
    return test::error_of([&] { NmpcController c(model, o, rate); });
  };
  NmpcOptions o = small_options();
  EXPECT_NE(error(o, 1234.0).find("nmpc: step_s: expected a whole multiple of the call period"),
            std::string::npos);
  o.input_blocks = {1, 2, 3};
  EXPECT_NE(error(o, 1000.0).find("nmpc: input_blocks: lengths sum to 6; expected "
                                  "horizon_steps = 20"),
            std::string::npos);
  o = small_options();
  o.state_weights[4] = -1;
  EXPECT_NE(error(o, 1000.0).find("nmpc: state_weights[4]: expected a finite weight >= 0, got -1"),
            std::string::npos);
  o = small_options();
  o.min_thrust_N = 0.0;
  EXPECT_NE(error(o, 1000.0).find("nmpc: min_thrust_N: expected > 0, got 0"), std::string::npos);
  o = small_options();
  o.max_iterations = -1;
  EXPECT_NE(error(o, 1000.0).find("nmpc: max_iterations"), std::string::npos);
  o = small_options();
  o.moment_observer_time_constant_s = -0.05;
  EXPECT_NE(error(o, 1000.0).find("nmpc: moment_observer_time_constant_s: expected a finite number "
                                  ">= 0 (0 = off), got -0.05"),
            std::string::npos);
  o = small_options();
  o.max_moment_disturbance_Nm = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(error(o, 1000.0).find("nmpc: max_moment_disturbance_Nm: expected a finite number >= 0"),
            std::string::npos);
}

}  // namespace
}  // namespace dronetwin
