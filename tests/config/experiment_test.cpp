// Tests of experiment files (include/dronetwin/config/experiment.hpp): the shipped experiments and
// a file using every key parse to the right values, defaults are what the docs say, model and
// controller paths resolve as documented, the closed-loop input parses every reference type, and
// every file of tests/data/bad_experiments is rejected with a message that starts with the file
// and names the field.
#include "dronetwin/config/experiment.hpp"
#include "dronetwin/config/fleet_experiment.hpp"
#include "dronetwin/logging/text_file.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <set>
#include <sstream>
#include <string>
#include <variant>
#include <vector>

#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/config/track_loader.hpp"
#include "dronetwin/control/trajectory_reference.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/planning/min_snap.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

const std::string kSourceDir = DRONETWIN_SOURCE_DIR;
const std::string kBadDir = kSourceDir + "/tests/data/bad_experiments";
const std::string kExperimentDir = kSourceDir + "/config/experiments";
const std::string kModel = kSourceDir + "/models/qdrone2.yaml";
const std::string kPid = kSourceDir + "/config/controllers/pid.yaml";

using test::error_of;

using test::TempDir;

/// Minimal valid experiment text around `extra` lines (model given as an absolute path).
std::string minimal(const std::string& extra = "",
                    const std::string& input = "input: {type: hover}\n") {
  return "name: t\nmodel: " + kModel + "\nduration_s: 1.0\n" + extra + input;
}

// ---- good files -------------------------------------------------------------------------------

TEST(Experiment, MinimalFileGetsTheDocumentedDefaults) {
  const Experiment e = parse_experiment(minimal(), "mem.yaml");
  EXPECT_EQ(e.name, "t");
  EXPECT_EQ(e.source, "mem.yaml");
  EXPECT_EQ(fs::path(e.model_path), fs::path(kModel).lexically_normal());
  EXPECT_EQ(e.sim.seed, 0u);
  EXPECT_EQ(e.duration_s, 1.0);
  EXPECT_EQ(e.sim.dt_s, 0.001);
  EXPECT_EQ(e.sim.integrator, Integrator::kRk4);
  EXPECT_TRUE(e.sim.motor_dynamics);
  EXPECT_FALSE(e.sim.noise.enabled);
  EXPECT_EQ(e.sim.noise.parameters.drift, OuDrift::kPerSample);
  EXPECT_EQ(e.sim.noise.parameters.theta[2].a, OuParameters::thesis().theta[2].a);
  EXPECT_EQ(e.sim.environment.wind_W_m_s, Vec3::Zero());
  EXPECT_EQ(e.sim.environment.gravity_W_m_s2, Vec3(0, 0, -9.81));
  const DisturbanceSwitches d = e.sim.disturbances;
  EXPECT_TRUE(d.rotor_drag && d.rolling_moment && d.drag_moment && d.ground_effect &&
              d.gyroscopic && d.body_drag);
  EXPECT_TRUE(e.sim.ground.enabled);
  EXPECT_EQ(e.sim.ground.crash_speed_m_s, GroundConfig{}.crash_speed_m_s);
  EXPECT_EQ(e.initial_state.position_m, Vec3::Zero());
  EXPECT_EQ(e.initial_state.quaternion_wxyz, Vec4(1, 0, 0, 0));
  EXPECT_EQ(e.initial_state.rotor_speeds.kind, RotorSpeedSetting::Kind::kStopped);
  EXPECT_EQ(e.log.every_n_steps, 1);
  EXPECT_FALSE(e.log.wrench_breakdown);
  EXPECT_TRUE(e.log.measured);
  EXPECT_TRUE(std::holds_alternative<HoverInput>(e.input));
  EXPECT_EQ(input_type_name(e.input), "hover");
  EXPECT_EQ(e.num_steps(), 1000);
}

TEST(Experiment, EveryKeyParsesToItsValue) {
  const std::string text = R"(
name: full
description: every key
model: )" + kModel + R"(
seed: 18446744073709551615
duration_s: 2.5
physics_dt_s: 0.002
integrator: euler
motor_dynamics: false
noise:
  enabled: true
  drift: continuous
  theta: {a: 0.5, b: 0.1}
  sigma: {a: 0.01, b: 0.002}
wind_m_s: [1, -2, 0.5]
gravity_m_s2: [0, 0, -9.80665]
disturbances: {ground_effect: false, body_drag: false}
ground: {enabled: true, crash_speed_m_s: 2.0, crash_tilt_rad: 0.5}
initial_state:
  position_m: [1, 2, 3]
  velocity_m_s: [0.1, 0.2, 0.3]
  euler_rad: [0.1, -0.2, 0.3]
  angular_velocity_rad_s: [0.01, 0.02, 0.03]
  rotor_speeds_rad_s: hover
log: {every_n_steps: 10, wrench_breakdown: true, measured: false}
input:
  type: constant_generalized_force
  u: [14.75, 0.01, -0.02, 0.003]
  allocation: thesis
)";
  const Experiment e = parse_experiment(text, "full.yaml");
  EXPECT_EQ(e.name, "full");
  EXPECT_EQ(e.description, "every key");
  EXPECT_EQ(e.sim.seed, 18446744073709551615u);
  EXPECT_EQ(e.duration_s, 2.5);
  EXPECT_EQ(e.sim.dt_s, 0.002);
  EXPECT_EQ(e.sim.integrator, Integrator::kEuler);
  EXPECT_FALSE(e.sim.motor_dynamics);
  EXPECT_TRUE(e.sim.noise.enabled);
  EXPECT_EQ(e.sim.noise.parameters.drift, OuDrift::kContinuous);
  for (int k = 0; k < 4; ++k) {
    EXPECT_EQ(e.sim.noise.parameters.theta[static_cast<std::size_t>(k)].a, 0.5);
    EXPECT_EQ(e.sim.noise.parameters.theta[static_cast<std::size_t>(k)].b, 0.1);
    EXPECT_EQ(e.sim.noise.parameters.sigma[static_cast<std::size_t>(k)].a, 0.01);
    EXPECT_EQ(e.sim.noise.parameters.sigma[static_cast<std::size_t>(k)].b, 0.002);
  }
  EXPECT_EQ(e.sim.environment.wind_W_m_s, Vec3(1, -2, 0.5));
  EXPECT_EQ(e.sim.environment.gravity_W_m_s2, Vec3(0, 0, -9.80665));
  EXPECT_TRUE(e.sim.disturbances.rotor_drag);
  EXPECT_TRUE(e.sim.disturbances.gyroscopic);
  EXPECT_FALSE(e.sim.disturbances.ground_effect);
  EXPECT_FALSE(e.sim.disturbances.body_drag);
  EXPECT_EQ(e.sim.ground.crash_speed_m_s, 2.0);
  EXPECT_EQ(e.sim.ground.crash_tilt_rad, 0.5);
  EXPECT_EQ(e.initial_state.position_m, Vec3(1, 2, 3));
  EXPECT_EQ(e.initial_state.velocity_m_s, Vec3(0.1, 0.2, 0.3));
  EXPECT_EQ(e.initial_state.quaternion_wxyz, math::from_euler(0.1, -0.2, 0.3));
  EXPECT_EQ(e.initial_state.angular_velocity_rad_s, Vec3(0.01, 0.02, 0.03));
  EXPECT_EQ(e.initial_state.rotor_speeds.kind, RotorSpeedSetting::Kind::kHover);
  EXPECT_EQ(e.log.every_n_steps, 10);
  EXPECT_TRUE(e.log.wrench_breakdown);
  EXPECT_FALSE(e.log.measured);
  const auto* u = std::get_if<ConstantGeneralizedForceInput>(&e.input);
  ASSERT_NE(u, nullptr);
  EXPECT_EQ(u->u, GeneralizedForce(14.75, 0.01, -0.02, 0.003));
  EXPECT_EQ(u->allocation, AllocationMethod::kThesis);

  const SimConfig c = e.sim_config();
  EXPECT_EQ(c.dt_s, 0.002);
  EXPECT_EQ(c.integrator, Integrator::kEuler);
  EXPECT_FALSE(c.motor_dynamics);
  EXPECT_EQ(std::get<ConstantGeneralizedForceInput>(e.input).allocation, AllocationMethod::kThesis);
  EXPECT_EQ(c.environment.wind_W_m_s, Vec3(1, -2, 0.5));
  EXPECT_EQ(c.environment.gravity_W_m_s2, Vec3(0, 0, -9.80665));
  EXPECT_FALSE(c.disturbances.ground_effect);
  EXPECT_TRUE(c.noise.enabled);
  EXPECT_EQ(c.ground.crash_speed_m_s, 2.0);
  EXPECT_EQ(c.seed, 18446744073709551615u);
  EXPECT_EQ(e.num_steps(), 1250);

  const StateVector x = e.initial_state.state();
  EXPECT_EQ(x.segment<3>(state_index::kPosition), Vec3(1, 2, 3));
  EXPECT_EQ(x.segment<4>(state_index::kQuaternion), math::from_euler(0.1, -0.2, 0.3));
  EXPECT_EQ(x.segment<3>(state_index::kAngularVelocity), Vec3(0.01, 0.02, 0.03));
}

