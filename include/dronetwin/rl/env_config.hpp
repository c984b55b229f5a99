#pragma once
// What a reinforcement-learning environment is: the task, how actions drive the vehicle, what
// the policy observes, the reward, episode limits, and the ranges drawn at every reset (domain
// randomisation). Plain data, checked by validate(); rl/vec_env.hpp runs it, and
// config/env_config_loader.hpp reads it from YAML (docs/rl.md has the fields and defaults).
//
//   EnvConfig c;                               // racing, relative-position actions, Eq. 4.18
//   c.track = load_track("config/tracks/circuit.yaml");
//   c.randomization.mass_scale = {0.9, 1.1};
//   VecEnv<float> env(model, c, 1024, 2);

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "dronetwin/control/body_rate.hpp"
#include "dronetwin/control/reference.hpp"
#include "dronetwin/control/se3.hpp"
#include "dronetwin/sensors/depth_camera.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"
#include "dronetwin/sim/sim_config.hpp"
#include "dronetwin/world/track.hpp"

namespace dronetwin::rl {

enum class Task : std::uint8_t {
  kHover,       ///< reach a (random) setpoint from a random start and hold it
  kTrajectory,  ///< follow a Reference of the control library
  kRacing,      ///< fly a track's gates in order (thesis Sec. 4.4)
};
inline constexpr std::array<std::string_view, 3> kTaskNames = {"hover", "trajectory", "racing"};

/// How an action moves the vehicle (thesis Sec. 4.3.1.2 and the usual low-level modes). Every
/// mode's action is a box (VecEnv::action_low/high); an action outside it is clipped, and with
/// EnvConfig::normalized_actions the box is [-1, 1] mapped affinely onto those bounds.
enum class ActionMode : std::uint8_t {
  /// [dx, dy, dz] m: the SE(3) inner loop tracks p + a (Eq. 4.19), |a_i| <= relative_scale_m.
  kRelativePosition,
  /// [x, y, z, yaw]: the SE(3) inner loop tracks that point (inside the arena, yaw in [-pi, pi]).
  kGlobalPosition,
  /// Rotor speed references in rad/s, [min_speed, max_speed] of each rotor.
  kRotorSpeeds,
  /// [T (N), w_x, w_y, w_z (rad/s)]: collective thrust and body rates, tracked by the body-rate
  /// controller (control/body_rate.hpp); T in [0, total max thrust], |w| <= max_body_rate.
  kCtbr,
  /// [T (N), tau_x, tau_y, tau_z (N m)] through the thrust-first allocation, held for the step.
  kGeneralizedForce,
};
inline constexpr std::array<std::string_view, 5> kActionModeNames = {
    "relative_position", "global_position", "rotor_speeds", "ctbr", "generalized_force"};

/// Named observation pieces, concatenated in the order given (VecEnv::observation_layout()).
enum class ObservationPiece : std::uint8_t {
  kPosition,        ///< p (3), world frame, m
  kVelocity,        ///< v (3), world frame, m/s
  kRotation,        ///< B_I R = R^T (9, row-major): rows are the world axes seen in the body
  kQuaternion,      ///< q = [w, x, y, z] (4), body to world
  kBodyRates,       ///< w_B (3), rad/s
  kPreviousAction,  ///< a_{t-1} as given (clipped), action size; zeros after a reset
  kGateCorners,     ///< 4 opening corners - p of the next gate_lookahead gates (12 each)
  kRotorSpeeds,     ///< w_i / max_speed_i (rotors)
  kTargetRelative,  ///< target - p (3): hover setpoint, trajectory point, next gate centre
  kTargetVelocity,  ///< v_target - v (3): zero target velocity except on a trajectory
};
inline constexpr std::array<std::string_view, 10> kObservationPieceNames = {
    "position",        "velocity",     "rotation",     "quaternion",      "body_rates",
    "previous_action", "gate_corners", "rotor_speeds", "target_relative", "target_velocity"};

/// Reward r_t = sum of weighted terms (Eq. 4.20), each reported separately. A weight of 0 turns a
/// term off. Defaults: Eq. 4.22 and Eq. 4.21.
struct RewardWeights {
  double progress = 1.0;       ///< lambda_1 (d_{t-1} - d_t), d the distance to the target
  double action_rate = -1e-4;  ///< lambda_2 ||a_t - a_{t-1}||^2
  double angular = -2e-4;      ///< lambda_3 ||w_B||
  double crash = -5.0;         ///< r_crash, once, when the episode ends in a crash or flip
  double gate = 0.0;           ///< per gate passed (not in the thesis)
  double distance = 0.0;       ///< times d_t (a hover/tracking penalty; not in the thesis)
  /// Per env step that does not end in a crash (not in the thesis): with a distance penalty, it
  /// keeps an early crash from paying more than staying in the air.
  double alive = 0.0;
};
enum class RewardTerm : std::uint8_t {
  kProgress,
  kActionRate,
  kAngular,
  kCrash,
  kGate,
  kDistance,
  kAlive
};
inline constexpr int kNumRewardTerms = 7;
inline constexpr std::array<std::string_view, kNumRewardTerms> kRewardTermNames = {
    "progress", "action_rate", "angular", "crash", "gate", "distance", "alive"};

/// A closed interval [lo, hi]; lo == hi is a constant.
struct Interval {
  double lo = 0.0, hi = 0.0;
};

/// Drawn independently per env at every reset, uniformly. Scales multiply the model's nominal
/// value ({1, 1}: no change). Perturbations are added to the task's start pose, each axis within
/// +-value.
struct Randomization {
  Interval mass_scale{1.0, 1.0};
  Interval inertia_scale{1.0, 1.0};     ///< J_xx, J_yy, J_zz together
  Interval thrust_scale{1.0, 1.0};      ///< K1, K2, K3 of every rotor together
  Interval motor_time_scale{1.0, 1.0};  ///< tau_rise and tau_fall together
  Interval drag_scale{1.0, 1.0};        ///< body drag x, y, z and rotor drag together
  double wind_speed_max_m_s = 0.0;      ///< uniform direction, speed uniform in [0, max]
  Vec3 position_m = Vec3::Zero();       ///< start position offset, per axis
  Vec3 velocity_m_s = Vec3::Zero();     ///< start velocity, per axis
  Vec3 attitude_rad = Vec3::Zero();     ///< roll, pitch, yaw offsets
  Vec3 body_rate_rad_s = Vec3::Zero();  ///< start body rates, per axis
};

struct EnvConfig {
  Task task = Task::kRacing;
  ActionMode action = ActionMode::kRelativePosition;
  /// Empty: the task's default (racing: exactly Eq. 4.18; see default_observation()).
  std::vector<ObservationPiece> observation;
  int gate_lookahead = 2;  ///< gates in kGateCorners (Eq. 4.18: 2)

