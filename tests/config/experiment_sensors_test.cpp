// Tests of the `sensors:` list of experiment files (Experiment::sensors,
// docs/experiment-format.md "Sensors"): every type with every key overridden parses to those
// values, a sensor given only its type gets SensorSpec::defaults with its type's default name,
// the shipped hover_sensors.yaml loads, and every bad input is rejected with a message that
// starts with the file and names the sensor and its field.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <variant>
#include <vector>

#include "dronetwin/config/experiment.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

using test::error_of;

const std::string kSourceDir = DRONETWIN_SOURCE_DIR;
const std::string kModel = kSourceDir + "/models/qdrone2.yaml";

/// A minimal hover experiment with `sensors` (the YAML of the list, after "sensors:") and
/// `extra` top-level lines.
std::string with_sensors(const std::string& sensors, const std::string& extra = "") {
  return "name: t\nmodel: " + kModel + "\nduration_s: 1.0\n" + extra +
         "input: {type: hover}\nsensors:" + sensors;
}

Experiment parse(const std::string& sensors, const std::string& extra = "") {
  return parse_experiment(with_sensors(sensors, extra), "s.yaml");
}

/// The message of parsing `sensors`, checked to contain every one of `expected`.
void expect_error(const std::string& sensors, const std::vector<std::string>& expected,
                  const std::string& extra = "") {
  const std::string m = error_of([&] { (void)parse(sensors, extra); });
  for (const std::string& part : expected)
    EXPECT_NE(m.find(part), std::string::npos) << "missing: " << part << "\nin: " << m;
}

Vec4 from_euler_deg(double roll, double pitch, double yaw) {
  constexpr double k = std::numbers::pi / 180.0;
  return math::from_euler(roll * k, pitch * k, yaw * k);
}

void expect_triad(const TriadNoise& t, double base) {
  EXPECT_EQ(t.noise_density, base + 0.1);
  EXPECT_EQ(t.bias_random_walk, base + 0.2);
  EXPECT_EQ(t.bias_instability, base + 0.3);
  EXPECT_EQ(t.bias_correlation_time_s, base + 0.4);
  EXPECT_EQ(t.turn_on_bias, base + 0.5);
  EXPECT_EQ(t.range, base + 0.6);
}

// ---- good files -------------------------------------------------------------------------------

TEST(ExperimentSensors, NoSensorsByDefault) {
  const Experiment e = parse_experiment(
      "name: t\nmodel: " + kModel + "\nduration_s: 1.0\ninput: {type: hover}\n", "s.yaml");
  EXPECT_TRUE(e.sensors.empty());
  EXPECT_TRUE(parse(" []\n").sensors.empty());
}

