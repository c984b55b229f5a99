// Experiment runner: model + Simulator + controller (or the open-loop input as one) flown by
// ClosedLoop::run() + CSV log + sidecar + summary.json.
#include "dronetwin/app/run_experiment.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <system_error>
#include <utility>
#include <variant>
#include <vector>

#include "depth_recording.hpp"
#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/app/metrics.hpp"
#include "dronetwin/app/open_loop_input.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/ground.hpp"
#include "dronetwin/estimation/sensor_fusion.hpp"
#include "dronetwin/logging/csv_log.hpp"
#include "dronetwin/logging/json_writer.hpp"
#include "dronetwin/logging/log_metadata.hpp"
#include "dronetwin/logging/output_folder.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"
#include "dronetwin/world/collision.hpp"
#include "vehicle_run.hpp"

namespace dronetwin {

namespace {

namespace fs = std::filesystem;

/// Statistics of a controller diagnostic over the updates where it was finite.
DiagnosticSummary summarise(const std::string& name, std::vector<double> v) {
  DiagnosticSummary d;
  d.name = name;
  d.count = static_cast<std::int64_t>(v.size());
  if (v.empty()) return d;
  std::sort(v.begin(), v.end());
  for (const double x : v) d.sum += x;
  d.mean = d.sum / static_cast<double>(v.size());
  const std::size_t n = v.size();
  d.median = n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  // Nearest rank: the smallest value with at least 99 % of the samples at or below it.
  const auto rank = static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(n)));
  d.p99 = v[std::max<std::size_t>(rank, 1) - 1];
  d.max = v.back();
  return d;
}

/// The sensors of a run and the estimator on them, sensed once per physics step before the
/// controller (ClosedLoop::set_state_source): the controller reads the estimate when the
/// experiment asks for it, else the simulator's measured state.
class RunSensing final : public StateSource {
 public:
  RunSensing(const Experiment& e, const Simulator& sim, SensorSuite& suite)
      : sim_(sim), suite_(suite), previous_(sim.state()) {
    if (e.estimation) {
      fusion_.emplace(e.sensors, e.estimation->fusion, sim.state());
      on_estimate_ = e.estimation->control_on_estimate;
    }
  }
  void sense(const Simulator& sim) override {
    suite_.update(sim.step_count(), make_sensor_truth(sim, previous_));
    previous_ = sim.state();
    if (fusion_) fusion_->process(suite_);
  }
  const StateVector& state() const override {
    return on_estimate_ ? fusion_->estimate() : sim_.measured_state();
  }
  const SensorFusion* fusion() const { return fusion_ ? &*fusion_ : nullptr; }

 private:
  const Simulator& sim_;
  SensorSuite& suite_;
  StateVector previous_;
  std::optional<SensorFusion> fusion_;
  bool on_estimate_ = false;
};

/// What a run shows ClosedLoop::run(): one CSV row at t = 0 and after every log.every_n_steps-th
/// step (and the last good state when the run fails), statistics over every physics step, and
/// for controller inputs the tracking error and the controller's diagnostics.
class RunObserver final : public LoopObserver {
 public:
  RunObserver(const Experiment& e, const ControllerLoopInput* controller_input,
              const ControllerBase& controller, const Simulator& sim, const SensorSuite& sensors,
              const RunSensing* sensing, DepthRecording& depth, CsvLogWriter& log,
              RunSummary& summary, bool interaction)
      : e_(e),
        interaction_(interaction),
        input_(controller_input),
        sensors_(sensors),
        sensing_(sensing),
        depth_(depth),
        log_(log),
        s_(summary),
        tracking_(e.sim.dt_s, e.metrics.window_s),
        row_(log.num_columns()) {
    if (input_ != nullptr) diag_names_ = controller.diagnostic_names();
    diag_now_.assign(diag_names_.size(), 0.0);
    diag_values_.resize(diag_names_.size());
    // The statistics start at the initial state, even if the controller fails before t = 0.
    s_.min_z_m = s_.max_z_m = sim.state()[state_index::kPosition + 2];
  }

