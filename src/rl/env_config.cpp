#include "dronetwin/rl/env_config.hpp"

#include <cmath>
#include <string>

#include "dronetwin/core/error.hpp"

namespace dronetwin::rl {

namespace {

template <std::size_t N>
std::size_t lookup(std::string_view name, const std::array<std::string_view, N>& names,
                   const char* what) {
  for (std::size_t i = 0; i < N; ++i)
    if (names[i] == name) return i;
  std::string valid;
  for (std::size_t i = 0; i < N; ++i) valid += (i ? ", " : "") + std::string(names[i]);
  throw InvalidArgument("unknown " + std::string(what) + " '" + std::string(name) +
                        "' (valid: " + valid + ")");
}

void check_interval(const Interval& i, const char* field, bool positive) {
  require(std::isfinite(i.lo) && std::isfinite(i.hi) && i.lo <= i.hi, "EnvConfig: ", field,
          ": expected finite [lo, hi] with lo <= hi, got [", i.lo, ", ", i.hi, "]");
  if (positive)
    require(i.lo > 0.0, "EnvConfig: ", field, ": expected scale factors > 0, got [", i.lo, ", ",
            i.hi, "]");
}

void check_nonnegative(const Vec3& v, const char* field) {
  require(v.allFinite() && (v.array() >= 0.0).all(), "EnvConfig: ", field,
          ": expected three finite numbers >= 0, got [", v.transpose(), "]");
}

}  // namespace

std::vector<ObservationPiece> default_observation(Task task) {
  using P = ObservationPiece;
  switch (task) {
    case Task::kRacing:  // Eq. 4.18
      return {P::kPosition,  P::kVelocity,       P::kRotation,
              P::kBodyRates, P::kPreviousAction, P::kGateCorners};
    case Task::kHover:
      return {P::kTargetRelative, P::kVelocity, P::kRotation, P::kBodyRates, P::kPreviousAction};
    case Task::kTrajectory:
      return {P::kTargetRelative, P::kTargetVelocity, P::kRotation, P::kBodyRates,
              P::kPreviousAction};
  }
  return {};
}

void validate(const EnvConfig& c) {
  dronetwin::validate(c.sim);
  require(std::isfinite(c.control_rate_hz) && c.control_rate_hz > 0.0,
          "EnvConfig: control_rate_hz: expected a positive number, got ", c.control_rate_hz);
  const double substeps = 1.0 / (c.control_rate_hz * c.sim.dt_s);
  require(substeps >= 0.5 && std::abs(substeps - std::round(substeps)) < 1e-9 * substeps,
          "EnvConfig: control_rate_hz: one env step must be a whole number of physics steps "
          "(1 / (control_rate_hz * dt_s)), got ",
          substeps, " (control_rate_hz ", c.control_rate_hz, ", dt_s ", c.sim.dt_s, ")");
  require(std::isfinite(c.episode_time_s) && c.episode_time_s > 0.0,
          "EnvConfig: episode_time_s: expected a positive number, got ", c.episode_time_s);
  require(c.gate_lookahead >= 1 && c.gate_lookahead <= 8,
          "EnvConfig: gate_lookahead: expected 1 to 8, got ", c.gate_lookahead);
  for (std::size_t i = 0; i < c.observation.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j)
      require(c.observation[i] != c.observation[j], "EnvConfig: observation[", i, "]: '",
              kObservationPieceNames[static_cast<std::size_t>(c.observation[i])],
              "' is listed twice");
    if (c.observation[i] == ObservationPiece::kGateCorners)
      require(c.task == Task::kRacing, "EnvConfig: observation[", i,
              "]: 'gate_corners' needs the racing task, got task '",
              kTaskNames[static_cast<std::size_t>(c.task)], "'");
  }
  require(c.relative_scale_m.allFinite() && (c.relative_scale_m.array() > 0.0).all(),
          "EnvConfig: relative_scale_m: expected three positive numbers, got [",
          c.relative_scale_m.transpose(), "]");
  require(std::isfinite(c.max_thrust_to_weight) && c.max_thrust_to_weight >= 0.0,
          "EnvConfig: max_thrust_to_weight: expected a number >= 0 (0: full rotor range), got ",
          c.max_thrust_to_weight);
  require(c.max_body_rate_rad_s.allFinite() && (c.max_body_rate_rad_s.array() > 0.0).all(),
          "EnvConfig: max_body_rate_rad_s: expected three positive numbers, got [",
          c.max_body_rate_rad_s.transpose(), "]");
  require(std::isfinite(c.vehicle_radius_m),
          "EnvConfig: vehicle_radius_m: expected a number (<= 0 for the model's extent), got ",
          c.vehicle_radius_m);
  require(std::isfinite(c.max_tilt_rad) && c.max_tilt_rad > 0.0 && c.max_tilt_rad <= M_PI,
          "EnvConfig: max_tilt_rad: expected (0, pi], got ", c.max_tilt_rad);
  require(std::isfinite(c.min_height_m), "EnvConfig: min_height_m: expected a number, got ",
          c.min_height_m);
  require(c.hover_target_m.allFinite() && c.hover_start_offset_m.allFinite(),
          "EnvConfig: hover_target_m / hover_start_offset_m: expected finite numbers");
  check_nonnegative(c.hover_target_range_m, "hover_target_range_m");
  require(c.arena_min_m.allFinite() && c.arena_max_m.allFinite() &&
              (c.arena_min_m.array() < c.arena_max_m.array()).all(),
          "EnvConfig: arena: expected min < max on every axis, got min [",
          c.arena_min_m.transpose(), "], max [", c.arena_max_m.transpose(), "]");
  require(c.laps >= 0, "EnvConfig: laps: expected >= 0 (0: no limit), got ", c.laps);
  require(std::isfinite(c.reference_time_offset_max_s) && c.reference_time_offset_max_s >= 0.0,
          "EnvConfig: reference_time_offset_max_s: expected a number >= 0, got ",
          c.reference_time_offset_max_s);
  const RewardWeights& w = c.reward;
  for (double v : {w.progress, w.action_rate, w.angular, w.crash, w.gate, w.distance})
    require(std::isfinite(v), "EnvConfig: reward: expected finite weights, got ", v);
  const Randomization& r = c.randomization;
  check_interval(r.mass_scale, "randomization.mass_scale", true);
  check_interval(r.inertia_scale, "randomization.inertia_scale", true);
  check_interval(r.thrust_scale, "randomization.thrust_scale", true);
  check_interval(r.motor_time_scale, "randomization.motor_time_scale", true);
  check_interval(r.drag_scale, "randomization.drag_scale", true);
  require(std::isfinite(r.wind_speed_max_m_s) && r.wind_speed_max_m_s >= 0.0,
          "EnvConfig: randomization.wind_speed_max_m_s: expected a number >= 0, got ",
          r.wind_speed_max_m_s);
  check_nonnegative(r.position_m, "randomization.position_m");
  check_nonnegative(r.velocity_m_s, "randomization.velocity_m_s");
  check_nonnegative(r.attitude_rad, "randomization.attitude_rad");
  check_nonnegative(r.body_rate_rad_s, "randomization.body_rate_rad_s");
  // Sensors sample at most once per env step.
  const double control_dt_s = 1.0 / c.control_rate_hz;
  std::vector<std::string> names;
  for (std::size_t i = 0; i < c.sensors.size(); ++i) {
    try {
      validate(c.sensors[i], control_dt_s);
    } catch (const InvalidArgument& e) {
      throw InvalidArgument(detail::concat("EnvConfig: sensors[", i, "] (", c.sensors[i].name, ").",
                                           e.what(), " (control_rate_hz ", c.control_rate_hz, ")"));
    }
    names.push_back(c.sensors[i].name);
  }
  for (std::size_t i = 0; i < c.depth_cameras.size(); ++i) {
    const DepthCameraParameters& p = c.depth_cameras[i].parameters;
    try {
      validate(p);
    } catch (const InvalidArgument& e) {
      throw InvalidArgument(
          detail::concat("EnvConfig: depth camera '", c.depth_cameras[i].name, "': ", e.what()));
    }
    require(p.rate_hz <= c.control_rate_hz * (1.0 + 1e-9), "EnvConfig: depth camera '",
            c.depth_cameras[i].name, "': rate_hz: expected at most control_rate_hz (",
            c.control_rate_hz, " Hz), got ", p.rate_hz);
    names.push_back(c.depth_cameras[i].name);
  }
  for (std::size_t i = 0; i < names.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      require(names[i] != names[j], "EnvConfig: sensors: the name '", names[i], "' is used twice");
  switch (c.task) {
    case Task::kTrajectory:
      require(c.reference != nullptr,
              "EnvConfig: reference: the trajectory task needs a reference to follow, got none");
      break;
    case Task::kRacing:
      require(!c.track.gates.empty(),
              "EnvConfig: track: the racing task needs a track with gates, got none");
      break;
    case Task::kHover:
      break;
  }
}

Task task_from_name(std::string_view name) {
  return static_cast<Task>(lookup(name, kTaskNames, "task"));
}
ActionMode action_mode_from_name(std::string_view name) {
  return static_cast<ActionMode>(lookup(name, kActionModeNames, "action mode"));
}
ObservationPiece observation_piece_from_name(std::string_view name) {
  return static_cast<ObservationPiece>(lookup(name, kObservationPieceNames, "observation piece"));
}

}  // namespace dronetwin::rl
