// VehicleLink (src/ros/vehicle_link.hpp), the simulator half of dronetwin_ros, without ROS: its
// stamps are exact, each kind of command flies exactly what the same controller flown directly
// on a Simulator flies, bad commands are refused without touching the flight, and bad files and
// rates are named. The ROS half is tested against a real roscore in tests/ros/test_bridge.py.

#include "vehicle_link.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/config/experiment.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/control/body_rate.hpp"
#include "dronetwin/model/model_parameters.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"
#include "dronetwin/sensors/sensor_truth.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin::ros_bridge {
namespace {

namespace si = state_index;

std::string experiment(const std::string& name) {
  return test::source_path("config/experiments/" + name + ".yaml");
}

// The experiment's own simulator, started as the link starts it.
Simulator simulator_of(const Experiment& e, std::shared_ptr<const VehicleModel>& model) {
  model = std::make_shared<const VehicleModel>(load_vehicle_model(e.model_path));
  Simulator sim(model, e.sim_config());
  sim.reset(e.initial_state.state(),
            e.initial_state.rotor_speeds.resolve(*model, e.gravity_magnitude()));
  if (e.scene) sim.set_scene(e.scene);
  return sim;
}

Eigen::Matrix3d rotation_of(const LinkBodyState& s) {
  const auto& q = s.orientation_wxyz;
  return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
}

Vec3 world_velocity(const LinkBodyState& s) {
  return rotation_of(s) * Vec3(s.velocity_B_m_s.data());
}

void expect_same_pose(const LinkSnapshot& s, const StateVector& x) {
  for (int i = 0; i < 3; ++i) EXPECT_EQ(s.state.position_m[i], x[si::kPosition + i]) << i;
  for (int i = 0; i < 4; ++i) EXPECT_EQ(s.state.orientation_wxyz[i], x[si::kQuaternion + i]) << i;
  for (int i = 0; i < 3; ++i) EXPECT_EQ(s.state.rates_B_rad_s[i], x[si::kAngularVelocity + i]);
}

TEST(VehicleLink, StampsAreExactMultiplesOfThePeriodUpToTheDuration) {
  VehicleLink link({experiment("ros_hover"), "", 0.0});
  EXPECT_EQ(link.airframe().control_rate_hz, 100.0);  // the experiment's control rate
  std::uint64_t periods = 0;
  while (!link.finished()) {
    EXPECT_EQ(link.stamp_ns(), periods * 10'000'000ULL);
    ASSERT_EQ(link.command_ctbr(link.airframe().mass_kg * 9.81, {0.0, 0.0, 0.0}), "");
    ASSERT_EQ(link.advance(), "");
    ++periods;
  }
  EXPECT_EQ(periods, 500U);  // 5 s at 100 Hz
  EXPECT_EQ(link.stamp_ns(), 5'000'000'000ULL);
}

// With no command the link flies the experiment's initial rotor speeds: the open-loop hover,
// step for step what a Simulator holding the hover speeds does (noise, disturbances and all).
TEST(VehicleLink, RotorSpeedCommandsFlyExactlyWhatTheSimulatorFlies) {
  const Experiment e = load_experiment(experiment("hover_open_loop"));
  std::shared_ptr<const VehicleModel> model;
  Simulator sim = simulator_of(e, model);
  VehicleLink link({experiment("hover_open_loop"), "", 50.0});
  const RotorVector hover = sim.rotor_speed_reference_rad_s();
  RotorVector commanded = hover;
  for (int period = 0; period < 100; ++period) {
    if (period == 40) {  // from 0.8 s on, 2 % more on rotor 0 through the command path
      commanded[0] *= 1.02;
      ASSERT_EQ(link.command_rotor_speeds({commanded.data(), commanded.data() + 4}), "");
    }
    ASSERT_EQ(link.advance(), "");
    for (int k = 0; k < 20; ++k) {
      sim.set_rotor_speed_reference(commanded);
      ASSERT_TRUE(sim.step().ok());
    }
  }
  expect_same_pose(link.snapshot(), sim.state());
  EXPECT_NE(sim.state()[si::kAngularVelocity + 1], 0.0);  // the extra thrust did something
}

// The experiment's sensors are sampled at every physics step as `dronetwin run` samples them
// (sensors/sensor_suite.hpp, seeded with the experiment's seed), and each period's snapshot
// holds exactly the readings delivered in that period: stamps and values bit for bit.
TEST(VehicleLink, SensorReadingsAreTheExperimentsSensorsDeliveredInThePeriod) {
  const Experiment e = load_experiment(experiment("hover_sensors"));
  std::shared_ptr<const VehicleModel> model;
  Simulator sim = simulator_of(e, model);
  SensorSuite suite(e.sensors, e.sim.dt_s, model->num_rotors(), e.sim.seed);
  VehicleLink link({experiment("hover_sensors"), "", 100.0});
  const std::vector<LinkSensor> sensors = link.sensors();
  ASSERT_EQ(sensors.size(), e.sensors.size());
  EXPECT_EQ(sensors[0].name, "imu");
  EXPECT_EQ(sensors[0].type, "imu");
  EXPECT_EQ(sensors[0].channels, (std::vector<std::string>{"fx", "fy", "fz", "wx", "wy", "wz"}));
  EXPECT_EQ(sensors[0].position_B_m, (std::array<double, 3>{0.02, 0.0, 0.01}));

  const RotorVector hover = model->hover_speeds_rad_s(e.gravity_magnitude());
  ASSERT_EQ(link.command_rotor_speeds({hover.data(), hover.data() + hover.size()}), "");
  StateVector previous = sim.state();
  std::vector<LinkSensorReading> expected;
  const auto sense = [&] {
    suite.update(sim.step_count(), make_sensor_truth(sim, previous));
    previous = sim.state();
    for (int i = 0; i < suite.size(); ++i) {
      if (!suite.fresh(i)) continue;
      const SensorReading& r = suite.latest(i);
      LinkSensorReading e_r{i, static_cast<std::uint64_t>(std::llround(r.stamp_s * 1e9)), r.size};
      std::copy(r.values.begin(), r.values.begin() + r.size, e_r.values.begin());
      expected.push_back(e_r);
    }
  };
  std::vector<int> count(sensors.size(), 0);
  sense();                                       // step 0
  for (int period = 0; period < 50; ++period) {  // 0.5 s
    const std::vector<LinkSensorReading> got = link.snapshot().sensor_readings;
    ASSERT_EQ(got.size(), expected.size()) << "period " << period;
    for (std::size_t k = 0; k < got.size(); ++k) {
      EXPECT_EQ(got[k].sensor, expected[k].sensor);
      EXPECT_EQ(got[k].stamp_ns, expected[k].stamp_ns);
      // Bit for bit, NaN (no return, no reading yet) included.
      ASSERT_EQ(got[k].size, expected[k].size);
      ASSERT_EQ(got[k].size, static_cast<int>(sensors[got[k].sensor].channels.size()));
      EXPECT_EQ(std::memcmp(got[k].values.data(), expected[k].values.data(),
                            static_cast<std::size_t>(got[k].size) * sizeof(double)),
                0)
          << sensors[got[k].sensor].name << " at " << got[k].stamp_ns << " ns";
      ++count[got[k].sensor];
    }
    expected.clear();
    ASSERT_EQ(link.advance(), "");
    for (int k = 0; k < 10; ++k) {
      sim.set_rotor_speed_reference(hover);
      ASSERT_TRUE(sim.step().ok());
      sense();
    }
  }
  // Deliveries up to t = 0.49 s: sample n of a sensor is taken at n / rate and delivered a
  // latency later (the IMU at 1 kHz: 491 from step 0; the GPS at 10 Hz, 0.1 s late: 4).
  for (std::size_t i = 0; i < sensors.size(); ++i) {
    if (sensors[i].type == "range_finder" || sensors[i].type == "optical_flow")
      continue;  // dropouts
    const SensorSpec& spec = e.sensors[i];
    const int due = static_cast<int>(std::floor((0.49 - spec.latency_s) * spec.rate_hz + 1e-9)) + 1;
    EXPECT_EQ(count[i], due) << spec.name;
  }
  EXPECT_EQ(count[0], 491);
}

// A CTBR command is the body-rate controller run every physics step on the measured state.
TEST(VehicleLink, CtbrCommandsAreTheBodyRateControllerAtThePhysicsRate) {
  const Experiment e = load_experiment(experiment("hover_open_loop"));
  std::shared_ptr<const VehicleModel> model;
  Simulator sim = simulator_of(e, model);
  BodyRateController rates(model, BodyRateGains{});
  VehicleLink link({experiment("hover_open_loop"), "", 0.0});
  const double thrust_N = model->mass_kg() * 9.81 * 1.1;
  const Vec3 rates_cmd(0.3, -0.2, 0.5);
  rates.set_command(thrust_N, rates_cmd);
  ASSERT_EQ(link.command_ctbr(thrust_N, {0.3, -0.2, 0.5}), "");
  for (int period = 0; period < 50; ++period) {
    ASSERT_EQ(link.advance(), "");
    for (int k = 0; k < 10; ++k) {  // hover_open_loop has no controller: 100 Hz periods
      ControlInput in;
      in.time_s = sim.time_s();
      in.state = sim.measured_state();
      sim.set_rotor_speed_reference(rates.calculate_actuator_cmd(in));
      ASSERT_TRUE(sim.step().ok());
    }
  }
  expect_same_pose(link.snapshot(), sim.state());
  // The body z rate is near its command after 0.5 s (10 time constants of the yaw loop).
  EXPECT_NEAR(link.snapshot().state.rates_B_rad_s[2], 0.5, 0.1);
}

TEST(VehicleLink, PoseCommandsAreFlownByThePositionController) {
  const std::string se3 = test::source_path("config/controllers/se3.yaml");
  VehicleLink link({experiment("hover_open_loop"), se3, 0.0});
  ASSERT_TRUE(link.accepts_position_commands());
  ASSERT_EQ(link.command_pose({0.5, 0.0, 1.2}, 0.0), "");
  while (!link.finished()) ASSERT_EQ(link.advance(), "");
  const LinkSnapshot s = link.snapshot();
  // 5 s is ample for the SE(3) controller to settle on a 0.5 m step.
  EXPECT_NEAR(s.state.position_m[0], 0.5, 0.02);
  EXPECT_NEAR(s.state.position_m[2], 1.2, 0.02);
}

// The twist is in the body frame (REP 105): rotating it back gives the world velocity, which
// the true position's central difference over one period approximates.
TEST(VehicleLink, TwistIsInTheBodyFrameAndImuReadsTheSpecificForce) {
  const std::string se3 = test::source_path("config/controllers/se3.yaml");
  VehicleLink link({experiment("hover_open_loop"), se3, 1000.0});
  ASSERT_EQ(link.command_pose({1.0, 1.0, 1.5}, 1.0), "");
  for (int k = 0; k < 800; ++k) ASSERT_EQ(link.advance(), "");
  const LinkSnapshot before = link.snapshot();
  ASSERT_EQ(link.advance(), "");
  const LinkSnapshot now = link.snapshot();
  ASSERT_EQ(link.advance(), "");
  const LinkSnapshot after = link.snapshot();
  const Eigen::Matrix3d R = rotation_of(now.state);
  const Vec3 v_W = world_velocity(now.state);
  const Vec3 difference =
      (Vec3(after.state.position_m.data()) - Vec3(before.state.position_m.data())) / 2e-3;
  EXPECT_GT(v_W.norm(), 0.05);  // it is moving, and turning (yaw 1 rad)
  EXPECT_LT((v_W - difference).norm(), 1e-5 + 1e-3 * v_W.norm());
  // Specific force: the world acceleration (central difference of the neighbours' world
  // velocities) minus gravity, in the body frame.
  const Vec3 v_before = world_velocity(before.state);
  const Vec3 v_after = world_velocity(after.state);
  const Vec3 a_W = (v_after - v_before) / 2e-3;
  const Vec3 f_B = R.transpose() * (a_W - Vec3(0, 0, -9.81));
  EXPECT_LT((Vec3(now.specific_force_B_m_s2.data()) - f_B).norm(), 0.05);
}

// With the rotors stopped and no drag an accelerometer reads only what the stopped rotors push:
// the thrust polynomial's constant term K3 (Eq. 2.22) on each, 4 K3 / m along body z.
TEST(VehicleLink, AFallingVehicleFeelsOnlyTheStoppedRotorsThrust) {
  VehicleLink link({experiment("freefall"), "", 0.0});
  const Experiment e = load_experiment(experiment("freefall"));
  const VehicleModel model = load_vehicle_model(e.model_path);
  const double k3_N = parameter_value(model.spec(), ModelParameter::kThrustK3);
  for (int k = 0; k < 20; ++k) ASSERT_EQ(link.advance(), "");
  const LinkSnapshot s = link.snapshot();
  EXPECT_LT(s.state.velocity_B_m_s[2], -1.9);  // falling: 0.2 s at ~g
  EXPECT_EQ(s.specific_force_B_m_s2[0], 0.0);
  EXPECT_EQ(s.specific_force_B_m_s2[1], 0.0);
  EXPECT_NEAR(s.specific_force_B_m_s2[2], 4.0 * k3_N / model.mass_kg(), 1e-12);
}

TEST(VehicleLink, BadCommandsAreRefusedAndTheFlightIsUntouched) {
  VehicleLink plain({experiment("hover_open_loop"), "", 0.0});
  VehicleLink link({experiment("hover_open_loop"), "", 0.0});
  EXPECT_EQ(link.command_rotor_speeds({1.0, 2.0, 3.0}),
            "3 rotor speeds, expected 4 (one per rotor of qdrone2)");
  EXPECT_NE(link.command_rotor_speeds({1.0, -2.0, 3.0, 4.0}).find("rotor speed [1] = -2"),
            std::string::npos);
  EXPECT_NE(link.command_ctbr(std::nan(""), {0.0, 0.0, 0.0}).find("finite thrust"),
            std::string::npos);
  EXPECT_NE(link.command_ctbr(-1.0, {0.0, 0.0, 0.0}).find("thrust -1 N"), std::string::npos);
  EXPECT_NE(link.command_pose({0.0, 0.0, 1.0}, 0.0).find("no position controller"),
            std::string::npos);
  for (int k = 0; k < 30; ++k) {
    ASSERT_EQ(plain.advance(), "");
    ASSERT_EQ(link.advance(), "");
  }
  EXPECT_EQ(link.snapshot().state.position_m, plain.snapshot().state.position_m);
  EXPECT_EQ(link.snapshot().rotor_speeds_rad_s, plain.snapshot().rotor_speeds_rad_s);
}

TEST(VehicleLink, AFailedStepIsReportedAndStays) {
  // A pose command onto the obstacle course's first gate: the collision ends the flight.
  const std::string se3 = test::source_path("config/controllers/se3.yaml");
  VehicleLink link({experiment("ros_hover"), se3, 0.0});
  ASSERT_EQ(link.command_pose({2.0, 0.76, 1.2}, 0.0), "");  // onto the entry gate's left bar
  std::string failure;
  while (!link.finished() && failure.empty()) failure = link.advance();
  ASSERT_NE(failure, "");
  EXPECT_NE(failure.find("entry"), std::string::npos) << failure;
  EXPECT_EQ(link.advance(), failure);
}

TEST(VehicleLink, SceneItemsAreTheExperimentsGatesAndObstacles) {
  VehicleLink link({experiment("ros_hover"), "", 0.0});
  const Experiment e = load_experiment(experiment("ros_hover"));
  const std::vector<LinkSceneItem> items = link.scene();
  ASSERT_EQ(items.size(), e.scene->gates.size() + e.scene->obstacles.size());
  const LinkSceneItem& gate = items.front();
  EXPECT_EQ(gate.kind, LinkSceneItem::Kind::kGate);
  EXPECT_EQ(gate.name, e.scene->gates.front().name);
  for (const LinkSceneItem& item : items) {
    if (item.name == "pillar") {  // cylinder r 0.25, 3 m high (config/tracks/obstacle_course)
      EXPECT_EQ(item.kind, LinkSceneItem::Kind::kCylinder);
      EXPECT_DOUBLE_EQ(item.size_m[0], 0.5);
      EXPECT_DOUBLE_EQ(item.size_m[2], 3.0);
    }
  }
  EXPECT_TRUE(VehicleLink({experiment("hover_open_loop"), "", 0.0}).scene().empty());
}

TEST(VehicleLink, BadFilesAndRatesAreNamed) {
  try {
    VehicleLink link({"/nonexistent/experiment.yaml", "", 0.0});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& err) {
    EXPECT_NE(std::string(err.what()).find("/nonexistent/experiment.yaml"), std::string::npos);
  }
  try {
    VehicleLink link({experiment("ros_hover"), "", 300.0});  // 1000 / 300 steps
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& err) {
    EXPECT_NE(std::string(err.what()).find("control rate 300 Hz"), std::string::npos) << err.what();
  }
  try {
    VehicleLink link({experiment("ros_hover"), "/nonexistent/se3.yaml", 0.0});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& err) {
    EXPECT_NE(std::string(err.what()).find("/nonexistent/se3.yaml"), std::string::npos);
  }
  EXPECT_THROW(VehicleLink({"", "", 0.0}), std::invalid_argument);
  EXPECT_THROW(VehicleLink({experiment("ros_hover"), "", -1.0}), std::invalid_argument);
}

}  // namespace
}  // namespace dronetwin::ros_bridge