  void observe(const ClosedLoop& loop) override {
    const Simulator& sim = loop.simulator();
    const StateVector& x = sim.state();
    depth_.record(sim);
    if (sensing_ != nullptr && sensing_->fusion() != nullptr) {
      // The estimate against the truth at every step (RunSensing sensed this step already).
      const StateVector& est = sensing_->fusion()->estimate();
      est_p2_ += (est.segment<3>(0) - x.segment<3>(0)).squaredNorm();
      est_v2_ += (est.segment<3>(3) - x.segment<3>(3)).squaredNorm();
      const double c = std::min(1.0, std::abs(Vec4(est.segment<4>(6)).dot(Vec4(x.segment<4>(6)))));
      est_a2_ += std::pow(2.0 * std::acos(c), 2);
      ++est_n_;
    }
    const double z = x[state_index::kPosition + 2];
    s_.min_z_m = std::min(s_.min_z_m, z);
    s_.max_z_m = std::max(s_.max_z_m, z);
    s_.max_speed_m_s = std::max(s_.max_speed_m_s, x.segment<3>(state_index::kVelocity).norm());
    s_.max_tilt_rad = std::max(s_.max_tilt_rad, tilt_angle_rad(x));
    if (input_ != nullptr) {
      tracking_.add(sim.step_count(), x, loop.reference().at(sim.time_s()));
      if (loop.control_updates() != updates_seen_ && !diag_names_.empty()) {
        loop.controller().diagnostics(diag_now_.data());
        for (std::size_t i = 0; i < diag_now_.size(); ++i)
          if (std::isfinite(diag_now_[i])) diag_values_[i].push_back(diag_now_[i]);
      }
      updates_seen_ = loop.control_updates();
    }
    if (sim.step_count() % e_.log.every_n_steps == 0) write_row(loop);
    if (progress_ && observed_++ % kProgressEverySteps == 0) progress_(sim.time_s(), e_.duration_s);
  }

  void finish(const ClosedLoop& loop, const StepResult& result) override {
    // A failed run also logs its last good state, for diagnosis.
    if (!result.ok() && logged_step_ != loop.simulator().step_count()) write_row(loop);
    if (progress_) progress_(loop.simulator().time_s(), e_.duration_s);
  }

  void set_progress(RunProgressFn progress) { progress_ = std::move(progress); }

  std::optional<EstimationSummary> estimation_summary() const {
    if (sensing_ == nullptr || sensing_->fusion() == nullptr) return std::nullopt;
    EstimationSummary s;
    const double n = static_cast<double>(std::max<std::int64_t>(est_n_, 1));
    s.position_rmse_m = std::sqrt(est_p2_ / n);
    s.velocity_rmse_m_s = std::sqrt(est_v2_ / n);
    s.attitude_rmse_rad = std::sqrt(est_a2_ / n);
    s.samples = est_n_;
    s.updates = sensing_->fusion()->updates();
    s.controller_on_estimate = e_.estimation->control_on_estimate;
    return s;
  }

  ClosedLoopSummary closed_loop_summary(const ClosedLoop& loop) const {
    const double end_s = loop.simulator().time_s();
    const ControllerBase& controller = loop.controller();
    ClosedLoopSummary c;
    c.controller_name = std::string(controller.name());
    c.controller_path = input_->controller_path;
    c.allocation = std::string(allocation_name(controller.allocation()));
    c.reference_type = input_->reference_type;
    c.reference = input_->reference->describe();
    c.control_rate_hz = input_->control_rate_hz;
    c.real_time = input_->real_time;
    c.rmse = tracking_.rmse();
    c.rmse_window_s = tracking_.window_s(end_s);
    c.rmse_samples = tracking_.samples();
    c.control_updates = loop.control_updates();
    c.saturated_updates = loop.saturated_updates();
    c.saturated_fraction = c.control_updates > 0 ? static_cast<double>(c.saturated_updates) /
                                                       static_cast<double>(c.control_updates)
                                                 : 0.0;
    for (std::size_t i = 0; i < diag_names_.size(); ++i)
      c.diagnostics.push_back(summarise(diag_names_[i], diag_values_[i]));
    return c;
  }

