// Bindings of parameter identification (identification/fit.hpp): flights read from logs, the
// fit with its options and its result.

#include "bindings.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/identification/fit.hpp"
#include "dronetwin/identification/flight_data.hpp"
#include "dronetwin/model/model_parameters.hpp"

namespace dronetwin::python {

namespace {

py::dict stats_dict(const ResidualStats& s) {
  py::dict d;
  d["intervals"] = s.intervals;
  d["linear_acceleration_m_s2"] = s.linear_acceleration_m_s2;
  d["angular_acceleration_rad_s2"] = s.angular_acceleration_rad_s2;
  d["position_m"] = s.position_m;
  d["attitude_rad"] = s.attitude_rad;
  d["motor_speed_rad_s"] = s.motor_speed_rad_s;
  return d;
}

std::vector<ModelParameter> parameters_from(py::handle obj) {
  if (py::isinstance<py::str>(obj)) return parse_parameter_list(obj.cast<std::string>());
  std::string list;
  for (py::handle item : obj) {
    if (!py::isinstance<py::str>(item)) {
      throw py::type_error(detail::concat(
          "params: expected a str or a list of str, got an item that is ", describe_object(item)));
    }
    if (!list.empty()) list += ',';
    list += item.cast<std::string>();
  }
  return parse_parameter_list(list);
}

}  // namespace

void bind_fit(py::module_& m) {
  py::class_<FlightData>(m, "FlightData",
                         "A logged flight as the fit sees it (one entry per log row).\n\n"
                         "    flight = dronetwin.read_flight('out/id/log.csv', num_rotors=4)\n"
                         "    flight.state.shape          # (rows, 13): [p, v, q_wxyz, w_B]")
      .def_property_readonly("source", &FlightData::source)
      .def_property_readonly("num_rotors", &FlightData::num_rotors)
      .def_property_readonly("used_measured", &FlightData::used_measured,
                             "True when the state came from the meas_* columns.")
      .def_property_readonly(
          "has_body_rates", &FlightData::has_body_rates,
          "False when the log had no wx, wy, wz (then derived from the attitudes).")
      .def_property_readonly("has_specific_force", &FlightData::has_specific_force,
                             "True when the log had acc_x, acc_y, acc_z.")
      .def_property_readonly("nbytes", &FlightData::bytes,
                             "Bytes held by the rows (201 per row for a quadrotor with every "
                             "column).")
      .def_property_readonly(
          "t_s",
          [](const FlightData& d) {
            py::array_t<double> a(static_cast<py::ssize_t>(d.rows()));
            auto out = a.mutable_unchecked<1>();
            for (std::size_t k = 0; k < d.rows(); ++k) out(static_cast<py::ssize_t>(k)) = d.t_s(k);
            return a;
          },
          "Row times, s (a copy).")
      .def_property_readonly(
          "state",
          [](const FlightData& d) {
            return rows_of(d.rows(), kStateSize, [&](std::size_t k) { return d.state(k); });
          },
          "(rows, 13) state, a copy.")
      .def_property_readonly(
          "rotor_speed_rad_s",
          [](const FlightData& d) {
            return rows_of(d.rows(), d.num_rotors(),
                           [&](std::size_t k) { return d.rotor_speeds_rad_s(k); });
          },
          "(rows, num_rotors) rotor speeds, a copy.")
      .def(
          "__len__", [](const FlightData& d) { return d.rows(); }, "Number of rows.");

  m.def(
      "read_flight",
      [](const std::string& path, int num_rotors, bool prefer_measured) {
        return read_flight_data(path, num_rotors, prefer_measured);
      },
      py::arg("path"), py::arg("num_rotors"), py::arg("prefer_measured") = true,
      py::call_guard<py::gil_scoped_release>(),
      "Reads a log (CSV) into a FlightData, streaming it (only the columns the fit reads are "
      "kept): t, the state (measured columns when present and prefer_measured), omega_0.., and "
      "omega_ref_*, in_contact, acc_* when present. ValueError naming the file and the missing "
      "column otherwise.");

  py::class_<FittedParameter>(m, "FittedParameter", "One identified parameter.")
      .def_readonly("name", &FittedParameter::name)
      .def_readonly("unit", &FittedParameter::unit)
      .def_readonly("initial", &FittedParameter::initial, "Value in the starting model.")
      .def_readonly("estimate", &FittedParameter::estimate)
      .def_readonly("std_error", &FittedParameter::std_error,
                    "Standard error from Ceres' covariance (NaN when it could not be computed).")
      .def("__repr__", [](const FittedParameter& p) {
        return detail::concat("FittedParameter(", p.name, " = ", p.estimate, " +- ", p.std_error,
                              " ", p.unit, ")");
      });

  py::class_<FitResult>(
      m, "FitResult",
      "The result of fit_model: estimates with standard errors, correlations, "
      "residuals before/after on the fitted and held-out parts, warnings, and the "
      "fitted model spec.")
      .def_readonly("parameters", &FitResult::parameters)
      .def_property_readonly(
          "correlation", [](const FitResult& r) { return Eigen::MatrixXd(r.correlation); },
          "Correlation matrix of the estimates (parameters order); empty if the "
          "covariance failed.")
      .def_readonly("warnings", &FitResult::warnings)
      .def_property_readonly(
          "fit_before", [](const FitResult& r) { return stats_dict(r.fit_before); },
          "Residual RMS on the fitted intervals with the starting model.")
      .def_property_readonly(
          "fit_after", [](const FitResult& r) { return stats_dict(r.fit_after); },
          "Residual RMS on the fitted intervals with the estimates.")
      .def_property_readonly(
          "holdout_before", [](const FitResult& r) { return stats_dict(r.holdout_before); },
          "Residual RMS on the held-out intervals with the starting model.")
      .def_property_readonly(
          "holdout_after", [](const FitResult& r) { return stats_dict(r.holdout_after); },
          "Residual RMS on the held-out intervals with the estimates.")
      .def_property_readonly(
          "speed_sensor_gains",
          [](const FitResult& r) {
            py::list l;
            for (const FittedGain& g : r.speed_sensor_gains)
              l.append(py::make_tuple(g.estimate, g.std_error));
            return l;
          },
          "[(gain, std_error)] per rotor (true speed = gain x logged speed; mean 1); empty when "
          "the gains were not fitted.")
      .def_property_readonly(
          "holdout_check",
          [](const FitResult& r) {
            py::dict d;
            d["available"] = r.holdout_check.available;
            d["worse"] = r.holdout_check.worse;
            d["summary"] = r.holdout_check.summary;
            py::dict channels;
            for (const HoldoutCheck::Channel& c : r.holdout_check.channels)
              channels[py::str(c.name)] = py::make_tuple(c.before, c.after);
            d["channels"] = channels;
            return d;
          },
          "The fitted model against the starting one on the held-out part: {'available', "
          "'worse', 'summary', 'channels': {name: (before, after)}} (mean loss per residual in "
          "noise levels). `dronetwin fit` does not write a model whose check is worse unless "
          "--force.")
      .def_property_readonly(
          "holdout_worse", [](const FitResult& r) { return r.holdout_check.worse; },
          "True when the fit explains the held-out part worse than the starting model.")
      .def_property_readonly(
          "channels",
          [](const FitResult& r) {
            std::vector<std::string> c;
            if (r.used_linear) c.emplace_back("linear");
            if (r.used_angular) c.emplace_back("angular");
            return c;
          },
          "The equation-error channels the fit used.")
      .def_property_readonly("loss",
                             [](const FitResult& r) { return std::string(fit_loss_name(r.loss)); })
      .def_readonly("loss_scale", &FitResult::loss_scale)
      .def_readonly("rows", &FitResult::rows)
      .def_readonly("intervals_used", &FitResult::intervals_used)
      .def_readonly("intervals_holdout", &FitResult::intervals_holdout)
      .def_readonly("gaps", &FitResult::gaps)
      .def_readonly("iterations", &FitResult::iterations)
      .def_readonly("coarse_stride", &FitResult::coarse_stride)
      .def_readonly("termination", &FitResult::termination)
      .def_readonly("solve_time_s", &FitResult::solve_time_s)
      .def_readonly("fitted_spec", &FitResult::fitted_spec,
                    "The starting model's spec with the estimates written in (VehicleModel(spec) "
                    "validates it).")
      .def(
          "estimates",
          [](const FitResult& r) {
            py::dict d;
            for (const FittedParameter& p : r.parameters)
              d[py::str(p.name)] = py::make_tuple(p.estimate, p.std_error);
            return d;
          },
          "{name: (estimate, std_error)}.")
      .def("report", &format_fit_report, "The report `dronetwin fit` prints.")
      .def("to_json", &fit_result_to_json,
           "The report as JSON text (what `dronetwin fit --report` writes).");

  m.def(
      "fit_model",
      [](const std::shared_ptr<VehicleModel>& model, const FlightData& flight, py::object params,
         const std::string& method, double holdout, py::object switches, double min_height_m,
         double window_s, int max_windows, int max_iterations, const std::string& channels,
         const std::string& loss, std::optional<double> loss_scale, const std::string& speed_gains,
         int num_threads, long long coarse_intervals) {
        FitOptions o;
        o.parameters = parameters_from(params);
        if (method == "equation")
          o.method = FitMethod::kEquationError;
        else if (method == "output")
          o.method = FitMethod::kOutputError;
        else if (method == "both")
          o.method = FitMethod::kBoth;
        else
          throw InvalidArgument(detail::concat(
              "fit_model: method must be 'equation', 'output' or 'both', got '", method, "'"));
        o.channels = parse_fit_channels(channels);
        o.loss = parse_fit_loss(loss);
        o.loss_scale = loss_scale;
        o.speed_sensor_gains = parse_speed_sensor_gains(speed_gains);
        o.holdout_fraction = holdout;
        if (!switches.is_none()) o.switches = switches.cast<DisturbanceSwitches>();
        o.min_height_m = min_height_m;
        o.window_s = window_s;
        o.max_windows = max_windows;
        o.max_iterations = max_iterations;
        o.num_threads = num_threads;
        require(coarse_intervals >= 0, "fit_model: coarse_intervals must be >= 0, got ",
                coarse_intervals);
        o.coarse_intervals = static_cast<std::size_t>(coarse_intervals);
        py::gil_scoped_release release;
        return fit_model(*model, flight, o);
      },
      py::arg("model"), py::arg("flight"), py::arg("params"), py::kw_only(),
      py::arg("method") = "both", py::arg("holdout") = 0.2, py::arg("switches") = py::none(),
      py::arg("min_height_m") = -std::numeric_limits<double>::infinity(),
      py::arg("window_s") = 0.05, py::arg("max_windows") = 200, py::arg("max_iterations") = 50,
      py::arg("channels") = "auto", py::arg("loss") = "huber", py::arg("loss_scale") = py::none(),
      py::arg("speed_gains") = "auto", py::arg("num_threads") = 1,
      py::arg("coarse_intervals") = 200000,
      "Identifies `params` (names or groups, as a list or a comma-separated str: mass, inertia, "
      "thrust, yaw_moment_per_thrust, drag_moment, rotor_drag, rolling_moment, body_drag, "
      "ground_effect, motor, ...) of `model` from `flight` with Ceres; the same fit as "
      "`dronetwin fit`, with the same options and checks: channels ('auto', 'linear', 'angular', "
      "'linear,angular'), loss ('huber', 'cauchy', 'none') with loss_scale in noise levels, "
      "speed_gains ('auto', 'fit', 'off'), num_threads (the result is the same on any number), "
      "coarse_intervals (a longer log starts on a subsample; 0: never). "
      "Check r.holdout_worse before using the fitted model. The GIL is released while it runs.\n\n"
      "    flight = dronetwin.read_flight('out/id/log.csv', 4)\n"
      "    r = dronetwin.fit_model(model, flight, 'thrust,inertia')\n"
      "    print(r.report()); fitted = dronetwin.VehicleModel(r.fitted_spec)");
  const auto single = [](const std::string& name) {
    const std::vector<ModelParameter> p = parse_parameter_list(name);
    require(p.size() == 1, "'", name, "' names a group of ", p.size(),
            " parameters; give one parameter");
    return p[0];
  };
  m.def(
      "parameter_value",
      [single](const VehicleSpec& spec, const std::string& name) {
        return parameter_value(spec, single(name));
      },
      py::arg("spec"), py::arg("name"),
      "Value of one identifiable parameter in a spec (the mean over rotors for per-rotor ones).");
  m.def(
      "set_parameter_value",
      [single](VehicleSpec& spec, const std::string& name, double value) {
        set_parameter_value(spec, single(name), value);
      },
      py::arg("spec"), py::arg("name"), py::arg("value"),
      "Writes one identifiable parameter into a spec (per-rotor coefficients are scaled "
      "together).");
  m.def(
      "parameter_names",
      [] {
        std::vector<std::string> names;
        for (int j = 0; j < kNumModelParameters; ++j)
          names.emplace_back(parameter_name(static_cast<ModelParameter>(j)));
        return names;
      },
      "Names of every parameter fit_model can identify.");
}

}  // namespace dronetwin::python
