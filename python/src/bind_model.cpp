// Bindings of the vehicle model layer: RotorParams, VehicleSpec (editable plain data),
// VehicleModel (immutable, shared by simulators and controllers), loading and saving model files,
// and the allocation.

#include "bindings.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/model/allocation.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin::python {

namespace {

using ModelPtr = std::shared_ptr<VehicleModel>;

ModelPtr share(VehicleModel model) { return std::make_shared<VehicleModel>(std::move(model)); }

}  // namespace

void bind_model(py::module_& m) {
  py::enum_<AllocationMethod>(
      m, "AllocationMethod", "How generalized forces [T, tau_x, tau_y, tau_z] become rotor speeds.")
      .value("EXACT", AllocationMethod::kExact,
             "Thrust-first pseudo-inverse of the allocation matrix with saturation handling.")
      .value("THESIS", AllocationMethod::kThesis,
             "Thesis Eq. 2.31: w_i^2 = (A^+ u)_i / 'K1 (drops 'K2 and 'K3).");

  py::class_<RotorParams>(
      m, "RotorParams", "Parameters of one rotor (propeller + motor), SI units (thesis Table 2.1).")
      .def(py::init<>())
      .def_property(
          "position_m", [](const RotorParams& r) { return r.position_m; },
          [](RotorParams& r, py::handle v) { r.position_m = to_fixed<3>(v, "position_m"); },
          "Hub position relative to the centre of mass, body frame, m.")
      .def_property(
          "axis", [](const RotorParams& r) { return r.axis; },
          [](RotorParams& r, py::handle v) { r.axis = to_fixed<3>(v, "axis"); },
          "Thrust direction, body frame (normalised when a model is built).")
      .def_readwrite("spin", &RotorParams::spin,
                     "Turning direction epsilon in {+1, -1} (thesis Eq. 2.24 sign convention).")
      .def_readwrite("thrust_coefficients", &RotorParams::thrust_coefficients,
                     "['K1 (N s^2/rad^2), 'K2 (N s/rad), 'K3 (N)] of T(w) = 'K1 w^2 + 'K2 w + 'K3 "
                     "(Eq. 2.22).")
      .def_readwrite("yaw_moment_per_thrust_m", &RotorParams::yaw_moment_per_thrust_m,
                     "Reaction moment per unit thrust 1/K_tau, m (Eq. 2.23).")
      .def_readwrite("rotor_drag_coefficient", &RotorParams::rotor_drag_coefficient,
                     "C_D, N s^2/(rad m) (Eq. 2.32).")
      .def_readwrite("rolling_moment_coefficient", &RotorParams::rolling_moment_coefficient,
                     "C_R, N s^2/rad (Eq. 2.32).")
      .def_readwrite("drag_moment_coefficient", &RotorParams::drag_moment_coefficient,
                     "C_MD, m (Eq. 2.32).")
      .def_readwrite("ground_effect_coefficient", &RotorParams::ground_effect_coefficient,
                     "C_G, m^2 (appendix C.2 form).")
      .def_readwrite("inertia_kgm2", &RotorParams::inertia_kgm2,
                     "Spinning-part inertia about the axis, kg m^2 (Eq. 2.35).")
      .def_readwrite("time_constant_rise_s", &RotorParams::time_constant_rise_s,
                     "Motor lag time constant while speeding up, s (Eq. 2.43-2.45).")
      .def_readwrite("time_constant_fall_s", &RotorParams::time_constant_fall_s,
                     "Motor lag time constant while slowing down, s.")
      .def_readwrite("min_speed_rad_s", &RotorParams::min_speed_rad_s)
      .def_readwrite("max_speed_rad_s", &RotorParams::max_speed_rad_s)
      .def(
          "thrust", [](const RotorParams& r, double w) { return r.thrust(w); },
          py::arg("speed_rad_s"), "Thrust T(w) in N at rotor speed w in rad/s (Eq. 2.22).")
      .def("speed_for_thrust", &RotorParams::speed_for_thrust, py::arg("thrust_N"),
           "The speed (rad/s) giving `thrust_N`, clamped to the speed limits.")
      .def("__repr__", [](const RotorParams& r) {
        return "RotorParams(position_m=[" + std::to_string(r.position_m.x()) + ", " +
               std::to_string(r.position_m.y()) + ", " + std::to_string(r.position_m.z()) +
               "], spin=" + std::to_string(r.spin) + ")";
      });

  py::class_<VehicleSpec>(
      m, "VehicleSpec",
      "Everything a model file says, as editable plain data. Edit, then build a VehicleModel:\n\n"
      "    spec = dronetwin.load_spec('models/qdrone2.yaml')\n"
      "    spec.mass_kg *= 1.1\n"
      "    model = dronetwin.VehicleModel(spec)      # validates\n\n"
      "Trap: `rotors` is returned as a copy; assign the whole list back after editing it.")
      .def(py::init<>())
      .def_readwrite("name", &VehicleSpec::name)
      .def_readwrite("source", &VehicleSpec::source, "Where the spec came from (for messages).")
      .def_readwrite("mass_kg", &VehicleSpec::mass_kg)
      .def_readwrite("inertia_kgm2", &VehicleSpec::inertia_kgm2,
                     "3x3 inertia about the centre of mass, body frame, kg m^2.")
      .def_readwrite("body_drag_Ns_per_m", &VehicleSpec::body_drag_Ns_per_m,
                     "3x3 body drag matrix A (F = -A v_air, body frame), N s/m.")
      .def_readwrite("ground_effect_min_height_m", &VehicleSpec::ground_effect_min_height_m)
      .def_readwrite("rotors", &VehicleSpec::rotors,
                     "The rotors (a copy; assign a list to change).")
      .def_readwrite("collision", &VehicleSpec::collision,
                     "CollisionShape, or None for a sphere over the rotors.")
      .def("to_yaml", &vehicle_spec_to_yaml, "The spec as model-file YAML text.")
      .def("save", &save_vehicle_spec, py::arg("path"), "Writes the spec as a model file.");

  py::class_<AllocationResult>(m, "AllocationResult", "Result of an allocation with saturation.")
      .def_property_readonly("speeds_rad_s",
                             [](const AllocationResult& r) { return copy_of(r.speeds_rad_s); })
      .def_property_readonly("thrusts_N",
                             [](const AllocationResult& r) { return copy_of(r.thrusts_N); })
      .def_property_readonly(
          "achieved", [](const AllocationResult& r) { return copy_of(r.achieved); },
          "The generalized force the thrusts give (= the request unless saturated).")
      .def_readonly("moment_scale", &AllocationResult::moment_scale,
                    "Factor (0..1) applied to the requested moments to respect the rotor limits.")
      .def_readonly("saturated", &AllocationResult::saturated);

  py::class_<VehicleModel, ModelPtr>(
      m, "VehicleModel",
      "A validated, immutable vehicle model (airframe, rotors, derived allocation matrices).\n"
      "Simulators and controllers share one model; it never changes after construction.\n\n"
      "    model = dronetwin.load_model('models/qdrone2.yaml')\n"
      "    model.hover_speeds_rad_s()        # numpy array, one speed per rotor")
      .def(py::init([](const VehicleSpec& spec) { return std::make_shared<VehicleModel>(spec); }),
           py::arg("spec"), "Validates `spec` (ValueError naming the field otherwise).")
      .def_property_readonly("name", &VehicleModel::name)
      .def_property_readonly("num_rotors", &VehicleModel::num_rotors)
      .def_property_readonly("mass_kg", &VehicleModel::mass_kg)
      .def_property_readonly("inertia_kgm2",
                             [](const VehicleModel& v) { return Mat3(v.inertia_kgm2()); })
      .def_property_readonly("body_drag_Ns_per_m",
                             [](const VehicleModel& v) { return Mat3(v.body_drag_Ns_per_m()); })
      .def_property_readonly(
          "collision_shape", [](const VehicleModel& v) { return v.collision_shape(); },
          "The file's CollisionShape, or a sphere of the largest rotor-hub distance + 0.1 m.")
      .def_property_readonly(
          "spec", [](const VehicleModel& v) { return v.spec(); },
          "A copy of the spec the model was built from (edit it for variants).")
      .def_property_readonly(
          "rotors",
          [](const VehicleModel& v) {
            std::vector<RotorParams> r;
            for (int i = 0; i < v.num_rotors(); ++i) r.push_back(v.rotor(i));
            return r;
          },
          "Copies of the rotor parameters.")
      .def(
          "rotor",
          [](const VehicleModel& v, int i) {
            if (i < 0 || i >= v.num_rotors())
              throw py::index_error("rotor index " + std::to_string(i) + " out of range [0, " +
                                    std::to_string(v.num_rotors()) + ")");
            return v.rotor(i);
          },
          py::arg("index"), "A copy of rotor `index`'s parameters.")
      .def_property_readonly(
          "allocation_matrix",
          [](const VehicleModel& v) { return Eigen::MatrixXd(v.allocation_matrix()); },
          "4 x N matrix A: [T, tau_x, tau_y, tau_z] = A @ rotor thrusts (Eq. 2.30).")
      .def_property_readonly(
          "allocation_pseudo_inverse",
          [](const VehicleModel& v) { return Eigen::MatrixXd(v.allocation_pseudo_inverse()); },
          "N x 4 right pseudo-inverse of the allocation matrix.")
      .def_property_readonly(
          "wrench_matrix", [](const VehicleModel& v) { return Eigen::MatrixXd(v.wrench_matrix()); },
          "6 x N matrix: [F_B; M_B] per unit thrust of each rotor.")
      .def_property_readonly("wrench_rank", &VehicleModel::wrench_rank)
      .def(
          "hover_speeds_rad_s",
          [](const VehicleModel& v, double g) { return copy_of(v.hover_speeds_rad_s(g)); },
          py::arg("gravity_m_s2") = 9.81, "Rotor speeds that hold the vehicle level in hover.")
      .def(
          "hover_thrusts_N",
          [](const VehicleModel& v, double g) { return copy_of(v.hover_thrusts_N(g)); },
          py::arg("gravity_m_s2") = 9.81, "Rotor thrusts in hover.")
      .def(
          "thrusts_for",
          [](const VehicleModel& v, py::handle u) {
            return copy_of(v.thrusts_for(to_fixed<4>(u, "thrusts_for: u")));
          },
          py::arg("u"), "Rotor thrusts A^+ u for a generalized force u = [T, tau_x, tau_y, tau_z].")
      .def(
          "allocate",
          [](const VehicleModel& v, py::handle u, AllocationMethod method) {
            const GeneralizedForce uu = to_fixed<4>(u, "allocate: u");
            if (method == AllocationMethod::kExact) return allocate_with_saturation(v, uu);
            AllocationResult r;
            r.speeds_rad_s = allocate_speeds(v, uu, method);
            r.thrusts_N.resize(v.num_rotors());
            for (int i = 0; i < v.num_rotors(); ++i)
              r.thrusts_N[i] = v.rotor(i).thrust(r.speeds_rad_s[i]);
            r.achieved = v.allocation_matrix() * r.thrusts_N;
            r.saturated = (r.achieved - uu).norm() > 1e-9 * (1.0 + uu.norm());
            return r;
          },
          py::arg("u"), py::arg("method") = AllocationMethod::kExact,
          "Rotor speeds for the generalized force u, with saturation information.")
      .def(
          "to_yaml", [](const VehicleModel& v) { return vehicle_spec_to_yaml(v.spec()); },
          "The model's spec as model-file YAML text.")
      .def("__repr__", [](const VehicleModel& v) {
        return "VehicleModel('" + v.name() + "', rotors=" + std::to_string(v.num_rotors()) +
               ", mass_kg=" + std::to_string(v.mass_kg()) + ")";
      });

  m.def(
      "load_model", [](const std::string& path) { return share(load_vehicle_model(path)); },
      py::arg("path"),
      "Reads and validates a model file (docs/model-format.md). ValueError names the file and "
      "field of any problem.");
  m.def(
      "load_spec", &load_vehicle_spec, py::arg("path"),
      "Reads a model file into an editable VehicleSpec (validated when a VehicleModel is built).");
  m.def(
      "parse_model",
      [](const std::string& text, const std::string& source) {
        return share(VehicleModel(parse_vehicle_spec(text, source)));
      },
      py::arg("yaml_text"), py::arg("source_name") = "<string>",
      "Builds a model from model-file YAML text; `source_name` stands for the file in messages.");
}

}  // namespace dronetwin::python
