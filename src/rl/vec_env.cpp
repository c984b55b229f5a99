#include "dronetwin/rl/vec_env.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/model/model_parameters.hpp"
#include "dronetwin/noise/counter_normal.hpp"
#include "dronetwin/rl/action_space.hpp"
#include "dronetwin/sensors/sample_schedule.hpp"
#include "dronetwin/sensors/sensor_truth.hpp"
#include "dronetwin/world/gate.hpp"
#include "dronetwin/world/obstacle.hpp"

namespace dronetwin::rl {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Uniform draws per episode of one env's stream (the resets use fewer).
constexpr std::uint64_t kDrawsPerEpisode = 64;
// Envs per task of the parallel evaluation: enough to amortise a task hand-out.
constexpr int kEnvsPerTask = 64;
// Room for the previous action of any mode (rotor speeds: one per rotor).
constexpr int kMaxActionSize = std::max(4, kMaxRotors);

}  // namespace

template <class T>
std::size_t VecEnv<T>::lane(int env) const {
  require(env >= 0 && env < num_envs_, "VecEnv: env ", env, " is out of range [0, ", num_envs_,
          ")");
  return static_cast<std::size_t>(env);
}

template <class T>
VecEnv<T>::VecEnv(std::shared_ptr<const VehicleModel> model, EnvConfig config, int num_envs,
                  int num_threads)
    : model_(std::move(model)), config_(std::move(config)), num_envs_(num_envs) {
  require(model_ != nullptr, "VecEnv: model: expected a vehicle model, got none");
  validate(config_);
  require(num_envs >= 1 && num_envs <= kMaxBatchVehicles, "VecEnv: num_envs: expected 1 to ",
          kMaxBatchVehicles, ", got ", num_envs);
  // validate() checked that this is a whole number.
  substeps_ = static_cast<int>(std::lround(1.0 / (config_.control_rate_hz * config_.sim.dt_s)));
  if (config_.observation.empty()) config_.observation = default_observation(config_.task);
  collision_ = config_.vehicle_radius_m > 0.0 ? CollisionShape::sphere(config_.vehicle_radius_m)
                                              : model_->collision_shape();
  const double g = config_.sim.environment.gravity_W_m_s2.norm();
  // Summed in a loop: Eigen's sum() over the dynamic-size rotor vector makes GCC 12 report a
  // false maybe-uninitialized in its AVX-512 reduction (-march=native builds).
  const RotorVector hover_thrusts = model_->hover_thrusts_N(g);
  for (Eigen::Index i = 0; i < hover_thrusts.size(); ++i) hover_thrust_N_ += hover_thrusts[i];
  hover_speeds_ = model_->hover_speeds_rad_s(g);

  batch_ = std::make_unique<BatchSimulator<T>>(model_, config_.sim, num_envs, num_threads);
  const int stride = batch_->stride();
  switch (config_.action) {
    case ActionMode::kRelativePosition:
    case ActionMode::kGlobalPosition:
      se3_ = std::make_unique<BatchSe3Controller<T>>(model_, config_.se3_gains, config_.se3_options,
                                                     num_envs);
      break;
    case ActionMode::kCtbr:
      rates_ = std::make_unique<BatchBodyRateController<T>>(model_, config_.rate_gains, num_envs);
      break;
    case ActionMode::kGeneralizedForce:
      force_.assign(4 * static_cast<std::size_t>(stride), T(0));
      break;
    case ActionMode::kRotorSpeeds:
      break;
  }
  build_spaces();

  const auto n = static_cast<std::size_t>(num_envs);
  const auto a = n * static_cast<std::size_t>(action_size_);
  key_.assign(n, 0);
  episode_.assign(n, -1);
  action_.assign(a, 0.0);
  previous_action_.assign(a, 0.0);
  start_position_.assign(3 * n, 0.0);
  start_quaternion_.assign(4 * n, 0.0);
  invalid_action_.assign(n, 0);
  yaw_reference_.assign(n, 0.0);
  target_.assign(3 * n, 0.0);
  time_offset_.assign(n, 0.0);
  next_gate_.assign(n, 0);
  gates_passed_.assign(n, 0);
  laps_.assign(n, 0);
  lap_start_s_.assign(n, 0.0);
  best_lap_s_.assign(n, std::numeric_limits<double>::quiet_NaN());
  length_.assign(n, 0);
  return_.assign(n, 0.0);
  const std::size_t o = n * static_cast<std::size_t>(observation_size_);
  for (int b = 0; b < 2; ++b) {
    if (config_.observation_float32) {
      observation32_[b].assign(o, 0.0F);
      final32_[b].assign(o, 0.0F);
    } else {
      observation64_[b].assign(o, 0.0);
      final64_[b].assign(o, 0.0);
    }
  }
  reward_.assign(n, 0.0);
  reward_terms_.assign(static_cast<std::size_t>(kNumRewardTerms) * n, 0.0);
  terminated_.assign(n, 0);
  truncated_.assign(n, 0);
  done_.assign(n, 0);
  end_cause_.assign(n, 0);
  finished_return_.assign(n, 0.0);
  finished_best_lap_.assign(n, std::numeric_limits<double>::quiet_NaN());
  finished_length_.assign(n, 0);
  finished_gates_.assign(n, 0);
  finished_laps_.assign(n, 0);
  final_state_.assign(n * static_cast<std::size_t>(kStateSize), 0.0);
  final_rotor_speed_.assign(n * static_cast<std::size_t>(model_->num_rotors()), 0.0);
  build_sensors();
  reset(config_.seed);
}