TEST(ExperimentSensors, EveryTypeWithEveryKeyOverridden) {
  const Experiment e = parse(R"(
  - type: imu
    name: imu_front
    rate_hz: 500
    latency_s: 0.002
    mounting: {position_m: [0.1, -0.02, 0.03], rpy_deg: [10, -20, 30]}
    gyro: {noise_density: 1.1, bias_random_walk: 1.2, bias_instability: 1.3,
           bias_correlation_time_s: 1.4, turn_on_bias: 1.5, range: 1.6}
    accel: {noise_density: 2.1, bias_random_walk: 2.2, bias_instability: 2.3,
            bias_correlation_time_s: 2.4, turn_on_bias: 2.5, range: 2.6}
  - type: magnetometer
    name: compass
    rate_hz: 75
    field_uT: [20, 1, -40]
    noise_uT: 0.5
    hard_iron_uT: [1, 2, 3]
  - type: barometer
    name: baro2
    noise_Pa: 2.5
    drift_Pa_per_sqrt_s: 0.2
    offset_Pa: -30
    origin_altitude_m: 1500
  - type: gps
    name: gnss
    rate_hz: 5
    latency_s: 0.2
    position_noise_m: [0.1, 0.2, 0.3]
    position_error_m: [1, 2, 4]
    position_error_time_s: 120
    velocity_noise_m_s: [0.01, 0.02, 0.03]
  - type: motion_capture
    name: vicon
    rate_hz: 200
    position_noise_m: 0.001
    attitude_noise_rad: 0.002
  - type: range_finder
    name: lidar
    mounting: {position_m: [0, 0, -0.05]}
    min_range_m: 0.1
    max_range_m: 12
    noise_m: 0.02
    noise_fraction: 0.01
    dropout_probability: 0.05
  - type: optical_flow
    name: px_flow
    mounting: {rpy_deg: [180, 0, 90]}
    noise_rad_s: 0.1
    min_distance_m: 0.3
    max_distance_m: 8
  - type: rotor_speed
    name: esc
    rate_hz: 1000
    noise_rad_s: 5
)");
  ASSERT_EQ(e.sensors.size(), 8u);
  for (std::size_t i = 0; i < 8; ++i) {
    EXPECT_EQ(e.sensors[i].parameters.index(), i);
    EXPECT_EQ(e.sensors[i].type_name(), kSensorTypeNames[i]);
  }

  const SensorSpec& imu = e.sensors[0];
  EXPECT_EQ(imu.name, "imu_front");
  EXPECT_EQ(imu.rate_hz, 500.0);
  EXPECT_EQ(imu.latency_s, 0.002);
  EXPECT_EQ(imu.mounting.position_B_m, Vec3(0.1, -0.02, 0.03));
  EXPECT_TRUE(imu.mounting.rotation_BS_wxyz.isApprox(from_euler_deg(10, -20, 30), 1e-15));
  const auto& ip = std::get<ImuParameters>(imu.parameters);
  expect_triad(ip.gyro, 1.0);
  expect_triad(ip.accel, 2.0);

  const SensorSpec& mag = e.sensors[1];
  EXPECT_EQ(mag.name, "compass");
  EXPECT_EQ(mag.rate_hz, 75.0);
  const auto& mp = std::get<MagnetometerParameters>(mag.parameters);
  EXPECT_EQ(mp.field_W_uT, Vec3(20, 1, -40));
  EXPECT_EQ(mp.noise_uT, 0.5);
  EXPECT_EQ(mp.hard_iron_uT, Vec3(1, 2, 3));

  const auto& bp = std::get<BarometerParameters>(e.sensors[2].parameters);
  EXPECT_EQ(e.sensors[2].name, "baro2");
  EXPECT_EQ(e.sensors[2].rate_hz, SensorSpec::barometer().rate_hz);  // not given: the default
  EXPECT_EQ(bp.noise_Pa, 2.5);
  EXPECT_EQ(bp.drift_Pa_per_sqrt_s, 0.2);
  EXPECT_EQ(bp.offset_Pa, -30.0);
  EXPECT_EQ(bp.origin_altitude_m, 1500.0);

  const SensorSpec& gps = e.sensors[3];
  EXPECT_EQ(gps.name, "gnss");
  EXPECT_EQ(gps.rate_hz, 5.0);
  EXPECT_EQ(gps.latency_s, 0.2);
  const auto& gp = std::get<GpsParameters>(gps.parameters);
  EXPECT_EQ(gp.position_noise_m, Vec3(0.1, 0.2, 0.3));
  EXPECT_EQ(gp.position_error_m, Vec3(1, 2, 4));
  EXPECT_EQ(gp.position_error_time_s, 120.0);
  EXPECT_EQ(gp.velocity_noise_m_s, Vec3(0.01, 0.02, 0.03));

  const auto& cp = std::get<MotionCaptureParameters>(e.sensors[4].parameters);
  EXPECT_EQ(e.sensors[4].name, "vicon");
  EXPECT_EQ(e.sensors[4].rate_hz, 200.0);
  EXPECT_EQ(cp.position_noise_m, 0.001);
  EXPECT_EQ(cp.attitude_noise_rad, 0.002);

  // Only the position is given: the rotation stays the range finder's default (looking down).
  const SensorSpec& range = e.sensors[5];
  EXPECT_EQ(range.name, "lidar");
  EXPECT_EQ(range.mounting.position_B_m, Vec3(0, 0, -0.05));
  EXPECT_EQ(range.mounting.rotation_BS_wxyz, Mounting::looking_down().rotation_BS_wxyz);
  const auto& rp = std::get<RangeFinderParameters>(range.parameters);
  EXPECT_EQ(rp.min_range_m, 0.1);
  EXPECT_EQ(rp.max_range_m, 12.0);
  EXPECT_EQ(rp.noise_m, 0.02);
  EXPECT_EQ(rp.noise_fraction, 0.01);
  EXPECT_EQ(rp.dropout_probability, 0.05);

  // Only the rotation is given: the position stays the default.
  const SensorSpec& flow = e.sensors[6];
  EXPECT_EQ(flow.name, "px_flow");
  EXPECT_EQ(flow.mounting.position_B_m, Vec3::Zero());
  EXPECT_TRUE(flow.mounting.rotation_BS_wxyz.isApprox(from_euler_deg(180, 0, 90), 1e-15));
  const auto& fp = std::get<OpticalFlowParameters>(flow.parameters);
  EXPECT_EQ(fp.noise_rad_s, 0.1);
  EXPECT_EQ(fp.min_distance_m, 0.3);
  EXPECT_EQ(fp.max_distance_m, 8.0);

  EXPECT_EQ(e.sensors[7].name, "esc");
  EXPECT_EQ(e.sensors[7].rate_hz, 1000.0);
  EXPECT_EQ(std::get<RotorSpeedSensorParameters>(e.sensors[7].parameters).noise_rad_s, 5.0);

  EXPECT_NO_THROW(validate(e));
}