TEST(Experiment, ScalarShorthands) {
  const Experiment e = parse_experiment(
      minimal("noise: true\ndisturbances: none\nground: false\n"
              "initial_state: {position_m: [0, 0, -2], quaternion_wxyz: [0, 1, 0, 0]}\n",
              "input: {type: constant_rotor_speeds, rotor_speeds_rad_s: [1, 2, 3, 4.5]}\n"),
      "s.yaml");
  EXPECT_TRUE(e.sim.noise.enabled);
  EXPECT_FALSE(e.sim.disturbances.rotor_drag || e.sim.disturbances.rolling_moment ||
               e.sim.disturbances.drag_moment || e.sim.disturbances.ground_effect ||
               e.sim.disturbances.gyroscopic || e.sim.disturbances.body_drag);
  EXPECT_FALSE(e.sim.ground.enabled);  // which is what allows z < 0
  EXPECT_EQ(e.initial_state.quaternion_wxyz, Vec4(0, 1, 0, 0));
  const auto* c = std::get_if<ConstantRotorSpeedsInput>(&e.input);
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->rotor_speeds.kind, RotorSpeedSetting::Kind::kValues);
  EXPECT_EQ(c->rotor_speeds.values_rad_s, (std::vector<double>{1, 2, 3, 4.5}));
  EXPECT_EQ(input_type_name(e.input), "constant_rotor_speeds");

  const Experiment all =
      parse_experiment(minimal("disturbances: all\nnoise: {drift: per_sample}\n"), "a.yaml");
  EXPECT_TRUE(all.sim.disturbances.body_drag && all.sim.disturbances.ground_effect);
  EXPECT_TRUE(all.sim.noise.enabled);  // the map form defaults enabled to true
}

TEST(Experiment, ShippedExperimentsLoadAndMatchTheirModels) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(kExperimentDir)) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().string());
    // Fleet files (a `vehicles:` list) name experiments of this folder: each is checked itself.
    if (looks_like_fleet_experiment(read_text_file(entry.path().string(), "experiment"))) {
      const FleetExperiment f = load_fleet_experiment(entry.path().string());
      EXPECT_GE(f.vehicles.size(), 2u);
      continue;
    }
    const Experiment e = load_experiment(entry.path().string());
    const VehicleModel model = load_vehicle_model(e.model_path);
    EXPECT_NO_THROW(check_against_model(e, model));
    EXPECT_NO_THROW((void)e.sim_config());
    names.insert(e.name);
  }
  EXPECT_TRUE(names.count("hover_open_loop") && names.count("step_open_loop") &&
              names.count("freefall"));
  for (const char* closed_loop : {"pid_pulse", "pid_pulse_noise_off", "pid_pulse_thesis_gains",
                                  "se3_circle", "se3_circle_noise_off", "hover_pid"})
    EXPECT_TRUE(names.count(closed_loop)) << closed_loop;
}

TEST(Experiment, HoverOpenLoopIsTheReadmeDemo) {
  const Experiment e = load_experiment(kExperimentDir + "/hover_open_loop.yaml");
  EXPECT_EQ(fs::path(e.model_path).filename(), "qdrone2.yaml");
  EXPECT_TRUE(fs::equivalent(e.model_path, kModel));
  EXPECT_EQ(e.sim.seed, 1u);
  EXPECT_EQ(e.duration_s, 5.0);
  EXPECT_TRUE(e.sim.noise.enabled);
  EXPECT_TRUE(e.sim.disturbances.ground_effect && e.sim.disturbances.rotor_drag);
  EXPECT_EQ(e.initial_state.position_m, Vec3(0, 0, 1));
  EXPECT_EQ(e.initial_state.rotor_speeds.kind, RotorSpeedSetting::Kind::kHover);
  EXPECT_TRUE(std::holds_alternative<HoverInput>(e.input));
  EXPECT_EQ(e.log.every_n_steps, 1);
}

TEST(Experiment, StepOpenLoopSegments) {
  const Experiment e = load_experiment(kExperimentDir + "/step_open_loop.yaml");
  const auto* p = std::get_if<PiecewiseRotorSpeedsInput>(&e.input);
  ASSERT_NE(p, nullptr);
  ASSERT_EQ(p->segments.size(), 4u);
  EXPECT_EQ(p->segments[0].start_s, 0.0);
  EXPECT_EQ(p->segments[0].rotor_speeds.kind, RotorSpeedSetting::Kind::kStopped);
  EXPECT_EQ(p->segments[1].start_s, 0.5);
  const VehicleModel model = load_vehicle_model(e.model_path);
  const double hover = model.hover_speeds_rad_s()[0];
  EXPECT_NEAR(hover, 1173.9151, 1e-3);
  // The explicit numbers are 1.05 and 0.97 times the hover speed, to the written digits.
  EXPECT_NEAR(p->segments[1].rotor_speeds.resolve(model, 9.81)[0], 1.05 * hover, 1e-3);
  EXPECT_NEAR(p->segments[2].rotor_speeds.resolve(model, 9.81)[0], 0.97 * hover, 1e-3);
  EXPECT_FALSE(e.sim.noise.enabled);
  EXPECT_EQ(e.initial_state.position_m, Vec3::Zero());
}

