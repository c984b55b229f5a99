#pragma once
// Experiment files: one YAML document that says which model to fly, how (step, integrator,
// disturbances, noise, wind, ground), from where (initial state), with which input, for how long
// and what to log. Format: docs/experiment-format.md. Parsing is strict, like the model loader:
// an unknown key (with a closest-key suggestion), a missing required key, a wrong type or length
// or a non-finite number is an InvalidArgument whose message starts with the file and names the
// field path ("x.yaml: input.segments[1].start_s: expected a number, got 'a'").
//
//   Experiment e = load_experiment("config/experiments/hover_open_loop.yaml");
//   auto model = std::make_shared<const VehicleModel>(load_vehicle_model(e.model_path));
//   check_against_model(e, *model);          // rotor counts, named by field
//   Simulator sim(model, e.sim_config());
//
// Trap: checks that need the model (a rotor-speed vector must have one entry per rotor) cannot
// run while parsing; call check_against_model() (run_experiment() does) before using the inputs.
//
// Closed loop: `input: {type: controller, controller: ../controllers/pid.yaml, reference: ...}`
// becomes a ControllerLoopInput holding the resolved controller file and the parsed Reference;
// run_experiment() builds the controller with load_controller() and flies it with a ClosedLoop.
//
// Adding an input kind means adding one struct to ExperimentInput and one branch to the parser,
// the model check and the runner; nothing else changes shape.

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "dronetwin/control/reference.hpp"
#include "dronetwin/core/types.hpp"
#include "dronetwin/dynamics/ground.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/estimation/sensor_fusion.hpp"
#include "dronetwin/integrators/integrator.hpp"
#include "dronetwin/model/allocation.hpp"
#include "dronetwin/model/vehicle_model.hpp"
#include "dronetwin/sensors/depth_camera.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"
#include "dronetwin/sim/sim_config.hpp"
#include "dronetwin/world/track.hpp"

namespace dronetwin {

/// Rotor speeds as an experiment states them: stopped, the model's hover speeds, or explicit
/// numbers (rad/s, one per rotor; the count is checked against the model later).
struct RotorSpeedSetting {
  enum class Kind { kStopped, kHover, kValues };
  Kind kind = Kind::kStopped;
  std::vector<double> values_rad_s;

  static RotorSpeedSetting stopped() { return {}; }
  static RotorSpeedSetting hover() { return {Kind::kHover, {}}; }
  static RotorSpeedSetting values(std::vector<double> v) { return {Kind::kValues, std::move(v)}; }