TEST(ExperimentSensors, OnlyTheTypeGivesTheDefaultsAndDefaultNames) {
  std::string list;
  for (std::string_view type : kSensorTypeNames) list += "\n  - type: " + std::string(type);
  const Experiment e = parse(list + "\n");
  ASSERT_EQ(e.sensors.size(), kSensorTypeNames.size());
  const std::vector<std::string> names = {"imu",   "mag",   "baro", "gps",
                                          "mocap", "range", "flow", "rpm"};
  for (std::size_t i = 0; i < e.sensors.size(); ++i) {
    SCOPED_TRACE(kSensorTypeNames[i]);
    const SensorSpec& s = e.sensors[i];
    const SensorSpec d = SensorSpec::defaults(kSensorTypeNames[i], names[i]);
    EXPECT_EQ(s.name, names[i]);
    EXPECT_EQ(s.parameters.index(), i);
    EXPECT_EQ(s.rate_hz, d.rate_hz);
    EXPECT_EQ(s.latency_s, d.latency_s);
    EXPECT_EQ(s.mounting.position_B_m, d.mounting.position_B_m);
    EXPECT_EQ(s.mounting.rotation_BS_wxyz, d.mounting.rotation_BS_wxyz);
  }
  const auto& imu = std::get<ImuParameters>(e.sensors[0].parameters);
  EXPECT_EQ(imu.gyro.noise_density, ImuParameters{}.gyro.noise_density);
  EXPECT_EQ(imu.accel.range, ImuParameters{}.accel.range);
  EXPECT_EQ(std::get<GpsParameters>(e.sensors[3].parameters).position_error_m,
            GpsParameters{}.position_error_m);
  EXPECT_EQ(std::get<RangeFinderParameters>(e.sensors[5].parameters).max_range_m,
            RangeFinderParameters{}.max_range_m);
  // The mounting map may give nothing: the defaults stay.
  const Experiment m = parse("\n  - {type: range_finder, mounting: {}}\n");
  EXPECT_EQ(m.sensors[0].mounting.rotation_BS_wxyz, Mounting::looking_down().rotation_BS_wxyz);
}

TEST(ExperimentSensors, ShippedHoverSensorsExperimentLoads) {
  const Experiment e = load_experiment(kSourceDir + "/config/experiments/hover_sensors.yaml");
  EXPECT_EQ(e.name, "hover_sensors");
  EXPECT_EQ(e.duration_s, 20.0);
  EXPECT_TRUE(std::holds_alternative<ControllerLoopInput>(e.input));
  EXPECT_TRUE(e.sim.noise.enabled);
  ASSERT_EQ(e.sensors.size(), 8u);
  std::vector<std::string_view> types;
  for (const SensorSpec& s : e.sensors) types.push_back(s.type_name());
  for (std::string_view type : kSensorTypeNames)
    EXPECT_NE(std::find(types.begin(), types.end(), type), types.end()) << type;
  for (const SensorSpec& s : e.sensors) {
    if (s.type_name() == "imu") {
      EXPECT_EQ(s.rate_hz, 1000.0);
    }
    if (s.type_name() == "motion_capture") {
      EXPECT_EQ(s.rate_hz, 100.0);
    }
  }
  EXPECT_NO_THROW(check_against_model(e, load_vehicle_model(e.model_path)));
  EXPECT_NO_THROW(validate(e));
}

