// The time-optimal flying lap (time_optimal/time_optimal_lap.hpp, docs/planning.md) as
// dronetwin.planning.time_optimal_lap: a track and a model in, the lap as numpy arrays out.
// A recorded flight to start from comes as three arrays (times, states, rotor speeds), checked
// here for shape and by the C++ for content (which names the bad sample's index).

#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "dronetwin/model/vehicle_model.hpp"
#include "dronetwin/time_optimal/time_optimal_lap.hpp"
#include "dronetwin/world/track.hpp"

namespace dronetwin::python {

namespace {

/// A 2-D float64 array of shape (n, cols), copied row by row.
template <class Row>
std::vector<Row> read_rows(const py::handle obj, py::ssize_t cols, const char* what) {
  const std::string expected = std::string("time_optimal_lap: ") + what +
                               ": expected a 2-D float64 array with " + std::to_string(cols) +
                               " columns, got " + describe_object(obj);
  if (!py::isinstance<py::array>(obj)) throw py::type_error(expected);
  const auto a = py::reinterpret_borrow<py::array>(obj);
  if (!a.dtype().is(py::dtype::of<double>())) throw py::type_error(expected);
  if (a.ndim() != 2 || a.shape(1) != cols) throw py::value_error(expected);
  const auto view = a.unchecked<double, 2>();
  std::vector<Row> rows;
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    Row row(cols);
    for (py::ssize_t j = 0; j < cols; ++j) row[j] = view(i, j);
    rows.push_back(std::move(row));
  }
  return rows;
}

/// A 1-D float64 array, copied.
std::vector<double> column_of(const py::handle obj, const char* what) {
  const std::string expected = std::string("time_optimal_lap: ") + what +
                               ": expected a 1-D float64 array, got " + describe_object(obj);
  if (!py::isinstance<py::array>(obj)) throw py::type_error(expected);
  const auto a = py::reinterpret_borrow<py::array>(obj);
  if (!a.dtype().is(py::dtype::of<double>())) throw py::type_error(expected);
  if (a.ndim() != 1) throw py::value_error(expected);
  const auto view = a.unchecked<double, 1>();
  std::vector<double> out;
  for (py::ssize_t i = 0; i < a.shape(0); ++i) out.push_back(view(i));
  return out;
}

py::dict lap_dict(const TimeOptimalLap& lap, int num_rotors) {
  py::dict d;
  d["lap_time_s"] = lap.lap_time_s;
  d["segment_times_s"] = copy_of(Eigen::Map<const Eigen::VectorXd>(
      lap.segment_times_s.data(), static_cast<Eigen::Index>(lap.segment_times_s.size())));
  d["times_s"] = copy_of(Eigen::Map<const Eigen::VectorXd>(
      lap.times_s.data(), static_cast<Eigen::Index>(lap.times_s.size())));
  d["states"] =
      rows_of(lap.states.size(), kStateSize, [&](std::size_t k) { return lap.states[k]; });
  d["rotor_speeds_rad_s"] = rows_of(lap.rotor_speeds_rad_s.size(), num_rotors,
                                    [&](std::size_t k) { return lap.rotor_speeds_rad_s[k]; });
  py::list gate_nodes;
  for (int k : lap.gate_nodes) gate_nodes.append(k);
  d["gate_nodes"] = gate_nodes;
  d["max_violation"] = lap.max_violation;
  d["converged"] = lap.converged;
  d["warm_start_lap_time_s"] = lap.warm_start_lap_time_s;
  d["min_snap_lap_time_s"] = lap.warm_start.lap_time_s;
  d["min_snap_trajectory"] = lap.warm_start.trajectory;
  d["gate_margin_m"] = lap.gate_margin_m;
  d["outer_iterations"] = lap.outer_iterations;
  d["inner_iterations"] = lap.inner_iterations;
  d["solve_time_s"] = lap.solve_time_s;
  return d;
}

}  // namespace

