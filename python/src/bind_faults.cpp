// Rotor faults (faults/rotor_fault.hpp): lost effectiveness, a stop, a stuck motor from a given
// time on, for SimConfig.faults, Simulator.set_faults and Experiment.faults (lists of RotorFault).
#include <string>
#include <vector>

#include "bindings.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/faults/rotor_fault.hpp"
#include "dronetwin/sim/simulator.hpp"

namespace dronetwin::python {

FaultSettings fault_settings_of(const std::vector<RotorFault>& faults) {
  require(faults.size() <= static_cast<std::size_t>(kMaxRotorFaults), "faults: expected at most ",
          kMaxRotorFaults, " rotor faults, got ", faults.size());
  FaultSettings f;
  for (std::size_t i = 0; i < faults.size(); ++i) f.rotor[i] = faults[i];
  f.num_rotor_faults = static_cast<int>(faults.size());
  return f;
}

std::vector<RotorFault> fault_list_of(const FaultSettings& f) {
  return {f.rotor.begin(), f.rotor.begin() + f.num_rotor_faults};
}

void bind_faults(py::module_& m) {
  py::enum_<RotorFaultKind>(m, "RotorFaultKind", "What goes wrong with the rotor.")
      .value("EFFECTIVENESS", RotorFaultKind::kEffectiveness,
             "It makes `effectiveness` times its thrust (and the moments proportional to it).")
      .value("STOP", RotorFaultKind::kStop, "Its motor's reference becomes zero.")
      .value("STUCK", RotorFaultKind::kStuck, "It keeps its speed whatever the reference.");

  py::class_<RotorFault>(
      m, "RotorFault",
      "A rotor fault from start_s on (from the physics step nearest it); the controller is not "
      "told.\n\n"
      "    cfg.faults = [dronetwin.RotorFault.degraded(0, 10.0, 0.5)]")
      .def(py::init([](RotorFaultKind kind, int rotor, double start_s, double effectiveness) {
             return RotorFault{kind, rotor, start_s, effectiveness};
           }),
           py::arg("kind"), py::arg("rotor"), py::arg("start_s"), py::arg("effectiveness") = 1.0)
      .def_static(
          "degraded",
          [](int rotor, double start_s, double effectiveness) {
            return RotorFault{RotorFaultKind::kEffectiveness, rotor, start_s, effectiveness};
          },
          py::arg("rotor"), py::arg("start_s"), py::arg("effectiveness"),
          "Lost effectiveness: the rotor makes `effectiveness` (in [0, 1]) times its thrust.")
      .def_static(
          "stop",
          [](int rotor, double start_s) {
            return RotorFault{RotorFaultKind::kStop, rotor, start_s, 1.0};
          },
          py::arg("rotor"), py::arg("start_s"))
      .def_static(
          "stuck",
          [](int rotor, double start_s) {
            return RotorFault{RotorFaultKind::kStuck, rotor, start_s, 1.0};
          },
          py::arg("rotor"), py::arg("start_s"))
      .def_readwrite("kind", &RotorFault::kind)
      .def_readwrite("rotor", &RotorFault::rotor)
      .def_readwrite("start_s", &RotorFault::start_s)
      .def_readwrite("effectiveness", &RotorFault::effectiveness)
      .def("__repr__", [](const RotorFault& f) {
        return "RotorFault(" + std::string(kRotorFaultNames[static_cast<std::size_t>(f.kind)]) +
               ", rotor=" + std::to_string(f.rotor) + ", start_s=" + std::to_string(f.start_s) +
               (f.kind == RotorFaultKind::kEffectiveness
                    ? ", effectiveness=" + std::to_string(f.effectiveness)
                    : std::string()) +
               ")";
      });
}

}  // namespace dronetwin::python