template <class T>
void VecEnv<T>::build_sensors() {
  const auto n = static_cast<std::size_t>(num_envs_);
  suites_.clear();
  if (!config_.sensors.empty()) {
    suites_.reserve(n);
    for (std::size_t e = 0; e < n; ++e)
      suites_.emplace_back(config_.sensors, control_dt_s(), model_->num_rotors(), 0);
  }
  cameras_.clear();
  std::size_t pixels = 0;
  for (const DepthCameraSpec& c : config_.depth_cameras) {
    cameras_.emplace_back(c.parameters);
    pixels += cameras_.back().pixels();
  }
  frames_.assign(n * pixels, 0.0F);
  camera_frames_.assign(n * cameras_.size(), 0);
  camera_next_step_.assign(n * cameras_.size(), 0);
  camera_rng_.assign(n * cameras_.size(), Random());
  previous_rates_.assign(6 * n, 0.0);
}

template <class T>
void VecEnv<T>::sense(int env, bool start) {
  if (suites_.empty() && cameras_.empty()) return;
  const auto e = static_cast<std::size_t>(env);
  const double dt = control_dt_s();
  SensorTruth t;
  t.time_s = static_cast<double>(length_[e]) * dt;
  t.state = batch_->state(env);
  // The accelerations over the env step: what an IMU's delta-velocity output averaged over it
  // gives (zero at the episode's start, where the inner loops hold the vehicle).
  double* previous = previous_rates_.data() + 6 * e;
  for (int k = 0; k < 3; ++k) {
    const double v = t.state[state_index::kVelocity + k];
    const double w = t.state[state_index::kAngularVelocity + k];
    if (!start) {
      t.acceleration_W_m_s2[k] = (v - previous[k]) / dt;
      t.angular_acceleration_B_rad_s2[k] = (w - previous[3 + k]) / dt;
    }
    previous[k] = v;
    previous[3 + k] = w;
  }
  t.gravity_W_m_s2 = config_.sim.environment.gravity_W_m_s2;
  t.rotor_speed_rad_s = batch_->rotor_speeds(env);
  t.scene = config_.task == Task::kRacing ? &config_.track : nullptr;
  // Each episode's sensor noise from the env's counter stream (kDrawsPerEpisode - 2 is free).
  const std::uint64_t seed = counter_bits(
      key_[e], static_cast<std::uint64_t>(episode_[e]) * kDrawsPerEpisode + kDrawsPerEpisode - 2);
  if (!suites_.empty()) {
    if (start) suites_[e].reset(seed);
    suites_[e].update(length_[e], t);
  }
  const std::size_t pixels = frames_.size() / static_cast<std::size_t>(num_envs_);
  std::size_t at = e * pixels;
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    const std::size_t i = e * cameras_.size() + c;
    const DepthCameraParameters& p = cameras_[c].parameters();
    if (start) {
      camera_frames_[i] = 0;
      camera_next_step_[i] = 0;
      camera_rng_[i].reseed(sensor_stream_seed(seed, config_.depth_cameras[c].name));
    }
    if (length_[e] >= camera_next_step_[i]) {
      cameras_[c].render(t.state, t.scene, frames_.data() + at,
                         p.noise_at_1m_m > 0.0 ? &camera_rng_[i] : nullptr);
      ++camera_frames_[i];
      camera_next_step_[i] =
          std::max(length_[e] + 1, step_of_sample(camera_frames_[i], p.rate_hz, dt));
    }
    at += cameras_[c].pixels();
  }
}

template <class T>
template <class O>
void VecEnv<T>::write_sensor_values(int env, O* row) const {
  const auto e = static_cast<std::size_t>(env);
  const std::size_t pixels = frames_.size() / static_cast<std::size_t>(num_envs_);
  const float* frame = frames_.data() + e * pixels;
  int sensor = 0;
  for (const SensorSlice& slice : sensor_slices_) {
    O* out = row + slice.offset;
    if (slice.depth) {
      for (int k = 0; k < slice.size; ++k) out[k] = static_cast<O>(frame[k]);
      frame += slice.size;
      continue;
    }
    // No reading yet or no return (NaN channels): zeros and a flag of 0, never a NaN.
    const SensorReading& r = suites_[e].latest(sensor++);
    bool valid = true;
    for (int k = 0; k + 1 < slice.size; ++k) {
      const double v = r.values[static_cast<std::size_t>(k)];
      valid = valid && std::isfinite(v);
      out[k] = static_cast<O>(std::isfinite(v) ? v : 0.0);
    }
    out[slice.size - 1] = static_cast<O>(valid ? 1.0 : 0.0);
  }
}