 private:
  /// One log row (layout of log_columns()).
  void write_row(const ClosedLoop& loop) {
    const Simulator& sim = loop.simulator();
    std::size_t k = 0;
    row_[k++] = sim.time_s();
    const StateVector& x = sim.state();
    for (int i = 0; i < kStateSize; ++i) row_[k++] = x[i];
    const int n = sim.model().num_rotors();
    for (int i = 0; i < n; ++i) row_[k++] = sim.rotor_speeds_rad_s()[i];
    for (int i = 0; i < n; ++i) row_[k++] = sim.rotor_speed_reference_rad_s()[i];
    if (e_.log.measured) {
      const StateVector& m = sim.measured_state();
      for (int i = 0; i < kStateSize; ++i) row_[k++] = m[i];
    }
    row_[k++] = sim.contact().in_contact ? 1.0 : 0.0;
    row_[k++] = sim.contact().crashed ? 1.0 : 0.0;
    if (e_.sim.wind.varies())
      for (int i = 0; i < 3; ++i) row_[k++] = sim.wind_W_m_s()[i];
    if (e_.sim.battery.enabled) {
      row_[k++] = sim.battery().soc;
      row_[k++] = sim.battery().voltage_V;
      row_[k++] = sim.battery().current_A;
    }
    if (e_.sim.payload.enabled) {
      const PayloadState& p = sim.payload();
      for (int i = 0; i < 3; ++i) row_[k++] = p.position_W_m[i];
      for (int i = 0; i < 3; ++i) row_[k++] = p.velocity_W_m_s[i];
      const SwingAngles a = sim.swing_angles();
      row_[k++] = a.gamma1_rad;
      row_[k++] = a.gamma2_rad;
      row_[k++] = a.gamma1_rate_rad_s;
      row_[k++] = a.gamma2_rate_rad_s;
      row_[k++] = sim.payload_tension_N();
    }
    if (interaction_) {
      const SimData& d = sim.data();
      for (int i = 0; i < 3; ++i) row_[k++] = d.interaction_flow_W_m_s[i];
      for (int i = 0; i < 6; ++i) row_[k++] = d.interaction_wrench_B[i];
    }
    if (e_.log.wrench_breakdown) {
      const WrenchBreakdown b = sim.wrench_breakdown();
      for (const Wrench<double>& w : b.terms) {
        for (int i = 0; i < 3; ++i) row_[k++] = w.force_B[i];
        for (int i = 0; i < 3; ++i) row_[k++] = w.moment_B[i];
      }
    }
    for (int i = 0; i < sensors_.size(); ++i) {
      const SensorReading& r = sensors_.latest(i);
      row_[k++] = r.stamp_s;
      for (int j = 0; j < r.size; ++j) row_[k++] = r.values[static_cast<std::size_t>(j)];
    }
    depth_.write_columns(row_, k);
    if (sensing_ != nullptr && sensing_->fusion() != nullptr) {
      const StateVector& est = sensing_->fusion()->estimate();
      for (int i = 0; i < kStateSize; ++i) row_[k++] = est[i];
    }
    if (input_ != nullptr) {
      // ref_x, ref_y, ref_z, ref_yaw, u_T, u_tau_x, u_tau_y, u_tau_z, saturated, diagnostics
      const ReferencePoint r = loop.reference().at(sim.time_s());
      for (int i = 0; i < 3; ++i) row_[k++] = r.position_m[i];
      row_[k++] = r.yaw_rad;
      for (int i = 0; i < 4; ++i) row_[k++] = loop.last_command()[i];
      const bool saturated = loop.controller().level() == ControlLevel::kGeneralizedForce &&
                             loop.last_allocation().saturated;
      row_[k++] = saturated ? 1.0 : 0.0;
      if (!diag_names_.empty()) {
        loop.controller().diagnostics(row_.data() + k);
        k += diag_names_.size();
      }
    }
    log_.write_row(row_);
    logged_step_ = sim.step_count();
  }

