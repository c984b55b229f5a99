// Experiment runner: model + Simulator + input schedule (or controller + ClosedLoop) + CSV log +
// summary.json.
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

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/ground.hpp"
#include "dronetwin/logging/csv_log.hpp"
#include "dronetwin/logging/json_writer.hpp"
#include "dronetwin/logging/log_metadata.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

namespace {

namespace fs = std::filesystem;

template <class... Fs>
struct Overloaded : Fs... {
  using Fs::operator()...;
};
template <class... Fs>
Overloaded(Fs...) -> Overloaded<Fs...>;

/// Turns the experiment's input into simulator commands, one call before every physics step.
/// Everything is resolved against the model up front, so apply() does not allocate.
class InputDriver {
 public:
  InputDriver(const Experiment& e, const VehicleModel& model) {
    const double g = e.gravity_magnitude();
    // One lambda per input kind: a kind added to ExperimentInput without one does not compile.
    std::visit(Overloaded{
                   [&](const ConstantRotorSpeedsInput& c) {
                     schedule_.push_back({0, c.rotor_speeds.resolve(model, g)});
                   },
                   [&](const PiecewiseRotorSpeedsInput& p) {
                     for (const RotorSpeedSegment& s : p.segments)
                       schedule_.push_back({segment_start_step(s.start_s, e.physics_dt_s),
                                            s.rotor_speeds.resolve(model, g)});
                   },
                   [&](const ConstantGeneralizedForceInput& u) {
                     force_ = u.u;
                     use_force_ = true;
                   },
                   [&](const HoverInput&) {
                     schedule_.push_back({0, model.hover_speeds_rad_s(g)});
                   },
                   // Flown by ControllerDriver; nothing to schedule.
                   [&](const ControllerLoopInput&) {},
               },
               e.input);
  }

  void apply(Simulator& sim) {
    if (use_force_) {
      // Constant: allocating once is enough (the simulator holds the reference).
      if (sim.step_count() == 0) sim.set_generalized_force(force_);
      return;
    }
    // Later segments may share a start step (starts closer than dt): the last one wins.
    while (next_ < schedule_.size() && sim.step_count() >= schedule_[next_].start_step) {
      sim.set_rotor_speed_reference(schedule_[next_].reference_rad_s);
      ++next_;
    }
  }

 private:
  struct Entry {
    std::int64_t start_step;
    RotorVector reference_rad_s;
  };
  std::vector<Entry> schedule_;
  std::size_t next_ = 0;
  GeneralizedForce force_ = GeneralizedForce::Zero();
  bool use_force_ = false;
};

/// A controller input in flight: the controller built from its file, the ClosedLoop that flies
/// it, and the tracking-error sums. Not movable (the loop refers to the controller).
class ControllerDriver {
 public:
  ControllerDriver(const Experiment& e, const ControllerLoopInput& in,
                   const std::shared_ptr<const VehicleModel>& model, Simulator& sim)
      : input_(in) {
    try {
      controller_ = load_controller(in.controller_path, model, in.control_rate_hz);
    } catch (const InvalidArgument& err) {
      throw InvalidArgument(e.source + ": input.controller: " + err.what());
    }
    if (in.allocation) controller_->set_allocation(*in.allocation);
    controller_->reset();
    loop_.emplace(sim, *controller_, *in.reference, in.control_rate_hz);
    loop_->set_real_time(in.real_time);
    diag_names_ = controller_->diagnostic_names();
    diag_now_.assign(diag_names_.size(), 0.0);
    diag_values_.resize(diag_names_.size());
    // Sample k (t = k dt) is in the window when first_ <= k <= last_ (1e-9-step tolerance, as
    // segment_start_step()).
    if (e.metrics.window_s) {
      const auto [t0, t1] = *e.metrics.window_s;
      first_ = segment_start_step(t0, e.physics_dt_s);
      const double last = std::floor(t1 / e.physics_dt_s + 1e-9);
      last_ = last < 9e18 ? static_cast<std::int64_t>(last) : last_;
      window_ = {t0, t1};
    }
  }
  ControllerDriver(const ControllerDriver&) = delete;
  ControllerDriver& operator=(const ControllerDriver&) = delete;

  void update() {
    if (loop_->update() && !diag_names_.empty()) {
      controller_->diagnostics(diag_now_.data());
      for (std::size_t i = 0; i < diag_now_.size(); ++i)
        if (std::isfinite(diag_now_[i])) diag_values_[i].push_back(diag_now_[i]);
    }
  }
  StepResult step() { return loop_->step(); }
  const std::vector<std::string>& diagnostic_names() const { return diag_names_; }

