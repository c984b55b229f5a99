#pragma once
// Shared helpers of the pybind11 extension dronetwin._core: strict conversion of Python inputs to
// the fixed-size Eigen types of the core (wrong shapes and dtypes are refused with a message that
// says what was expected, instead of being converted silently), and numpy views onto C++ memory.
//
// One bind_*.cpp per layer (model, sim, control, io), each registering its classes in `m`.

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>
#include <vector>

#include "dronetwin/core/types.hpp"
#include "dronetwin/faults/rotor_fault.hpp"
#include "dronetwin/noise/dryden.hpp"

namespace dronetwin::python {

namespace py = pybind11;

void bind_model(py::module_& m);
void bind_sim(py::module_& m);
void bind_control(py::module_& m);
void bind_io(py::module_& m);
void bind_real_data(py::module_& m);
void bind_fit(py::module_& m);
void bind_batch(py::module_& m);
void bind_rl(py::module_& m);
void bind_policy(py::module_& m);
void bind_world(py::module_& m);
void bind_sensors(py::module_& m);
void bind_noise(py::module_& m);
void bind_wind(py::module_& m);
void bind_faults(py::module_& m);
void bind_battery(py::module_& m);
void bind_payload(py::module_& m);
void bind_fleet(py::module_& m);
void bind_planning(py::module_& m);  // after bind_control: TrajectoryReference is a Reference
/// dronetwin.planning.time_optimal_lap, into the planning submodule `pl` (from bind_planning).
void bind_time_optimal(py::module_& pl);

/// 'light', 'moderate' or 'severe' (ValueError naming the choices otherwise).
TurbulenceSeverity severity_from_name(const std::string& name);

/// Rotor faults as a Python list and back (at most kMaxRotorFaults; ValueError beyond).
FaultSettings fault_settings_of(const std::vector<RotorFault>& faults);
std::vector<RotorFault> fault_list_of(const FaultSettings& f);

/// "a float64 array of shape (3,)", "a list of length 2", "a str", for messages.
std::string describe_object(py::handle obj);

/// Reads a 1-D float vector of exactly `n` numbers from `obj` into `out`. A numpy array must be
/// float64 and 1-D (TypeError / ValueError otherwise: no silent dtype conversion); a list or tuple
/// of numbers is accepted. `what` names the argument in messages.
void read_vector(py::handle obj, int n, const char* what, double* out);

template <int N>
Eigen::Matrix<double, N, 1> to_fixed(py::handle obj, const char* what) {
  Eigen::Matrix<double, N, 1> v;
  read_vector(obj, N, what, v.data());
  return v;
}

/// A rotor vector of exactly `n` entries (n = the model's rotor count).
RotorVector to_rotor_vector(py::handle obj, int n, const char* what);

/// A 1-D float64 numpy array of `n` numbers at `data`, without copying. `owner` is kept alive as
/// long as the array (its base), so the view can never dangle.
py::array_t<double> view(double* data, py::ssize_t n, py::handle owner, bool writable);
py::array_t<double> view(const double* data, py::ssize_t n, py::handle owner);

/// A new (rows, width) numpy array whose row i is a copy of row(i) (anything indexable).
template <class Row>
py::array_t<double> rows_of(std::size_t rows, int width, Row&& row) {
  py::array_t<double> a({static_cast<py::ssize_t>(rows), static_cast<py::ssize_t>(width)});
  auto out = a.mutable_unchecked<2>();
  for (std::size_t i = 0; i < rows; ++i) {
    const auto values = row(i);
    for (int j = 0; j < width; ++j) out(static_cast<py::ssize_t>(i), j) = values[j];
  }
  return a;
}

/// A copy of a vector as a new numpy array (for computed values).
template <class Vector>
py::array_t<double> copy_of(const Vector& v) {
  py::array_t<double> a(static_cast<py::ssize_t>(v.size()));
  double* out = a.mutable_data();
  for (Eigen::Index i = 0; i < v.size(); ++i) out[i] = v[i];
  return a;
}

}  // namespace dronetwin::python