  const Experiment& e_;
  bool interaction_;  // the downwash_* columns (a fleet's vehicle)
  const ControllerLoopInput* input_;
  const SensorSuite& sensors_;
  const RunSensing* sensing_;
  DepthRecording& depth_;
  double est_p2_ = 0.0, est_v2_ = 0.0, est_a2_ = 0.0;
  std::int64_t est_n_ = 0;
  CsvLogWriter& log_;
  RunSummary& s_;
  TrackingRmse tracking_;
  std::vector<double> row_;
  std::int64_t logged_step_ = -1;
  std::int64_t updates_seen_ = 0;
  std::vector<std::string> diag_names_;
  std::vector<double> diag_now_;
  std::vector<std::vector<double>> diag_values_;  // finite values per diagnostic, every update
  RunProgressFn progress_;
  std::int64_t observed_ = 0;
};

}  // namespace

std::string summary_to_json(const RunSummary& s) {
  using json::json_array;
  using json::json_number;
  using json::JsonObject;
  using namespace state_index;
  const StateVector& x = s.final_state;
  JsonObject state(2);
  state.num("t_s", s.final_time_s)
      .raw("position_m", json_array(Vec3(x.segment<3>(kPosition))))
      .raw("velocity_m_s", json_array(Vec3(x.segment<3>(kVelocity))))
      .raw("quaternion_wxyz", json_array(Vec4(x.segment<4>(kQuaternion))))
      .raw("angular_velocity_rad_s", json_array(Vec3(x.segment<3>(kAngularVelocity))))
      .raw("rotor_speeds_rad_s", json_array(s.final_rotor_speeds_rad_s));
  JsonObject j(0);
  j.str("dronetwin_version", s.version)
      .str("experiment", s.experiment_name)
      .str("experiment_path", s.experiment_path)
      .str("model", s.model_name)
      .str("model_path", s.model_path)
      .raw("seed", std::to_string(s.seed))
      .num("dt_s", s.dt_s)
      .str("integrator", integrator_name(s.integrator))
      .str("input_type", s.input_type)
      .integer("steps_requested", s.steps_requested)
      .integer("steps", s.steps)
      .num("duration_s", s.duration_s)
      .str("status", status_name(s.status))
      .str("failure_message", s.failure_message)
      .str("scene_path", s.scene_path)
      .str("collided_with", s.collided_with)
      .raw("final_state", state.done())
      .num("min_z_m", s.min_z_m)
      .num("max_z_m", s.max_z_m)
      .num("max_speed_m_s", s.max_speed_m_s)
      .num("max_tilt_rad", s.max_tilt_rad)
      .boolean("crashed", s.crashed)
      .integer("touchdowns", s.touchdowns)
      .num("max_touchdown_speed_m_s", s.max_touchdown_speed_m_s);
  if (s.closed_loop) {
    const ClosedLoopSummary& c = *s.closed_loop;
    JsonObject controller(2);
    controller.str("name", c.controller_name)
        .str("path", c.controller_path)
        .str("allocation", c.allocation);
    JsonObject rmse(2);
    rmse.num("x", c.rmse[0]).num("y", c.rmse[1]).num("z", c.rmse[2]).num("yaw", c.rmse[3]);
    j.raw("controller", controller.done())
        .str("reference_type", c.reference_type)
        .str("reference", c.reference)
        .num("control_rate_hz", c.control_rate_hz)
        .boolean("real_time", c.real_time)
        .raw("rmse", rmse.done())
        .raw("rmse_window_s", json_array(Eigen::Vector2d(c.rmse_window_s[0], c.rmse_window_s[1])))
        .integer("rmse_samples", c.rmse_samples)
        .integer("control_updates", c.control_updates)
        .integer("saturated_updates", c.saturated_updates)
        .num("saturated_fraction", c.saturated_fraction);
    if (!c.diagnostics.empty()) {
      JsonObject diag(2);
      for (const DiagnosticSummary& d : c.diagnostics) {
        JsonObject one(4);
        one.integer("count", d.count)
            .num("sum", d.sum)
            .num("mean", d.mean)
            .num("median", d.median)
            .num("p99", d.p99)
            .num("max", d.max);
        diag.raw(d.name, one.done());
      }
      j.raw("diagnostics", diag.done());
    }
  }
  if (s.estimation) {
    const EstimationSummary& es = *s.estimation;
    JsonObject est(2);
    est.num("position_rmse_m", es.position_rmse_m)
        .num("velocity_rmse_m_s", es.velocity_rmse_m_s)
        .num("attitude_rmse_rad", es.attitude_rmse_rad)
        .integer("samples", es.samples)
        .integer("updates", es.updates)
        .boolean("controller_on_estimate", es.controller_on_estimate);
    j.raw("estimation", est.done());
  }
  if (!s.depth_frames.empty()) {
    std::string frames = "[";
    for (std::size_t i = 0; i < s.depth_frames.size(); ++i) {
      const DepthFramesSummary& d = s.depth_frames[i];
      JsonObject one(4);
      one.str("name", d.name)
          .str("path", d.path)
          .raw("shape", detail::concat("[", d.frames, ", ", d.height_px, ", ", d.width_px, "]"))
          .str("dtype", "float32");
      frames += (i ? ", " : "") + one.done();
    }
    j.raw("depth_frames", frames + "]");
  }
  std::string warnings = "[";
  for (std::size_t i = 0; i < s.warnings.size(); ++i)
    warnings += (i ? ", " : "") + json::json_string(s.warnings[i]);
  j.raw("warnings", warnings + "]");
  j.integer("log_rows", s.log_rows)
      .str("log_path", s.log_path)
      .str("metadata_path", s.metadata_path)
      .num("wall_clock_s", s.wall_clock_s)
      .num("real_time_factor", s.real_time_factor);
  return j.done() + "\n";
}