  /// Adds the tracking error at the simulator's current instant when it is in the window.
  void observe(const Simulator& sim) {
    const std::int64_t k = sim.step_count();
    if (k < first_ || k > last_) return;
    const StateVector& x = sim.state();
    const ReferencePoint r = input_.reference->at(sim.time_s());
    const Vec3 e_p = r.position_m - x.segment<3>(state_index::kPosition);
    const double yaw = math::to_euler(Vec4(x.segment<4>(state_index::kQuaternion)))[2];
    const double e_yaw = std::remainder(r.yaw_rad - yaw, 2.0 * std::numbers::pi);
    sum_sq_.head<3>() += e_p.cwiseAbs2();
    sum_sq_[3] += e_yaw * e_yaw;
    ++samples_;
  }

  /// ref_x, ref_y, ref_z, ref_yaw, u_T, u_tau_x, u_tau_y, u_tau_z, saturated at `out`.
  std::size_t fill(const Simulator& sim, double* out) const {
    const ReferencePoint r = input_.reference->at(sim.time_s());
    std::size_t k = 0;
    for (int i = 0; i < 3; ++i) out[k++] = r.position_m[i];
    out[k++] = r.yaw_rad;
    for (int i = 0; i < 4; ++i) out[k++] = loop_->last_command()[i];
    out[k++] = saturated() ? 1.0 : 0.0;
    if (!diag_names_.empty()) {
      controller_->diagnostics(out + k);
      k += diag_names_.size();
    }
    return k;
  }

  ClosedLoopSummary summary(double end_s) const {
    ClosedLoopSummary c;
    c.controller_name = std::string(controller_->name());
    c.controller_path = input_.controller_path;
    c.allocation = std::string(allocation_name(controller_->allocation()));
    c.reference_type = input_.reference_type;
    c.reference = input_.reference->describe();
    c.control_rate_hz = input_.control_rate_hz;
    c.real_time = input_.real_time;
    if (samples_ > 0) c.rmse = (sum_sq_ / static_cast<double>(samples_)).cwiseSqrt();
    c.rmse_window_s = {window_[0], std::min(window_[1], end_s)};
    c.rmse_samples = samples_;
    c.control_updates = loop_->control_updates();
    c.saturated_updates = loop_->saturated_updates();
    c.saturated_fraction = c.control_updates > 0 ? static_cast<double>(c.saturated_updates) /
                                                       static_cast<double>(c.control_updates)
                                                 : 0.0;
    for (std::size_t i = 0; i < diag_names_.size(); ++i) {
      DiagnosticSummary d;
      d.name = diag_names_[i];
      std::vector<double> v = diag_values_[i];
      d.count = static_cast<std::int64_t>(v.size());
      if (!v.empty()) {
        std::sort(v.begin(), v.end());
        for (const double x : v) d.sum += x;
        d.mean = d.sum / static_cast<double>(v.size());
        const std::size_t n = v.size();
        d.median = n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
        // Nearest rank: the smallest value with at least 99 % of the samples at or below it.
        const auto rank = static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(n)));
        d.p99 = v[std::max<std::size_t>(rank, 1) - 1];
        d.max = v.back();
      }
      c.diagnostics.push_back(std::move(d));
    }
    return c;
  }

 private:
  bool saturated() const {
    return controller_->level() == ControlLevel::kGeneralizedForce &&
           loop_->controller().last_allocation().saturated;
  }

  ControllerLoopInput input_;
  std::unique_ptr<ControllerBase> controller_;
  std::optional<ClosedLoop> loop_;
  std::int64_t first_ = 0;
  std::int64_t last_ = std::numeric_limits<std::int64_t>::max();
  std::array<double, 2> window_{0.0, std::numeric_limits<double>::infinity()};
  Vec4 sum_sq_ = Vec4::Zero();
  std::int64_t samples_ = 0;
  std::vector<std::string> diag_names_;
  std::vector<double> diag_now_;
  std::vector<std::vector<double>> diag_values_;  // finite values per diagnostic, every update
};