TEST(Experiment, RotorSpeedSettingResolves) {
  const VehicleModel model = load_vehicle_model(kModel);
  EXPECT_EQ(RotorSpeedSetting::stopped().resolve(model, 9.81), RotorVector::Zero(4));
  EXPECT_EQ(RotorSpeedSetting::hover().resolve(model, 9.81), model.hover_speeds_rad_s(9.81));
  EXPECT_EQ(RotorSpeedSetting::values({1, 2, 3, 4}).resolve(model, 9.81)[3], 4.0);
  EXPECT_THROW((void)RotorSpeedSetting::values({1, 2}).resolve(model, 9.81), InvalidArgument);
}

TEST(Experiment, StepCountsRoundToTheNearestWholeStep) {
  Experiment e = parse_experiment(minimal(), "m.yaml");
  e.duration_s = 5.0;
  EXPECT_EQ(e.num_steps(), 5000);
  e.duration_s = 0.3;  // 0.3 / 0.001 = 299.99999999999994
  EXPECT_EQ(e.num_steps(), 300);
  e.duration_s = 0.0015;  // not a multiple: rounded up
  EXPECT_EQ(e.num_steps(), 2);
  EXPECT_EQ(segment_start_step(0.0, 0.001), 0);
  EXPECT_EQ(segment_start_step(0.5, 0.001), 500);
  EXPECT_EQ(segment_start_step(5.26, 0.001), 5260);
  EXPECT_EQ(segment_start_step(0.0005, 0.001), 1);
}

TEST(Experiment, ASegmentStartBeyondEveryRunNeverTakesEffect) {
  // 1e300 s / 1 ms does not fit an int64 step count (converting it was undefined behaviour).
  constexpr std::int64_t kNever = std::numeric_limits<std::int64_t>::max();
  EXPECT_EQ(segment_start_step(1e300, 0.001), kNever);
  EXPECT_EQ(segment_start_step(9.3e15, 0.001), kNever);
  EXPECT_GT(segment_start_step(9.2e15, 0.001), 9199999999000000000);
  EXPECT_LT(segment_start_step(9.2e15, 0.001), kNever);
  const Experiment e = parse_experiment(
      minimal("",
              "input: {type: piecewise_rotor_speeds, segments: [{start_s: 0, "
              "rotor_speeds_rad_s: hover}, {start_s: 1e300, rotor_speeds_rad_s: stopped}]}\n"),
      "late.yaml");
  EXPECT_NO_THROW(validate(e));
  // Two such segments would land on one step: the earlier one is named.
  const std::string message = error_of([] {
    (void)parse_experiment(
        minimal("",
                "input: {type: piecewise_rotor_speeds, segments: [{start_s: 0, "
                "rotor_speeds_rad_s: hover}, {start_s: 1e299, rotor_speeds_rad_s: hover}, "
                "{start_s: 1e300, rotor_speeds_rad_s: stopped}]}\n"),
        "late2.yaml");
  });
  EXPECT_NE(message.find("late2.yaml: input.segments[2].start_s: "), std::string::npos) << message;
  EXPECT_NE(message.find("takes effect at the same physics step (9223372036854775807"),
            std::string::npos)
      << message;
}

TEST(Experiment, ValidateCatchesOverriddenFields) {
  Experiment e = parse_experiment(minimal(), "o.yaml");
  EXPECT_NO_THROW(validate(e));
  e.duration_s = -2.0;
  const std::string m = error_of([&] { validate(e); });
  EXPECT_NE(m.find("o.yaml: duration_s: expected a number > 0, got -2"), std::string::npos) << m;
}

// ---- closed loop: type controller -------------------------------------------------------------

/// A controller input around `reference` (a YAML flow map) and `extra` input keys.
std::string controller_input(const std::string& reference, const std::string& extra = "") {
  return "input:\n  type: controller\n  controller: " + kPid + "\n" + extra +
         "  reference: " + reference + "\n";
}

/// The ControllerLoopInput of a minimal experiment with `reference`.
ControllerLoopInput parse_loop(const std::string& reference, const std::string& extra = "",
                               const std::string& top = "") {
  const Experiment e = parse_experiment(minimal(top, controller_input(reference, extra)), "c.yaml");
  const auto* in = std::get_if<ControllerLoopInput>(&e.input);
  if (in == nullptr) {
    ADD_FAILURE() << "not a controller input";
    return {};
  }
  return *in;
}

/// Both references agree (position, velocity, acceleration, yaw, yaw rate) at a few instants.
void expect_same_reference(const Reference& a, const Reference& b) {
  for (double t : {0.0, 0.3, 1.7, 4.0, 22.0, 31.0, 36.5, 47.0, 55.0, 100.0}) {
    const ReferencePoint pa = a.at(t), pb = b.at(t);
    EXPECT_EQ(pa.position_m, pb.position_m) << "t = " << t;
    EXPECT_EQ(pa.velocity_m_s, pb.velocity_m_s) << "t = " << t;
    EXPECT_EQ(pa.acceleration_m_s2, pb.acceleration_m_s2) << "t = " << t;
    EXPECT_EQ(pa.yaw_rad, pb.yaw_rad) << "t = " << t;
    EXPECT_EQ(pa.yaw_rate_rad_s, pb.yaw_rate_rad_s) << "t = " << t;
    EXPECT_EQ(pa.jerk_m_s3, pb.jerk_m_s3) << "t = " << t;
    EXPECT_EQ(pa.snap_m_s4, pb.snap_m_s4) << "t = " << t;
    EXPECT_EQ(pa.yaw_acceleration_rad_s2, pb.yaw_acceleration_rad_s2) << "t = " << t;
  }
  EXPECT_EQ(a.describe(), b.describe());
}

TEST(ExperimentController, MinimalInputGetsTheDocumentedDefaults) {
  const Experiment e = parse_experiment(
      minimal("", controller_input("{type: setpoint, position_m: [0, 0, 1]}")), "c.yaml");
  const auto* in = std::get_if<ControllerLoopInput>(&e.input);
  ASSERT_NE(in, nullptr);
  EXPECT_EQ(input_type_name(e.input), "controller");
  EXPECT_EQ(fs::path(in->controller_path), fs::path(kPid).lexically_normal());
  EXPECT_EQ(in->control_rate_hz, 1000.0);
  EXPECT_FALSE(in->allocation.has_value());  // the controller file's own choice
  EXPECT_FALSE(in->real_time);
  EXPECT_EQ(in->reference_type, "setpoint");
  ASSERT_NE(in->reference, nullptr);
  expect_same_reference(*in->reference, SetpointReference(Vec3(0, 0, 1), 0.0));
  EXPECT_FALSE(e.metrics.window_s.has_value());
  EXPECT_FALSE(e.initial_state.on_reference);
}

