#pragma once
// VecEnv<T>: num_envs reinforcement-learning environments stepped together, in the style of
// envpool and gymnasium's VectorEnv, on the batched engine (one BatchSimulator lane per env).
// Thesis Sec. 4.3: an env step is 1 / control_rate_hz of simulated time, i.e. substeps() physics
// steps (10 at 100 Hz over 1 kHz), with the action mode's inner loop (batched SE(3), body rate,
// or none) at every physics step; then each env's reward, end of episode and observation.
//
//   EnvConfig c;                                        // racing with the thesis's settings
//   c.track = load_track("config/tracks/circuit.yaml");
//   VecEnv<float> env(model, c, 1024, /*num_threads=*/2);
//   env.reset(7);
//   std::vector<float> actions(1024 * env.action_size());
//   for (int t = 0; t < 1000; ++t) {
//     policy(env.observation<float>(), actions);        // (num_envs, observation_size)
//     env.step(actions.data());                         // (num_envs, action_size)
//     use(env.reward_data(), env.terminated_data(), env.truncated_data());
//   }
//
// Auto-reset (gymnasium 0.29 / envpool "same step"): an env whose episode ends in step t is
// reset at once; step t's observation is its new episode's first one, and the last observation
// of the old episode is in final_observation() (done_data() marks those envs), with the
// episode's statistics in the finished_* arrays.
//
// Layout: every output is a row-major (num_envs, k) or (num_envs) array of plain memory,
// read-only to callers and valid until the step after next: observations alternate between two
// buffers, so the observation an agent acted on is still intact when the next one arrives.
//
// Determinism: env i's resets (start state, randomised parameters, wind, noise seed) are drawn
// from a counter-based stream keyed by (seed, i) and its episode number; the physics is the
// batch's. So env i's trajectory does not depend on num_envs, the thread count or the other envs
// (tests/rl: bitwise).
//
// Trap: one VecEnv is stepped by one thread at a time (SimulationError if two try); it uses the
// batch's own threads.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "dronetwin/batch/batch_body_rate.hpp"
#include "dronetwin/batch/batch_se3.hpp"
#include "dronetwin/batch/batch_simulator.hpp"
#include "dronetwin/core/single_thread.hpp"
#include "dronetwin/rl/env_config.hpp"
#include "dronetwin/rl/episode.hpp"
#include "dronetwin/rl/observation.hpp"
#include "dronetwin/sensors/depth_camera.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"
#include "dronetwin/world/collision.hpp"

namespace dronetwin::rl {

/// A sensor's (channels, then 1 when they hold a reading and 0 when not: none yet, no return) or
/// a depth camera's (height x width depths, m) part of an observation row.
struct SensorSlice {
  std::string name;
  bool depth = false;
  int offset = 0;
  int size = 0;
};

template <class T>
class VecEnv {
 public:
  /// `num_envs` envs of `model` under `config` (validated: InvalidArgument names the field),
  /// stepped by `num_threads` threads. Every env is reset with config.seed.
  VecEnv(std::shared_ptr<const VehicleModel> model, EnvConfig config, int num_envs,
         int num_threads = 1);

  int num_envs() const { return num_envs_; }
  int action_size() const { return action_size_; }
  int observation_size() const { return observation_size_; }
  int substeps() const { return substeps_; }
  double control_dt_s() const { return substeps_ * config_.sim.dt_s; }
  const EnvConfig& config() const { return config_; }
  const VehicleModel& model() const { return *model_; }
  /// Where each sensor's and depth camera's values sit in an observation row (after the
  /// pieces of observation_layout()).
  const std::vector<SensorSlice>& sensor_slices() const { return sensor_slices_; }
  /// What touches gates and obstacles: a sphere of EnvConfig::vehicle_radius_m when that is
  /// set, else the model's collision shape (VehicleModel::collision_shape()).
  const CollisionShape& collision_shape() const { return collision_; }
  /// The sphere's radius, or the radius of a sphere about the body origin holding the box.
  double vehicle_radius_m() const {
    return collision_.kind == CollisionShape::Kind::kSphere ? collision_.radius_m
                                                            : collision_.bounding_radius_m();
  }