/// Fills one log row from the simulator (layout of log_column_names()).
void fill_row(const Simulator& sim, const LogSettings& log, const ControllerDriver* controller,
              std::vector<double>& row) {
  std::size_t k = 0;
  row[k++] = sim.time_s();
  const StateVector& x = sim.state();
  for (int i = 0; i < kStateSize; ++i) row[k++] = x[i];
  const int n = sim.model().num_rotors();
  for (int i = 0; i < n; ++i) row[k++] = sim.rotor_speeds_rad_s()[i];
  for (int i = 0; i < n; ++i) row[k++] = sim.rotor_speed_reference_rad_s()[i];
  if (log.measured) {
    const StateVector m = sim.measured_state();
    for (int i = 0; i < kStateSize; ++i) row[k++] = m[i];
  }
  row[k++] = sim.contact().in_contact ? 1.0 : 0.0;
  row[k++] = sim.contact().crashed ? 1.0 : 0.0;
  if (log.wrench_breakdown) {
    const WrenchBreakdown b = sim.wrench_breakdown();
    for (const Wrench<double>& w : b.terms) {
      for (int i = 0; i < 3; ++i) row[k++] = w.force_B[i];
      for (int i = 0; i < 3; ++i) row[k++] = w.moment_B[i];
    }
  }
  if (controller != nullptr) k += controller->fill(sim, row.data() + k);
}

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
        .raw("rmse_window_s",
             "[" + json_number(c.rmse_window_s[0]) + ", " + json_number(c.rmse_window_s[1]) + "]")
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
  j.integer("log_rows", s.log_rows)
      .str("log_path", s.log_path)
      .str("metadata_path", s.metadata_path)
      .num("wall_clock_s", s.wall_clock_s)
      .num("real_time_factor", s.real_time_factor);
  return j.done() + "\n";
}

namespace {

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
  m.seed = e.seed;
  m.dt_s = e.physics_dt_s;
  m.integrator = e.integrator;
  m.motor_dynamics = e.motor_dynamics;
  m.log_every_n_steps = e.log.every_n_steps;
  m.log_rate_hz = 1.0 / (e.physics_dt_s * static_cast<double>(e.log.every_n_steps));
  if (const auto* in = std::get_if<ControllerLoopInput>(&e.input)) {
    m.controller_path = in->controller_path;
    m.control_rate_hz = in->control_rate_hz;
  }
  m.noise = e.noise.enabled;
  m.disturbances = e.disturbances;
  m.ground = e.ground.enabled;
  m.wind_m_s = e.wind_m_s;
  m.gravity_m_s2 = e.gravity_m_s2;
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
               const std::string& out_dir, std::optional<std::string> model_hash);

}  // namespace

RunSummary run_experiment(const Experiment& e, const std::string& out_dir) {
  validate(e);
  // Read once: the model flown is exactly the text hashed.
  const std::string text = read_text_file(e.model_path, "model file");
  auto model =
      std::make_shared<const VehicleModel>(VehicleModel(parse_vehicle_spec(text, e.model_path)));
  return run(e, std::move(model), out_dir, content_hash(text));
}

RunSummary run_experiment(const Experiment& e, std::shared_ptr<const VehicleModel> model,
                          const std::string& out_dir) {
  require(model != nullptr, e.source, ": run_experiment: the model is null");
  validate(e);
  std::optional<std::string> hash = hash_if_same_model(e.model_path, *model);
  return run(e, std::move(model), out_dir, std::move(hash));
}