  /// The speeds for `model`: zeros, model.hover_speeds_rad_s(gravity_m_s2) or the values. The
  /// value count must match the rotor count (check_against_model() reports it by field).
  RotorVector resolve(const VehicleModel& model, double gravity_m_s2) const;
};

// ---- inputs -----------------------------------------------------------------------------------

/// `type: constant_rotor_speeds`: one rotor speed reference for the whole run.
struct ConstantRotorSpeedsInput {
  RotorSpeedSetting rotor_speeds;
};

/// One piece of `type: piecewise_rotor_speeds`: from start_s on, until the next segment starts.
struct RotorSpeedSegment {
  double start_s = 0.0;
  RotorSpeedSetting rotor_speeds;
};

/// `type: piecewise_rotor_speeds`: a zero-order-hold schedule of rotor speed references. The first
/// segment starts at 0; starts strictly increase. A segment takes effect at the first physics step
/// whose start time k dt reaches start_s (see segment_start_step()).
struct PiecewiseRotorSpeedsInput {
  std::vector<RotorSpeedSegment> segments;
};

/// `type: constant_generalized_force`: u = [T, tau_x, tau_y, tau_z] (N, N m) for the whole run,
/// allocated to rotor speed references with `allocation` (model/allocation.hpp).
struct ConstantGeneralizedForceInput {
  GeneralizedForce u = GeneralizedForce::Zero();
  AllocationMethod allocation = AllocationMethod::kExact;
};

/// `type: hover`: rotor speed references = the model's hover speeds (for |gravity_m_s2|).
struct HoverInput {};

/// `type: controller`: a controller (a file of config/controllers, docs/controllers.md) tracking
/// a reference in closed loop (control/closed_loop.hpp). The controller runs every
/// f_physics / control_rate_hz physics steps on the measured state; its rotor speed command is
/// held in between.
struct ControllerLoopInput {
  /// Controller file, resolved like Experiment::model_path (the experiment's directory first).
  std::string controller_path;
  /// Must divide the physics rate 1 / physics_dt_s into a whole number of steps (Eq. 3.11).
  double control_rate_hz = 1000.0;
  /// Overrides the controller file's `allocation` (ControllerBase::set_allocation); empty: the
  /// file's choice.
  std::optional<AllocationMethod> allocation;
  /// Pace the run at real time (ClosedLoop::set_real_time); `dronetwin run --real-time` sets it.
  bool real_time = false;
  /// `reference:` in the file (never null after parsing).
  std::shared_ptr<const Reference> reference;
  /// Its `type:` name (setpoint, thesis_pulse, piecewise, circle, figure_eight, waypoints).
  std::string reference_type;
};

/// What drives the rotors: open-loop schedules or a closed-loop controller.
using ExperimentInput =
    std::variant<ConstantRotorSpeedsInput, PiecewiseRotorSpeedsInput, ConstantGeneralizedForceInput,
                 HoverInput, ControllerLoopInput>;

/// The `type:` name of an input ("constant_rotor_speeds", ...).
std::string_view input_type_name(const ExperimentInput& input);

// ---- the experiment ---------------------------------------------------------------------------

/// `estimation:` of an experiment file (docs/experiment-format.md, "Estimation").
struct EstimationSettings {
  /// The IMU and the sensors the filter fuses (names of `sensors:` entries).
  FusionSettings fusion;
  /// `controller_input: estimate` (default) flies the controller on the estimate;
  /// `measured_state` keeps it on the simulator's measured state and only logs the estimate.
  bool control_on_estimate = true;
};

/// Initial condition; default: at rest, level, at the origin (on the ground), rotors stopped.
struct InitialStateSpec {
  Vec3 position_m = Vec3::Zero();
  Vec3 velocity_m_s = Vec3::Zero();
  /// Unit quaternion q_WB (w, x, y, z); `euler_rad` in the file is converted to it.
  Vec4 quaternion_wxyz = Vec4(1.0, 0.0, 0.0, 0.0);
  Vec3 angular_velocity_rad_s = Vec3::Zero();
  RotorSpeedSetting rotor_speeds;
  /// `on_reference: true` (controller inputs only): the parser has set position and velocity to
  /// the reference at t = 0, a level attitude at the reference yaw and hover rotor speeds. Kept
  /// as a record; the fields above already hold the values.
  bool on_reference = false;