TEST(ExperimentSensors, FuzzSeedIsAnAcceptedExperiment) {
  // The experiment fuzzer reads its inputs as config/experiments/fuzz_input.yaml.
  std::ifstream in(kSourceDir + "/tests/fuzz/corpus/experiment/seed_sensors.yaml");
  ASSERT_TRUE(in);
  std::stringstream text;
  text << in.rdbuf();
  const Experiment e =
      parse_experiment(text.str(), kSourceDir + "/config/experiments/fuzz_input.yaml");
  EXPECT_EQ(e.sensors.size(), kSensorTypeNames.size());
}

// ---- bad input --------------------------------------------------------------------------------

TEST(ExperimentSensors, UnknownTypeSuggestsTheClosest) {
  expect_error("\n  - type: imus\n",
               {"s.yaml: sensors[0].type: unknown sensor type 'imus'; did you mean 'imu'?",
                "(valid: imu, magnetometer, barometer, gps, motion_capture, range_finder, "
                "optical_flow, rotor_speed, depth_camera)"});
  expect_error("\n  - name: imu\n", {"s.yaml: sensors[0]: missing required key 'type'"});
}

// ---- depth cameras ------------------------------------------------------------------------------

TEST(ExperimentDepthCameras, ReadTheirKeysOverTheDefaults) {
  const Experiment e = parse(
      "\n  - type: imu\n  - {type: depth_camera, name: front, rate_hz: 15, width_px: 80, "
      "height_px: 60, horizontal_fov_deg: 70, max_range_m: 8, noise_at_1m_m: 0.01, "
      "mounting: {position_m: [0.1, 0, 0], rpy_deg: [0, 30, 0]}}\n  - type: depth_camera\n");
  ASSERT_EQ(e.sensors.size(), 1u);
  ASSERT_EQ(e.depth_cameras.size(), 2u);
  const DepthCameraSpec& c = e.depth_cameras[0];
  EXPECT_EQ(c.name, "front");
  EXPECT_EQ(c.parameters.rate_hz, 15.0);
  EXPECT_EQ(c.parameters.width_px, 80);
  EXPECT_EQ(c.parameters.height_px, 60);
  EXPECT_EQ(c.parameters.horizontal_fov_deg, 70.0);
  EXPECT_EQ(c.parameters.max_range_m, 8.0);
  EXPECT_EQ(c.parameters.noise_at_1m_m, 0.01);
  EXPECT_EQ(c.parameters.mounting.position_B_m, Vec3(0.1, 0, 0));
  // Pitched 30 deg down from looking forward: the optical axis (camera z) in the body frame.
  const Vec3 axis = math::rotation_matrix<double>(c.parameters.mounting.rotation_BS_wxyz).col(2);
  EXPECT_NEAR(axis.x(), std::cos(std::numbers::pi / 6), 1e-15);
  EXPECT_NEAR(axis.z(), -0.5, 1e-15);
  // The second has the defaults and the default name.
  EXPECT_EQ(e.depth_cameras[1].name, "depth");
  EXPECT_EQ(e.depth_cameras[1].parameters.width_px, 64);
}

TEST(ExperimentDepthCameras, BadSettingsNameTheField) {
  expect_error("\n  - {type: depth_camera, width_px: 0}\n",
               {"s.yaml: sensors[0].width_px: expected 1 .. 4096 pixels, got 0", "(line 6)"});
  expect_error("\n  - {type: depth_camera, height_px: 2.5}\n",
               {"s.yaml: sensors[0].height_px: expected a whole number of pixels, got '2.5'"});
  expect_error("\n  - {type: depth_camera, rate_hz: 2000}\n",
               {"sensors[0].rate_hz: 2000 Hz is faster than the physics step (1000 Hz)"});
  expect_error("\n  - {type: depth_camera, horizontal_fov_deg: 180}\n",
               {"sensors[0].horizontal_fov_deg: expected a number in (0, 179], got 180"});
  expect_error("\n  - {type: depth_camera, latency_s: 0.01}\n",
               {"sensors[0]: unknown key 'latency_s'"});
  expect_error("\n  - {type: imu, name: cam}\n  - {type: depth_camera, name: cam}\n",
               {"sensors[1].name: 'cam' is already the name of sensors[0]"});
}

TEST(ExperimentDepthCameras, ValidateRechecksThemAfterOverrides) {
  Experiment e = parse("\n  - {type: depth_camera, rate_hz: 100}\n");
  e.sim.dt_s = 0.02;
  const std::string m = error_of([&] { validate(e); });
  EXPECT_NE(m.find("s.yaml: depth camera 'depth': rate_hz: 100 Hz is faster than the physics step"),
            std::string::npos)
      << m;
}