  SimConfig sim;                   ///< physics (dt_s = 1 ms by default), noise, disturbances
  double control_rate_hz = 100.0;  ///< env steps per second; 1 / (rate dt_s) must be an integer
  double episode_time_s = 20.0;    ///< truncation (time limit)
  /// Seed of reset() without one; env i's stream is keyed by (seed, i).
  std::uint64_t seed = 0;
  bool observation_float32 = false;

  // Action modes.
  bool normalized_actions = false;
  Vec3 relative_scale_m = Vec3(1.0, 1.0, 1.5);  ///< thesis Sec. 4.4.1
  Vec3 max_body_rate_rad_s = Vec3(10.0, 10.0, 5.0);
  /// Upper end of the thrust action (CTBR, generalized force) as a multiple of the nominal weight
  /// m g; 0: every rotor at full speed. 2 centres a normalised action of 0 on hover.
  double max_thrust_to_weight = 0.0;
  Se3Gains se3_gains;  ///< default: config/controllers/se3.yaml (set by the loader)
  Se3Options se3_options;
  BodyRateGains rate_gains;

  // Termination.
  /// Radius of the sphere that stands for the vehicle in collisions (gate frames, obstacles);
  /// <= 0: the rotor-disc extent of the model (largest rotor arm + 0.1 m).
  double vehicle_radius_m = 0.0;
  /// Flipped when the angle between body z and world z exceeds this (rad).
  double max_tilt_rad = 1.5707963267948966;
  /// Below this height of the body origin the vehicle has hit the ground (m, >= ground height).
  double min_height_m = 0.05;

  // Tasks.
  Vec3 hover_target_m = Vec3(0.0, 0.0, 1.5);
  Vec3 hover_target_range_m = Vec3::Zero();          ///< target drawn within +-range per axis
  Vec3 hover_start_offset_m = Vec3(0.0, 0.0, -0.5);  ///< start = target + offset (+ random)
  Vec3 arena_min_m = Vec3(-10.0, -10.0, -1.0);  ///< hover/trajectory arena (racing: the track's)
  Vec3 arena_max_m = Vec3(10.0, 10.0, 10.0);
  std::shared_ptr<const Reference> reference;  ///< trajectory task
  double reference_time_offset_max_s = 0.0;    ///< random start time along the reference
  Track track;                                 ///< racing task
  int laps = 2;                    ///< racing: the episode ends (not a crash) after this many laps
  bool random_start_gate = false;  ///< racing curriculum: start before a random gate

  RewardWeights reward;
  Randomization randomization;

  // Sensors (docs/rl.md, "Sensors in observations"): each env has these, sampled at most once
  // per env step from the true state (rates <= control_rate_hz; the IMU reads the step's mean
  // acceleration), their latest readings appended to the observation after its pieces.
  std::vector<SensorSpec> sensors;
  std::vector<DepthCameraSpec> depth_cameras;
};

/// The default observation of a task (racing: Eq. 4.18).
std::vector<ObservationPiece> default_observation(Task task);

/// Throws InvalidArgument naming the field for anything a VecEnv cannot run (with the model:
/// rotor count for the action size, the vehicle radius).
void validate(const EnvConfig& config);

/// Name lookups for files and Python: InvalidArgument "unknown <what> 'x' (valid: ...)".
Task task_from_name(std::string_view name);
ActionMode action_mode_from_name(std::string_view name);
ObservationPiece observation_piece_from_name(std::string_view name);

}  // namespace dronetwin::rl
