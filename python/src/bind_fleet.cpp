// Several vehicles (fleet/fleet.hpp) and the downwash between them (dynamics/downwash.hpp):
// DownwashSettings, WakeSource, DownwashEffect and the functions that compute them; fleet
// experiment files (load_fleet_experiment, run_fleet_experiment) and their summaries.
#include <string>
#include <vector>

#include "bindings.hpp"
#include "dronetwin/app/run_fleet.hpp"
#include "dronetwin/config/fleet_experiment.hpp"
#include "dronetwin/dynamics/downwash.hpp"

namespace dronetwin::python {

void bind_fleet(py::module_& m) {
  py::class_<DownwashSettings>(m, "DownwashSettings",
                               "The wake model (docs/fleet.md): a round turbulent jet "
                               "(spreading_rate S) and the thrust it takes from a rotor in it "
                               "(thrust_lapse kappa: dT/T = -kappa w / v_h).")
      .def(py::init([](bool enabled, double spreading_rate, double propeller_radius_m,
                       double thrust_lapse, double air_density_kg_m3) {
             return DownwashSettings{enabled, spreading_rate, propeller_radius_m, thrust_lapse,
                                     air_density_kg_m3};
           }),
           py::arg("enabled") = true, py::arg("spreading_rate") = 0.094,
           py::arg("propeller_radius_m") = 0.1, py::arg("thrust_lapse") = 0.5,
           py::arg("air_density_kg_m3") = 1.225)
      .def_readwrite("enabled", &DownwashSettings::enabled)
      .def_readwrite("spreading_rate", &DownwashSettings::spreading_rate)
      .def_readwrite("propeller_radius_m", &DownwashSettings::propeller_radius_m)
      .def_readwrite("thrust_lapse", &DownwashSettings::thrust_lapse)
      .def_readwrite("air_density_kg_m3", &DownwashSettings::air_density_kg_m3);

  py::class_<WakeSource>(m, "WakeSource",
                         "A vehicle as a source of wake: position_W_m, thrust_axis_W (b3), "
                         "thrust_N, half_width_m (rotor layout).")
      .def(py::init<>())
      .def_property(
          "position_W_m", [](const WakeSource& w) { return copy_of(w.position_W_m); },
          [](WakeSource& w, py::handle v) { w.position_W_m = to_fixed<3>(v, "position_W_m"); })
      .def_property(
          "thrust_axis_W", [](const WakeSource& w) { return copy_of(w.thrust_axis_W); },
          [](WakeSource& w, py::handle v) { w.thrust_axis_W = to_fixed<3>(v, "thrust_axis_W"); })
      .def_readwrite("thrust_N", &WakeSource::thrust_N)
      .def_readwrite("half_width_m", &WakeSource::half_width_m);

  py::class_<DownwashEffect>(m, "DownwashEffect",
                             "What wakes do to a vehicle: flow_W_m_s (air velocity at its centre "
                             "of mass) and wrench_B ([F_B, M_B] of its rotors' thrust change).")
      .def_property_readonly("flow_W_m_s",
                             [](const DownwashEffect& e) { return copy_of(e.flow_W_m_s); })
      .def_property_readonly("wrench_B",
                             [](const DownwashEffect& e) { return copy_of(e.wrench_B); });

  m.def(
      "wake_source",
      [](const DownwashSettings& s, const VehicleModel& model, py::handle x, py::handle speeds) {
        return wake_source(s, model, to_fixed<kStateSize>(x, "wake_source: state"),
                           to_rotor_vector(speeds, model.num_rotors(), "wake_source: speeds"));
      },
      py::arg("settings"), py::arg("model"), py::arg("state"), py::arg("rotor_speeds_rad_s"),
      "The WakeSource of a vehicle of `model` at `state` with these rotor speeds.");
  m.def(
      "wake_velocity",
      [](const DownwashSettings& s, const WakeSource& w, py::handle p) {
        return copy_of(wake_velocity_W_m_s(s, w, to_fixed<3>(p, "wake_velocity: point_W")));
      },
      py::arg("settings"), py::arg("source"), py::arg("point_W"),
      "Mean wake velocity of `source` at `point_W`, world frame, m/s.");
  m.def(
      "downwash_effect",
      [](const DownwashSettings& s, const VehicleModel& model, py::handle x, py::handle speeds,
         const std::vector<WakeSource>& sources) {
        return downwash_effect(
            s, model, to_fixed<kStateSize>(x, "downwash_effect: state"),
            to_rotor_vector(speeds, model.num_rotors(), "downwash_effect: rotor_speeds_rad_s"),
            sources.data(), static_cast<int>(sources.size()));
      },
      py::arg("settings"), py::arg("model"), py::arg("state"), py::arg("rotor_speeds_rad_s"),
      py::arg("sources"),
      "What the wakes of `sources` (a list of WakeSource) do to this vehicle: a DownwashEffect, "
      "for Simulator.set_interaction.");

  py::class_<FleetVehicleSummary>(m, "FleetVehicleSummary",
                                  "One vehicle of a fleet run: name, folder, run (its "
                                  "RunSummary), max_downwash_flow_m_s, max_thrust_loss_N.")
      .def_readonly("name", &FleetVehicleSummary::name)
      .def_readonly("folder", &FleetVehicleSummary::folder)
      .def_readonly("run", &FleetVehicleSummary::run)
      .def_readonly("max_downwash_flow_m_s", &FleetVehicleSummary::max_downwash_flow_m_s)
      .def_readonly("max_thrust_loss_N", &FleetVehicleSummary::max_thrust_loss_N);
  py::class_<FleetRunSummary>(m, "FleetRunSummary",
                              "The outcome of run_fleet_experiment (fleet_summary.json).")
      .def_readonly("experiment_name", &FleetRunSummary::experiment_name)
      .def_readonly("downwash", &FleetRunSummary::downwash)
      .def_readonly("steps", &FleetRunSummary::steps)
      .def_readonly("steps_requested", &FleetRunSummary::steps_requested)
      .def_readonly("duration_s", &FleetRunSummary::duration_s)
      .def_readonly("status", &FleetRunSummary::status)
      .def_readonly("failure_message", &FleetRunSummary::failure_message)
      .def_readonly("vehicles", &FleetRunSummary::vehicles)
      .def_readonly("summary_path", &FleetRunSummary::summary_path)
      .def_property_readonly("ok", &FleetRunSummary::ok);

  m.def(
      "run_fleet_experiment",
      [](const std::string& path, const std::string& out_dir, bool overwrite, py::object downwash,
         py::object duration_s) {
        FleetExperiment f = load_fleet_experiment(path);
        if (!downwash.is_none()) f.downwash = downwash.cast<DownwashSettings>();
        if (!duration_s.is_none()) {
          f.duration_s = duration_s.cast<double>();
          for (FleetVehicleSpec& v : f.vehicles) v.experiment.duration_s = f.duration_s;
        }
        py::gil_scoped_release release;
        return run_fleet_experiment(f, out_dir, overwrite);
      },
      py::arg("path"), py::arg("out_dir"), py::arg("overwrite") = false,
      py::arg("downwash") = py::none(), py::arg("duration_s") = py::none(),
      "Runs a fleet experiment file as `dronetwin run` does: out_dir/<vehicle>/ (log.csv, "
      "log.json, summary.json) for each vehicle and out_dir/fleet_summary.json. `downwash` (a "
      "DownwashSettings) and `duration_s` replace the file's. The GIL is released during the "
      "run.");
}

}  // namespace dronetwin::python