TEST(ExperimentController, EveryInputKeyParsesToItsValue) {
  const ControllerLoopInput in =
      parse_loop("{type: setpoint, position_m: [1, -2, 3], yaw_rad: 0.25}",
                 "  control_rate_hz: 250\n  allocation: thesis\n  real_time: true\n");
  EXPECT_EQ(in.control_rate_hz, 250.0);
  ASSERT_TRUE(in.allocation.has_value());
  EXPECT_EQ(*in.allocation, AllocationMethod::kThesis);
  EXPECT_TRUE(in.real_time);
  expect_same_reference(*in.reference, SetpointReference(Vec3(1, -2, 3), 0.25));
  EXPECT_EQ(*parse_loop("{type: thesis_pulse}", "  allocation: exact\n").allocation,
            AllocationMethod::kExact);
}

TEST(ExperimentController, EveryReferenceType) {
  ControllerLoopInput in = parse_loop("{type: thesis_pulse}");
  EXPECT_EQ(in.reference_type, "thesis_pulse");
  expect_same_reference(*in.reference, PiecewiseConstantReference::thesis_pulse());
  // Eq. 3.14 spot checks: z = 0.75 m from 22 s, x = 0.75 m in [35, 45) s.
  EXPECT_EQ(in.reference->at(21.9).position_m, Vec3(0, 0, 0));
  EXPECT_EQ(in.reference->at(40.0).position_m, Vec3(0.75, 0, 0.75));

  in = parse_loop(
      "{type: piecewise, segments: [{start_s: 0, position_m: [0, 0, 1]},"
      " {start_s: 2.5, position_m: [1, 0, 1], yaw_rad: 0.5}, {start_s: 4, position_m: [1, 1, "
      "2]}]}");
  EXPECT_EQ(in.reference_type, "piecewise");
  expect_same_reference(*in.reference, PiecewiseConstantReference({{0.0, Vec3(0, 0, 1), 0.0},
                                                                   {2.5, Vec3(1, 0, 1), 0.5},
                                                                   {4.0, Vec3(1, 1, 2), 0.0}}));

  in = parse_loop("{type: circle}");  // defaults: Eq. 3.28
  EXPECT_EQ(in.reference_type, "circle");
  expect_same_reference(*in.reference, CircleReference(Vec3(0, 0, 1), 2.0, 7.0, 0.0));
  EXPECT_EQ(in.reference->at(0.0).position_m, Vec3(2, 0, 1));
  in = parse_loop("{type: circle, center_m: [1, 2, 3], radius_m: 0.5, period_s: 4, yaw_rad: -1}");
  expect_same_reference(*in.reference, CircleReference(Vec3(1, 2, 3), 0.5, 4.0, -1.0));

  in = parse_loop("{type: figure_eight}");  // defaults: Eq. 3.25
  EXPECT_EQ(in.reference_type, "figure_eight");
  expect_same_reference(*in.reference, FigureEightReference(Vec3(0, 0, 1.2), 0.8, 0.6, 60.0));
  in = parse_loop(
      "{type: figure_eight, center_m: [0, 1, 2], amplitude_x_m: 1.5, amplitude_y_m: 0.25, "
      "period_s: 20}");
  expect_same_reference(*in.reference, FigureEightReference(Vec3(0, 1, 2), 1.5, 0.25, 20.0));

  in = parse_loop(
      "{type: waypoints, points: [{time_s: 0, position_m: [0, 0, 1]},"
      " {time_s: 3, position_m: [2, 0, 1], yaw_rad: 1.0}, {time_s: 5.5, position_m: [2, 2, "
      "1.5]}]}");
  EXPECT_EQ(in.reference_type, "waypoints");
  expect_same_reference(*in.reference, WaypointReference({{0.0, Vec3(0, 0, 1), 0.0},
                                                          {3.0, Vec3(2, 0, 1), 1.0},
                                                          {5.5, Vec3(2, 2, 1.5), 0.0}}));

  // min_snap: the planner's trajectory through the points, from start_s; or with allocated times.
  std::vector<planning::Waypoint> w(3);
  w[0].position_m = Vec3(0, 0, 1);
  w[1].position_m = Vec3(2, 0, 1);
  w[1].yaw_rad = 1.0;
  w[1].velocity_m_s = Vec3(1, 0.5, 0);
  w[2].position_m = Vec3(2, 2, 1.5);
  in = parse_loop(
      "{type: min_snap, start_s: 1.5, points: [{time_s: 0, position_m: [0, 0, 1]},"
      " {time_s: 3, position_m: [2, 0, 1], yaw_rad: 1.0, velocity_m_s: [1, 0.5, 0]},"
      " {time_s: 5.5, position_m: [2, 2, 1.5]}]}");
  EXPECT_EQ(in.reference_type, "min_snap");
  expect_same_reference(*in.reference,
                        TrajectoryReference(planning::plan_min_snap(w, {3.0, 2.5}), 1.5));
  // The second point at 1.5 + 3 s.
  EXPECT_NEAR((in.reference->at(4.5).position_m - Vec3(2, 0, 1)).norm(), 0.0, 1e-12);
  w[1].velocity_m_s.reset();
  in = parse_loop(
      "{type: min_snap, time_weight: 20, points: [{position_m: [0, 0, 1]},"
      " {position_m: [2, 0, 1], yaw_rad: 1.0}, {position_m: [2, 2, 1.5]}]}");
  expect_same_reference(*in.reference, TrajectoryReference(planning::plan_min_snap(
                                           w, planning::allocate_segment_times(w, 20.0))));

  // min_snap through a track: its start, then every gate's centre facing its passage direction,
  // laps times, yaw unwrapped; the times allocated by time_weight.
  const std::string circuit = test::source_path("config/tracks/circuit.yaml");
  const Track track = load_track(circuit);
  std::vector<planning::Waypoint> gates{{track.start_position_m, track.start_yaw_rad, {}, {}}};
  for (int lap = 0; lap < 2; ++lap)
    for (const Gate& g : track.gates)
      gates.push_back({g.center_m, std::atan2(g.normal().y(), g.normal().x()), {}, {}});
  planning::TimeAllocationOptions unwrapped;
  unwrapped.min_snap.unwrap_yaw = true;
  in = parse_loop("{type: min_snap, time_weight: 100, laps: 2, track: '" + circuit + "'}");
  EXPECT_EQ(in.reference_type, "min_snap");
  expect_same_reference(
      *in.reference,
      TrajectoryReference(planning::plan_min_snap(
          gates, planning::allocate_segment_times(gates, 100.0, unwrapped), unwrapped.min_snap)));
  // Independently of the planner: it starts at the start, at rest, and passes every gate centre
  // (the knots) in order, twice, turning two full turns of heading (counter-clockwise).
  const auto* plan = dynamic_cast<const TrajectoryReference*>(in.reference.get());
  ASSERT_NE(plan, nullptr);
  const std::vector<double>& knots = plan->trajectory().knot_times_s();
  ASSERT_EQ(knots.size(), 2 * track.gates.size() + 1);
  EXPECT_EQ(in.reference->at(0.0).position_m, track.start_position_m);
  EXPECT_EQ(in.reference->at(0.0).velocity_m_s, Vec3::Zero());
  for (std::size_t i = 1; i < knots.size(); ++i) {
    const Gate& g = track.gates[(i - 1) % track.gates.size()];
    EXPECT_LT((in.reference->at(knots[i]).position_m - g.center_m).norm(), 1e-9) << i;
  }
  const double turned_rad = in.reference->at(knots.back()).yaw_rad - in.reference->at(0.0).yaw_rad;
  const double last_gate_yaw =
      std::atan2(track.gates.back().normal().y(), track.gates.back().normal().x());
  EXPECT_NEAR(turned_rad, 4.0 * std::numbers::pi + last_gate_yaw - track.start_yaw_rad, 1e-9);
  // One lap by default.
  in = parse_loop("{type: min_snap, time_weight: 100, track: '" + circuit + "'}");
  const auto* one_lap = dynamic_cast<const TrajectoryReference*>(in.reference.get());
  ASSERT_NE(one_lap, nullptr);
  EXPECT_EQ(one_lap->trajectory().segments().size(), track.gates.size());
}

