// Sensors in RL observations (EnvConfig::sensors, depth_cameras): the slices after the pieces,
// readings against the truth of a still hover (an ideal IMU reads +g along body z, the downward
// range finder and the centre pixel of a downward depth camera read the height), no NaN where a
// sensor has nothing to say (its flag is 0 instead), the same bits on any number of threads, and
// rates above the env's step refused by name.

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "dronetwin/config/env_config_loader.hpp"
#include "dronetwin/rl/vec_env.hpp"
#include "test_support.hpp"

namespace dronetwin::rl {
namespace {

// Hover at (0, 0, 1.5) from a start exactly there: no randomisation, the target fixed.
const std::string kStill =
    "{hover: {target_m: [0, 0, 1.5], target_range_m: [0, 0, 0], start_offset_m: [0, 0, 0]}, "
    "randomization: {position_m: [0, 0, 0], velocity_m_s: [0, 0, 0], attitude_rad: [0, 0, 0]}, ";

// An IMU without noise or bias, a range finder without dropouts, a camera looking down, and a
// range finder looking up (nothing above it: never a return).
const std::string kSensors =
    "sensors: [{type: imu, rate_hz: 100, gyro: {noise_density: 0, bias_random_walk: 0, "
    "bias_instability: 0, turn_on_bias: 0}, accel: {noise_density: 0, bias_random_walk: 0, "
    "bias_instability: 0, turn_on_bias: 0}}, "
    "{type: range_finder, rate_hz: 50, noise_m: 0, noise_fraction: 0, dropout_probability: 0}, "
    "{type: range_finder, name: up, rate_hz: 50, mounting: {rpy_deg: [0, 0, 0]}}, "
    "{type: depth_camera, name: cam, rate_hz: 25, width_px: 9, height_px: 7, "
    "mounting: {rpy_deg: [0, 90, 0]}}]}";

VecEnv<double> make(int n, int threads = 1) {
  EnvFile f = load_env_config(test::source_path("config/rl/hover.yaml"), kStill + kSensors);
  return VecEnv<double>(f.model, f.config, n, threads);
}

const SensorSlice& slice(const VecEnv<double>& env, const std::string& name) {
  for (const SensorSlice& s : env.sensor_slices())
    if (s.name == name) return s;
  throw std::runtime_error("no slice " + name);
}

TEST(VecEnvSensors, SlicesFollowThePieces) {
  const VecEnv<double> env = make(2);
  const PieceSlice& last = env.observation_layout().back();
  int offset = last.offset + last.size;
  const std::vector<std::pair<std::string, int>> expected = {
      {"imu", 7}, {"range", 2}, {"up", 2}, {"cam", 63}};
  ASSERT_EQ(env.sensor_slices().size(), expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const SensorSlice& s = env.sensor_slices()[i];
    EXPECT_EQ(s.name, expected[i].first);
    EXPECT_EQ(s.offset, offset);
    EXPECT_EQ(s.size, expected[i].second);
    EXPECT_EQ(s.depth, s.name == "cam");
    offset += s.size;
  }
  EXPECT_EQ(env.observation_size(), offset);
  EXPECT_EQ(env.observation_high()[static_cast<std::size_t>(offset - 1)], 20.0);  // max range
}

TEST(VecEnvSensors, AStillHoverReadsGravityAndItsHeight) {
  VecEnv<double> env = make(1);
  const std::vector<double> hold(static_cast<std::size_t>(env.action_size()), 0.0);
  for (int k = 0; k < 100; ++k) {
    const double* o = env.observation<double>();
    const StateVector x = env.batch().state(0);
    const double z = x[2];
    // The IMU: specific force R^T (a - g); holding still, +g along body z (9.81 m/s^2).
    const SensorSlice& imu = slice(env, "imu");
    EXPECT_NEAR(o[imu.offset + 2], 9.81, 0.05) << "step " << k;
    EXPECT_NEAR(o[imu.offset + 0], 0.0, 0.05) << "step " << k;
    EXPECT_EQ(o[imu.offset + 6], 1.0);
    // The range finder at the centre of mass, looking down: the height (held for up to 20 ms).
    const SensorSlice& range = slice(env, "range");
    EXPECT_NEAR(o[range.offset], z, 0.01) << "step " << k;
    EXPECT_EQ(o[range.offset + 1], 1.0);
    // Looking up at nothing: 0 with a flag of 0, never NaN.
    const SensorSlice& up = slice(env, "up");
    EXPECT_EQ(o[up.offset], 0.0);
    EXPECT_EQ(o[up.offset + 1], 0.0);
    // The camera looking down (7 x 9 pixels): the centre pixel's depth is the height.
    const SensorSlice& cam = slice(env, "cam");
    EXPECT_NEAR(o[cam.offset + 3 * 9 + 4], z, 0.02) << "step " << k;
    for (int i = 0; i < env.observation_size(); ++i) ASSERT_TRUE(std::isfinite(o[i])) << i;
    env.step(hold.data());
  }
}

TEST(VecEnvSensors, TheSameBitsOnAnyNumberOfThreads) {
  // Noisy defaults (the IMU's and the camera's) with random starts: 64 envs on 1 and 2 threads.
  const std::string noisy =
      "{sensors: [{type: imu, rate_hz: 100}, {type: barometer, rate_hz: 50}, "
      "{type: depth_camera, name: cam, rate_hz: 50, width_px: 8, height_px: 6, "
      "noise_at_1m_m: 0.01}]}";
  EnvFile f = load_env_config(test::source_path("config/rl/hover.yaml"), noisy);
  VecEnv<double> a(f.model, f.config, 64, 1), b(f.model, f.config, 64, 2);
  std::vector<double> actions(static_cast<std::size_t>(64 * a.action_size()), 0.1);
  for (int k = 0; k < 30; ++k) {
    const auto n = static_cast<std::size_t>(64 * a.observation_size());
    const double* oa = a.observation<double>();
    const double* ob = b.observation<double>();
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(oa[i], ob[i]) << "step " << k << " value " << i;
    a.step(actions.data());
    b.step(actions.data());
  }
}

TEST(VecEnvSensors, RatesAboveTheEnvStepAreRefused) {
  const std::string message = test::error_of([] {
    (void)load_env_config(test::source_path("config/rl/hover.yaml"),
                          "{sensors: [{type: imu, rate_hz: 1000}]}");
  });
  EXPECT_NE(message.find("sensors[0].rate_hz: 1000 Hz is faster than"), std::string::npos)
      << message;
  const std::string camera = test::error_of([] {
    (void)load_env_config(test::source_path("config/rl/hover.yaml"),
                          "{sensors: [{type: depth_camera, width_px: 0}]}");
  });
  EXPECT_NE(camera.find("sensors[0].width_px: expected 1 .. 4096 pixels, got 0"), std::string::npos)
      << camera;
}

}  // namespace
}  // namespace dronetwin::rl