TEST(ExperimentSensors, NegativeNoiseNamesTheField) {
  expect_error(
      "\n  - type: imu\n  - type: imu\n    name: imu2\n    gyro: {noise_density: -1}\n",
      {"s.yaml: sensors[1].gyro.noise_density: expected a finite number >= 0, got -1", "(line 9)"});
  expect_error("\n  - {type: gps, position_noise_m: [0.1, -0.2, 0.3]}\n",
               {"s.yaml: sensors[0].position_noise_m[1]: expected a finite number >= 0, got -0.2"});
}

TEST(ExperimentSensors, NonPositiveRateIsRejected) {
  expect_error("\n  - {type: barometer, rate_hz: 0}\n",
               {"s.yaml: sensors[0].rate_hz: expected a finite number > 0, got 0"});
  expect_error("\n  - {type: barometer, rate_hz: -5}\n",
               {"s.yaml: sensors[0].rate_hz: expected a finite number > 0, got -5"});
}

TEST(ExperimentSensors, RateFasterThanThePhysicsStepIsRejected) {
  expect_error("\n  - {type: imu, rate_hz: 2000}\n",
               {"s.yaml: sensors[0].rate_hz: 2000 Hz is faster than the physics step (1000 Hz)"});
  // The IMU's default 1 kHz against a 100 Hz physics step: the step is read before the sensors.
  expect_error("\n  - type: imu\n",
               {"s.yaml: sensors[0].rate_hz: 1000 Hz is faster than the physics step (100 Hz)"},
               "physics_dt_s: 0.01\n");
  // A bad step is reported as such, not as a sensor that is too fast for it.
  expect_error("\n  - type: imu\n", {"s.yaml: physics_dt_s: expected a step in (0, 0.1] s"},
               "physics_dt_s: 0.5\n");
  EXPECT_NO_THROW((void)parse("\n  - {type: imu, rate_hz: 100}\n", "physics_dt_s: 0.01\n"));
}

TEST(ExperimentSensors, BadNameIsRejected) {
  expect_error(
      "\n  - {type: imu, name: IMU 1}\n",
      {"s.yaml: sensors[0].name: expected 1-32 lower-case letters, digits or '_'", "got 'IMU 1'"});
  expect_error("\n  - {type: imu, name: \"\"}\n",
               {"s.yaml: sensors[0].name: expected a non-empty string"});
}

TEST(ExperimentSensors, DuplicateNamesAreRejected) {
  expect_error("\n  - type: imu\n  - type: barometer\n  - {type: imu, name: imu}\n",
               {"s.yaml: sensors[2].name: 'imu' is already the name of sensors[0]"});
  // Two of a type without names share the default name.
  expect_error("\n  - type: gps\n  - type: gps\n",
               {"s.yaml: sensors[1].name: 'gps' is already the name of sensors[0]",
                "the default name of its type"});
}

TEST(ExperimentSensors, KeysOfAnotherTypeOrUnknownKeysAreRejected) {
  expect_error("\n  - {type: imu, noise_Pa: 1}\n",
               {"s.yaml: sensors[0]: unknown key 'noise_Pa' for a sensor of type imu",
                "a key of type barometer",
                "valid keys: type, name, rate_hz, latency_s, "
                "mounting, faults, gyro, accel"});
  expect_error("\n  - {type: gps, noise_rad_s: 1}\n",
               {"s.yaml: sensors[0]: unknown key 'noise_rad_s' for a sensor of type gps (it is a "
                "key of type optical_flow, rotor_speed)"});
  expect_error("\n  - {type: barometer, rate_hx: 10}\n",
               {"s.yaml: sensors[0]: unknown key 'rate_hx'; did you mean 'rate_hz'?"});
  expect_error("\n  - {type: imu, gyro: {noise_densty: 1}}\n",
               {"s.yaml: sensors[0].gyro: unknown key 'noise_densty'; did you mean "
                "'noise_density'?"});
  expect_error("\n  - {type: imu, mounting: {rpy_dg: [0, 0, 0]}}\n",
               {"s.yaml: sensors[0].mounting: unknown key 'rpy_dg'; did you mean 'rpy_deg'?"});
  expect_error("\n  - {type: imu, type: gps}\n", {"duplicate key 'type'"});
}

