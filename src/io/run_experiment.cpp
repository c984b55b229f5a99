// Experiment runner: model + Simulator + input schedule + CSV log + summary.json.
#include "dronetwin/io/run_experiment.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <system_error>
#include <utility>
#include <variant>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/ground.hpp"
#include "dronetwin/io/csv_log.hpp"
#include "dronetwin/io/model_loader.hpp"

#ifndef DRONETWIN_VERSION
#define DRONETWIN_VERSION "unknown"
#endif

namespace dronetwin {

std::string_view version() { return DRONETWIN_VERSION; }

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

/// Fills one log row from the simulator (layout of log_column_names()).
void fill_row(const Simulator& sim, const LogSettings& log, std::vector<double>& row) {
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
}

// ---- JSON -------------------------------------------------------------------------------------

std::string json_string(std::string_view s) {
  std::string out = "\"";
  for (const char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(c));
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

/// %.17g (round-trips); JSON has no NaN or infinity, so those become null.
std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

template <class Vector>
std::string json_array(const Vector& v) {
  std::string out = "[";
  for (Eigen::Index i = 0; i < v.size(); ++i) out += (i ? ", " : "") + json_number(v[i]);
  return out + "]";
}

/// Writes "key": value pairs with two-space indentation.
class JsonObject {
 public:
  explicit JsonObject(int indent) : pad_(static_cast<std::size_t>(indent), ' ') {}
  JsonObject& raw(std::string_view key, const std::string& value) {
    text_ += (text_.empty() ? "" : ",\n") + pad_ + "  " + json_string(key) + ": " + value;
    return *this;
  }
  JsonObject& str(std::string_view key, std::string_view v) { return raw(key, json_string(v)); }
  JsonObject& num(std::string_view key, double v) { return raw(key, json_number(v)); }
  JsonObject& integer(std::string_view key, long long v) { return raw(key, std::to_string(v)); }
  JsonObject& boolean(std::string_view key, bool v) { return raw(key, v ? "true" : "false"); }
  std::string done() const { return "{\n" + text_ + "\n" + pad_ + "}"; }

 private:
  std::string pad_;
  std::string text_;
};

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  require(static_cast<bool>(out), path.string(), ": cannot open for writing");
  out << text;
  out.close();
  require(static_cast<bool>(out), path.string(), ": error while writing");
}

}  // namespace

std::string summary_to_json(const RunSummary& s) {
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
      .num("max_touchdown_speed_m_s", s.max_touchdown_speed_m_s)
      .integer("log_rows", s.log_rows)
      .str("log_path", s.log_path)
      .num("wall_clock_s", s.wall_clock_s)
      .num("real_time_factor", s.real_time_factor);
  return j.done() + "\n";
}

RunSummary run_experiment(const Experiment& e, const std::string& out_dir) {
  validate(e);
  return run_experiment(e, std::make_shared<const VehicleModel>(load_vehicle_model(e.model_path)),
                        out_dir);
}

RunSummary run_experiment(const Experiment& e, std::shared_ptr<const VehicleModel> model,
                          const std::string& out_dir) {
  require(model != nullptr, e.source, ": run_experiment: the model is null");
  validate(e);
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

  // Only now, with every input checked, touch the file system.
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  require(!ec && fs::is_directory(out_dir), out_dir, ": cannot create the output directory (",
          ec ? ec.message() : std::string("not a directory"), ")");
  const fs::path log_path = fs::path(out_dir) / "log.csv";
  const fs::path summary_path = fs::path(out_dir) / "summary.json";

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

  const LogLayout layout{model->num_rotors(), e.log.measured, e.log.wrench_breakdown};
  CsvLogWriter log(log_path.string(), log_column_names(layout));
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

  const auto start = std::chrono::steady_clock::now();
  input.apply(sim);
  fill_row(sim, e.log, row);
  log.write_row(row);
  bool last_logged = true;
  for (std::int64_t k = 0; k < s.steps_requested; ++k) {
    if (!sim.step().ok()) break;
    // Command first, then log: a row at time t shows the reference in effect from t on.
    input.apply(sim);
    observe(sim);
    last_logged = sim.step_count() % e.log.every_n_steps == 0;
    if (last_logged) {
      fill_row(sim, e.log, row);
      log.write_row(row);
    }
  }
  if (sim.status() != StepStatus::kOk && !last_logged) {
    fill_row(sim, e.log, row);  // the last good state, for diagnosis
    log.write_row(row);
  }
  log.close();
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  s.steps = sim.step_count();
  s.duration_s = sim.time_s();
  s.status = sim.status();
  s.failure_message = sim.failure_message();
  s.final_time_s = sim.time_s();
  s.final_state = sim.state();
  s.final_rotor_speeds_rad_s = sim.rotor_speeds_rad_s();
  s.crashed = sim.contact().crashed;
  s.touchdowns = sim.contact().touchdowns;
  s.max_touchdown_speed_m_s = sim.contact().max_touchdown_speed_m_s;
  s.log_rows = static_cast<std::int64_t>(log.rows_written());
  s.wall_clock_s = wall_s;
  s.real_time_factor = wall_s > 0.0 ? s.duration_s / wall_s : 0.0;
  write_text(summary_path, summary_to_json(s));
  return s;
}

}  // namespace dronetwin
