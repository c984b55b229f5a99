// Bindings of the io layer: experiment files and the runner (the same code as `dronetwin run`),
// controller files, and run logs read into numpy arrays with their JSON sidecar (LogMetadata).

#include "bindings.hpp"
#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/app/metrics.hpp"
#include "dronetwin/app/run_experiment.hpp"
#include "dronetwin/config/controller_config.hpp"
#include "dronetwin/config/experiment.hpp"
#include "dronetwin/config/log_metadata_reader.hpp"
#include "dronetwin/logging/csv_log.hpp"
#include "dronetwin/logging/log_metadata.hpp"

namespace dronetwin::python {

namespace {

ControllerLoopInput& controller_input(Experiment& e) {
  if (auto* c = std::get_if<ControllerLoopInput>(&e.input)) return *c;
  throw py::value_error(e.source + ": input is '" + std::string(input_type_name(e.input)) +
                        "', not a controller");
}

RunSummary run(const Experiment& e, const std::string& out_dir,
               const std::shared_ptr<VehicleModel>& model, bool overwrite) {
  py::gil_scoped_release release;
  if (model) return run_experiment(e, model, out_dir, overwrite);
  return run_experiment(e, out_dir, overwrite);
}

}  // namespace

void bind_io(py::module_& m) {
  py::class_<LogSettings>(m, "LogSettings", "What an experiment logs.")
      .def(py::init<>())
      .def_readwrite("every_n_steps", &LogSettings::every_n_steps)
      .def_readwrite("wrench_breakdown", &LogSettings::wrench_breakdown)
      .def_readwrite("measured", &LogSettings::measured);

  py::class_<MetricsSettings>(m, "MetricsSettings", "Where a closed-loop run's RMSE is taken.")
      .def(py::init<>())
      .def_readwrite("window_s", &MetricsSettings::window_s,
                     "(t0, t1) in s, 0 <= t0 < t1, or None for the whole run.");

  py::class_<Experiment>(
      m, "Experiment",
      "An experiment file (docs/experiment-format.md), loaded and checked. Fields may be edited\n"
      "before running it (sweeps over seeds, wind, duration, ...); run_experiment re-validates.\n\n"
      "    e = dronetwin.load_experiment('config/experiments/pid_tuned_pulse.yaml')\n"
      "    e.seed = 3\n"
      "    s = dronetwin.run_experiment(e, 'out/pid_seed3')\n"
      "    s.closed_loop.rmse             # [x, y, z, yaw]")
      .def_readwrite("name", &Experiment::name)
      .def_readwrite("description", &Experiment::description)
      .def_readonly("source", &Experiment::source)
      .def_readwrite("model_path", &Experiment::model_path)
      .def_readonly("scene_path", &Experiment::scene_path, "The `scene:` track file, or ''.")
      .def_property(
          "seed", [](const Experiment& e) { return e.sim.seed; },
          [](Experiment& e, std::uint64_t v) { e.sim.seed = v; })
      .def_readwrite("duration_s", &Experiment::duration_s)
      .def_readwrite("sim", &Experiment::sim,
                     "The simulator settings (SimConfig); the properties below are views of it.")
      .def_property(
          "physics_dt_s", [](const Experiment& e) { return e.sim.dt_s; },
          [](Experiment& e, double v) { e.sim.dt_s = v; })
      .def_property(
          "integrator", [](const Experiment& e) { return e.sim.integrator; },
          [](Experiment& e, Integrator v) { e.sim.integrator = v; })
      .def_property(
          "motor_dynamics", [](const Experiment& e) { return e.sim.motor_dynamics; },
          [](Experiment& e, bool v) { e.sim.motor_dynamics = v; })
      .def_property(
          "noise", [](const Experiment& e) { return e.sim.noise; },
          [](Experiment& e, const NoiseConfig& v) { e.sim.noise = v; })
      .def_property(
          "wind_m_s", [](const Experiment& e) { return e.sim.environment.wind_W_m_s; },
          [](Experiment& e, py::handle w) {
            e.sim.environment.wind_W_m_s = to_fixed<3>(w, "Experiment.wind_m_s");
          })
      .def_property(
          "faults", [](const Experiment& e) { return fault_list_of(e.sim.faults); },
          [](Experiment& e, const std::vector<RotorFault>& f) {
            e.sim.faults = fault_settings_of(f);
          },
          "Rotor faults (a list of RotorFault; assign a new list to change them).")
      .def_property(
          "battery",
          py::cpp_function([](Experiment& e) -> BatterySettings& { return e.sim.battery; },
                           py::return_value_policy::reference_internal),
          [](Experiment& e, const BatterySettings& v) { e.sim.battery = v; },
          "The battery (BatterySettings, a view: edit it in place).")
      .def_property(
          "payload",
          py::cpp_function([](Experiment& e) -> PayloadSettings& { return e.sim.payload; },
                           py::return_value_policy::reference_internal),
          [](Experiment& e, const PayloadSettings& v) { e.sim.payload = v; },
          "The slung payload (PayloadSettings, a view: edit it in place).")
      .def_property(
          "wind",
          py::cpp_function([](Experiment& e) -> WindSettings& { return e.sim.wind; },
                           py::return_value_policy::reference_internal),
          [](Experiment& e, const WindSettings& v) { e.sim.wind = v; },
          "Shear, gusts and turbulence (WindSettings, a view: edit it in place).")
      .def_property(
          "gravity_m_s2", [](const Experiment& e) { return e.sim.environment.gravity_W_m_s2; },
          [](Experiment& e, py::handle g) {
            e.sim.environment.gravity_W_m_s2 = to_fixed<3>(g, "Experiment.gravity_m_s2");
          })
      .def_property(
          "disturbances", [](const Experiment& e) { return e.sim.disturbances; },
          [](Experiment& e, const DisturbanceSwitches& v) { e.sim.disturbances = v; })
      .def_property(
          "ground", [](const Experiment& e) { return e.sim.ground; },
          [](Experiment& e, const GroundConfig& v) { e.sim.ground = v; })
      .def_property(
          "divergence", [](const Experiment& e) { return e.sim.divergence; },
          [](Experiment& e, const DivergenceLimits& v) { e.sim.divergence = v; })
      .def_readwrite("log", &Experiment::log)
      .def_readwrite("metrics", &Experiment::metrics)
      .def_property_readonly(
          "input_type", [](const Experiment& e) { return std::string(input_type_name(e.input)); })
      .def_property(
          "controller_path", [](Experiment& e) { return controller_input(e).controller_path; },
          [](Experiment& e, const std::string& p) { controller_input(e).controller_path = p; },
          "The controller file of a `type: controller` input (ValueError for other inputs).")
      .def_property(
          "control_rate_hz", [](Experiment& e) { return controller_input(e).control_rate_hz; },
          [](Experiment& e, double r) { controller_input(e).control_rate_hz = r; })
      .def_property_readonly(
          "reference",
          [](Experiment& e) {
            return std::shared_ptr<Reference>(controller_input(e).reference->clone());
          },
          "A copy of the reference of a controller input.")
      .def("sim_config", &Experiment::sim_config, "The Simulator settings (validated).")
      .def("num_steps", &Experiment::num_steps,
           "Physics steps of the run: duration_s / physics_dt_s rounded up.")
      .def(
          "validate", [](const Experiment& e) { validate(e); },
          "Re-checks the editable fields; ValueError naming the field.");

  m.def("load_experiment", &load_experiment, py::arg("path"),
        "Reads and checks an experiment file; ValueError '<path>: <field>: <what>' otherwise.");
  m.def("parse_experiment", &parse_experiment, py::arg("yaml_text"), py::arg("source_name"),
        "An experiment from YAML text; relative paths resolve against source_name's directory.");

  py::class_<DiagnosticSummary>(m, "DiagnosticSummary",
                                "Statistics of one controller diagnostic over a run.")
      .def_readonly("name", &DiagnosticSummary::name)
      .def_readonly("count", &DiagnosticSummary::count)
      .def_readonly("sum", &DiagnosticSummary::sum)
      .def_readonly("mean", &DiagnosticSummary::mean)
      .def_readonly("median", &DiagnosticSummary::median)
      .def_readonly("p99", &DiagnosticSummary::p99)
      .def_readonly("max", &DiagnosticSummary::max);

  py::class_<ClosedLoopSummary>(m, "ClosedLoopSummary",
                                "What a closed-loop run adds to its summary.")
      .def_readonly("controller_name", &ClosedLoopSummary::controller_name)
      .def_readonly("controller_path", &ClosedLoopSummary::controller_path)
      .def_readonly("allocation", &ClosedLoopSummary::allocation)
      .def_readonly("reference_type", &ClosedLoopSummary::reference_type)
      .def_readonly("reference", &ClosedLoopSummary::reference)
      .def_readonly("control_rate_hz", &ClosedLoopSummary::control_rate_hz)
      .def_property_readonly(
          "rmse", [](const ClosedLoopSummary& s) { return Vec4(s.rmse); },
          "RMSE [x, y, z, yaw] (m, m, m, rad) of the true state in the window.")
      .def_readonly("rmse_window_s", &ClosedLoopSummary::rmse_window_s)
      .def_readonly("rmse_samples", &ClosedLoopSummary::rmse_samples)
      .def_readonly("control_updates", &ClosedLoopSummary::control_updates)
      .def_readonly("saturated_updates", &ClosedLoopSummary::saturated_updates)
      .def_readonly("saturated_fraction", &ClosedLoopSummary::saturated_fraction)
      .def_readonly("diagnostics", &ClosedLoopSummary::diagnostics,
                    "Per-diagnostic statistics (e.g. the NMPC's solve times and failures).");

  py::class_<EstimationSummary>(m, "EstimationSummary",
                                "The estimator against the true state over every physics step.")
      .def_readonly("position_rmse_m", &EstimationSummary::position_rmse_m)
      .def_readonly("velocity_rmse_m_s", &EstimationSummary::velocity_rmse_m_s)
      .def_readonly("attitude_rmse_rad", &EstimationSummary::attitude_rmse_rad)
      .def_readonly("samples", &EstimationSummary::samples)
      .def_readonly("updates", &EstimationSummary::updates)
      .def_readonly("controller_on_estimate", &EstimationSummary::controller_on_estimate);

  py::class_<RunSummary>(m, "RunSummary",
                         "The outcome of run_experiment (summary.json as an object).")
      .def_readonly("experiment_name", &RunSummary::experiment_name)
      .def_readonly("model_name", &RunSummary::model_name)
      .def_readonly("seed", &RunSummary::seed)
      .def_readonly("dt_s", &RunSummary::dt_s)
      .def_readonly("steps", &RunSummary::steps)
      .def_readonly("steps_requested", &RunSummary::steps_requested)
      .def_readonly("duration_s", &RunSummary::duration_s)
      .def_readonly("status", &RunSummary::status)
      .def_readonly("failure_message", &RunSummary::failure_message)
      .def_readonly("warnings", &RunSummary::warnings)
      .def_property_readonly("ok", &RunSummary::ok)
      .def_property_readonly("final_state",
                             [](const RunSummary& s) { return StateVector(s.final_state); })
      .def_readonly("min_z_m", &RunSummary::min_z_m)
      .def_readonly("max_z_m", &RunSummary::max_z_m)
      .def_readonly("max_speed_m_s", &RunSummary::max_speed_m_s)
      .def_readonly("max_tilt_rad", &RunSummary::max_tilt_rad)
      .def_readonly("crashed", &RunSummary::crashed)
      .def_readonly("collided_with", &RunSummary::collided_with,
                    "Status COLLIDED: what was touched (\"obstacle 'pillar' (box)\"); else ''.")
      .def_readonly("scene_path", &RunSummary::scene_path)
      .def_readonly("closed_loop", &RunSummary::closed_loop, "ClosedLoopSummary or None.")
      .def_property_readonly(
          "depth_frames",
          [](const RunSummary& s) {
            py::list out;
            for (const DepthFramesSummary& d : s.depth_frames)
              out.append(
                  py::dict(py::arg("name") = d.name, py::arg("path") = d.path,
                           py::arg("shape") = py::make_tuple(d.frames, d.height_px, d.width_px)));
            return out;
          },
          "One dict per depth camera: name, path of its <name>.npy (numpy.load it), shape "
          "(frames, height, width).")
      .def_readonly("estimation", &RunSummary::estimation,
                    "EstimationSummary or None (experiments with `estimation:`).")
      .def_readonly("log_rows", &RunSummary::log_rows)
      .def_readonly("wall_clock_s", &RunSummary::wall_clock_s)
      .def_readonly("real_time_factor", &RunSummary::real_time_factor)
      .def_readonly("log_path", &RunSummary::log_path)
      .def_readonly("summary_path", &RunSummary::summary_path)
      .def_readonly("metadata_path", &RunSummary::metadata_path,
                    "The log's JSON sidecar (log.json: units and run settings).")
      .def("to_json", &summary_to_json, "The text of summary.json.")
      .def("__repr__", [](const RunSummary& s) {
        return "RunSummary('" + s.experiment_name +
               "', status=" + std::string(status_name(s.status)) +
               ", steps=" + std::to_string(s.steps) + ")";
      });

  m.def(
      "tracking_rmse",
      [](const py::array_t<double, py::array::c_style | py::array::forcecast>& t,
         const py::array_t<double, py::array::c_style | py::array::forcecast>& state,
         const py::array_t<double, py::array::c_style | py::array::forcecast>& reference,
         double dt_s, std::optional<std::array<double, 2>> window_s) {
        const py::ssize_t rows = t.ndim() == 1 ? t.shape(0) : -1;
        if (rows < 0) throw py::value_error("tracking_rmse: t must be 1-D (rows,)");
        if (state.ndim() != 2 || state.shape(0) != rows || state.shape(1) != kStateSize)
          throw py::value_error("tracking_rmse: state must be (" + std::to_string(rows) +
                                ", 13), got " + describe_object(state));
        if (reference.ndim() != 2 || reference.shape(0) != rows || reference.shape(1) != 4)
          throw py::value_error("tracking_rmse: reference must be (" + std::to_string(rows) +
                                ", 4), got " + describe_object(reference));
        return Vec4(tracking_rmse(t.data(), state.data(), reference.data(), rows, dt_s, window_s));
      },
      py::arg("t"), py::arg("state"), py::arg("reference"), py::arg("dt_s"),
      py::arg("window_s") = py::none(),
      "Tracking RMSE [x, y, z, yaw] of recorded rows: the one definition of dronetwin (the\n"
      "runner's summary.json uses it too): the true state against the reference over the physics\n"
      "steps in window_s = (t0, t1) (None: all), yaw error wrapped into [-pi, pi].");

  m.def("run_experiment", &run, py::arg("experiment"), py::arg("out_dir"),
        py::arg("model") = nullptr, py::arg("overwrite") = false,
        "Runs an Experiment exactly as `dronetwin run` does, writing out_dir/log.csv,\n"
        "log.json and summary.json; returns the RunSummary. `model` (optional) replaces the model\n"
        "file (sweeps load it once). An earlier run's files in out_dir are replaced only with\n"
        "overwrite=True (ValueError otherwise); a second run into a folder being written fails.\n"
        "The GIL is released during the run.");
  m.def(
      "run_experiment_file",
      [](const std::string& path, const std::string& out_dir, bool overwrite) {
        return run(load_experiment(path), out_dir, nullptr, overwrite);
      },
      py::arg("path"), py::arg("out_dir"), py::arg("overwrite") = false,
      "load_experiment(path) then run_experiment.");

  m.def(
      "read_log_table",
      [](const std::string& path) {
        LogTable t = [&] {
          py::gil_scoped_release release;
          return read_csv_log(path);
        }();
        const auto rows = static_cast<py::ssize_t>(t.rows());
        const auto cols = static_cast<py::ssize_t>(t.columns.size());
        py::array_t<double> a({rows, cols});
        std::copy(t.values.begin(), t.values.end(), a.mutable_data());
        return py::make_tuple(t.columns, a);
      },
      py::arg("path"),
      "Reads a run log (CSV) into (column names, 2-D float64 array). ValueError naming the file,\n"
      "line and column for a malformed file. Prefer dronetwin.read_log (dict or DataFrame).");
  py::class_<LogColumn>(m, "LogColumn", "One column of a log: name, unit and a one-line meaning.")
      .def_readonly("name", &LogColumn::name)
      .def_readonly("unit", &LogColumn::unit,
                    "'s', 'm', 'm/s', '1' (dimensionless), 'rad', 'rad/s', 'N', 'N m', 'bool', ...")
      .def_readonly("meaning", &LogColumn::meaning)
      .def("__repr__",
           [](const LogColumn& c) { return "LogColumn('" + c.name + "', unit='" + c.unit + "')"; });

  py::class_<LogMetadata>(
      m, "LogMetadata",
      "A run log's JSON sidecar (log.json, docs/log-format.md): how the log was made and what\n"
      "every column holds.\n\n"
      "    meta = dronetwin.read_log_metadata('out/hover')      # run dir, log.csv or log.json\n"
      "    meta.dt_s, meta.log_rate_hz, meta.seed, meta.column('vz').unit\n"
      "    meta.model_hash == dronetwin.file_hash(meta.model_path)")
      .def_readonly("source", &LogMetadata::source, "The sidecar file it was read from.")
      .def_readonly("format", &LogMetadata::format)
      .def_readonly("format_version", &LogMetadata::format_version)
      .def_readonly("dronetwin_version", &LogMetadata::dronetwin_version)
      .def_readonly("experiment", &LogMetadata::experiment)
      .def_readonly("experiment_path", &LogMetadata::experiment_path)
      .def_readonly("input_type", &LogMetadata::input_type)
      .def_readonly("model", &LogMetadata::model)
      .def_readonly("model_path", &LogMetadata::model_path)
      .def_readonly("model_hash", &LogMetadata::model_hash,
                    "'fnv1a64:<16 hex digits>' of the model file, or None when the run flew a\n"
                    "model given in memory that differs from that file.")
      .def_readonly("seed", &LogMetadata::seed)
      .def_readonly("dt_s", &LogMetadata::dt_s, "Physics step, s.")
      .def_readonly("integrator", &LogMetadata::integrator)
      .def_readonly("motor_dynamics", &LogMetadata::motor_dynamics)
      .def_readonly("log_every_n_steps", &LogMetadata::log_every_n_steps)
      .def_readonly("log_rate_hz", &LogMetadata::log_rate_hz, "1 / (log_every_n_steps dt_s).")
      .def_readonly("controller_path", &LogMetadata::controller_path, "None in open loop.")
      .def_readonly("control_rate_hz", &LogMetadata::control_rate_hz, "None in open loop.")
      .def_readonly("noise", &LogMetadata::noise)
      .def_readonly("disturbances", &LogMetadata::disturbances)
      .def_readonly("ground", &LogMetadata::ground)
      .def_property_readonly("wind_m_s", [](const LogMetadata& d) { return Vec3(d.wind_m_s); })
      .def_property_readonly("gravity_m_s2",
                             [](const LogMetadata& d) { return Vec3(d.gravity_m_s2); })
      .def_readonly("num_rotors", &LogMetadata::num_rotors)
      .def_readonly("columns", &LogMetadata::columns, "The CSV's columns in order (LogColumn).")
      .def("column", &LogMetadata::column, py::arg("name"),
           "The LogColumn called `name`; ValueError naming the sidecar otherwise.")
      .def("column_names", &LogMetadata::column_names, "The column names in CSV order.")
      .def(
          "units",
          [](const LogMetadata& d) {
            py::dict units;
            for (const LogColumn& c : d.columns) units[py::str(c.name)] = c.unit;
            return units;
          },
          "{column name: unit} for every column.")
      .def("to_json", &log_metadata_to_json,
           "The sidecar's JSON text (as run_experiment writes it).")
      .def("__repr__", [](const LogMetadata& d) {
        return "LogMetadata('" + d.experiment + "', model='" + d.model +
               "', seed=" + std::to_string(d.seed) + ", " + std::to_string(d.columns.size()) +
               " columns)";
      });

  m.def("read_log_metadata", &read_log_metadata, py::arg("json_path"),
        "Reads a run log's JSON sidecar (log.json) into a LogMetadata; ValueError naming the file\n"
        "and field for a malformed one. dronetwin.read_log_metadata also takes the run directory\n"
        "or the CSV.");
  m.def("parse_log_metadata", &parse_log_metadata, py::arg("json_text"),
        py::arg("source_name") = "<string>", "A LogMetadata from sidecar JSON text.");
  m.def("sidecar_path", &sidecar_path, py::arg("csv_path"),
        "The sidecar of a log: the same stem with '.json' ('out/log.csv' -> 'out/log.json').");
  m.def("file_hash", &file_hash, py::arg("path"),
        "'fnv1a64:<16 hex digits>': 64-bit FNV-1a of a file's bytes, as in a sidecar's\n"
        "model_hash (check a log against a model file). ValueError if it cannot be read.");
  m.def(
      "fnv1a64", [](const py::bytes& data) { return fnv1a64(std::string_view(data)); },
      py::arg("data"), "64-bit FNV-1a of a bytes object, as an int.");

  m.def(
      "log_column_names",
      [](int num_rotors, bool measured, bool wrench_breakdown, bool controller) {
        return log_column_names(LogLayout{num_rotors, measured, wrench_breakdown, controller});
      },
      py::arg("num_rotors") = 4, py::arg("measured") = true, py::arg("wrench_breakdown") = false,
      py::arg("controller") = false, "The column names of a run log with these groups.");

  m.def(
      "load_controller",
      [](const std::string& path, const std::shared_ptr<VehicleModel>& model, double rate) {
        if (!model)
          throw py::value_error("load_controller: model must be a VehicleModel, got None");
        return load_controller(path, model, rate);
      },
      py::arg("path"), py::arg("model"), py::arg("control_rate_hz"),
      "Builds the controller a controller file describes (docs/controllers.md) for `model`.");
  m.def(
      "controller_from_yaml",
      [](const std::string& text, const std::shared_ptr<VehicleModel>& model, double rate,
         const std::string& source) {
        if (!model)
          throw py::value_error("controller_from_yaml: model must be a VehicleModel, got None");
        return make_controller_from_yaml(text, source, model, rate);
      },
      py::arg("yaml_text"), py::arg("model"), py::arg("control_rate_hz"),
      py::arg("source_name") = "<string>", "A controller from controller-file YAML text.");
}

}  // namespace dronetwin::python