TEST(ExperimentController, ControllerPathIsRelativeToTheExperimentFileFirst) {
  TempDir dir;
  std::ifstream in(kPid);
  std::stringstream text;
  text << in.rdbuf();
  dir.write("controllers/mine.yaml", text.str());
  const std::string path =
      dir.write("exp/x.yaml", "name: x\nmodel: " + kModel +
                                  "\nduration_s: 1\ninput:\n  type: controller\n"
                                  "  controller: ../controllers/mine.yaml\n"
                                  "  reference: {type: thesis_pulse}\n");
  const Experiment e = load_experiment(path);
  EXPECT_EQ(fs::path(std::get<ControllerLoopInput>(e.input).controller_path),
            (dir.path() / "controllers/mine.yaml").lexically_normal());

  // A bad controller file is reported when the experiment is loaded, through the experiment.
  dir.write("controllers/broken.yaml", "type: pid\ngains: {outer_p: [1, 2]}\n");
  const std::string broken =
      dir.write("exp/y.yaml", "name: y\nmodel: " + kModel +
                                  "\nduration_s: 1\ninput:\n  type: controller\n"
                                  "  controller: ../controllers/broken.yaml\n"
                                  "  reference: {type: thesis_pulse}\n");
  const std::string m = error_of([&] { (void)load_experiment(broken); });
  EXPECT_EQ(m.rfind(broken + ": input.controller: bad controller file: ", 0), 0u) << m;
  EXPECT_NE(m.find("broken.yaml"), std::string::npos) << m;
}

TEST(ExperimentController, OnReferenceStartsOnTheReferenceAtHover) {
  const Experiment e = parse_experiment(minimal("initial_state: {on_reference: true}\n",
                                                controller_input("{type: circle, yaw_rad: 0.5}")),
                                        "on.yaml");
  EXPECT_TRUE(e.initial_state.on_reference);
  // Eq. 3.28 at t = 0: p = (2, 0, 1), v = (0, 2 pi r / T, 0).
  EXPECT_EQ(e.initial_state.position_m, Vec3(2, 0, 1));
  EXPECT_NEAR(e.initial_state.velocity_m_s.x(), 0.0, 1e-15);
  EXPECT_NEAR(e.initial_state.velocity_m_s.y(), 4.0 * std::numbers::pi / 7.0, 1e-15);
  EXPECT_EQ(e.initial_state.velocity_m_s.z(), 0.0);
  EXPECT_EQ(e.initial_state.quaternion_wxyz, math::from_euler(0.0, 0.0, 0.5));
  EXPECT_EQ(e.initial_state.angular_velocity_rad_s, Vec3::Zero());
  EXPECT_EQ(e.initial_state.rotor_speeds.kind, RotorSpeedSetting::Kind::kHover);

  const Experiment off =
      parse_experiment(minimal("initial_state: {on_reference: false, position_m: [0, 0, 0.5]}\n",
                               controller_input("{type: circle}")),
                       "off.yaml");
  EXPECT_FALSE(off.initial_state.on_reference);
  EXPECT_EQ(off.initial_state.position_m, Vec3(0, 0, 0.5));
}

TEST(ExperimentController, MetricsWindow) {
  const Experiment e = parse_experiment(
      minimal("metrics: {window_s: [5, 30.5]}\n", controller_input("{type: circle}")), "m.yaml");
  ASSERT_TRUE(e.metrics.window_s.has_value());
  EXPECT_EQ((*e.metrics.window_s)[0], 5.0);
  EXPECT_EQ((*e.metrics.window_s)[1], 30.5);
  EXPECT_FALSE(
      parse_experiment(minimal("metrics: {}\n", controller_input("{type: circle}")), "m.yaml")
          .metrics.window_s.has_value());
}

TEST(ExperimentController, ShippedClosedLoopExperiments) {
  const Experiment pulse = load_experiment(kExperimentDir + "/pid_pulse.yaml");
  const auto& p = std::get<ControllerLoopInput>(pulse.input);
  EXPECT_EQ(fs::path(p.controller_path).filename(), "pid.yaml");
  EXPECT_EQ(p.control_rate_hz, 1000.0);
  EXPECT_EQ(p.reference_type, "thesis_pulse");
  EXPECT_EQ(pulse.duration_s, 60.0);
  EXPECT_EQ(pulse.sim.seed, 1u);
  EXPECT_TRUE(pulse.sim.noise.enabled);
  EXPECT_EQ(pulse.initial_state.position_m, Vec3::Zero());
  EXPECT_EQ(pulse.initial_state.rotor_speeds.kind, RotorSpeedSetting::Kind::kStopped);
  EXPECT_FALSE(load_experiment(kExperimentDir + "/pid_pulse_noise_off.yaml").sim.noise.enabled);
  const Experiment printed = load_experiment(kExperimentDir + "/pid_pulse_thesis_gains.yaml");
  EXPECT_EQ(fs::path(std::get<ControllerLoopInput>(printed.input).controller_path).filename(),
            "pid_thesis.yaml");

  const Experiment circle = load_experiment(kExperimentDir + "/se3_circle.yaml");
  const auto& c = std::get<ControllerLoopInput>(circle.input);
  EXPECT_EQ(fs::path(c.controller_path).filename(), "se3.yaml");
  EXPECT_EQ(c.reference_type, "circle");
  expect_same_reference(*c.reference, CircleReference());
  EXPECT_EQ(circle.duration_s, 35.0);
  EXPECT_TRUE(circle.sim.noise.enabled);
  EXPECT_TRUE(circle.initial_state.on_reference);
  EXPECT_EQ(circle.initial_state.position_m, Vec3(2, 0, 1));
  EXPECT_FALSE(load_experiment(kExperimentDir + "/se3_circle_noise_off.yaml").sim.noise.enabled);

  const Experiment hover = load_experiment(kExperimentDir + "/hover_pid.yaml");
  expect_same_reference(*std::get<ControllerLoopInput>(hover.input).reference,
                        SetpointReference(Vec3(0, 0, 1)));
  EXPECT_EQ(hover.initial_state.position_m, Vec3::Zero());
  EXPECT_EQ(hover.duration_s, 10.0);
  EXPECT_TRUE(hover.sim.noise.enabled);
}