template <class T>
void VecEnv<T>::build_spaces() {
  const VehicleModel& m = *model_;
  const int rotors = m.num_rotors();
  const ActionBox box = action_box(m, config_);
  action_low_ = box.low;
  action_high_ = box.high;
  action_size_ = static_cast<int>(action_low_.size());

  layout_ =
      rl::observation_layout(config_.observation, action_size_, rotors, config_.gate_lookahead);
  const auto has = [&](ObservationPiece piece) {
    return std::find(config_.observation.begin(), config_.observation.end(), piece) !=
           config_.observation.end();
  };
  observes_target_ =
      has(ObservationPiece::kTargetRelative) || has(ObservationPiece::kTargetVelocity);
  observes_rotor_speeds_ = has(ObservationPiece::kRotorSpeeds);
  observation_low_.clear();
  observation_high_.clear();
  int offset = 0;
  for (const PieceSlice& slice : layout_) {
    const ObservationPiece p = slice.piece;
    offset += slice.size;
    for (int i = 0; i < slice.size; ++i) {
      double lo = -kInf, hi = kInf;
      if (p == ObservationPiece::kRotation || p == ObservationPiece::kQuaternion) {
        lo = -1.0;
        hi = 1.0;
      } else if (p == ObservationPiece::kRotorSpeeds) {
        lo = 0.0;
        hi = 1.0;
      } else if (p == ObservationPiece::kPreviousAction) {
        lo = config_.normalized_actions ? -1.0 : action_low_[static_cast<std::size_t>(i)];
        hi = config_.normalized_actions ? 1.0 : action_high_[static_cast<std::size_t>(i)];
      }
      observation_low_.push_back(lo);
      observation_high_.push_back(hi);
    }
  }
  sensor_slices_.clear();
  for (const SensorSpec& sensor : config_.sensors) {
    const int size = static_cast<int>(sensor_channels(sensor, rotors).size()) + 1;
    sensor_slices_.push_back({sensor.name, false, offset, size});
    offset += size;
    for (int i = 0; i + 1 < size; ++i) {
      observation_low_.push_back(-kInf);
      observation_high_.push_back(kInf);
    }
    observation_low_.push_back(0.0);  // the reading's flag
    observation_high_.push_back(1.0);
  }
  for (const DepthCameraSpec& camera : config_.depth_cameras) {
    const DepthCameraParameters& p = camera.parameters;
    const int size = p.width_px * p.height_px;
    sensor_slices_.push_back({camera.name, true, offset, size});
    offset += size;
    observation_low_.insert(observation_low_.end(), static_cast<std::size_t>(size), 0.0);
    observation_high_.insert(observation_high_.end(), static_cast<std::size_t>(size),
                             p.max_range_m);
  }
  observation_size_ = offset;
}

template <class T>
double VecEnv<T>::uniform(int env, int draw) const {
  const auto e = static_cast<std::size_t>(env);
  const std::uint64_t bits =
      counter_bits(key_[e], static_cast<std::uint64_t>(episode_[e]) * kDrawsPerEpisode +
                                static_cast<std::uint64_t>(draw));
  return static_cast<double>(bits >> 11) * 0x1.0p-53;
}

template <class T>
Vec3 VecEnv<T>::position(int env) const {
  const BatchSimulator<T>& b = *batch_;
  return Vec3(static_cast<double>(b.state_at(state_index::kPosition, env)),
              static_cast<double>(b.state_at(state_index::kPosition + 1, env)),
              static_cast<double>(b.state_at(state_index::kPosition + 2, env)));
}

template <class T>
Vec3 VecEnv<T>::measured(int env, int element) const {
  const T* x = batch_->measured_state_data();
  const auto s = static_cast<std::size_t>(batch_->stride());
  const auto l = static_cast<std::size_t>(env);
  return Vec3(static_cast<double>(x[static_cast<std::size_t>(element) * s + l]),
              static_cast<double>(x[static_cast<std::size_t>(element + 1) * s + l]),
              static_cast<double>(x[static_cast<std::size_t>(element + 2) * s + l]));
}

template <class T>
Vec3 VecEnv<T>::target_at(int env, double t_s, Vec3* velocity) const {
  const auto e = static_cast<std::size_t>(env);
  if (velocity != nullptr) velocity->setZero();
  switch (config_.task) {
    case Task::kHover:
      return Vec3(target_[3 * e], target_[3 * e + 1], target_[3 * e + 2]);
    case Task::kTrajectory: {
      const ReferencePoint r = config_.reference->at(t_s + time_offset_[e]);
      if (velocity != nullptr) *velocity = r.velocity_m_s;
      return r.position_m;
    }
    case Task::kRacing:
      return config_.track.gates[static_cast<std::size_t>(next_gate_[e])].center_m;
  }
  return Vec3::Zero();
}

template <class T>
Vec3 VecEnv<T>::target(int env) const {
  const std::size_t e = lane(env);
  return target_at(env, static_cast<double>(length_[e]) * control_dt_s(), nullptr);
}

template <class T>
void VecEnv<T>::reset(std::uint64_t seed) {
  const SingleThreadGuard::Hold hold(guard_, "VecEnv::reset");
  seed_ = seed;
  current_ ^= 1;
  for (int env = 0; env < num_envs_; ++env) {
    const auto e = static_cast<std::size_t>(env);
    key_[e] = counter_stream_key(seed, e);
    episode_[e] = -1;
    begin_episode(env, nullptr);
    reward_[e] = 0.0;
    terminated_[e] = truncated_[e] = done_[e] = end_cause_[e] = 0;
    write_observation(env);
  }
  std::fill(reward_terms_.begin(), reward_terms_.end(), 0.0);
}

template <class T>
void VecEnv<T>::reset_env(int env, const StateVector& state) {
  const SingleThreadGuard::Hold hold(guard_, "VecEnv::reset_env");
  lane(env);
  begin_episode(env, &state);
  write_observation(env);
}

template <class T>
void VecEnv<T>::reset_env(int env) {
  const SingleThreadGuard::Hold hold(guard_, "VecEnv::reset_env");
  lane(env);
  begin_episode(env, nullptr);
  write_observation(env);
}