namespace {

/// True when the experiment flies or starts at the model's hover rotor speeds.
bool uses_hover_speeds(const Experiment& e) {
  using Kind = RotorSpeedSetting::Kind;
  if (e.initial_state.rotor_speeds.kind == Kind::kHover || e.initial_state.on_reference)
    return true;
  if (std::holds_alternative<HoverInput>(e.input)) return true;
  if (const auto* c = std::get_if<ConstantRotorSpeedsInput>(&e.input))
    return c->rotor_speeds.kind == Kind::kHover;
  if (const auto* p = std::get_if<PiecewiseRotorSpeedsInput>(&e.input)) {
    for (const RotorSpeedSegment& s : p->segments)
      if (s.rotor_speeds.kind == Kind::kHover) return true;
  }
  return false;
}

/// The sidecar of a run (log_metadata.hpp), everything but the columns.
LogMetadata run_metadata(const Experiment& e, const VehicleModel& model,
                         std::optional<std::string> model_hash) {
  LogMetadata m;
  m.dronetwin_version = std::string(version());
  m.experiment = e.name;
  m.experiment_path = e.source;
  m.input_type = std::string(input_type_name(e.input));
  m.model = model.name();
  m.model_path = e.model_path;
  m.model_hash = std::move(model_hash);
  m.seed = e.sim.seed;
  m.dt_s = e.sim.dt_s;
  m.integrator = e.sim.integrator;
  m.motor_dynamics = e.sim.motor_dynamics;
  m.log_every_n_steps = e.log.every_n_steps;
  m.log_rate_hz = 1.0 / (e.sim.dt_s * static_cast<double>(e.log.every_n_steps));
  if (const auto* in = std::get_if<ControllerLoopInput>(&e.input)) {
    m.controller_path = in->controller_path;
    m.control_rate_hz = in->control_rate_hz;
  }
  m.noise = e.sim.noise.enabled;
  m.disturbances = e.sim.disturbances;
  m.ground = e.sim.ground.enabled;
  m.wind_m_s = e.sim.environment.wind_W_m_s;
  m.gravity_m_s2 = e.sim.environment.gravity_W_m_s2;
  m.num_rotors = model.num_rotors();
  return m;
}

/// The hash of the model file when `model` is what that file describes (compared through the
/// full-precision YAML of both specs, which leaves out only the source path); empty when the
/// model given in memory differs from the file or the file cannot be read or parsed.
std::optional<std::string> hash_if_same_model(const std::string& path, const VehicleModel& model) {
  try {
    const std::string text = read_text_file(path, "model file");
    if (vehicle_spec_to_yaml(parse_vehicle_spec(text, path)) == vehicle_spec_to_yaml(model.spec()))
      return content_hash(text);
  } catch (const InvalidArgument&) {
  }
  return std::nullopt;
}

RunSummary run(const Experiment& e, std::shared_ptr<const VehicleModel> model,
               const std::string& out_dir, bool overwrite, std::optional<std::string> model_hash,
               const RunProgressFn& progress);

}  // namespace