TEST(ExperimentSensors, FaultsAreReadInOrder) {
  const Experiment e = parse(
      "\n  - type: imu\n    faults:\n"
      "      - {type: bias_step, start_s: 20, channel: wz, value: 0.05}\n"
      "      - {type: bias_step, start_s: 1, end_s: 2, channel: fx, value: -0.5}\n"
      "  - type: motion_capture\n    faults: [{type: dropout, start_s: 10, end_s: 12}]\n"
      "  - {type: gps, faults: [{type: dropout, start_s: 3}]}\n");
  ASSERT_EQ(e.sensors.size(), 3u);
  ASSERT_EQ(e.sensors[0].faults.size(), 2u);
  const SensorFault& wz = e.sensors[0].faults[0];
  EXPECT_EQ(wz.kind, SensorFaultKind::kBiasStep);
  EXPECT_EQ(wz.start_s, 20.0);
  EXPECT_TRUE(std::isinf(wz.end_s));
  EXPECT_EQ(wz.channel, "wz");
  EXPECT_EQ(wz.value, 0.05);
  EXPECT_EQ(e.sensors[0].faults[1].end_s, 2.0);
  EXPECT_EQ(e.sensors[0].faults[1].value, -0.5);
  ASSERT_EQ(e.sensors[1].faults.size(), 1u);
  EXPECT_EQ(e.sensors[1].faults[0].kind, SensorFaultKind::kDropout);
  EXPECT_EQ(e.sensors[1].faults[0].end_s, 12.0);
  EXPECT_TRUE(std::isinf(e.sensors[2].faults[0].end_s));
}

TEST(ExperimentSensors, BadFaultsNameTheFieldAndLine) {
  expect_error(
      "\n  - type: barometer\n    faults:\n"
      "      - {type: bias_step, start_s: 1, channel: z, value: 3}\n",
      {"s.yaml: sensors[0].faults[0].channel: expected a channel of a barometer (p), "
       "got 'z'",
       "(line 8)"});
  expect_error("\n  - {type: imu, faults: [{type: bias_stp, start_s: 1}]}\n",
               {"s.yaml: sensors[0].faults[0].type: unknown sensor fault type 'bias_stp'; did "
                "you mean 'bias_step'?"});
  expect_error("\n  - {type: imu, faults: [{type: bias_step, start_s: 1, value: 3}]}\n",
               {"s.yaml: sensors[0].faults[0]: missing required key 'channel'"});
  expect_error("\n  - {type: imu, faults: [{type: dropout, start_s: 1, value: 3}]}\n",
               {"s.yaml: sensors[0].faults[0].value: only a bias_step has a channel and a value"});
  expect_error("\n  - {type: imu, faults: [{type: dropout, start_s: 5, end_s: 4}]}\n",
               {"s.yaml: sensors[0].faults[0].end_s: expected a time at least one physics step "
                "after start_s (or none: the fault lasts), got 4"});
  expect_error("\n  - {type: imu, faults: [{type: dropout, start_s: -1}]}\n",
               {"s.yaml: sensors[0].faults[0].start_s: expected a finite number >= 0, got -1"});
  expect_error("\n  - {type: imu, faults: {type: dropout, start_s: 1}}\n",
               {"s.yaml: sensors[0].faults: expected a list of at most 16 faults"});
  expect_error("\n  - {type: imu, faults: [{type: dropout, start_s: 1, chanel: wz}]}\n",
               {"s.yaml: sensors[0].faults[0]: unknown key 'chanel'; did you mean 'channel'?"});
}

TEST(ExperimentSensors, RangeFinderMaxMustExceedMin) {
  expect_error("\n  - {type: range_finder, min_range_m: 1, max_range_m: 0.5}\n",
               {"s.yaml: sensors[0].max_range_m: expected a number > min_range_m, got 0.5"});
  expect_error("\n  - {type: range_finder, min_range_m: 2, max_range_m: 2}\n",
               {"s.yaml: sensors[0].max_range_m: expected a number > min_range_m, got 2"});
  // Against the default maximum (4 m): the message still names the field.
  expect_error("\n  - {type: range_finder, min_range_m: 5}\n",
               {"s.yaml: sensors[0].max_range_m: expected a number > min_range_m, got 4"});
}