TEST(ExperimentController, ValidateRechecksTheControlRate) {
  Experiment e = parse_experiment(
      minimal("", controller_input("{type: circle}", "  control_rate_hz: 500\n")), "r.yaml");
  EXPECT_NO_THROW(validate(e));
  e.sim.dt_s = 0.003;  // 333.3 Hz physics: 500 Hz control is faster than physics
  const std::string m = error_of([&] { validate(e); });
  EXPECT_NE(m.find("r.yaml: input.control_rate_hz: expected a rate that divides the physics rate"),
            std::string::npos)
      << m;
}

TEST(ExperimentController, InlineDefectsNameTheirFields) {
  const auto msg = [](const std::string& reference, const std::string& extra = "",
                      const std::string& top = "") {
    return error_of([&] {
      (void)parse_experiment(minimal(top, controller_input(reference, extra)), "i.yaml");
    });
  };
  const auto has = [](const std::string& m, const std::string& s) {
    EXPECT_NE(m.find(s), std::string::npos) << "missing '" << s << "' in: " << m;
  };
  has(error_of([] {
        (void)parse_experiment(minimal("", "input: {type: controller, controller: " + kPid + "}\n"),
                               "i.yaml");
      }),
      "i.yaml: input: missing required key 'reference'");
  has(error_of([] {
        (void)parse_experiment(
            minimal("", "input: {type: controller, reference: {type: circle}}\n"), "i.yaml");
      }),
      "input: missing required key 'controller'");
  has(msg("{type: circle}", "  controler_rate_hz: 100\n"),
      "input: unknown key 'controler_rate_hz'; did you mean 'control_rate_hz'?");
  has(msg("{type: circle}", "  control_rate_hz: 0\n"),
      "input.control_rate_hz: expected a number > 0, got 0");
  has(msg("{type: circle}", "  allocation: fastest\n"), "input.allocation: unknown allocation");
  has(msg("{type: circle}", "  real_time: yes\n"), "input.real_time: expected true or false");
  has(msg("circle"), "input.reference: expected a map with a 'type'");
  has(msg("{radius_m: 2}"), "input.reference: missing required key 'type'");
  has(msg("{type: setpoint}"), "input.reference: missing required key 'position_m'");
  has(msg("{type: setpoint, position_m: [0, 1]}"),
      "input.reference.position_m: expected 3 numbers (x, y, z in m), got 2");
  has(msg("{type: setpoint, position_m: [0, 0, 1], yaw: 1}"),
      "input.reference: unknown key 'yaw' (valid keys: type, position_m, yaw_rad)");
  has(msg("{type: thesis_pulse, period_s: 60}"), "input.reference: unknown key 'period_s'");
  has(msg("{type: circle, radius_m: -2}"),
      "input.reference.radius_m: expected a radius >= 0, got -2");
  has(msg("{type: circle, center_m: [0, 0]}"), "input.reference.center_m: expected 3 numbers");
  has(msg("{type: circle, period_s: \"7\"}"),
      "input.reference.period_s: expected a number, got the string");
  has(msg("{type: figure_eight, amplitude_x_m: -1}"),
      "input.reference.amplitude_x_m: expected an amplitude >= 0");
  has(msg("{type: figure_eight, period_s: 0}"), "input.reference.period_s: expected a number > 0");
  has(msg("{type: piecewise, segments: []}"),
      "input.reference.segments: expected a non-empty list");
  has(msg("{type: piecewise, segments: [{start_s: 1, position_m: [0, 0, 1]}]}"),
      "input.reference.segments[0].start_s: expected 0");
  has(msg("{type: piecewise, segments: [{start_s: 0, position_m: [0, 0, 1]}, "
          "{start_s: 0, position_m: [0, 0, 2]}]}"),
      "input.reference.segments[1].start_s: expected a time after 0 s");
  has(msg("{type: piecewise, segments: [{start_s: 0}]}"),
      "input.reference.segments[0]: missing required key 'position_m'");
  has(msg("{type: waypoints, points: [{time_s: -1, position_m: [0, 0, 1]}]}"),
      "input.reference.points[0].time_s: expected a time >= 0 s, got -1");
  has(msg("{type: waypoints, points: [{time_s: 0, position_m: [0, 0, 1]}, "
          "{time_s: 2, position_m: [0, 0, 1]}, {time_s: 1, position_m: [0, 0, 1]}]}"),
      "input.reference.points[2].time_s: expected a time after 2 s");
  has(msg("{type: waypoints, points: [{t: 0, position_m: [0, 0, 1]}]}"),
      "input.reference.points[0]: unknown key 't'");
  has(msg("{type: min_snap, points: [{time_s: 0, position_m: [0, 0, 1]}]}"),
      "input.reference.points: expected a list of at least 2 points");
  has(msg("{type: min_snap, points: [{time_s: 1, position_m: [0, 0, 1]}, "
          "{time_s: 2, position_m: [1, 0, 1]}]}"),
      "input.reference.points[0].time_s: expected 0 (times count from start_s), got 1");
  has(msg("{type: min_snap, points: [{time_s: 0, position_m: [0, 0, 1]}, "
          "{time_s: 2, position_m: [1, 0, 1]}, {time_s: 2, position_m: [2, 0, 1]}]}"),
      "input.reference.points[2].time_s: expected a time after 2 s");
  has(msg("{type: min_snap, points: [{time_s: 0, position_m: [0, 0, 1]}, "
          "{position_m: [1, 0, 1]}]}"),
      "input.reference.points[1]: missing required key 'time_s'");
  has(msg("{type: min_snap, time_weight: 10, points: [{time_s: 0, position_m: [0, 0, 1]}, "
          "{position_m: [1, 0, 1]}]}"),
      "input.reference.points[0].time_s: expected no time_s: time_weight allocates the times");
  has(msg("{type: min_snap, time_weight: 0, points: [{position_m: [0, 0, 1]}, "
          "{position_m: [1, 0, 1]}]}"),
      "input.reference.time_weight: expected a number > 0, got 0");
  has(msg("{type: min_snap, points: [{time_s: 0, position_m: [0, 0, 1]}, "
          "{time_s: 1, position_m: [1, 0, 1]}, {time_s: 2, position_m: [1, 0, 1]}]}"),
      "input.reference.points: plan_min_snap: waypoints[1] and waypoints[2] are the same point");
  has(msg("{type: min_snap, start_s: -1, points: [{time_s: 0, position_m: [0, 0, 1]}, "
          "{time_s: 1, position_m: [1, 0, 1]}]}"),
      "input.reference.start_s: expected a time >= 0 s, got -1");
  has(msg("{type: min_snap, points: [{time_s: 0, position_m: [0, 0, 1], speed: 2}, "
          "{time_s: 1, position_m: [1, 0, 1]}]}"),
      "input.reference.points[0]: unknown key 'speed'");
  const std::string circuit = test::source_path("config/tracks/circuit.yaml");
  has(msg("{type: min_snap, track: '" + circuit + "'}"),
      "input.reference.track: a track's gates have no times: give time_weight");
  has(msg("{type: min_snap, time_weight: 1, track: '" + circuit +
          "', points: [{position_m: [0, 0, 1]}, {position_m: [1, 0, 1]}]}"),
      "input.reference.points: expected either points or track, not both");
  has(msg("{type: min_snap, time_weight: 1, track: no_such_track.yaml}"),
      "track file 'no_such_track.yaml' not found");
  has(msg("{type: min_snap, time_weight: 1, laps: 0, track: '" + circuit + "'}"),
      "input.reference.laps: expected an integer in [1, 1000], got 0");
  has(msg("{type: min_snap, time_weight: 1, laps: 1.5, track: '" + circuit + "'}"),
      "input.reference.laps: expected an integer in [1, 1000]");
  has(msg("{type: min_snap, time_weight: 1, laps: 2, track: '" +
          test::source_path("config/tracks/straight.yaml") + "'}"),
      "is open (one pass through its gates); expected laps: 1, got 2");
  has(msg("{type: min_snap, laps: 2, points: [{time_s: 0, position_m: [0, 0, 1]}, "
          "{time_s: 1, position_m: [1, 0, 1]}]}"),
      "input.reference.laps: laps goes with track; no track is given");

  // metrics
  has(msg("{type: circle}", "", "metrics: {window_s: [3, 1]}\n"),
      "metrics.window_s: expected 0 <= t0 < t1, got [3, 1]");
  has(msg("{type: circle}", "", "metrics: {window_s: [-1, 1]}\n"), "metrics.window_s: expected 0");
  has(msg("{type: circle}", "", "metrics: {window_s: [1]}\n"),
      "metrics.window_s: expected 2 numbers (t0, t1 in s), got 1");
  has(msg("{type: circle}", "", "metrics: {window: [0, 1]}\n"),
      "metrics: unknown key 'window'; did you mean 'window_s'?");
  has(error_of([] { (void)parse_experiment(minimal("metrics: {window_s: [0, 1]}\n"), "i.yaml"); }),
      "i.yaml: metrics: only for input type 'controller'");

  // on_reference
  has(msg("{type: circle}", "", "initial_state: {on_reference: true, position_m: [0, 0, 1]}\n"),
      "initial_state.position_m: on_reference: true sets the whole initial state");
  has(msg("{type: circle}", "", "initial_state: {on_reference: true, rotor_speeds_rad_s: hover}\n"),
      "initial_state.rotor_speeds_rad_s: on_reference: true sets the whole initial state");
  has(msg("{type: circle}", "", "initial_state: {on_reference: 1}\n"),
      "initial_state.on_reference: expected true or false");
  has(msg("{type: circle, center_m: [0, 0, -1]}", "", "initial_state: {on_reference: true}\n"),
      "initial_state.on_reference: the reference starts below the ground");
  has(error_of([] {
        (void)parse_experiment(minimal("initial_state: {on_reference: true}\n"), "i.yaml");
      }),
      "i.yaml: initial_state.on_reference: only for input type 'controller'");
}

