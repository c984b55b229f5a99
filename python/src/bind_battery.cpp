// The battery (power/battery.hpp): an equivalent-circuit pack for SimConfig.battery,
// Simulator.set_battery and Experiment.battery; Simulator.battery reads its state.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/power/battery.hpp"

namespace dronetwin::python {

void bind_battery(py::module_& m) {
  py::class_<BatteryPack>(
      m, "BatteryPack",
      "An equivalent-circuit pack (docs/battery.md): OCV(SoC) per cell, series resistance and one "
      "RC branch; drained by the rotors' shaft power over `efficiency`; its terminal voltage caps "
      "the rotor speed at K_V V. Defaults: a 6S 2200 mAh LiPo for the QDrone2 (assumed).")
      .def(py::init<>())
      .def_readwrite("cells_in_series", &BatteryPack::cells_in_series)
      .def_readwrite("capacity_Ah", &BatteryPack::capacity_Ah)
      .def_property(
          "ocv_cell_V",
          [](const BatteryPack& p) {
            return std::vector<double>(p.ocv_cell_V.begin(), p.ocv_cell_V.end());
          },
          [](BatteryPack& p, const std::vector<double>& v) {
            require(v.size() == static_cast<std::size_t>(kOcvPoints),
                    "BatteryPack.ocv_cell_V: expected ", kOcvPoints,
                    " cell voltages (SoC 0, 0.1, ..., 1), got ", v.size());
            std::copy(v.begin(), v.end(), p.ocv_cell_V.begin());
          },
          "Rest voltage of one cell at SoC 0, 0.1, ..., 1, V (11 values, not falling).")
      .def_readwrite("series_resistance_ohm", &BatteryPack::series_resistance_ohm)
      .def_readwrite("rc_resistance_ohm", &BatteryPack::rc_resistance_ohm)
      .def_readwrite("rc_capacitance_F", &BatteryPack::rc_capacitance_F)
      .def_readwrite("efficiency", &BatteryPack::efficiency,
                     "Shaft power over electrical power (motors and ESCs).")
      .def_readwrite("motor_speed_constant_rad_per_V_s",
                     &BatteryPack::motor_speed_constant_rad_per_V_s,
                     "K_V, rad/(V s): the rotor speed cap is K_V times the terminal voltage.")
      .def_readwrite("cutoff_voltage_V", &BatteryPack::cutoff_voltage_V)
      .def_readwrite("initial_soc", &BatteryPack::initial_soc)
      .def(
          "open_circuit_voltage_V",
          [](const BatteryPack& p, double soc) { return open_circuit_voltage_V(p, soc); },
          py::arg("soc"),
          "The pack's open-circuit voltage at a state of charge (clamped to 0..1).");

  py::class_<BatterySettings>(m, "BatterySettings", "SimConfig.battery: on/off and the pack.")
      .def(py::init([](bool enabled, const BatteryPack& pack) {
             return BatterySettings{enabled, pack};
           }),
           py::arg("enabled") = true, py::arg("pack") = BatteryPack{})
      .def_readwrite("enabled", &BatterySettings::enabled)
      .def_readwrite("pack", &BatterySettings::pack);

  py::class_<BatteryState>(m, "BatteryState",
                           "The pack now (Simulator.battery, a copy): charge, RC voltage, the "
                           "last step's current and the terminal voltage under it.")
      .def_readonly("soc", &BatteryState::soc)
      .def_readonly("rc_voltage_V", &BatteryState::rc_voltage_V)
      .def_readonly("current_A", &BatteryState::current_A)
      .def_readonly("voltage_V", &BatteryState::voltage_V)
      .def_readonly("energy_drawn_J", &BatteryState::energy_drawn_J)
      .def_readonly("depleted", &BatteryState::depleted)
      .def("__repr__", [](const BatteryState& b) {
        char text[160];
        std::snprintf(text, sizeof text,
                      "BatteryState(soc=%.4f, voltage_V=%.3f, current_A=%.3f, depleted=%s)", b.soc,
                      b.voltage_V, b.current_A, b.depleted ? "True" : "False");
        return std::string(text);
      });
}

}  // namespace dronetwin::python
