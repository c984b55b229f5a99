// Bindings of the batched engine: BatchSimulator in float64 and float32 (the Python function
// dronetwin.BatchSimulator picks one by dtype).
//
// The state, rotor speeds, references and wind are numpy views onto the C++ arrays (no copy; the
// view keeps the batch alive): `state` is an (N, 13) array whose rows are the lanes, laid out as
// structure of arrays underneath (strides (itemsize, stride * itemsize)), so writing a column for
// every lane is one contiguous store. Writes act on the next step, which checks them per lane.

#include <pybind11/pybind11.h>

#include <limits>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "dronetwin/batch/batch_body_rate.hpp"
#include "dronetwin/batch/batch_pid.hpp"
#include "dronetwin/batch/batch_se3.hpp"
#include "dronetwin/batch/batch_simulator.hpp"

namespace dronetwin::python {

namespace {

/// (rows, columns) view of structure-of-arrays memory: element k of lane l at data[k * stride + l].
template <class T>
py::array_t<T> soa_view(T* data, int rows, py::ssize_t columns, int stride, py::handle owner,
                        bool writable) {
  const auto item = static_cast<py::ssize_t>(sizeof(T));
  py::array_t<T> a({static_cast<py::ssize_t>(rows), columns},
                   {item, static_cast<py::ssize_t>(stride) * item}, data, owner);
  if (!writable)
    py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

template <class T>
py::array_t<T> lane_view(BatchSimulator<T>& b, T* data, py::ssize_t columns, py::handle owner,
                         bool writable) {
  return soa_view<T>(data, b.size(), columns, b.stride(), owner, writable);
}

ModelParameter parameter_named(const std::string& name) {
  const std::vector<ModelParameter> p = parse_parameter_list(name);
  if (p.size() != 1)
    throw py::value_error("BatchSimulator: '" + name + "' names a group of " +
                          std::to_string(p.size()) + " parameters; give one (e.g. thrust_k1)");
  return p.front();
}

/// The lanes a call addresses: None (all), an int, a sequence of ints, or a bool mask of N.
std::vector<int> lanes_of(py::handle lanes, int n, const char* what) {
  std::vector<int> out;
  if (lanes.is_none()) {
    for (int l = 0; l < n; ++l) out.push_back(l);
    return out;
  }
  if (py::isinstance<py::int_>(lanes)) {
    out.push_back(lanes.cast<int>());
    return out;
  }
  py::array a = py::array::ensure(lanes);
  if (!a || a.ndim() != 1) {
    throw py::type_error(std::string(what) +
                         ": lanes: expected None, an int, a 1-D sequence of ints or a bool mask "
                         "of the batch size, got " +
                         describe_object(lanes));
  }
  if (a.dtype().kind() == 'b') {
    if (a.shape(0) != n)
      throw py::value_error(std::string(what) + ": lanes: a bool mask must have " +
                            std::to_string(n) + " entries (one per lane), got " +
                            std::to_string(a.shape(0)));
    auto m = py::array_t<bool, py::array::c_style | py::array::forcecast>::ensure(a);
    for (int l = 0; l < n; ++l)
      if (m.at(l)) out.push_back(l);
    return out;
  }
  if (a.dtype().kind() != 'i' && a.dtype().kind() != 'u')
    throw py::type_error(std::string(what) + ": lanes: expected integers or bools, got " +
                         describe_object(lanes));
  auto ints = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(a);
  for (py::ssize_t i = 0; i < ints.shape(0); ++i) out.push_back(static_cast<int>(ints.at(i)));
  return out;
}

/// Row `i` of a (k, cols) float64 array, or the one row of a (cols,) array for every i.
Eigen::VectorXd row_of(const py::array_t<double, py::array::c_style | py::array::forcecast>& a,
                       std::size_t i, int cols, std::size_t count, const char* what) {
  if (a.ndim() == 1 && a.shape(0) == cols) {
    return Eigen::Map<const Eigen::VectorXd>(a.data(), cols);
  }
  if (a.ndim() == 2 && a.shape(1) == cols && static_cast<std::size_t>(a.shape(0)) == count) {
    return Eigen::Map<const Eigen::VectorXd>(a.data() + i * static_cast<std::size_t>(cols), cols);
  }
  throw py::value_error(std::string(what) + ": expected shape (" + std::to_string(cols) +
                        ",) or (" + std::to_string(count) + ", " + std::to_string(cols) +
                        ") (one row per lane addressed), got an array of " +
                        std::to_string(a.ndim()) + " dimensions");
}

/// (N,) copy of one field of every lane's pack.
template <class T>
py::array_t<double> battery_field(const BatchSimulator<T>& b, double BatteryState::*field) {
  py::array_t<double> a(b.size());
  for (int l = 0; l < b.size(); ++l) a.mutable_at(l) = b.battery(l).*field;
  return a;
}

template <class T>
void bind_one(py::module_& m, const char* class_name, const char* dtype) {
  using B = BatchSimulator<T>;
  py::class_<B>(
      m, class_name,
      (std::string("N vehicles stepped together in ") + dtype + " (see dronetwin.BatchSimulator).")
          .c_str())
      .def(py::init([](const std::shared_ptr<VehicleModel>& model, const SimConfig& config,
                       int num_vehicles, int num_threads) {
             if (!model) throw py::value_error("model: expected a VehicleModel, got None");
             return std::make_unique<B>(model, config, num_vehicles, num_threads);
           }),
           py::arg("model"), py::arg("config"), py::arg("num_vehicles"), py::arg("num_threads") = 1)
      .def("__len__", &B::size)
      .def_property_readonly("size", &B::size)
      .def_property_readonly("num_rotors", &B::num_rotors)
      .def_property_readonly("num_threads", &B::num_threads)
      .def_property_readonly("lanes_per_pack", [](const B&) { return B::kLanes; })
      .def_property_readonly("dt_s", &B::dt_s)
      .def_property_readonly(
          "state",
          [](py::object self) {
            B& b = self.cast<B&>();
            return lane_view<T>(b, b.state_data(), kStateSize, self, true);
          },
          "(N, 13) live view: one row per lane [x, y, z, vx, vy, vz, qw, qx, qy, qz, wx, wy, wz].")
      .def_property_readonly(
          "measured_state",
          [](py::object self) {
            B& b = self.cast<B&>();
            // Read-only view; the const is the batch's (the array is its own output).
            return lane_view<T>(b, const_cast<T*>(b.measured_state_data()), kStateSize, self,
                                false);
          },
          "(N, 13) read-only view: state + OU noise as of the last step or reset (the state "
          "itself when noise is off).")
      .def_property_readonly("noise_enabled", &B::noise_enabled)
      .def(
          "set_seed",
          [](B& b, py::handle seeds, py::handle lanes) {
            const std::vector<int> which = lanes_of(lanes, b.size(), "BatchSimulator.set_seed");
            // Python integers one by one, so a negative or too large seed is named, not wrapped.
            const py::list items =
                py::module_::import("numpy").attr("atleast_1d")(seeds).attr("tolist")();
            if (items.size() != 1 && items.size() != which.size())
              throw py::value_error("BatchSimulator.set_seed: seeds: expected one seed or " +
                                    std::to_string(which.size()) +
                                    " (one per lane addressed), got " +
                                    std::to_string(items.size()));
            std::vector<std::uint64_t> values;
            for (std::size_t i = 0; i < items.size(); ++i) {
              const py::handle item = items[i];
              if (!py::isinstance<py::int_>(item) || py::isinstance<py::bool_>(item) ||
                  item < py::int_(0) || item > py::int_(std::numeric_limits<std::uint64_t>::max()))
                throw py::value_error("BatchSimulator.set_seed: seeds[" + std::to_string(i) +
                                      "]: expected an integer in [0, 2**64), got " +
                                      py::repr(item).cast<std::string>());
              values.push_back(item.cast<std::uint64_t>());
            }
            for (std::size_t i = 0; i < which.size(); ++i)
              b.set_seed(which[i], values[values.size() == 1 ? 0 : i]);
          },
          py::arg("seeds"), py::arg("lanes") = py::none(),
          "Seeds of the lanes' noise streams (one seed, or one per lane addressed); a lane's noise "
          "depends only on its seed, its index and its step count. Usually followed by reset().")
      .def(
          "seeds",
          [](const B& b) {
            py::array_t<std::uint64_t> a(b.size());
            for (int l = 0; l < b.size(); ++l) a.mutable_at(l) = b.seed(l);
            return a;
          },
          "(N,) uint64: every lane's noise seed.")
      .def_property_readonly(
          "rotor_speeds",
          [](py::object self) {
            B& b = self.cast<B&>();
            return lane_view<T>(b, b.rotor_speed_data(), b.num_rotors(), self, false);
          },
          "(N, rotors) read-only view of the rotor speeds, rad/s.")
      .def_property_readonly(
          "rotor_speed_reference",
          [](py::object self) {
            B& b = self.cast<B&>();
            return lane_view<T>(b, b.rotor_speed_reference_data(), b.num_rotors(), self, true);
          },
          "(N, rotors) writable view of the rotor-speed references (clamped to the limits at "
          "each step; a non-finite entry stops its lane with status INVALID_INPUT).")
      .def_property_readonly(
          "wind",
          [](py::object self) {
            B& b = self.cast<B&>();
            return lane_view<T>(b, b.wind_data(), 3, self, true);
          },
          "(N, 3) writable view of each lane's wind, world frame, m/s: its mean wind when "
          "config.wind adds shear, gusts or turbulence (air_velocity(lane) is the total).")
      .def(
          "air_velocity", [](const B& b, int lane) { return copy_of(b.air_velocity(lane)); },
          py::arg("lane"),
          "Air velocity at the lane's vehicle now (mean wind sheared, gusts, turbulence), held "
          "over its next step, world frame, m/s.")
      .def_property_readonly(
          "status",
          [](py::object self) {
            const B& b = self.cast<const B&>();
            py::array_t<std::uint8_t> a({static_cast<py::ssize_t>(b.size())}, {1}, b.status_data(),
                                        self);
            py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
            return a;
          },
          "(N,) uint8 read-only view: 0 while a lane is ok, else its StepStatus value.")
      .def_property_readonly(
          "step_count",
          [](py::object self) {
            const B& b = self.cast<const B&>();
            py::array_t<std::int64_t> a({static_cast<py::ssize_t>(b.size())},
                                        {static_cast<py::ssize_t>(sizeof(std::int64_t))},
                                        b.step_count_data(), self);
            py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
            return a;
          },
          "(N,) int64 read-only view: steps taken by each lane since its reset.")
      .def(
          "battery", [](const B& b, int lane) { return b.battery(lane); }, py::arg("lane"),
          "The lane's pack (config.battery; full again at the lane's reset): a BatteryState.")
      .def(
          "battery_soc", [](const B& b) { return battery_field(b, &BatteryState::soc); },
          "(N,) state of charge of each lane's pack.")
      .def(
          "battery_voltage_V",
          [](const B& b) { return battery_field(b, &BatteryState::voltage_V); },
          "(N,) terminal voltage of each lane's pack over its last step, V (0 once cut off).")
      .def(
          "in_contact",
          [](const B& b) {
            py::array_t<bool> a(b.size());
            for (int l = 0; l < b.size(); ++l) a.mutable_at(l) = b.contact(l).in_contact;
            return a;
          },
          "(N,) bool: lanes resting on (or touching) the ground.")
      .def(
          "step",
          [](B& b, std::int64_t n, py::object inner_loop) {
            if (n < 0)
              throw py::value_error("BatchSimulator.step(n): expected n >= 0, got " +
                                    std::to_string(n));
            BatchInnerLoop<T>* loop = nullptr;
            if (!inner_loop.is_none()) {
              if (!py::isinstance<BatchInnerLoop<T>>(inner_loop))
                throw py::type_error(
                    std::string("BatchSimulator.step: inner_loop: expected a batched controller "
                                "of the batch's dtype (") +
                    (sizeof(T) == 8 ? "float64" : "float32") + "), got " +
                    py::repr(inner_loop).cast<std::string>());
              loop = &inner_loop.cast<BatchInnerLoop<T>&>();
            }
            // Blocks of about 2^22 vehicle-steps (tens of ms) with the GIL released, Ctrl-C
            // checked between them.
            const std::int64_t block =
                std::max<std::int64_t>(1, (std::int64_t{1} << 22) / b.size());
            int failed = 0;
            for (std::int64_t done = 0; done < n || n == 0;) {
              const std::int64_t k = std::min(block, n - done);
              {
                py::gil_scoped_release release;
                failed = loop != nullptr ? b.step(k, *loop) : b.step(k);
              }
              done += k;
              if (n == 0) break;
              if (done < n && PyErr_CheckSignals() != 0) throw py::error_already_set();
            }
            return failed;
          },
          py::arg("n") = 1, py::arg("inner_loop") = py::none(),
          "Steps every running lane n times (GIL released); with an inner_loop (a "
          "BatchSe3Controller or BatchBodyRateController) it sets each lane's rotor references "
          "from its measured state before every physics step. Returns how many lanes are not ok.")
      .def(
          "set_generalized_forces",
          [](B& b, py::handle u) {
            const auto a =
                py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(u);
            if (!a || a.ndim() != 2 || a.shape(0) != b.size() || a.shape(1) != 4)
              throw py::value_error("BatchSimulator.set_generalized_forces: u: expected shape (" +
                                    std::to_string(b.size()) +
                                    ", 4) ([T, tau_x, tau_y, tau_z] per lane)");
            std::vector<T> soa(static_cast<std::size_t>(4 * b.stride()), T(0));
            for (int l = 0; l < b.size(); ++l)
              for (int k = 0; k < 4; ++k)
                soa[static_cast<std::size_t>(k * b.stride() + l)] = static_cast<T>(a.at(l, k));
            b.set_generalized_forces(soa.data());
            py::array_t<std::uint8_t> flags(b.size());
            for (int l = 0; l < b.size(); ++l) flags.mutable_at(l) = b.saturated_data()[l];
            return flags;
          },
          py::arg("u"),
          "Rotor references of every lane from generalized forces u (N, 4) through the nominal "
          "model's thrust-first allocation. Returns (N,) uint8: 1 where the request saturated, "
          "2 where it was not finite (that lane's references unchanged).")
      .def(
          "reset",
          [](B& b, py::handle lanes, py::handle states, py::handle rotor_speeds) {
            const std::vector<int> which = lanes_of(lanes, b.size(), "BatchSimulator.reset");
            const auto x =
                py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(states);
            if (!x) throw py::type_error("BatchSimulator.reset: states: expected numbers");
            py::array_t<double, py::array::c_style | py::array::forcecast> w;
            if (!rotor_speeds.is_none()) {
              w = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(
                  rotor_speeds);
              if (!w) throw py::type_error("BatchSimulator.reset: rotor_speeds: expected numbers");
            }
            for (std::size_t i = 0; i < which.size(); ++i) {
              const StateVector s =
                  row_of(x, i, kStateSize, which.size(), "BatchSimulator.reset: states");
              if (rotor_speeds.is_none()) {
                b.reset(which[i], s);
              } else {
                b.reset(which[i], s,
                        row_of(w, i, b.num_rotors(), which.size(),
                               "BatchSimulator.reset: rotor_speeds"));
              }
            }
          },
          py::arg("lanes"), py::arg("states"), py::arg("rotor_speeds") = py::none(),
          "Resets lanes (None = all, an int, a list of ints, or a bool mask) to states (one row "
          "of 13, or one row per lane) and rotor speeds (rad/s; zero when omitted); clears their "
          "status, contact and step count.")
      .def(
          "set_parameter",
          [](B& b, const std::string& name, py::handle values, py::handle lanes) {
            const ModelParameter p = parameter_named(name);
            const std::vector<int> which =
                lanes_of(lanes, b.size(), "BatchSimulator.set_parameter");
            const auto v =
                py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(values);
            if (!v) throw py::type_error("BatchSimulator.set_parameter: values: expected numbers");
            const bool one = v.ndim() == 0 || (v.ndim() == 1 && v.shape(0) == 1);
            if (!one && !(v.ndim() == 1 && static_cast<std::size_t>(v.shape(0)) == which.size()))
              throw py::value_error(
                  "BatchSimulator.set_parameter: values: expected one number or " +
                  std::to_string(which.size()) + " (one per lane addressed)");
            for (std::size_t i = 0; i < which.size(); ++i)
              b.set_parameter(p, which[i], one ? v.data()[0] : v.data()[i]);
          },
          py::arg("name"), py::arg("values"), py::arg("lanes") = py::none(),
          "Sets a model parameter per lane (names of `dronetwin fit --params`: mass, inertia_xx, "
          "thrust_k1, rotor_drag, tau_rise, ...); a per-rotor coefficient is scaled in every "
          "rotor so their mean becomes the value.")
      .def(
          "parameter",
          [](const B& b, const std::string& name) {
            const ModelParameter p = parameter_named(name);
            py::array_t<double> a(b.size());
            for (int l = 0; l < b.size(); ++l) a.mutable_at(l) = b.parameter(p, l);
            return a;
          },
          py::arg("name"), "(N,) float64: the parameter's value in every lane.")
      .def(
          "set_generalized_force",
          [](B& b, int lane, py::handle u) {
            b.set_generalized_force(lane,
                                    to_fixed<4>(u, "BatchSimulator.set_generalized_force: u"));
          },
          py::arg("lane"), py::arg("u"),
          "Rotor references of one lane from [T, tau_x, tau_y, tau_z] (the model's allocation).")
      .def("set_num_threads", &B::set_num_threads, py::arg("num_threads"),
           "Rebuilds the thread pool with num_threads threads (results do not change).");
}

template <class T>
void bind_se3(py::module_& m, const char* base_name, const char* name, const char* dtype) {
  using C = BatchSe3Controller<T>;
  py::class_<BatchInnerLoop<T>>(
      m, base_name, (std::string("A batched inner-loop controller in ") + dtype + ".").c_str());
  py::class_<C, BatchInnerLoop<T>>(m, name,
                                   (std::string("The SE(3) controller for every lane of a ") +
                                    dtype + " batch (see dronetwin.BatchSe3Controller).")
                                       .c_str())
      .def(py::init([](const std::shared_ptr<VehicleModel>& model, const Se3Gains& gains,
                       const Se3Options& options, int num_vehicles) {
             if (!model) throw py::value_error("model: expected a VehicleModel, got None");
             return std::make_unique<C>(model, gains, options, num_vehicles);
           }),
           py::arg("model"), py::arg("gains"), py::arg("options"), py::arg("num_vehicles"))
      .def_property_readonly("size", &C::size)
      .def_property_readonly(
          "reference",
          [](py::object self) {
            C& c = self.cast<C&>();
            return soa_view<T>(c.reference_data(), c.size(), C::kReferenceSize, c.stride(), self,
                               true);
          },
          "(N, 11) writable view: [x, y, z, vx, vy, vz, ax, ay, az, cos(yaw), sin(yaw)] per lane.")
      .def(
          "set_reference",
          [](C& c, int lane, py::handle position, py::handle velocity, py::handle acceleration,
             double yaw_rad) {
            ReferencePoint r;
            r.position_m = to_fixed<3>(position, "BatchSe3Controller.set_reference: position");
            if (!velocity.is_none())
              r.velocity_m_s = to_fixed<3>(velocity, "BatchSe3Controller.set_reference: velocity");
            if (!acceleration.is_none())
              r.acceleration_m_s2 =
                  to_fixed<3>(acceleration, "BatchSe3Controller.set_reference: acceleration");
            r.yaw_rad = yaw_rad;
            c.set_reference(lane, r);
          },
          py::arg("lane"), py::arg("position"), py::arg("velocity") = py::none(),
          py::arg("acceleration") = py::none(), py::arg("yaw") = 0.0,
          "One lane's reference point (m, m/s, m/s^2, rad).")
      .def(
          "saturated_count",
          [](const C& c) {
            py::array_t<std::int64_t> a(c.size());
            for (int l = 0; l < c.size(); ++l) a.mutable_at(l) = c.saturated_count_data()[l];
            return a;
          },
          "(N,) int64: updates per lane whose allocation saturated.");
}

template <class T>
void bind_body_rate(py::module_& m, const char* name, const char* dtype) {
  using C = BatchBodyRateController<T>;
  py::class_<C, BatchInnerLoop<T>>(
      m, name,
      (std::string("The body-rate (CTBR) controller for every lane of a ") + dtype +
       " batch (see dronetwin.BatchBodyRateController).")
          .c_str())
      .def(py::init([](const std::shared_ptr<VehicleModel>& model, const BodyRateGains& gains,
                       int num_vehicles) {
             if (!model) throw py::value_error("model: expected a VehicleModel, got None");
             return std::make_unique<C>(model, gains, num_vehicles);
           }),
           py::arg("model"), py::arg("gains"), py::arg("num_vehicles"))
      .def_property_readonly("size", &C::size)
      .def_property_readonly(
          "command",
          [](py::object self) {
            C& c = self.cast<C&>();
            return soa_view<T>(c.command_data(), c.size(), 4, c.stride(), self, true);
          },
          "(N, 4) writable view: [T (N), wx, wy, wz (rad/s)] per lane; a non-finite entry stops "
          "its lane with CONTROLLER_FAILED at the next step.")
      .def(
          "set_command",
          [](C& c, int lane, double thrust_N, py::handle rates) {
            c.set_command(lane, thrust_N,
                          to_fixed<3>(rates, "BatchBodyRateController.set_command: rates"));
          },
          py::arg("lane"), py::arg("thrust_N"), py::arg("rates_rad_s"),
          "One lane's command, checked (finite, thrust >= 0).")
      .def(
          "saturated",
          [](const C& c) {
            py::array_t<std::uint8_t> a(c.size());
            for (int l = 0; l < c.size(); ++l) a.mutable_at(l) = c.saturated_data()[l];
            return a;
          },
          "(N,) uint8: 1 where the last allocation saturated.");
}

template <class T>
void bind_pid(py::module_& m, const char* name, const char* dtype) {
  using C = BatchCascadedPid<T>;
  py::class_<C, BatchInnerLoop<T>>(m, name,
                                   (std::string("The cascaded PID for every lane of a ") + dtype +
                                    " batch (see dronetwin.BatchCascadedPid).")
                                       .c_str())
      .def(py::init([](const std::shared_ptr<VehicleModel>& model, const PidGains& gains,
                       const PidOptions& options, double control_period_s, int num_vehicles) {
             if (!model) throw py::value_error("model: expected a VehicleModel, got None");
             return std::make_unique<C>(model, gains, options, control_period_s, num_vehicles);
           }),
           py::arg("model"), py::arg("gains"), py::arg("options"), py::arg("control_period_s"),
           py::arg("num_vehicles"))
      .def_property_readonly("size", &C::size)
      .def_property_readonly(
          "reference",
          [](py::object self) {
            C& c = self.cast<C&>();
            return soa_view<T>(c.reference_data(), c.size(), C::kReferenceSize, c.stride(), self,
                               true);
          },
          "(N, 17) writable view per lane: [x, y, z, vx, vy, vz, yaw, yaw_rate], then the "
          "feed-forward's acceleration [ax, ay, az], flat body rates [wx, wy, wz] and angular "
          "accelerations [dwx, dwy, dwz] (set_reference fills them).")
      .def("set_reference", &C::set_reference, py::arg("lane"), py::arg("reference"),
           "One lane's reference (a ReferencePoint): its columns, the feed-forward ones computed "
           "from its acceleration, jerk, snap and yaw motion as CascadedPid does.")
      .def_property_readonly(
          "integral",
          [](py::object self) {
            const C& c = self.cast<const C&>();
            // Read-only view; the const is the controller's (its memory, reset_integral clears).
            return soa_view<T>(const_cast<T*>(c.integral_data()), c.size(), 4, c.stride(), self,
                               false);
          },
          "(N, 4) read-only view: each lane's integral state [x, y, z, psi].")
      .def("reset_integral", &C::reset_integral, py::arg("lane"),
           "Clears one lane's integral (a new episode).");
}

}  // namespace

void bind_batch(py::module_& m) {
  bind_one<double>(m, "BatchSimulator64", "float64");
  bind_one<float>(m, "BatchSimulator32", "float32");
  bind_se3<double>(m, "BatchInnerLoop64", "BatchSe3Controller64", "float64");
  bind_se3<float>(m, "BatchInnerLoop32", "BatchSe3Controller32", "float32");
  bind_body_rate<double>(m, "BatchBodyRateController64", "float64");
  bind_body_rate<float>(m, "BatchBodyRateController32", "float32");
  bind_pid<double>(m, "BatchCascadedPid64", "float64");
  bind_pid<float>(m, "BatchCascadedPid32", "float32");
}

}  // namespace dronetwin::python
