// The slung payload (payload/slung_payload.hpp): SlungPayload and PayloadSettings for
// SimConfig.payload and Experiment.payload; Simulator.payload reads its state (PayloadState) and
// set_payload_state places it; Simulator.swing_angles() and payload_tension_N() read the cable.
#include <cstdio>
#include <string>

#include "bindings.hpp"
#include "dronetwin/payload/slung_payload.hpp"

namespace dronetwin::python {

void bind_payload(py::module_& m) {
  py::class_<SlungPayload>(m, "SlungPayload",
                           "A point mass on a cable from the vehicle's centre of mass "
                           "(docs/payload.md): mass_kg, tether_length_m, drag_area_m2, "
                           "air_density_kg_m3.")
      .def(py::init([](double mass_kg, double tether_length_m, double drag_area_m2,
                       double air_density_kg_m3) {
             return SlungPayload{mass_kg, tether_length_m, drag_area_m2, air_density_kg_m3};
           }),
           py::arg("mass_kg") = 0.5, py::arg("tether_length_m") = 0.5,
           py::arg("drag_area_m2") = 0.0, py::arg("air_density_kg_m3") = 1.225)
      .def_readwrite("mass_kg", &SlungPayload::mass_kg)
      .def_readwrite("tether_length_m", &SlungPayload::tether_length_m)
      .def_readwrite("drag_area_m2", &SlungPayload::drag_area_m2)
      .def_readwrite("air_density_kg_m3", &SlungPayload::air_density_kg_m3);

  py::class_<PayloadSettings>(m, "PayloadSettings",
                              "SimConfig.payload: on/off, the payload and the swing angles it "
                              "starts at (Eq. 3.33, rad).")
      .def(py::init([](bool enabled, const SlungPayload& payload, double swing1, double swing2) {
             return PayloadSettings{enabled, payload, swing1, swing2};
           }),
           py::arg("enabled") = true, py::arg("payload") = SlungPayload{},
           py::arg("initial_swing1_rad") = 0.0, py::arg("initial_swing2_rad") = 0.0)
      .def_readwrite("enabled", &PayloadSettings::enabled)
      .def_readwrite("payload", &PayloadSettings::payload)
      .def_readwrite("initial_swing1_rad", &PayloadSettings::initial_swing1_rad)
      .def_readwrite("initial_swing2_rad", &PayloadSettings::initial_swing2_rad);

  py::class_<PayloadState>(m, "PayloadState",
                           "The payload (a copy): position_W_m, velocity_W_m_s, taut, on_ground.")
      .def(py::init([](py::handle position, py::handle velocity) {
             PayloadState s;
             s.position_W_m = to_fixed<3>(position, "PayloadState: position_W_m");
             s.velocity_W_m_s = to_fixed<3>(velocity, "PayloadState: velocity_W_m_s");
             return s;
           }),
           py::arg("position_W_m"), py::arg("velocity_W_m_s") = py::make_tuple(0.0, 0.0, 0.0))
      .def_property_readonly("position_W_m",
                             [](const PayloadState& s) { return copy_of(s.position_W_m); })
      .def_property_readonly("velocity_W_m_s",
                             [](const PayloadState& s) { return copy_of(s.velocity_W_m_s); })
      .def_readonly("taut", &PayloadState::taut)
      .def_readonly("on_ground", &PayloadState::on_ground)
      .def("__repr__", [](const PayloadState& s) {
        char text[200];
        std::snprintf(text, sizeof text,
                      "PayloadState(position_W_m=[%.4f, %.4f, %.4f], taut=%s, on_ground=%s)",
                      s.position_W_m.x(), s.position_W_m.y(), s.position_W_m.z(),
                      s.taut ? "True" : "False", s.on_ground ? "True" : "False");
        return std::string(text);
      });

  py::class_<SwingAngles>(m, "SwingAngles", "Eq. 3.33's swing angles and rates (rad, rad/s).")
      .def_readonly("gamma1_rad", &SwingAngles::gamma1_rad)
      .def_readonly("gamma2_rad", &SwingAngles::gamma2_rad)
      .def_readonly("gamma1_rate_rad_s", &SwingAngles::gamma1_rate_rad_s)
      .def_readonly("gamma2_rate_rad_s", &SwingAngles::gamma2_rate_rad_s);
}

}  // namespace dronetwin::python