namespace {

RunSummary run(const Experiment& e, std::shared_ptr<const VehicleModel> model,
               const std::string& out_dir, std::optional<std::string> model_hash) {
  check_against_model(e, *model);
  const SimConfig config = e.sim_config();

  Simulator sim(model, config);
  try {
    sim.reset(e.initial_state.state(),
              e.initial_state.rotor_speeds.resolve(*model, e.gravity_magnitude()));
  } catch (const InvalidArgument& err) {
    throw InvalidArgument(e.source + ": initial_state: " + err.what());
  }
  InputDriver input(e, *model);
  // Built before any file is touched: a bad controller file throws here.
  std::optional<ControllerDriver> controller;
  if (const auto* in = std::get_if<ControllerLoopInput>(&e.input))
    controller.emplace(e, *in, model, sim);
  const ControllerDriver* const logged_controller = controller ? &*controller : nullptr;

  // Only now, with every input checked, touch the file system.
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  require(!ec && fs::is_directory(out_dir), out_dir, ": cannot create the output directory (",
          ec ? ec.message() : std::string("not a directory"), ")");
  const fs::path log_path = fs::path(out_dir) / "log.csv";
  const fs::path summary_path = fs::path(out_dir) / "summary.json";
  const fs::path metadata_path = sidecar_path(log_path.string());

  RunSummary s;
  s.experiment_name = e.name;
  s.experiment_path = e.source;
  s.model_name = model->name();
  s.model_path = e.model_path;
  s.seed = e.seed;
  s.dt_s = e.physics_dt_s;
  s.integrator = e.integrator;
  s.input_type = std::string(input_type_name(e.input));
  s.steps_requested = e.num_steps();
  s.version = std::string(version());
  s.log_path = log_path.string();
  s.summary_path = summary_path.string();
  s.metadata_path = metadata_path.string();

  const LogLayout layout{model->num_rotors(), e.log.measured, e.log.wrench_breakdown,
                         controller.has_value(),
                         controller ? controller->diagnostic_names() : std::vector<std::string>{}};
  LogMetadata metadata = run_metadata(e, *model, std::move(model_hash));
  metadata.columns = log_columns(layout);
  CsvLogWriter log(log_path.string(), metadata.column_names());
  // Before the run: the sidecar depends on the settings only, and is there even if the process
  // is stopped mid-run.
  write_log_metadata(metadata, metadata_path.string());
  std::vector<double> row(log.num_columns());

  const auto observe = [&s](const Simulator& sm) {
    const StateVector& x = sm.state();
    const double z = x[state_index::kPosition + 2];
    s.min_z_m = std::min(s.min_z_m, z);
    s.max_z_m = std::max(s.max_z_m, z);
    s.max_speed_m_s = std::max(s.max_speed_m_s, x.segment<3>(state_index::kVelocity).norm());
    s.max_tilt_rad = std::max(s.max_tilt_rad, tilt_angle_rad(x));
  };
  s.min_z_m = s.max_z_m = sim.state()[state_index::kPosition + 2];
  observe(sim);

  // Open loop: the input schedule sets the references, Simulator::step() steps. Closed loop:
  // ClosedLoop::update() runs the controller when a control instant is due, ClosedLoop::step()
  // steps (update() again, a no-op by then, and real-time pacing).
  const auto apply = [&] {
    if (controller) {
      controller->update();
      controller->observe(sim);
    } else {
      input.apply(sim);
    }
  };
  const auto step = [&] { return controller ? controller->step() : sim.step(); };

  // A controller that fails (non-finite output) ends the run like a non-finite state would.
  std::string controller_failure;
  const auto start = std::chrono::steady_clock::now();
  bool last_logged = false;
  try {
    apply();
    fill_row(sim, e.log, logged_controller, row);
    log.write_row(row);
    last_logged = true;
    for (std::int64_t k = 0; k < s.steps_requested; ++k) {
      if (!step().ok()) break;
      last_logged = false;
      // Command first, then log: a row at time t shows the reference in effect from t on.
      apply();
      observe(sim);
      last_logged = sim.step_count() % e.log.every_n_steps == 0;
      if (last_logged) {
        fill_row(sim, e.log, logged_controller, row);
        log.write_row(row);
      }
    }
  } catch (const SimulationError& err) {
    if (!controller) throw;
    controller_failure = err.what();
  }
  const bool failed = sim.status() != StepStatus::kOk || !controller_failure.empty();
  if (failed && !last_logged) {
    fill_row(sim, e.log, logged_controller, row);  // the last good state, for diagnosis
    log.write_row(row);
  }
  log.close();
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  s.steps = sim.step_count();
  s.duration_s = sim.time_s();
  s.status = sim.status();
  s.failure_message = sim.failure_message();
  if (!controller_failure.empty() && s.ok()) {
    s.status = StepStatus::kNonFinite;
    s.failure_message = controller_failure;
  }
  if (controller) s.closed_loop = controller->summary(sim.time_s());
  s.final_time_s = sim.time_s();
  s.final_state = sim.state();
  s.final_rotor_speeds_rad_s = sim.rotor_speeds_rad_s();
  s.crashed = sim.contact().crashed;
  s.touchdowns = sim.contact().touchdowns;
  s.max_touchdown_speed_m_s = sim.contact().max_touchdown_speed_m_s;
  s.log_rows = static_cast<std::int64_t>(log.rows_written());
  s.wall_clock_s = wall_s;
  s.real_time_factor = wall_s > 0.0 ? s.duration_s / wall_s : 0.0;
  write_text_file(summary_path, summary_to_json(s));
  return s;
}

}  // namespace

}  // namespace dronetwin