void bind_time_optimal(py::module_& pl) {
  const TimeOptimalOptions defaults;
  pl.def(
      "time_optimal_lap",
      [](const Track& track, const std::shared_ptr<VehicleModel>& model, int intervals,
         int substeps, double gate_margin_m, std::vector<double> warm_start_time_factors,
         int max_outer_iterations, int max_inner_iterations, const py::object& flight_times_s,
         const py::object& flight_states, const py::object& flight_rotor_speeds_rad_s,
         std::vector<int> intervals_per_segment) {
        if (!model)
          throw py::value_error("time_optimal_lap: model: expected a VehicleModel, got None");
        TimeOptimalOptions o;
        o.intervals = intervals;
        o.substeps = substeps;
        o.gate_margin_m = gate_margin_m;
        o.warm_start_time_factors = std::move(warm_start_time_factors);
        o.max_outer_iterations = max_outer_iterations;
        o.max_inner_iterations = max_inner_iterations;
        o.intervals_per_segment = std::move(intervals_per_segment);
        const int R = model->num_rotors();
        const int given = static_cast<int>(!flight_times_s.is_none()) +
                          static_cast<int>(!flight_states.is_none()) +
                          static_cast<int>(!flight_rotor_speeds_rad_s.is_none());
        if (given != 0 && given != 3)
          throw py::value_error(
              "time_optimal_lap: a flight to start from needs all of flight_times_s, "
              "flight_states and flight_rotor_speeds_rad_s");
        if (given == 0) {
          const TimeOptimalLap lap = [&] {
            py::gil_scoped_release release;
            return solve_time_optimal_lap(track, *model, o);
          }();
          return lap_dict(lap, R);
        }
        FlownTrajectory flight;
        flight.times_s = column_of(flight_times_s, "flight_times_s");
        for (const Eigen::VectorXd& x :
             read_rows<Eigen::VectorXd>(flight_states, kStateSize, "flight_states"))
          flight.states.push_back(x);
        flight.rotor_speeds_rad_s =
            read_rows<RotorVector>(flight_rotor_speeds_rad_s, R, "flight_rotor_speeds_rad_s");
        const TimeOptimalLap lap = [&] {
          py::gil_scoped_release release;
          return solve_time_optimal_lap(track, *model, o, flight);
        }();
        return lap_dict(lap, R);
      },
      py::arg("track"), py::arg("model"), py::arg("intervals") = defaults.intervals,
      py::arg("substeps") = defaults.substeps, py::arg("gate_margin_m") = defaults.gate_margin_m,
      py::arg("warm_start_time_factors") = defaults.warm_start_time_factors,
      py::arg("max_outer_iterations") = defaults.max_outer_iterations,
      py::arg("max_inner_iterations") = defaults.max_inner_iterations,
      py::arg("flight_times_s") = py::none(), py::arg("flight_states") = py::none(),
      py::arg("flight_rotor_speeds_rad_s") = py::none(),
      py::arg("intervals_per_segment") = std::vector<int>{},
      "The time-optimal flying lap of a closed track within the model's rotor-speed limits\n"
      "(docs/planning.md): multiple shooting over the full force model on Ceres, warm-started\n"
      "from the minimum-snap plan flown by SE(3) at each of warm_start_time_factors, or from a\n"
      "recorded flight (flight_times_s (n,), flight_states (n, 13), flight_rotor_speeds_rad_s\n"
      "(n, rotors), e.g. a policy's episode). gate_margin_m < 0: the collision shape's\n"
      "bounding radius. intervals_per_segment replaces intervals: one count per gate, for\n"
      "the segment that ends at it (the first segment runs from the last gate to the first);\n"
      "np.diff([0, *lap['gate_nodes']]) is a lap's own grid, to re-solve from it.\n"
      "Returns a dict: lap_time_s, segment_times_s, times_s (N+1,),\n"
      "states (N+1, 13), rotor_speeds_rad_s (N, rotors; held from node k to k+1), gate_nodes,\n"
      "max_violation, converged, warm_start_lap_time_s, min_snap_lap_time_s,\n"
      "min_snap_trajectory, gate_margin_m, iterations and solve_time_s. GIL released.");
}

}  // namespace dronetwin::python