// ---- model paths ------------------------------------------------------------------------------

TEST(Experiment, ModelPathIsRelativeToTheExperimentFileFirst) {
  TempDir dir;
  std::ifstream model_in(kModel);
  std::stringstream model_text;
  model_text << model_in.rdbuf();
  dir.write("models/m.yaml", model_text.str());
  const std::string path = dir.write(
      "exp/x.yaml", "name: x\nmodel: ../models/m.yaml\nduration_s: 1\ninput: {type: hover}\n");
  const Experiment e = load_experiment(path);
  EXPECT_EQ(fs::path(e.model_path), (dir.path() / "models/m.yaml").lexically_normal());
}

TEST(Experiment, ModelPathFallsBackToTheCurrentDirectory) {
  TempDir dir;
  const std::string relative = fs::relative(kModel, fs::current_path()).string();
  ASSERT_FALSE(fs::exists(dir.path() / relative));
  const std::string path = dir.write(
      "x.yaml", "name: x\nmodel: " + relative + "\nduration_s: 1\ninput: {type: hover}\n");
  const Experiment e = load_experiment(path);
  EXPECT_TRUE(fs::equivalent(e.model_path, kModel));
}

// ---- the malformed-file corpus ----------------------------------------------------------------

using BadCase = test::BadFileCase;