template <class T>
void VecEnv<T>::begin_episode(int env, const StateVector* given) {
  const auto e = static_cast<std::size_t>(env);
  ++episode_[e];
  int draw = 0;
  const auto u = [&] { return uniform(env, draw++); };
  const auto within = [&](const Interval& i) { return i.lo + (i.hi - i.lo) * u(); };
  const auto symmetric = [&](double half) { return half * (2.0 * u() - 1.0); };
  const Randomization& R = config_.randomization;

  // Parameters: set only when they differ from the lane's value (a change rebuilds its pack).
  BatchSimulator<T>& b = *batch_;
  const auto set = [&](ModelParameter p, double value) {
    if (b.parameter(p, env) != value) b.set_parameter(p, env, value);
  };
  const auto nominal = [&](ModelParameter p) { return parameter_value(model_->parameters(), p); };
  set(ModelParameter::kMass, nominal(ModelParameter::kMass) * within(R.mass_scale));
  const double inertia = within(R.inertia_scale);
  for (ModelParameter p :
       {ModelParameter::kInertiaXX, ModelParameter::kInertiaYY, ModelParameter::kInertiaZZ})
    set(p, nominal(p) * inertia);
  const double thrust = within(R.thrust_scale);
  for (ModelParameter p :
       {ModelParameter::kThrustK1, ModelParameter::kThrustK2, ModelParameter::kThrustK3})
    set(p, nominal(p) * thrust);
  const double motor = within(R.motor_time_scale);
  for (ModelParameter p : {ModelParameter::kTauRise, ModelParameter::kTauFall})
    set(p, nominal(p) * motor);
  const double drag = within(R.drag_scale);
  for (ModelParameter p : {ModelParameter::kBodyDragX, ModelParameter::kBodyDragY,
                           ModelParameter::kBodyDragZ, ModelParameter::kRotorDrag})
    set(p, nominal(p) * drag);
  // Wind: uniform direction on the sphere, speed uniform in [0, max].
  const double wz = 2.0 * u() - 1.0, phi = 2.0 * M_PI * u(), speed = R.wind_speed_max_m_s * u();
  const double wr = std::sqrt(std::max(0.0, 1.0 - wz * wz));
  b.set_wind(env, config_.sim.environment.wind_W_m_s +
                      speed * Vec3(wr * std::cos(phi), wr * std::sin(phi), wz));

  // The task's start pose and target.
  Vec3 start = Vec3::Zero();
  double yaw = 0.0;
  next_gate_[e] = 0;
  switch (config_.task) {
    case Task::kHover: {
      const Vec3 target = config_.hover_target_m + Vec3(symmetric(config_.hover_target_range_m[0]),
                                                        symmetric(config_.hover_target_range_m[1]),
                                                        symmetric(config_.hover_target_range_m[2]));
      for (int k = 0; k < 3; ++k) target_[3 * e + static_cast<std::size_t>(k)] = target[k];
      start = target + config_.hover_start_offset_m;
      break;
    }
    case Task::kTrajectory: {
      time_offset_[e] = config_.reference_time_offset_max_s * u();
      const ReferencePoint r = config_.reference->at(time_offset_[e]);
      start = r.position_m;
      yaw = r.yaw_rad;
      break;
    }
    case Task::kRacing: {
      const Track& track = config_.track;
      const int gates = static_cast<int>(track.gates.size());
      const int first =
          config_.random_start_gate ? std::min(gates - 1, static_cast<int>(u() * gates)) : 0;
      next_gate_[e] = first;
      if (first == 0) {
        start = track.start_position_m;
        yaw = track.start_yaw_rad;
      } else {
        // 2 m before the gate along its passage direction, facing it.
        const Gate& g = track.gates[static_cast<std::size_t>(first)];
        start = g.center_m - 2.0 * g.normal();
        yaw = std::atan2(g.normal()[1], g.normal()[0]);
      }
      break;
    }
  }
  StateVector x = StateVector::Zero();
  if (given != nullptr) {
    x = *given;
  } else {
    const Vec3 dp(symmetric(R.position_m[0]), symmetric(R.position_m[1]),
                  symmetric(R.position_m[2]));
    const Vec3 v(symmetric(R.velocity_m_s[0]), symmetric(R.velocity_m_s[1]),
                 symmetric(R.velocity_m_s[2]));
    const Vec3 att(symmetric(R.attitude_rad[0]), symmetric(R.attitude_rad[1]),
                   symmetric(R.attitude_rad[2]));
    const Vec3 w(symmetric(R.body_rate_rad_s[0]), symmetric(R.body_rate_rad_s[1]),
                 symmetric(R.body_rate_rad_s[2]));
    x.segment<3>(state_index::kPosition) = start + dp;
    x.segment<3>(state_index::kVelocity) = v;
    x.segment<4>(state_index::kQuaternion) = math::from_euler(att[0], att[1], yaw + att[2]);
    x.segment<3>(state_index::kAngularVelocity) = w;
  }
  b.reset(env, x, hover_speeds_);
  b.set_seed(env, counter_bits(key_[e], static_cast<std::uint64_t>(episode_[e]) * kDrawsPerEpisode +
                                            kDrawsPerEpisode - 1));
  const Vec4 q = b.state(env).template segment<4>(state_index::kQuaternion);
  yaw_reference_[e] = math::to_euler(q)[2];

  // Inner loops hold the start until the first action.
  const Vec3 p = b.state(env).template segment<3>(state_index::kPosition);
  const auto s = static_cast<std::size_t>(b.stride());
  if (se3_) {
    T* ref = se3_->reference_data();
    for (int k = 0; k < 9; ++k) ref[static_cast<std::size_t>(k) * s + e] = T(0);
    for (int k = 0; k < 3; ++k) ref[static_cast<std::size_t>(k) * s + e] = static_cast<T>(p[k]);
    ref[9 * s + e] = static_cast<T>(std::cos(yaw_reference_[e]));
    ref[10 * s + e] = static_cast<T>(std::sin(yaw_reference_[e]));
  }
  if (rates_) {
    T* c = rates_->command_data();
    c[e] = static_cast<T>(hover_thrust_N_);
    for (int k = 1; k < 4; ++k) c[static_cast<std::size_t>(k) * s + e] = T(0);
  }
  if (!force_.empty()) {
    force_[e] = static_cast<T>(hover_thrust_N_);
    for (int k = 1; k < 4; ++k) force_[static_cast<std::size_t>(k) * s + e] = T(0);
  }
  const auto a = static_cast<std::size_t>(action_size_);
  std::fill_n(previous_action_.begin() + static_cast<std::ptrdiff_t>(e * a), a, 0.0);
  std::fill_n(action_.begin() + static_cast<std::ptrdiff_t>(e * a), a, 0.0);
  gates_passed_[e] = 0;
  laps_[e] = 0;
  lap_start_s_[e] = 0.0;
  best_lap_s_[e] = std::numeric_limits<double>::quiet_NaN();
  length_[e] = 0;
  return_[e] = 0.0;
  sense(env, true);
}