TEST(ExperimentSensors, NonNumbersAndWrongShapesAreRejected) {
  expect_error("\n  - {type: imu, rate_hz: fast}\n",
               {"s.yaml: sensors[0].rate_hz: expected a number, got 'fast'"});
  expect_error("\n  - {type: barometer, noise_Pa: \"1.0\"}\n",
               {"s.yaml: sensors[0].noise_Pa: expected a number, got the string \"1.0\""});
  expect_error("\n  - {type: magnetometer, field_uT: [1, 2]}\n",
               {"s.yaml: sensors[0].field_uT: expected 3 numbers (x, y, z in uT, world frame), "
                "got 2"});
  expect_error("\n  - {type: imu, mounting: {rpy_deg: [0, .nan, 0]}}\n",
               {"s.yaml: sensors[0].mounting.rpy_deg[1]: expected a finite number, got .nan"});
  expect_error("\n  - {type: imu, gyro: 1}\n", {"s.yaml: sensors[0].gyro: expected a map"});
  expect_error(" {type: imu}\n", {"s.yaml: sensors: expected a list of sensor maps"});
  expect_error("\n  - imu\n", {"s.yaml: sensors[0]: expected a map with a 'type'"});
}

TEST(ExperimentSensors, ValidateRechecksTheSensorsAfterOverrides) {
  Experiment e = parse("\n  - type: imu\n  - type: barometer\n");
  EXPECT_NO_THROW(validate(e));
  e.sim.dt_s = 0.01;  // as Python's Experiment.physics_dt_s may set it
  std::string m = error_of([&] { validate(e); });
  EXPECT_NE(m.find("s.yaml: sensors[0].rate_hz: 1000 Hz is faster than the physics step"),
            std::string::npos)
      << m;
  e.sim.dt_s = 0.001;
  e.sensors[1].name = "imu";
  m = error_of([&] { validate(e); });
  EXPECT_NE(m.find("s.yaml: sensors[1].name: 'imu' is already the name of sensors[0]"),
            std::string::npos)
      << m;
}

}  // namespace
}  // namespace dronetwin

// ---- estimation --------------------------------------------------------------------------------

namespace dronetwin {
namespace {

const std::string kImuAndMocap =
    "\n  - {type: imu}\n  - {type: motion_capture}\n  - {type: rotor_speed}\n";

TEST(ExperimentEstimation, ReadsTheFilterSettings) {
  const Experiment e = parse(kImuAndMocap + "estimation: {imu: imu, updates: [mocap]}\n");
  ASSERT_TRUE(e.estimation.has_value());
  EXPECT_EQ(e.estimation->fusion.imu, "imu");
  EXPECT_EQ(e.estimation->fusion.updates, std::vector<std::string>{"mocap"});
  EXPECT_TRUE(e.estimation->control_on_estimate);
  const Experiment m = parse(
      kImuAndMocap + "estimation: {imu: imu, updates: [], controller_input: measured_state}\n");
  EXPECT_FALSE(m.estimation->control_on_estimate);
}

TEST(ExperimentEstimation, BadSettingsNameTheField) {
  expect_error(kImuAndMocap + "estimation: {imu: gyro, updates: [mocap]}\n",
               {"s.yaml: estimation.imu: no sensor named 'gyro' (sensors: imu, mocap, rpm)"});
  expect_error(kImuAndMocap + "estimation: {imu: mocap, updates: []}\n",
               {"estimation.imu: sensor 'mocap' is a motion_capture, not an imu"});
  expect_error(kImuAndMocap + "estimation: {imu: imu, updates: [rpm]}\n",
               {"estimation.updates[0]: the filter cannot use a rotor_speed"});
  expect_error(kImuAndMocap + "estimation: {imu: imu, updates: [mocap, mocap]}\n",
               {"estimation.updates[1]: 'mocap' is listed twice"});
  expect_error(kImuAndMocap + "estimation: {imu: imu, updates: [mocap], controller_input: truth}\n",
               {"estimation.controller_input: unknown controller input 'truth'"});
  expect_error(kImuAndMocap + "estimation: {imu: imu}\n",
               {"estimation: missing required key 'updates'"});
  const std::string m = error_of([&] {
    (void)parse_experiment("name: t\nmodel: " + kModel +
                               "\nduration_s: 1.0\ninput: {type: hover}\n"
                               "estimation: {imu: imu, updates: []}\n",
                           "s.yaml");
  });
  EXPECT_NE(m.find("estimation: needs sensors"), std::string::npos) << m;
}

}  // namespace
}  // namespace dronetwin