// One row per file of tests/data/bad_experiments (CorpusIsFullyCovered checks).
const std::vector<BadCase> kBadCases = {
    {"bad_quaternion_length.yaml",
     {"initial_state.quaternion_wxyz: expected 4 numbers (w, x, y, z), got 3", "line 7"}},
    {"circle_negative_period.yaml",
     {"input.reference.period_s: expected a number > 0, got -7.0", "line 11"}},
    {"control_rate_not_dividing.yaml",
     {"input.control_rate_hz: expected a rate that divides the physics rate 1000 Hz",
      "got 300 Hz"}},
    {"controller_is_a_directory.yaml",
     {"input.controller: controller file '../../../config/controllers' is a directory",
      "expected a controller YAML file", "line 7"}},
    {"control_rate_tiny.yaml",
     {"input.control_rate_hz: expected a rate that divides the physics rate", "got 1e-300 Hz"}},
    {"disturbance_key_typo.yaml",
     {"disturbances: unknown key 'groundeffect'", "did you mean 'ground_effect'?"}},
    {"missing_scene_file.yaml", {"scene: scene file 'no_such_scene.yaml' not found", "line 5"}},
    {"scene_degenerate_obstacle.yaml",
     {"scene: ", "flat_box.yaml: obstacles[0].size: expected three positive extents", "line 5"}},
    {"dt_too_large.yaml", {"physics_dt_s: expected a step in (0, 0.1] s, got 0.5"}},
    {"every_n_steps_zero.yaml", {"log.every_n_steps: expected an integer >= 1, got 0"}},
    {"fault_effectiveness_above_one.yaml",
     {"faults[0].effectiveness: expected the fraction of thrust left, in [0, 1], got 1.5",
      "line 6"}},
    {"fault_rotor_out_of_range.yaml",
     {"faults[0].rotor: expected 0 .. 3 (rotors of qdrone2), got 4"}},
    {"battery_efficiency_above_one.yaml",
     {"battery.efficiency: expected a fraction in (0, 1], got 1.2", "line 6"}},
    {"battery_ocv_falling.yaml",
     {"battery.ocv_cell_V: [3]: expected a voltage > 0 not below the one before it, got 3.6",
      "line 6"}},
    {"battery_key_typo.yaml", {"capacity_mAh", "did you mean 'capacity_Ah'?"}},
    {"payload_tether_zero.yaml",
     {"payload.tether_length_m: expected a number > 0, got 0", "line 6"}},
    {"payload_swing_too_large.yaml",
     {"payload.initial_swing_rad: expected angles within (-pi/2, pi/2), got [2, 0]", "line 6"}},
    {"payload_key_typo.yaml", {"tether_length", "did you mean 'tether_length_m'?"}},
    {"fault_type_typo.yaml",
     {"faults[0].type: unknown fault type 'rotor_stopp'", "did you mean 'rotor_stop'?", "line 6"}},
    {"first_segment_not_at_zero.yaml", {"input.segments[0].start_s: expected 0", "got 0.5"}},
    {"force_three_numbers.yaml", {"input.u: expected 4 numbers", "got 3"}},
    {"hover_input_extra_key.yaml", {"input: unknown key 'rotor_speeds_rad_s' (valid keys: type)"}},
    {"initial_rotor_count.yaml",
     {"initial_state.rotor_speeds_rad_s: expected 4 numbers (rotors of qdrone2), got 5"}},
    {"input_missing_type.yaml", {"input: missing required key 'type'"}},
    {"missing_input.yaml", {"missing required key 'input'"}},
    {"missing_controller_file.yaml",
     {"input.controller: controller file 'no_such_controller.yaml' not found", "line 7"}},
    {"missing_model_file.yaml", {"model: model file 'no_such_model.yaml' not found"}},
    {"nan_wind.yaml", {"wind_m_s[1]: expected a finite number, got .nan", "line 5"}},
    {"negative_duration.yaml", {"duration_s: expected a number > 0, got -1"}},
    {"negative_rotor_speed.yaml", {"input.rotor_speeds_rad_s[1]: expected a rotor speed >= 0"}},
    {"negative_seed.yaml", {"seed: expected an integer", "got '-3'"}},
    {"noise_drift_typo.yaml", {"noise.drift: unknown drift 'per_step'", "per_sample"}},
    {"noise_unstable_theta.yaml", {"noise.theta: the OU process is unstable"}},
    {"quaternion_and_euler.yaml",
     {"initial_state: give either quaternion_wxyz or euler_rad, not both"}},
    {"quoted_number.yaml", {"duration_s: expected a number, got the string \"1.0\""}},
    {"reference_not_finite_at_zero.yaml",
     {"input.reference: is not finite at t = 0 s (circle r = 2 m"}},
    {"rotor_speeds_in_rpm.yaml",
     {"input.rotor_speeds_rad_s[0]: expected a speed within the limits", "got 11210"}},
    {"segment_wrong_rotor_count.yaml",
     {"input.segments[1].rotor_speeds_rad_s: expected 4 numbers (rotors of qdrone2), got 3"}},
    {"segments_on_one_step.yaml",
     {"input.segments[2].start_s:", "takes effect at the same physics step (501",
      "as input.segments[1]", "the earlier segment would never fly"}},
    {"start_below_ground.yaml", {"initial_state.position_m[2]: expected z >= 0", "got -1"}},
    {"unknown_input_type.yaml",
     {"input.type: unknown input type 'constant_rotor_speed'",
      "did you mean 'constant_rotor_speeds'?"}},
    {"unknown_reference_type.yaml",
     {"input.reference.type: unknown reference type 'cirle'", "did you mean 'circle'?"}},
    {"unknown_integrator.yaml",
     {"integrator: unknown integrator 'rk5'", "did you mean 'rk4'?", "line 5"}},
    {"unknown_key_typo.yaml", {"unknown key 'duratoin_s'", "did you mean 'duration_s'?", "line 4"}},
    {"unsorted_segments.yaml",
     {"input.segments[2].start_s: expected a start after 2 s", "strictly increase", "got 1"}},
    {"wind_gust_zero_duration.yaml",
     {"wind.gusts[0].duration_s: expected a number > 0, got 0", "line 7"}},
    {"wind_shear_inside_roughness.yaml",
     {"wind.shear: reference_height_m (0.05) must be above twice roughness_length_m (0.04572)",
      "line 7"}},
    {"wind_too_many_gusts.yaml", {"wind.gusts: expected at most 8 gusts, got 9", "line 7"}},
    {"wind_turbulence_typo.yaml",
     {"wind.turbulence: unknown severity 'moderat'", "did you mean 'moderate'?", "line 5"}},
    {"wrong_rotor_count.yaml",
     {"input.rotor_speeds_rad_s: expected 4 numbers (rotors of qdrone2), got 3"}},
    {"yaml_syntax_error.yaml", {"line 6, column 6: YAML syntax error"}},
    {"yes_is_not_a_bool.yaml", {"motor_dynamics: expected true or false, got 'yes'"}},
};

/// Loads the file and, if that passes, checks it against its model: the error of either.
std::string load_and_check(const std::string& path) {
  return error_of([&] {
    const Experiment e = load_experiment(path);
    const VehicleModel model = load_vehicle_model(e.model_path);
    check_against_model(e, model);
  });
}

class BadExperiment : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadExperiment, IsRejectedNamingFileAndField) {
  const BadCase& c = GetParam();
  const std::string path = kBadDir + "/" + c.file;
  ASSERT_TRUE(fs::exists(path)) << path;
  const std::string message = load_and_check(path);
  EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << "message must start with the file: " << message;
  for (const std::string& s : c.expected)
    EXPECT_NE(message.find(s), std::string::npos) << "missing '" << s << "' in: " << message;
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadExperiment, ::testing::ValuesIn(kBadCases),
                         test::bad_file_case_name);

TEST(BadExperimentCorpus, CorpusIsFullyCovered) {
  std::set<std::string> files;
  for (const auto& entry : fs::directory_iterator(kBadDir))
    files.insert(entry.path().filename().string());
  std::set<std::string> covered;
  for (const BadCase& c : kBadCases) covered.insert(c.file);
  EXPECT_EQ(files, covered);
  EXPECT_EQ(files.size(), 52u);
  EXPECT_GE(files.size(), 10u);
}

TEST(BadExperimentCorpus, InlineDefectsNameTheirFields) {
  const auto msg = [](const std::string& extra,
                      const std::string& input = "input: {type: hover}\n") {
    return error_of([&] { (void)parse_experiment(minimal(extra, input), "inline.yaml"); });
  };
  EXPECT_NE(msg("gravity_m_s2: [0, 0, .inf]\n")
                .find("inline.yaml: gravity_m_s2[2]: expected a finite number"),
            std::string::npos);
  EXPECT_NE(msg("initial_state: {quaternion_wxyz: [1, 1, 0, 0]}\n")
                .find("initial_state.quaternion_wxyz: expected a unit quaternion"),
            std::string::npos);
  EXPECT_NE(
      msg("ground: {crash_speed_m_s: 0}\n").find("ground.crash_speed_m_s: expected a number > 0"),
      std::string::npos);
  EXPECT_NE(msg("log: {every_n_steps: 1.5}\n")
                .find("log.every_n_steps: expected an integer >= 1, got '1.5'"),
            std::string::npos);
  EXPECT_NE(msg("", "input: {type: piecewise_rotor_speeds, segments: []}\n")
                .find("input.segments: expected a non-empty list"),
            std::string::npos);
  EXPECT_NE(
      msg("", "input: {type: constant_generalized_force, u: [1, 0, 0, 0], allocation: fast}\n")
          .find("input.allocation: unknown allocation 'fast'"),
      std::string::npos);
  EXPECT_NE(msg("name: again\n").find("duplicate key 'name'"), std::string::npos);
  EXPECT_NE(
      error_of([] { (void)parse_experiment("", "empty.yaml"); }).find("empty.yaml: empty document"),
      std::string::npos);
  EXPECT_NE(error_of([] {
              (void)parse_experiment("- 1\n- 2\n", "list.yaml");
            }).find("list.yaml: expected a map of experiment settings, got a sequence of 2 items"),
            std::string::npos);
  EXPECT_NE(error_of([] {
              (void)load_experiment("/nonexistent/x.yaml");
            }).find("/nonexistent/x.yaml: cannot open experiment file"),
            std::string::npos);
}

}  // namespace
}  // namespace dronetwin