template <class T>
template <class A>
void VecEnv<T>::take_action(int env, const A* in) {
  const auto e = static_cast<std::size_t>(env);
  const auto n = static_cast<std::size_t>(action_size_);
  double* a = action_.data() + e * n;
  bool finite = true;
  for (std::size_t i = 0; i < n; ++i) finite = finite && std::isfinite(static_cast<double>(in[i]));
  invalid_action_[e] = finite ? 0 : 1;
  for (std::size_t i = 0; i < n; ++i) {
    const double lo = action_low_[i], hi = action_high_[i];
    double v = finite ? static_cast<double>(in[i]) : 0.0;
    if (config_.normalized_actions) {
      v = std::clamp(v, -1.0, 1.0);
      a[i] = lo + 0.5 * (v + 1.0) * (hi - lo);
    } else {
      a[i] = std::clamp(v, lo, hi);
    }
  }
  BatchSimulator<T>& b = *batch_;
  const auto s = static_cast<std::size_t>(b.stride());
  const Vec3 p = measured(env, state_index::kPosition);
  switch (config_.action) {
    case ActionMode::kRelativePosition: {
      // Eq. 4.19: track p + a (an invalid action holds the current position).
      T* ref = se3_->reference_data();
      for (std::size_t k = 0; k < 3; ++k)
        ref[k * s + e] = static_cast<T>(p[static_cast<Eigen::Index>(k)] + (finite ? a[k] : 0.0));
      break;
    }
    case ActionMode::kGlobalPosition: {
      T* ref = se3_->reference_data();
      for (std::size_t k = 0; k < 3; ++k)
        ref[k * s + e] = static_cast<T>(finite ? a[k] : p[static_cast<Eigen::Index>(k)]);
      const double yaw = finite ? a[3] : yaw_reference_[e];
      ref[9 * s + e] = static_cast<T>(std::cos(yaw));
      ref[10 * s + e] = static_cast<T>(std::sin(yaw));
      break;
    }
    case ActionMode::kRotorSpeeds: {
      T* ref = b.rotor_speed_reference_data();
      for (std::size_t i = 0; i < n; ++i)
        ref[i * s + e] =
            static_cast<T>(finite ? a[i] : hover_speeds_[static_cast<Eigen::Index>(i)]);
      break;
    }
    case ActionMode::kCtbr: {
      T* c = rates_->command_data();
      for (std::size_t k = 0; k < 4; ++k)
        c[k * s + e] = static_cast<T>(finite ? a[k] : (k == 0 ? hover_thrust_N_ : 0.0));
      break;
    }
    case ActionMode::kGeneralizedForce:
      for (std::size_t k = 0; k < 4; ++k)
        force_[k * s + e] = static_cast<T>(finite ? a[k] : (k == 0 ? hover_thrust_N_ : 0.0));
      break;
  }
}

template <class T>
void VecEnv<T>::step(const double* actions) {
  step_impl(actions);
}
template <class T>
void VecEnv<T>::step(const float* actions) {
  step_impl(actions);
}

