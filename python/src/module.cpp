// dronetwin._core: the pybind11 extension behind the Python package `dronetwin`.
//
// Error mapping: dronetwin::InvalidArgument derives from std::invalid_argument and surfaces as
// ValueError; SimulationError derives from std::runtime_error and surfaces as RuntimeError. Both
// keep the C++ message (pybind11's built-in translation of the standard exceptions).

#include <sstream>

#include "bindings.hpp"
#include "dronetwin/app/run_experiment.hpp"

namespace dronetwin::python {

namespace {
std::string with_article(const std::string& noun) {
  const bool vowel = !noun.empty() && std::string("aeiouAEIOU").find(noun[0]) != std::string::npos;
  return (vowel ? "an " : "a ") + noun;
}
}  // namespace

std::string describe_object(py::handle obj) {
  if (py::isinstance<py::array>(obj)) {
    const auto a = py::reinterpret_borrow<py::array>(obj);
    std::ostringstream s;
    s << with_article(py::str(a.dtype()).cast<std::string>()) << " array of shape (";
    for (py::ssize_t i = 0; i < a.ndim(); ++i)
      s << a.shape(i) << (a.ndim() == 1 || i + 1 < a.ndim() ? "," : "");
    s << ")";
    return s.str();
  }
  if (py::isinstance<py::list>(obj) || py::isinstance<py::tuple>(obj)) {
    return with_article(py::str(obj.get_type().attr("__name__")).cast<std::string>()) +
           " of length " + std::to_string(py::len(obj));
  }
  return with_article(py::str(obj.get_type().attr("__name__")).cast<std::string>());
}

void read_vector(py::handle obj, int n, const char* what, double* out) {
  const auto expected = [&] {
    return std::string(what) + ": expected a float64 array of shape (" + std::to_string(n) +
           ",) or a sequence of " + std::to_string(n) + " numbers, got " + describe_object(obj);
  };
  if (py::isinstance<py::array>(obj)) {
    const auto a = py::reinterpret_borrow<py::array>(obj);
    if (!a.dtype().is(py::dtype::of<double>())) throw py::type_error(expected());
    if (a.ndim() != 1 || a.shape(0) != n) throw py::value_error(expected());
    const auto typed = py::reinterpret_borrow<py::array_t<double>>(obj);
    const auto r = typed.unchecked<1>();  // honours strides: no copy for sliced views
    for (int i = 0; i < n; ++i) out[i] = r(i);
    return;
  }
  if (py::isinstance<py::list>(obj) || py::isinstance<py::tuple>(obj)) {
    const auto seq = py::reinterpret_borrow<py::sequence>(obj);
    if (static_cast<int>(py::len(seq)) != n) throw py::value_error(expected());
    for (int i = 0; i < n; ++i) {
      const py::handle item = seq[static_cast<std::size_t>(i)];
      try {
        out[i] = item.cast<double>();
      } catch (const py::cast_error&) {
        throw py::type_error(std::string(what) + "[" + std::to_string(i) +
                             "]: expected a number, got " + describe_object(item));
      }
    }
    return;
  }
  throw py::type_error(expected());
}

RotorVector to_rotor_vector(py::handle obj, int n, const char* what) {
  RotorVector v(n);
  read_vector(obj, n, what, v.data());
  return v;
}

py::array_t<double> view(double* data, py::ssize_t n, py::handle owner, bool writable) {
  py::array_t<double> a({n}, {static_cast<py::ssize_t>(sizeof(double))}, data, owner);
  if (!writable) {
    py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  }
  return a;
}

py::array_t<double> view(const double* data, py::ssize_t n, py::handle owner) {
  return view(const_cast<double*>(data), n, owner, false);
}

}  // namespace dronetwin::python

PYBIND11_MODULE(_core, m) {
  namespace dp = dronetwin::python;
  m.doc() =
      "dronetwin._core: the C++ engine of dronetwin (models, Simulator, controllers, references,\n"
      "experiment runner, logs). Import the package `dronetwin` rather than this module.";
  m.attr("__version__") = std::string(dronetwin::version());
  m.def(
      "version", [] { return std::string(dronetwin::version()); },
      "The dronetwin version the extension was built as.");
  dp::bind_model(m);
  dp::bind_wind(m);
  dp::bind_faults(m);
  dp::bind_battery(m);
  dp::bind_payload(m);
  dp::bind_sim(m);
  dp::bind_control(m);
  dp::bind_planning(m);  // TrajectoryReference derives from control's Reference
  dp::bind_io(m);
  dp::bind_fleet(m);
  dp::bind_real_data(m);
  dp::bind_fit(m);
  dp::bind_batch(m);
  dp::bind_rl(m);
  dp::bind_policy(m);
  dp::bind_world(m);
  dp::bind_sensors(m);
  dp::bind_noise(m);
}