  /// The action box (physical units; with normalized_actions the accepted box is [-1, 1] and
  /// these are what -1 and +1 mean).
  const std::vector<double>& action_low() const { return action_low_; }
  const std::vector<double>& action_high() const { return action_high_; }
  /// Bounds of each observation element (+-inf where unbounded).
  const std::vector<double>& observation_low() const { return observation_low_; }
  const std::vector<double>& observation_high() const { return observation_high_; }
  const std::vector<PieceSlice>& observation_layout() const { return layout_; }

  /// Every env starts a new episode; env i's draws come from stream (seed, i), episode 0.
  void reset(std::uint64_t seed);
  /// Env `env` starts a new episode (its next draws) at `state` instead of the task's random
  /// start (arbitrary resets for curricula): validated as Simulator::set_state.
  void reset_env(int env, const StateVector& state);
  /// Env `env` starts a new episode from the task's random start.
  void reset_env(int env);

  /// One env step for every env. `actions` is row-major (num_envs, action_size()), float or
  /// double. A non-finite action ends only that env's episode (EndCause::kInvalidAction).
  void step(const double* actions);
  void step(const float* actions);

  /// Changes what the next resets draw and what rewards weigh, between steps (curricula): every
  /// field except task, action mode, observation pieces and gate_lookahead, sim and
  /// control_rate_hz, which fix the spaces and the engine (InvalidArgument names the field).
  /// Takes effect at each env's next reset; reward weights and episode limits at once.
  void set_config(const EnvConfig& config);

  // ---- outputs of the last step or reset (row-major, see the top of this file) ----------------
  /// (num_envs, observation_size) of float (observation_float32) or double.
  template <class O>
  const O* observation() const;
  template <class O>
  const O* final_observation() const;
  bool observation_float32() const { return config_.observation_float32; }
  const double* reward_data() const { return reward_.data(); }
  /// (kNumRewardTerms, num_envs): each weighted term of the reward (term-major).
  const double* reward_terms_data() const { return reward_terms_.data(); }
  const std::uint8_t* terminated_data() const { return terminated_.data(); }
  const std::uint8_t* truncated_data() const { return truncated_.data(); }
  /// terminated or truncated: the env was reset in this step.
  const std::uint8_t* done_data() const { return done_.data(); }
  /// EndCause per env for this step (kNone when its episode goes on).
  const std::uint8_t* end_cause_data() const { return end_cause_.data(); }

  // Statistics of the episodes that ended in the last step (valid where done_data()).
  const double* finished_return_data() const { return finished_return_.data(); }
  const std::int64_t* finished_length_data() const { return finished_length_.data(); }
  const std::int32_t* finished_gates_data() const { return finished_gates_.data(); }
  const std::int32_t* finished_laps_data() const { return finished_laps_.data(); }
  /// Fastest complete lap of the episode, s (NaN without one).
  const double* finished_best_lap_data() const { return finished_best_lap_.data(); }
  /// (num_envs, 13): the true state the ended episode reached, [p, v, q, w] (its last frame,
  /// which the auto-reset replaced; recorders and viewers need it).
  const double* final_state_data() const { return final_state_.data(); }
  /// (num_envs, num_rotors): the rotor speeds the ended episode reached, rad/s.
  const double* final_rotor_speed_data() const { return final_rotor_speed_.data(); }

  // Running episode, per env.
  const std::int64_t* episode_length_data() const { return length_.data(); }
  const double* episode_return_data() const { return return_.data(); }
  const std::int32_t* next_gate_data() const { return next_gate_.data(); }
  const std::int32_t* gates_passed_data() const { return gates_passed_.data(); }
  const std::int32_t* laps_data() const { return laps_.data(); }
  const std::int64_t* episode_index_data() const { return episode_.data(); }
  /// Hover or trajectory target of env `env` now (racing: the next gate's centre).
  Vec3 target(int env) const;