template <class T>
template <class A>
void VecEnv<T>::step_impl(const A* actions) {
  const SingleThreadGuard::Hold hold(guard_, "VecEnv::step");
  require(actions != nullptr, "VecEnv::step: actions: expected (", num_envs_, ", ", action_size_,
          ") values, got none");
  BatchSimulator<T>& b = *batch_;
  const auto n = static_cast<std::size_t>(action_size_);
  const int tasks = (num_envs_ + kEnvsPerTask - 1) / kEnvsPerTask;
  // Each env writes only its own lane of the inner loop's inputs: the pool may share them out.
  b.thread_pool().run(tasks, [&](int task) {
    const int end = std::min(num_envs_, (task + 1) * kEnvsPerTask);
    for (int env = task * kEnvsPerTask; env < end; ++env) {
      const auto e = static_cast<std::size_t>(env);
      const Vec3 p = position(env);
      for (int k = 0; k < 3; ++k) start_position_[3 * e + static_cast<std::size_t>(k)] = p[k];
      const Vec4 q = batch_->state(env).template segment<4>(state_index::kQuaternion);
      for (int k = 0; k < 4; ++k) start_quaternion_[4 * e + static_cast<std::size_t>(k)] = q[k];
      take_action(env, actions + e * n);
    }
  });
  if (!force_.empty()) b.set_generalized_forces(force_.data());
  if (se3_)
    b.step(substeps_, *se3_);
  else if (rates_)
    b.step(substeps_, *rates_);
  else
    b.step(substeps_);

  current_ ^= 1;
  b.thread_pool().run(tasks, [&](int task) {
    const int end = std::min(num_envs_, (task + 1) * kEnvsPerTask);
    for (int env = task * kEnvsPerTask; env < end; ++env) evaluate(env);
  });
  // Auto-reset, in env order (a reset may rebuild a pack of the batch: not from the pool).
  const auto o = static_cast<std::size_t>(observation_size_);
  for (int env = 0; env < num_envs_; ++env) {
    const auto e = static_cast<std::size_t>(env);
    if (!done_[e]) continue;
    if (config_.observation_float32) {
      const float* from = observation32_[current_].data() + e * o;
      std::copy(from, from + o, final32_[current_].data() + e * o);
    } else {
      const double* from = observation64_[current_].data() + e * o;
      std::copy(from, from + o, final64_[current_].data() + e * o);
    }
    finished_return_[e] = return_[e];
    finished_length_[e] = length_[e];
    finished_gates_[e] = gates_passed_[e];
    finished_laps_[e] = laps_[e];
    finished_best_lap_[e] = best_lap_s_[e];
    for (int k = 0; k < kStateSize; ++k)
      final_state_[e * kStateSize + static_cast<std::size_t>(k)] =
          static_cast<double>(batch_->state_at(k, env));
    const int num_rotors = model_->num_rotors();
    const RotorVector omega = batch_->rotor_speeds(env);
    for (int r = 0; r < num_rotors; ++r)
      final_rotor_speed_[e * static_cast<std::size_t>(num_rotors) + static_cast<std::size_t>(r)] =
          static_cast<double>(omega[r]);
    begin_episode(env, nullptr);
    write_observation(env);
  }
}

template <class T>
void VecEnv<T>::evaluate(int env) {
  const auto e = static_cast<std::size_t>(env);
  const BatchSimulator<T>& b = *batch_;
  const double dt = control_dt_s();
  const double t_before = static_cast<double>(length_[e]) * dt;
  const double t_now = static_cast<double>(length_[e] + 1) * dt;  // as target() computes it
  const Vec3 p0(start_position_[3 * e], start_position_[3 * e + 1], start_position_[3 * e + 2]);
  const Vec3 p1 = position(env);
  const StateVector x = b.state(env);
  EndCause cause = EndCause::kNone;
  double d_before = 0.0, d_now = 0.0;
  int gates_now = 0;

  if (b.status(env) != StepStatus::kOk) {
    cause = EndCause::kSimulationFailed;
  } else if (invalid_action_[e]) {
    cause = EndCause::kInvalidAction;
  }
  if (config_.task == Task::kRacing) {
    const Track& track = config_.track;
    const int num_gates = static_cast<int>(track.gates.size());
    const Gate& g = track.gates[static_cast<std::size_t>(next_gate_[e])];
    // Progress towards the gate that was next at the start of the step (after passing it, the
    // next step measures to the new one).
    d_before = (p0 - g.center_m).norm();
    d_now = (p1 - g.center_m).norm();
    if (cause == EndCause::kNone) {
      const Vec4 q0(start_quaternion_[4 * e], start_quaternion_[4 * e + 1],
                    start_quaternion_[4 * e + 2], start_quaternion_[4 * e + 3]);
      const SceneContact contact = find_scene_contact(
          track, collision_, p0, q0, p1, x.template segment<4>(state_index::kQuaternion));
      if (contact.kind == SceneContact::Kind::kGate) cause = EndCause::kGateFrame;
      if (contact.kind == SceneContact::Kind::kObstacle) cause = EndCause::kObstacle;
    }
    if (cause == EndCause::kNone && cross_gate(g, p0, p1) == GateCrossing::kThrough) {
      ++gates_now;
      ++gates_passed_[e];
      const bool last_gate = ++next_gate_[e] == num_gates;
      if (last_gate) next_gate_[e] = track.closed ? 0 : num_gates - 1;
      // A lap: every gate once, in order, counted from the gate the episode started before (a
      // random start gate begins its laps there, not at g1). An open track ends at its last gate.
      if (track.closed ? gates_passed_[e] % num_gates == 0 : last_gate) {
        // Its time runs from the previous lap's end (or the start).
        ++laps_[e];
        const double lap = t_now - lap_start_s_[e];
        if (!(best_lap_s_[e] <= lap)) best_lap_s_[e] = lap;
        lap_start_s_[e] = t_now;
        if (!track.closed || (config_.laps > 0 && laps_[e] >= config_.laps))
          cause = EndCause::kFinished;
      }
    }
  } else {
    d_before = (p0 - target_at(env, t_before, nullptr)).norm();
    d_now = (p1 - target_at(env, t_now, nullptr)).norm();
  }

  if (cause == EndCause::kNone) {
    const Vec3 lo = config_.task == Task::kRacing ? config_.track.arena_min_m : config_.arena_min_m;
    const Vec3 hi = config_.task == Task::kRacing ? config_.track.arena_max_m : config_.arena_max_m;
    const ContactState& c = b.contact(env);
    // Body z . world z = 1 - 2 (qx^2 + qy^2) for a unit quaternion [w, x, y, z].
    const double qx = x[state_index::kQuaternion + 1], qy = x[state_index::kQuaternion + 2];
    const double qn = x.segment<4>(state_index::kQuaternion).squaredNorm();
    const double cos_tilt = 1.0 - 2.0 * (qx * qx + qy * qy) / qn;
    if (p1[2] < config_.min_height_m || c.in_contact || c.touchdowns > 0)
      cause = EndCause::kGround;
    else if (cos_tilt < std::cos(config_.max_tilt_rad))
      cause = EndCause::kFlip;
    else if ((p1.array() < lo.array()).any() || (p1.array() > hi.array()).any())
      cause = EndCause::kOutOfBounds;
  }
  if (cause == EndCause::kNone && t_now >= config_.episode_time_s - 1e-9 * dt)
    cause = EndCause::kTimeLimit;

  // Eq. 4.20-4.22, each term weighted.
  const auto n = static_cast<std::size_t>(action_size_);
  const double* a = action_.data() + e * n;
  double* a_prev = previous_action_.data() + e * n;
  double action_rate = 0.0;
  for (std::size_t i = 0; i < n; ++i) action_rate += (a[i] - a_prev[i]) * (a[i] - a_prev[i]);
  const RewardWeights& w = config_.reward;
  const std::array<double, kNumRewardTerms> terms = {
      w.progress * (d_before - d_now),
      w.action_rate * action_rate,
      w.angular * x.segment<3>(state_index::kAngularVelocity).norm(),
      is_crash(cause) ? w.crash : 0.0,
      w.gate * gates_now,
      w.distance * d_now,
      is_crash(cause) ? 0.0 : w.alive};
  double r = 0.0;
  const auto N = static_cast<std::size_t>(num_envs_);
  for (int k = 0; k < kNumRewardTerms; ++k) {
    reward_terms_[static_cast<std::size_t>(k) * N + e] = terms[static_cast<std::size_t>(k)];
    r += terms[static_cast<std::size_t>(k)];
  }
  std::copy(a, a + n, a_prev);
  reward_[e] = r;
  return_[e] += r;
  ++length_[e];
  end_cause_[e] = static_cast<std::uint8_t>(cause);
  truncated_[e] = cause == EndCause::kTimeLimit;
  terminated_[e] = cause != EndCause::kNone && cause != EndCause::kTimeLimit;
  done_[e] = cause != EndCause::kNone;
  sense(env, false);
  write_observation(env);
}