RunSummary run_experiment(const Experiment& e, const std::string& out_dir, bool overwrite,
                          const RunProgressFn& progress) {
  validate(e);
  // Read once: the model flown is exactly the text hashed.
  const std::string text = read_text_file(e.model_path, "model file");
  auto model =
      std::make_shared<const VehicleModel>(VehicleModel(parse_vehicle_spec(text, e.model_path)));
  return run(e, std::move(model), out_dir, overwrite, content_hash(text), progress);
}

RunSummary run_experiment(const Experiment& e, std::shared_ptr<const VehicleModel> model,
                          const std::string& out_dir, bool overwrite,
                          const RunProgressFn& progress) {
  require(model != nullptr, e.source, ": run_experiment: the model is null");
  validate(e);
  std::optional<std::string> hash = hash_if_same_model(e.model_path, *model);
  return run(e, std::move(model), out_dir, overwrite, std::move(hash), progress);
}

namespace app_detail {

struct VehicleRun::Impl {
  Impl(const Experiment& experiment, std::shared_ptr<const VehicleModel> m)
      : e(experiment), model(std::move(m)), sim(model, e.sim_config()) {}
  Experiment e;
  std::shared_ptr<const VehicleModel> model;
  Simulator sim;
  const ControllerLoopInput* controller_input = nullptr;
  std::unique_ptr<ControllerBase> controller;
  std::shared_ptr<const Reference> reference;
  std::optional<ClosedLoop> loop;
  std::optional<SensorSuite> sensors;
  std::optional<RunSensing> sensing;
  std::optional<OutputFolder> out;
  RunSummary s;
  std::optional<CsvLogWriter> log;
  std::optional<DepthRecording> depth;
  std::optional<RunObserver> observer;
  std::chrono::steady_clock::time_point start;
};

VehicleRun::VehicleRun(const Experiment& experiment, std::shared_ptr<const VehicleModel> model,
                       const std::string& out_dir, bool overwrite,
                       std::optional<std::string> model_hash, bool interaction_columns,
                       std::vector<std::string> more_inputs) {
  check_against_model(experiment, *model);
  impl_ = std::make_unique<Impl>(experiment, std::move(model));
  Impl& r = *impl_;
  const Experiment& e = r.e;
  Simulator& sim = r.sim;
  const std::shared_ptr<const VehicleModel>& m = r.model;
  try {
    sim.reset(e.initial_state.state(),
              e.initial_state.rotor_speeds.resolve(*m, e.gravity_magnitude()));
  } catch (const InvalidArgument& err) {
    throw InvalidArgument(e.source + ": initial_state: " + err.what());
  }
  if (e.scene != nullptr) {
    // A start inside an object is a mistake in the files, not a crash to fly into.
    const SceneContact at_start =
        find_scene_contact(*e.scene, m->collision_shape(), sim.state(), sim.state());
    require(!at_start, e.source, ": initial_state: the vehicle's collision shape (",
            collision_kind_name(m->collision_shape().kind), ", ", e.model_path, ") starts inside ",
            describe_contact(*e.scene, at_start), " of the scene ", e.scene_path);
    sim.set_scene(e.scene);
  }
  // Every experiment flies through a ClosedLoop: a controller input with its controller and
  // reference at its rate, an open-loop input as a schedule at the physics rate. Built before
  // any file is touched: a bad controller file throws here.
  r.controller_input = std::get_if<ControllerLoopInput>(&e.input);
  const ControllerLoopInput* controller_input = r.controller_input;
  double control_rate_hz = 1.0 / e.sim.dt_s;
  if (controller_input != nullptr) {
    try {
      r.controller =
          load_controller(controller_input->controller_path, m, controller_input->control_rate_hz);
    } catch (const InvalidArgument& err) {
      throw InvalidArgument(e.source + ": input.controller: " + err.what());
    }
    if (controller_input->allocation) r.controller->set_allocation(*controller_input->allocation);
    r.reference = controller_input->reference;
    control_rate_hz = controller_input->control_rate_hz;
  } else {
    r.controller = std::make_unique<OpenLoopInput>(e, m);
    r.reference = std::make_shared<SetpointReference>(Vec3::Zero());
  }
  r.controller->reset();
  r.loop.emplace(sim, *r.controller, *r.reference, control_rate_hz);
  ClosedLoop& loop = *r.loop;
  try {
    r.sensors.emplace(e.sensors, e.sim.dt_s, m->num_rotors(), e.sim.seed);
  } catch (const InvalidArgument& err) {
    throw InvalidArgument(e.source + ": " + err.what());
  }
  const std::vector<std::string> diagnostic_names =
      controller_input != nullptr ? r.controller->diagnostic_names() : std::vector<std::string>{};
  LogLayout layout{m->num_rotors(),          e.log.measured,
                   e.log.wrench_breakdown,   controller_input != nullptr,
                   diagnostic_names,         e.sensors,
                   e.estimation.has_value(), e.depth_cameras,
                   e.sim.wind.varies(),      e.sim.battery.enabled,
                   e.sim.payload.enabled,    interaction_columns};
  if (!e.sensors.empty()) {
    r.sensing.emplace(e, sim, *r.sensors);
    loop.set_state_source(&*r.sensing);
  }
  try {
    (void)log_columns(layout);
  } catch (const InvalidArgument& err) {
    throw InvalidArgument(e.source + ": sensors: " + err.what());
  }
  loop.set_real_time(controller_input != nullptr && controller_input->real_time);

  // Only now, with every input checked, touch the file system: lock the folder, refuse to replace
  // an earlier run (unless asked) or an input, write to temporaries and move them into place at
  // the end (logging/output_folder.hpp).
  std::vector<std::string> inputs{e.source, e.model_path};
  if (controller_input != nullptr) inputs.push_back(controller_input->controller_path);
  if (e.scene != nullptr) inputs.push_back(e.scene_path);
  for (std::string& i : more_inputs) inputs.push_back(std::move(i));
  std::vector<std::string> outputs{"log.csv", "log.json"};
  for (const DepthCameraSpec& c : e.depth_cameras) outputs.push_back(DepthRecording::file_name(c));
  outputs.push_back("summary.json");  // last: its presence marks a finished run
  r.out.emplace(out_dir, outputs, inputs, overwrite, "run");
  OutputFolder& out = *r.out;
  const fs::path log_path = out.final_path("log.csv");
  const fs::path summary_path = out.final_path("summary.json");
  const fs::path metadata_path = sidecar_path(log_path.string());

  RunSummary& s = r.s;
  s.experiment_name = e.name;
  s.experiment_path = e.source;
  s.model_name = m->name();
  s.model_path = e.model_path;
  s.scene_path = e.scene_path;
  s.seed = e.sim.seed;
  s.dt_s = e.sim.dt_s;
  s.integrator = e.sim.integrator;
  s.input_type = std::string(input_type_name(e.input));
  s.steps_requested = e.num_steps();
  s.version = std::string(version());
  s.log_path = log_path.string();
  s.summary_path = summary_path.string();
  s.metadata_path = metadata_path.string();

  LogMetadata metadata = run_metadata(e, *m, std::move(model_hash));
  metadata.columns = log_columns(layout);
  r.log.emplace(out.partial("log.csv").string(), metadata.column_names());
  write_log_metadata(metadata, out.partial("log.json").string());

  if (uses_hover_speeds(e) && !m->can_hover(e.gravity_magnitude())) {
    s.warnings.push_back(detail::concat(
        m->name(), " cannot hover at g = ", e.gravity_magnitude(),
        " m/s^2 within its rotor speed limits: the experiment's hover rotor speeds are clamped to "
        "the limits and do not hold it still (dronetwin info ",
        e.model_path, ")"));
  }
  r.depth.emplace(e.depth_cameras, e.sim.seed, e.sim.dt_s, out);
  r.observer.emplace(e, controller_input, *r.controller, sim, *r.sensors,
                     r.sensing ? &*r.sensing : nullptr, *r.depth, *r.log, s, interaction_columns);
  r.start = std::chrono::steady_clock::now();
}

VehicleRun::~VehicleRun() = default;

Simulator& VehicleRun::simulator() { return impl_->sim; }
ClosedLoop& VehicleRun::loop() { return *impl_->loop; }
LoopObserver& VehicleRun::observer() { return *impl_->observer; }
void VehicleRun::set_progress(RunProgressFn progress) {
  impl_->observer->set_progress(std::move(progress));
}
const Experiment& VehicleRun::experiment() const { return impl_->e; }

StepResult VehicleRun::fly() { return impl_->loop->run(impl_->e.duration_s, &*impl_->observer); }

RunSummary VehicleRun::finish(const StepResult& result, const std::string& collided_with) {
  Impl& r = *impl_;
  const Experiment& e = r.e;
  Simulator& sim = r.sim;
  ClosedLoop& loop = *r.loop;
  RunSummary& s = r.s;
  r.log->close();
  r.depth->close();
  for (std::size_t i = 0; i < r.depth->size(); ++i) {
    const DepthCameraParameters& p = r.depth->spec(i).parameters;
    s.depth_frames.push_back(
        {r.depth->spec(i).name,
         r.out->final_path(DepthRecording::file_name(r.depth->spec(i))).string(),
         r.depth->frames(i), p.height_px, p.width_px});
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - r.start).count();

  s.steps = sim.step_count();
  s.duration_s = sim.time_s();
  s.status = result.status;
  s.failure_message = result.status == StepStatus::kControllerFailed ? loop.failure_message()
                                                                     : sim.failure_message();
  if (r.controller_input != nullptr) s.closed_loop = r.observer->closed_loop_summary(loop);
  s.estimation = r.observer->estimation_summary();
  s.final_time_s = sim.time_s();
  s.final_state = sim.state();
  s.final_rotor_speeds_rad_s = sim.rotor_speeds_rad_s();
  s.crashed = sim.contact().crashed;
  if (!collided_with.empty()) {
    s.collided_with = collided_with;
    s.failure_message = "touched " + collided_with;
  } else if (result.status == StepStatus::kCollided) {
    s.collided_with = describe_contact(*e.scene, sim.data().failure.contact);
  }
  s.touchdowns = sim.contact().touchdowns;
  s.max_touchdown_speed_m_s = sim.contact().max_touchdown_speed_m_s;
  s.log_rows = static_cast<std::int64_t>(r.log->rows_written());
  s.wall_clock_s = wall_s;
  s.real_time_factor = wall_s > 0.0 ? s.duration_s / wall_s : 0.0;
  write_text_file(r.out->partial("summary.json"), summary_to_json(s));
  r.out->commit();
  return s;
}

}  // namespace app_detail

namespace {

RunSummary run(const Experiment& e, std::shared_ptr<const VehicleModel> model,
               const std::string& out_dir, bool overwrite, std::optional<std::string> model_hash,
               const RunProgressFn& progress) {
  app_detail::VehicleRun run(e, std::move(model), out_dir, overwrite, std::move(model_hash));
  run.set_progress(progress);
  const StepResult result = run.fly();
  return run.finish(result);
}

}  // namespace

}  // namespace dronetwin