  /// The vehicles (state, parameters, contact per lane = env); read them, do not step them.
  const BatchSimulator<T>& batch() const { return *batch_; }

 private:
  template <class A>
  void step_impl(const A* actions);
  void apply_actions_begin();
  template <class A>
  void take_action(int env, const A* a);
  void evaluate(int env);
  void begin_episode(int env, const StateVector* state);
  template <class O>
  void write_observation(int env, O* row) const;
  void write_observation(int env);
  Vec3 target_at(int env, double t_s, Vec3* velocity) const;
  Vec3 position(int env) const;
  Vec3 measured(int env, int element) const;
  double uniform(int env, int draw) const;
  void build_spaces();
  std::size_t lane(int env) const;
  /// The env's sensors and depth cameras at its current step (`start`: the episode's first).
  void sense(int env, bool start);
  void build_sensors();
  template <class O>
  void write_sensor_values(int env, O* out) const;

  std::shared_ptr<const VehicleModel> model_;
  EnvConfig config_;
  int num_envs_ = 0;
  int action_size_ = 0;
  int observation_size_ = 0;
  int substeps_ = 0;
  CollisionShape collision_;
  double hover_thrust_N_ = 0.0;
  RotorVector hover_speeds_;
  std::vector<PieceSlice> layout_;
  bool observes_target_ = false;        ///< the layout has a target piece
  bool observes_rotor_speeds_ = false;  ///< the layout has kRotorSpeeds
  std::vector<double> action_low_, action_high_, observation_low_, observation_high_;

  std::unique_ptr<BatchSimulator<T>> batch_;
  std::unique_ptr<BatchSe3Controller<T>> se3_;
  std::unique_ptr<BatchBodyRateController<T>> rates_;
  std::vector<T> force_;  // generalized-force actions, structure of arrays

  std::uint64_t seed_ = 0;
  std::vector<std::uint64_t> key_;
  std::vector<std::int64_t> episode_;
  // Per env: this and the previous action (physical units), position before the step.
  std::vector<double> action_, previous_action_, start_position_, start_quaternion_;
  std::vector<std::uint8_t> invalid_action_;
  std::vector<double> yaw_reference_, target_, time_offset_;
  std::vector<std::int32_t> next_gate_, gates_passed_, laps_;
  std::vector<double> lap_start_s_, best_lap_s_;
  std::vector<std::int64_t> length_;
  std::vector<double> return_;

  int current_ = 0;  // which observation buffer is the newest
  std::vector<float> observation32_[2], final32_[2];
  std::vector<double> observation64_[2], final64_[2];
  std::vector<double> reward_, reward_terms_;
  std::vector<std::uint8_t> terminated_, truncated_, done_, end_cause_;
  std::vector<double> finished_return_, finished_best_lap_, final_state_, final_rotor_speed_;
  std::vector<std::int64_t> finished_length_;
  std::vector<std::int32_t> finished_gates_, finished_laps_;
  // Sensors (EnvConfig::sensors, depth_cameras): one suite per env, sampled once per env step at
  // most; each camera's latest frame per env; the velocities of the previous step (the IMU's
  // acceleration over the step).
  std::vector<SensorSuite> suites_;
  std::vector<DepthCamera> cameras_;
  std::vector<float> frames_;
  std::vector<std::int64_t> camera_frames_, camera_next_step_;
  std::vector<Random> camera_rng_;
  std::vector<double> previous_rates_;  ///< per env: v (3) and w (3) after the last step
  std::vector<SensorSlice> sensor_slices_;
  SingleThreadGuard guard_;
};

extern template class VecEnv<double>;
extern template class VecEnv<float>;

}  // namespace dronetwin::rl
