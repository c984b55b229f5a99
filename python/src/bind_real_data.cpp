// Bindings of the real-data readers and fits: PX4 ULog files, the Crazyflie thrust stand and
// CrazyPAD flights, and the importers that turn them into dronetwin logs.

#include "bindings.hpp"
#include "dronetwin/adapters/crazyflie_csv.hpp"
#include "dronetwin/adapters/crazypad_import.hpp"
#include "dronetwin/adapters/thrust_stand_fit.hpp"
#include "dronetwin/adapters/ulog.hpp"
#include "dronetwin/adapters/ulog_import.hpp"
#include "dronetwin/identification/linear_fit.hpp"
#include "dronetwin/identification/vertical_fit.hpp"
#include "dronetwin/logging/csv_log.hpp"

namespace dronetwin::python {

namespace {

py::array_t<double> array_of(const std::vector<double>& v) {
  py::array_t<double> a(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

py::dict topic_dict(const ULogTopic& t) {
  py::dict d;
  for (std::size_t i = 0; i < t.columns.size(); ++i)
    d[py::str(t.columns[i])] = array_of(t.values[i]);
  return d;
}

}  // namespace

void bind_real_data(py::module_& m) {
  py::class_<ULogMessage>(m, "ULogMessage", "A logged text message of a PX4 ULog.")
      .def_readonly("level", &ULogMessage::level, "syslog level 0 (emergency) .. 7 (debug).")
      .def_readonly("timestamp_us", &ULogMessage::timestamp_us)
      .def_readonly("text", &ULogMessage::text)
      .def_readonly("tag", &ULogMessage::tag);

  py::class_<ULog>(
      m, "ULog",
      "A PX4 ULog file read into memory (format: PX4's ULog v1 description).\n\n"
      "    log = dronetwin.read_ulog('flight.ulg')\n"
      "    log.topic_names()                      # [('vehicle_attitude', 0), ...]\n"
      "    att = log.topic('vehicle_attitude')    # {field: numpy array}, timestamp in s")
      .def_readonly("source", &ULog::source)
      .def_readonly("version", &ULog::version)
      .def_readonly("start_timestamp_us", &ULog::start_timestamp_us)
      .def_readonly("info", &ULog::info, "Info messages: key -> value text.")
      .def_readonly("info_multiple", &ULog::info_multiple)
      .def_readonly("parameters", &ULog::parameters, "Initial parameter values.")
      .def_readonly("parameter_changes", &ULog::parameter_changes)
      .def_readonly("messages", &ULog::messages)
      .def_readonly("dropout_total_ms", &ULog::dropout_total_ms)
      .def_readonly("dropout_count", &ULog::dropout_count)
      .def(
          "topic_names",
          [](const ULog& l) {
            std::vector<std::pair<std::string, int>> names;
            for (const ULogTopic& t : l.topics) names.emplace_back(t.name, t.multi_id);
            return names;
          },
          "(name, multi_id) of every logged topic instance.")
      .def("has_topic", &ULog::has_topic, py::arg("name"), py::arg("multi_id") = 0,
           "Whether the topic instance was logged.")
      .def(
          "topic",
          [](const ULog& l, const std::string& name, int id) {
            return topic_dict(l.topic(name, id));
          },
          py::arg("name"), py::arg("multi_id") = 0,
          "A topic instance as {flattened field: float64 array}; 'timestamp' in seconds. "
          "ValueError listing the logged topics if it is absent.");
  m.def("read_ulog", &read_ulog, py::arg("path"), py::call_guard<py::gil_scoped_release>(),
        "Reads a PX4 ULog file; ValueError naming the file and byte offset if it is malformed.");

  py::class_<LinearFit>(m, "LinearFit",
                        "A least-squares fit with standard errors (Ceres covariance).")
      .def_readonly("names", &LinearFit::names)
      .def_readonly("coefficients", &LinearFit::coefficients)
      .def_readonly("std_errors", &LinearFit::std_errors)
      .def_readonly("residual_rms", &LinearFit::residual_rms)
      .def_readonly("num_points", &LinearFit::num_points)
      .def(
          "as_dict",
          [](const LinearFit& f) {
            py::dict d;
            for (std::size_t i = 0; i < f.names.size(); ++i)
              d[py::str(f.names[i])] = py::make_tuple(f.coefficients[i], f.std_errors[i]);
            return d;
          },
          "{name: (estimate, standard error)}.");

  py::class_<SpeedMap>(m, "SpeedMap",
                       "Rotor speed from PWM and battery voltage: w = a u + b, u = pwm/65535 vbat.")
      .def_readonly("a_rad_s_per_V", &SpeedMap::a_rad_s_per_V)
      .def_readonly("b_rad_s", &SpeedMap::b_rad_s)
      .def("speed_rad_s", &SpeedMap::speed_rad_s, py::arg("pwm"), py::arg("vbat_V"),
           "Rotor speed (rad/s) at this PWM and battery voltage (0 when the motor is off).");

  py::class_<ThrustStandFit>(m, "ThrustStandFit",
                             "Thrust-stand fit of the Crazyflie (docs/identification.md).")
      .def_readonly("source", &ThrustStandFit::source)
      .def_readonly("tare_g", &ThrustStandFit::tare_g)
      .def_readonly("thrust", &ThrustStandFit::thrust, "K1, K2, K3 of Eq. 2.22, per motor.")
      .def_readonly("speed_map_fit", &ThrustStandFit::speed_map_fit)
      .def_readonly("speed_map_quadratic", &ThrustStandFit::speed_map_quadratic)
      .def_readonly("speed_map", &ThrustStandFit::speed_map)
      .def_readonly("motor_speed_ratio", &ThrustStandFit::motor_speed_ratio)
      .def_readonly("min_speed_rad_s", &ThrustStandFit::min_speed_rad_s)
      .def_readonly("max_speed_rad_s", &ThrustStandFit::max_speed_rad_s)
      .def_readonly("max_thrust_N", &ThrustStandFit::max_thrust_N);
  m.def(
      "fit_thrust_stand",
      [](const std::string& path, bool subtract_tare) {
        py::gil_scoped_release release;
        ThrustStandOptions o;
        o.subtract_tare = subtract_tare;
        return fit_thrust_stand(read_thrust_stand_csv(path), o);
      },
      py::arg("path"), py::arg("subtract_tare") = true,
      "Fits the thrust polynomial (Eq. 2.22) and the speed map to a Crazyflie thrust-stand CSV.");

  py::class_<VerticalFitResult>(m, "VerticalFitResult",
                                "Vertical thrust-to-mass fit of a real flight.")
      .def_readonly("fit", &VerticalFitResult::fit)
      .def_readonly("mass_kg", &VerticalFitResult::mass_kg)
      .def_readonly("mass_std_error_kg", &VerticalFitResult::mass_std_error_kg)
      .def_readonly("prior_mass_kg", &VerticalFitResult::prior_mass_kg)
      .def_readonly("num_train", &VerticalFitResult::num_train)
      .def_readonly("num_test", &VerticalFitResult::num_test)
      .def_readonly("t_split_s", &VerticalFitResult::t_split_s)
      .def_readonly("rms_train_m_s2", &VerticalFitResult::rms_train_m_s2)
      .def_readonly("rms_test_m_s2", &VerticalFitResult::rms_test_m_s2,
                    "Held-out residual RMS with the fitted parameters.")
      .def_readonly("rms_test_prior_m_s2", &VerticalFitResult::rms_test_prior_m_s2,
                    "Held-out residual RMS with the prior mass (no fit).");
  m.def(
      "fit_vertical",
      [](const std::string& log_path, const std::shared_ptr<VehicleModel>& model,
         double train_fraction, bool fit_drag, double min_height_m, double prior_mass_kg) {
        if (!model) throw py::value_error("fit_vertical: model must be a VehicleModel, got None");
        py::gil_scoped_release release;
        VerticalFitOptions o;
        o.train_fraction = train_fraction;
        o.fit_drag = fit_drag;
        o.min_height_m = min_height_m;
        o.prior_mass_kg = prior_mass_kg;
        return fit_vertical(read_csv_log(log_path), *model, o);
      },
      py::arg("log_path"), py::arg("model"), py::arg("train_fraction") = 0.7,
      py::arg("fit_drag") = true, py::arg("min_height_m") = 0.15, py::arg("prior_mass_kg") = 0.0,
      "Fits thrust per unit mass (and a vertical drag) to an imported flight log's vertical\n"
      "acceleration, training on the first train_fraction and reporting the held-out error.");

  m.def(
      "import_crazypad",
      [](const std::string& flight_csv, const std::string& stand_csv, const std::string& stem,
         bool overwrite) {
        py::gil_scoped_release release;
        const ThrustStandFit stand = fit_thrust_stand(read_thrust_stand_csv(stand_csv));
        const CrazyPadImport imp = import_crazypad(read_crazypad_csv(flight_csv), stand.speed_map);
        write_crazypad_import(imp, stem, stand_csv, overwrite);
        return stem + ".csv";
      },
      py::arg("flight_csv"), py::arg("stand_csv"), py::arg("out_stem"),
      py::arg("overwrite") = false,
      "Converts a CrazyPAD flight (decoded CSV) to a dronetwin log OUT_STEM.csv + OUT_STEM.json\n"
      "(rotor speeds through the stand's speed map); returns the CSV path.");
  m.def(
      "import_ulog",
      [](const std::string& ulg, const std::string& stem, bool overwrite) {
        py::gil_scoped_release release;
        write_ulog_import(import_ulog(read_ulog(ulg)), stem, overwrite);
        return stem + ".csv";
      },
      py::arg("ulog_path"), py::arg("out_stem"), py::arg("overwrite") = false,
      "Converts a PX4 ULog to a dronetwin log OUT_STEM.csv + OUT_STEM.json (z up, rpm -> rad/s).");
}

}  // namespace dronetwin::python