  /// The 13-element state [p, v, q, w].
  StateVector state() const;
};

/// `metrics:` (controller inputs only): where the tracking RMSE is taken.
struct MetricsSettings {
  /// [t0, t1] in s, 0 <= t0 < t1; empty: the whole run. Clipped to the time the run reaches.
  std::optional<std::array<double, 2>> window_s;
};

struct LogSettings {
  /// A row at t = 0 and then after every n-th physics step.
  std::int64_t every_n_steps = 1;
  /// Adds F_<term>_{x,y,z}, M_<term>_{x,y,z} (body frame) for every force term.
  bool wrench_breakdown = false;
  /// Adds the measured (noisy) state, meas_x .. meas_wz.
  bool measured = true;
};

struct Experiment {
  std::string name;
  /// Free text, optional.
  std::string description;
  /// The experiment file (or the source name given to parse_experiment), for messages.
  std::string source;
  /// Model file, resolved: relative to the experiment file's directory if it exists there,
  /// otherwise relative to the current directory.
  std::string model_path;
  double duration_s = 0.0;
  /// The simulator's settings: physics step, integrator, motor lag, noise, wind, gravity,
  /// disturbance switches, ground, divergence limits and seed (the file's top-level keys
  /// physics_dt_s, integrator, motor_dynamics, noise, wind_m_s, gravity_m_s2, disturbances,
  /// ground, divergence and seed; docs/experiment-format.md).
  SimConfig sim{};
  InitialStateSpec initial_state{};
  LogSettings log{};
  MetricsSettings metrics{};
  ExperimentInput input = HoverInput{};
  /// `sensors:` in the file: the vehicle's sensors (sensors/sensor_suite.hpp), each its type's
  /// defaults (SensorSpec::defaults) with the file's keys laid over them, validated against
  /// physics_dt_s, names unique; empty: no sensors (the default). A runner builds a SensorSuite
  /// from them; docs/experiment-format.md, "Sensors".
  std::vector<SensorSpec> sensors;
  /// The `sensors:` items of type depth_camera: a run renders their frames into <name>.npy
  /// (sensors/depth_camera.hpp; docs/sensors.md, "Depth camera").
  std::vector<DepthCameraSpec> depth_cameras;
  /// `estimation:` in the file: an error-state EKF on the sensors (estimation/sensor_fusion.hpp),
  /// logged as est_*; with controller_input: estimate the controller flies on it. Needs sensors.
  std::optional<EstimationSettings> estimation;
  /// `scene:` in the file: a track file (docs/track-format.md) whose gates and obstacles the
  /// vehicle may not touch (the run ends with status collided, naming the object) and which the
  /// range finder, optical flow and depth camera see. Resolved like model_path; empty: none.
  std::string scene_path;
  std::shared_ptr<const Track> scene;

  /// Run settings for the Simulator, validated (InvalidArgument naming the field otherwise).
  SimConfig sim_config() const;
  /// Physics steps of the run: duration_s / physics_dt_s rounded up (a duration within 1e-9 steps
  /// of a whole multiple gives exactly that multiple).
  std::int64_t num_steps() const;
  /// |gravity|, the g used for hover speeds.
  double gravity_magnitude() const { return sim.environment.gravity_W_m_s2.norm(); }
};

/// Reads and checks an experiment file (everything that does not need the model; the model file
/// must exist). Throws InvalidArgument "<path>: <field>: <what>".
Experiment load_experiment(const std::string& path);

/// Same, from YAML text; `source_name` stands for the file in messages, and its directory is
/// where a relative model path is looked up first.
Experiment parse_experiment(const std::string& yaml_text, const std::string& source_name);

/// A `sensors:` list on its own (a YAML or JSON sequence of sensor maps, the format of the
/// experiment file's key, docs/experiment-format.md), checked against `physics_dt_s`. Python's
/// SensorSuite builds its specs with it. Errors name `source_name` and "sensors[i].<field>".
std::vector<SensorSpec> parse_sensor_specs(const std::string& yaml_text,
                                           const std::string& source_name, double physics_dt_s);

/// Checks the parts that depend on the model: every rotor-speed vector (initial state and input)
/// has one number per rotor of `model`. Throws InvalidArgument naming the field, e.g.
/// "x.yaml: input.segments[1].rotor_speeds_rad_s: expected 4 numbers (rotors of qdrone2), got 3".
void check_against_model(const Experiment& experiment, const VehicleModel& model);

/// Re-checks the fields a caller may override after loading (seed is free; duration_s > 0 and
/// finite, the run settings, a controller input's rate against physics_dt_s, and each sensor
/// (validate(SensorSpec, physics_dt_s), names unique)); used by the CLI after --duration.
void validate(const Experiment& experiment);

/// First physics step k (time k dt) at which a segment starting at `start_s` is in effect;
/// INT64_MAX (never) for a start beyond the int64 range of steps.
std::int64_t segment_start_step(double start_s, double dt_s);

}  // namespace dronetwin