template <class T>
void VecEnv<T>::write_observation(int env) {
  const auto row = static_cast<std::size_t>(env) * static_cast<std::size_t>(observation_size_);
  if (config_.observation_float32)
    write_observation(env, observation32_[current_].data() + row);
  else
    write_observation(env, observation64_[current_].data() + row);
}

template <class T>
template <class O>
void VecEnv<T>::write_observation(int env, O* row) const {
  const auto e = static_cast<std::size_t>(env);
  ObservationInput in;
  in.position_m = measured(env, state_index::kPosition);
  in.velocity_m_s = measured(env, state_index::kVelocity);
  in.body_rates_rad_s = measured(env, state_index::kAngularVelocity);
  const T* xs = batch_->measured_state_data();
  const auto s = static_cast<std::size_t>(batch_->stride());
  for (int k = 0; k < 4; ++k) {
    in.quaternion[k] =
        static_cast<double>(xs[static_cast<std::size_t>(state_index::kQuaternion + k) * s + e]);
  }
  // The previous action as the policy gave it: normalised actions are reported normalised.
  std::array<double, kMaxActionSize> previous{};
  const double* a = previous_action_.data() + e * static_cast<std::size_t>(action_size_);
  for (int i = 0; i < action_size_; ++i) {
    const auto u = static_cast<std::size_t>(i);
    previous[u] = config_.normalized_actions
                      ? 2.0 * (a[u] - action_low_[u]) / (action_high_[u] - action_low_[u]) - 1.0
                      : a[u];
  }
  in.previous_action = previous.data();
  std::array<double, kMaxRotors> rotor_fraction{};
  if (observes_rotor_speeds_) {
    const RotorVector w = batch_->rotor_speeds(env);
    for (int i = 0; i < model_->num_rotors(); ++i)
      rotor_fraction[static_cast<std::size_t>(i)] = w[i] / model_->rotor(i).max_speed_rad_s;
  }
  in.rotor_speed_fraction = rotor_fraction.data();
  in.track = &config_.track;
  in.next_gate = next_gate_[e];
  in.gate_lookahead = config_.gate_lookahead;
  if (observes_target_) {
    const double t_s = static_cast<double>(length_[e]) * control_dt_s();
    in.target_m = target_at(env, t_s, &in.target_velocity_m_s);
  }
  rl::write_observation(layout_, in, row);
  if (!sensor_slices_.empty()) write_sensor_values(env, row);
}

template <class T>
template <class O>
const O* VecEnv<T>::observation() const {
  if constexpr (std::is_same_v<O, float>) {
    require(config_.observation_float32,
            "VecEnv::observation: observations are float64 (observation_float32 is off)");
    return observation32_[current_].data();
  } else {
    require(!config_.observation_float32,
            "VecEnv::observation: observations are float32 (observation_float32 is on)");
    return observation64_[current_].data();
  }
}

template <class T>
template <class O>
const O* VecEnv<T>::final_observation() const {
  if constexpr (std::is_same_v<O, float>) {
    require(config_.observation_float32,
            "VecEnv::final_observation: observations are float64 (observation_float32 is off)");
    return final32_[current_].data();
  } else {
    require(!config_.observation_float32,
            "VecEnv::final_observation: observations are float32 (observation_float32 is on)");
    return final64_[current_].data();
  }
}

template <class T>
void VecEnv<T>::set_config(const EnvConfig& c) {
  const SingleThreadGuard::Hold hold(guard_, "VecEnv::set_config");
  validate(c);
  const auto same = [](bool ok, const char* field) {
    require(ok, "VecEnv::set_config: ", field,
            " cannot change in a running env (it fixes the spaces or the engine); make a new env");
  };
  same(c.task == config_.task, "task");
  same(c.action == config_.action, "action");
  same(c.observation.empty() ? default_observation(c.task) == config_.observation
                             : c.observation == config_.observation,
       "observation");
  same(c.gate_lookahead == config_.gate_lookahead, "gate_lookahead");
  same(c.control_rate_hz == config_.control_rate_hz, "control_rate_hz");
  same(c.sim.dt_s == config_.sim.dt_s && c.sim.noise.enabled == config_.sim.noise.enabled &&
           c.sim.integrator == config_.sim.integrator,
       "sim");
  same(c.normalized_actions == config_.normalized_actions, "normalized_actions");
  same(c.observation_float32 == config_.observation_float32, "observation_float32");
  same(c.relative_scale_m == config_.relative_scale_m &&
           c.max_body_rate_rad_s == config_.max_body_rate_rad_s &&
           c.max_thrust_to_weight == config_.max_thrust_to_weight,
       "action bounds (relative_scale_m, max_body_rate_rad_s, max_thrust_to_weight)");
  const Se3Gains &g = c.se3_gains, &h = config_.se3_gains;
  same(g.position_p == h.position_p && g.position_d == h.position_d &&
           g.attitude_p == h.attitude_p && g.attitude_d == h.attitude_d && g.mass_kg == h.mass_kg &&
           g.gravity_m_s2 == h.gravity_m_s2 &&
           c.se3_options.gravity_compensation == config_.se3_options.gravity_compensation &&
           c.se3_options.max_tilt_rad == config_.se3_options.max_tilt_rad &&
           c.se3_options.nonnegative_thrust == config_.se3_options.nonnegative_thrust &&
           c.se3_options.min_thrust_N == config_.se3_options.min_thrust_N &&
           c.rate_gains.rate_p == config_.rate_gains.rate_p,
       "inner-loop gains (se3_controller, body_rate_gains)");
  if (c.task == Task::kRacing)
    same(c.track.arena_min_m == config_.track.arena_min_m &&
             c.track.arena_max_m == config_.track.arena_max_m,
         "track arena (it bounds global-position actions)");
  else
    same(c.arena_min_m == config_.arena_min_m && c.arena_max_m == config_.arena_max_m,
         "arena (it bounds global-position actions)");
  const auto same_sensors = [&] {
    if (c.sensors.size() != config_.sensors.size() ||
        c.depth_cameras.size() != config_.depth_cameras.size())
      return false;
    for (std::size_t i = 0; i < c.sensors.size(); ++i)
      if (c.sensors[i].name != config_.sensors[i].name ||
          c.sensors[i].parameters.index() != config_.sensors[i].parameters.index())
        return false;
    for (std::size_t i = 0; i < c.depth_cameras.size(); ++i) {
      const DepthCameraParameters &a = c.depth_cameras[i].parameters,
                                  &b = config_.depth_cameras[i].parameters;
      if (c.depth_cameras[i].name != config_.depth_cameras[i].name || a.width_px != b.width_px ||
          a.height_px != b.height_px || a.max_range_m != b.max_range_m)
        return false;
    }
    return true;
  };
  same(same_sensors(), "sensors (names and types) and depth cameras (names, sizes, ranges)");
  const std::vector<ObservationPiece> pieces = config_.observation;
  config_ = c;
  config_.observation = pieces;
  // New noise settings or rates: fresh suites and cameras that sample at the next step (their
  // noise streams restart with each env's next episode).
  const std::vector<double> rates = previous_rates_;
  build_sensors();
  previous_rates_ = rates;
  if (c.vehicle_radius_m > 0.0) collision_ = CollisionShape::sphere(c.vehicle_radius_m);
  // Gate indices stay valid on a track with fewer gates.
  const int gates = static_cast<int>(config_.track.gates.size());
  if (config_.task == Task::kRacing)
    for (auto& next : next_gate_) next = std::min(next, gates - 1);
}

template class VecEnv<double>;
template class VecEnv<float>;
template const float* VecEnv<double>::observation<float>() const;
template const double* VecEnv<double>::observation<double>() const;
template const float* VecEnv<float>::observation<float>() const;
template const double* VecEnv<float>::observation<double>() const;
template const float* VecEnv<double>::final_observation<float>() const;
template const double* VecEnv<double>::final_observation<double>() const;
template const float* VecEnv<float>::final_observation<float>() const;
template const double* VecEnv<float>::final_observation<double>() const;

}  // namespace dronetwin::rl
