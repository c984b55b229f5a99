// Bindings of the planning layer (docs/planning.md) in the submodule dronetwin.planning:
// minimum-snap trajectories through waypoints, segment-time allocation, differential flatness,
// the feasibility check and time scaling; plus TrajectoryReference (a planned trajectory as a
// control reference) in the top-level module beside the other references.
//
// Inputs are strict like everywhere else (bindings.hpp): float64 arrays of the right shape or
// lists of numbers, refused by argument name otherwise. Errors of the C++ (InvalidArgument, which
// names the waypoint, segment or field) surface as ValueError unchanged.

#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "dronetwin/control/trajectory_reference.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/model/vehicle_model.hpp"
#include "dronetwin/planning/flatness.hpp"
#include "dronetwin/planning/min_snap.hpp"
#include "dronetwin/planning/polynomial.hpp"

namespace dronetwin::python {

namespace {

using planning::FeasibilityLimits;
using planning::FeasibilityReport;
using planning::FeasibilityViolation;
using planning::FlatOutput;
using planning::FlatState;
using planning::MinSnapOptions;
using planning::PolynomialSegment;
using planning::TimeAllocation;
using planning::TimeAllocationOptions;
using planning::Trajectory;
using planning::Waypoint;

using ModelPtr = std::shared_ptr<VehicleModel>;

const VehicleModel& model_of(const ModelPtr& model, const std::string& who) {
  if (!model) throw py::value_error(who + ": model: expected a VehicleModel, got None");
  return *model;
}

/// A 1-D float64 array or a list/tuple of numbers, of any length (the C++ checks the count).
std::vector<double> doubles_of(py::handle obj, const std::string& what) {
  const auto expected = [&] {
    return what + ": expected a 1-D float64 array or a sequence of numbers, got " +
           describe_object(obj);
  };
  py::ssize_t n = 0;
  if (py::isinstance<py::array>(obj)) {
    const auto a = py::reinterpret_borrow<py::array>(obj);
    if (!a.dtype().is(py::dtype::of<double>())) throw py::type_error(expected());
    if (a.ndim() != 1) throw py::value_error(expected());
    n = a.shape(0);
  } else if (py::isinstance<py::list>(obj) || py::isinstance<py::tuple>(obj)) {
    n = static_cast<py::ssize_t>(py::len(obj));
  } else {
    throw py::type_error(expected());
  }
  std::vector<double> out(static_cast<std::size_t>(n));
  read_vector(obj, static_cast<int>(n), what.c_str(), out.data());
  return out;
}

std::optional<Vec3> optional_vec3(py::handle obj, const char* what) {
  if (obj.is_none()) return std::nullopt;
  return to_fixed<3>(obj, what);
}

py::object none_or_array(const std::optional<Vec3>& v) {
  return v ? py::cast(Vec3(*v)) : py::none();
}

/// Waypoints from a list/tuple of planning.Waypoint, or from an (N, 3) or (N, 4) float64 array of
/// positions (m) and optionally yaw (rad): the quick way for points with nothing else given.
std::vector<Waypoint> waypoints_of(py::handle obj, const std::string& who) {
  const std::string what = who + ": waypoints";
  std::vector<Waypoint> out;
  if (py::isinstance<py::array>(obj)) {
    const auto a = py::reinterpret_borrow<py::array>(obj);
    const std::string expected = what +
                                 ": expected a list of planning.Waypoint or a float64 array of "
                                 "shape (N, 3) or (N, 4) (x, y, z[, yaw]), got " +
                                 describe_object(obj);
    if (!a.dtype().is(py::dtype::of<double>())) throw py::type_error(expected);
    if (a.ndim() != 2 || (a.shape(1) != 3 && a.shape(1) != 4)) throw py::value_error(expected);
    const auto r = py::reinterpret_borrow<py::array_t<double>>(obj).unchecked<2>();
    out.resize(static_cast<std::size_t>(r.shape(0)));
    for (py::ssize_t i = 0; i < r.shape(0); ++i) {
      Waypoint& w = out[static_cast<std::size_t>(i)];
      w.position_m = Vec3(r(i, 0), r(i, 1), r(i, 2));
      if (r.shape(1) == 4) w.yaw_rad = r(i, 3);
    }
    return out;
  }
  if (!py::isinstance<py::list>(obj) && !py::isinstance<py::tuple>(obj))
    throw py::type_error(what +
                         ": expected a list of planning.Waypoint or a float64 array of shape "
                         "(N, 3) or (N, 4), got " +
                         describe_object(obj));
  const auto seq = py::reinterpret_borrow<py::sequence>(obj);
  out.reserve(py::len(seq));
  for (std::size_t i = 0; i < py::len(seq); ++i) {
    const py::object item = seq[i];
    if (!py::isinstance<Waypoint>(item))
      throw py::type_error(what + "[" + std::to_string(i) +
                           "]: expected a planning.Waypoint, got " + describe_object(item));
    out.push_back(item.cast<Waypoint>());
  }
  return out;
}

/// Trajectory from per-segment durations (s) and an (n, 8, 4) float64 array of coefficients.
Trajectory trajectory_of(py::handle durations, py::handle coefficients) {
  const std::vector<double> durations_s = doubles_of(durations, "Trajectory: segment_durations_s");
  const auto n = static_cast<py::ssize_t>(durations_s.size());
  const std::string expected = "Trajectory: coefficients: expected a float64 array of shape (" +
                               std::to_string(n) + ", 8, 4) (segment, power of tau, x y z yaw), " +
                               "got " + describe_object(coefficients);
  if (!py::isinstance<py::array>(coefficients) ||
      !py::reinterpret_borrow<py::array>(coefficients).dtype().is(py::dtype::of<double>()))
    throw py::type_error(expected);
  const auto a = py::reinterpret_borrow<py::array_t<double>>(coefficients);
  if (a.ndim() != 3 || a.shape(0) != n || a.shape(1) != planning::kCoefficientCount ||
      a.shape(2) != planning::kAxisCount)
    throw py::value_error(expected);
  const auto r = a.unchecked<3>();
  std::vector<PolynomialSegment> segments(durations_s.size());
  for (py::ssize_t i = 0; i < n; ++i) {
    PolynomialSegment& s = segments[static_cast<std::size_t>(i)];
    s.duration_s = durations_s[static_cast<std::size_t>(i)];
    for (int k = 0; k < planning::kCoefficientCount; ++k)
      for (int axis = 0; axis < planning::kAxisCount; ++axis)
        s.coefficients(k, axis) = r(i, k, axis);
  }
  return Trajectory(std::move(segments));
}

py::array_t<double> coefficients_of(const Trajectory& t) {
  const auto n = static_cast<py::ssize_t>(t.segments().size());
  py::array_t<double> a(
      {n, py::ssize_t{planning::kCoefficientCount}, py::ssize_t{planning::kAxisCount}});
  auto w = a.mutable_unchecked<3>();
  for (py::ssize_t i = 0; i < n; ++i) {
    const auto& c = t.segments()[static_cast<std::size_t>(i)].coefficients;
    for (int k = 0; k < planning::kCoefficientCount; ++k)
      for (int axis = 0; axis < planning::kAxisCount; ++axis) w(i, k, axis) = c(k, axis);
  }
  return a;
}

/// Trajectory.sample: the flat outputs at every time, as arrays (row i = at(times_s[i])).
py::dict sample(const Trajectory& trajectory, py::handle times) {
  const std::vector<double> times_s = doubles_of(times, "Trajectory.sample: times_s");
  for (std::size_t i = 0; i < times_s.size(); ++i)
    if (std::isnan(times_s[i]))
      throw py::value_error("Trajectory.sample: times_s[" + std::to_string(i) +
                            "]: expected a time, got nan");
  const auto n = static_cast<py::ssize_t>(times_s.size());
  py::array_t<double> position({n, py::ssize_t{3}}), velocity({n, py::ssize_t{3}}),
      acceleration({n, py::ssize_t{3}}), jerk({n, py::ssize_t{3}}), snap({n, py::ssize_t{3}}),
      yaw(n), yaw_rate(n), yaw_acceleration(n);
  double *p = position.mutable_data(), *v = velocity.mutable_data(),
         *a = acceleration.mutable_data(), *j = jerk.mutable_data(), *s = snap.mutable_data(),
         *y = yaw.mutable_data(), *yr = yaw_rate.mutable_data(),
         *ya = yaw_acceleration.mutable_data();
  {
    py::gil_scoped_release release;  // plain arithmetic on memory Python cannot touch meanwhile
    for (py::ssize_t i = 0; i < n; ++i) {
      const FlatOutput f = trajectory.at(times_s[static_cast<std::size_t>(i)]);
      for (int c = 0; c < 3; ++c) {
        p[3 * i + c] = f.position_m[c];
        v[3 * i + c] = f.velocity_m_s[c];
        a[3 * i + c] = f.acceleration_m_s2[c];
        j[3 * i + c] = f.jerk_m_s3[c];
        s[3 * i + c] = f.snap_m_s4[c];
      }
      y[i] = f.yaw_rad;
      yr[i] = f.yaw_rate_rad_s;
      ya[i] = f.yaw_acceleration_rad_s2;
    }
  }
  py::dict d;
  d["position_m"] = position;
  d["velocity_m_s"] = velocity;
  d["acceleration_m_s2"] = acceleration;
  d["jerk_m_s3"] = jerk;
  d["snap_m_s4"] = snap;
  d["yaw_rad"] = yaw;
  d["yaw_rate_rad_s"] = yaw_rate;
  d["yaw_acceleration_rad_s2"] = yaw_acceleration;
  return d;
}

std::string vec_text(const Vec3& v) {
  return "[" + std::to_string(v.x()) + ", " + std::to_string(v.y()) + ", " + std::to_string(v.z()) +
         "]";
}

void bind_planning_module(py::module_& pl) {
  py::class_<Waypoint>(pl, "Waypoint",
                       "A waypoint of a minimum-snap plan: position (m), yaw (rad), and optionally "
                       "the velocity (m/s) and acceleration (m/s^2) to pass it with (None: free "
                       "inside, zero at the ends).")
      .def(py::init([](py::handle p, double yaw, py::handle v, py::handle a) {
             Waypoint w;
             w.position_m = to_fixed<3>(p, "Waypoint.position_m");
             w.yaw_rad = yaw;
             w.velocity_m_s = optional_vec3(v, "Waypoint.velocity_m_s");
             w.acceleration_m_s2 = optional_vec3(a, "Waypoint.acceleration_m_s2");
             return w;
           }),
           py::arg("position_m"), py::arg("yaw_rad") = 0.0, py::arg("velocity_m_s") = py::none(),
           py::arg("acceleration_m_s2") = py::none())
      .def_property(
          "position_m", [](const Waypoint& w) { return Vec3(w.position_m); },
          [](Waypoint& w, py::handle p) { w.position_m = to_fixed<3>(p, "Waypoint.position_m"); },
          "World position, m.")
      .def_readwrite("yaw_rad", &Waypoint::yaw_rad, "Heading, rad.")
      .def_property(
          "velocity_m_s", [](const Waypoint& w) { return none_or_array(w.velocity_m_s); },
          [](Waypoint& w, py::handle v) {
            w.velocity_m_s = optional_vec3(v, "Waypoint.velocity_m_s");
          },
          "Velocity to pass with, m/s, or None.")
      .def_property(
          "acceleration_m_s2", [](const Waypoint& w) { return none_or_array(w.acceleration_m_s2); },
          [](Waypoint& w, py::handle a) {
            w.acceleration_m_s2 = optional_vec3(a, "Waypoint.acceleration_m_s2");
          },
          "Acceleration to pass with, m/s^2, or None.")
      .def("__repr__", [](const Waypoint& w) {
        return "Waypoint(position_m=" + vec_text(w.position_m) +
               ", yaw_rad=" + std::to_string(w.yaw_rad) + ")";
      });

  py::class_<MinSnapOptions>(pl, "MinSnapOptions", "Options of plan_min_snap.")
      .def(py::init([](bool unwrap) {
             MinSnapOptions o;
             o.unwrap_yaw = unwrap;
             return o;
           }),
           py::arg("unwrap_yaw") = MinSnapOptions{}.unwrap_yaw)
      .def_readwrite("unwrap_yaw", &MinSnapOptions::unwrap_yaw,
                     "Turn the short way between waypoint yaws (yaw then matches modulo 2 pi).");

  py::class_<FlatOutput>(pl, "FlatOutput",
                         "Flat outputs at one time: position (m) to snap (m/s^4), yaw (rad) to "
                         "yaw acceleration (rad/s^2). Vectors default to zero.")
      .def(py::init([](py::handle p, py::handle v, py::handle a, py::handle j, py::handle s,
                       double yaw, double yaw_rate, double yaw_acceleration) {
             FlatOutput f;
             if (!p.is_none()) f.position_m = to_fixed<3>(p, "FlatOutput.position_m");
             if (!v.is_none()) f.velocity_m_s = to_fixed<3>(v, "FlatOutput.velocity_m_s");
             if (!a.is_none()) f.acceleration_m_s2 = to_fixed<3>(a, "FlatOutput.acceleration_m_s2");
             if (!j.is_none()) f.jerk_m_s3 = to_fixed<3>(j, "FlatOutput.jerk_m_s3");
             if (!s.is_none()) f.snap_m_s4 = to_fixed<3>(s, "FlatOutput.snap_m_s4");
             f.yaw_rad = yaw;
             f.yaw_rate_rad_s = yaw_rate;
             f.yaw_acceleration_rad_s2 = yaw_acceleration;
             return f;
           }),
           py::arg("position_m") = py::none(), py::arg("velocity_m_s") = py::none(),
           py::arg("acceleration_m_s2") = py::none(), py::arg("jerk_m_s3") = py::none(),
           py::arg("snap_m_s4") = py::none(), py::arg("yaw_rad") = 0.0,
           py::arg("yaw_rate_rad_s") = 0.0, py::arg("yaw_acceleration_rad_s2") = 0.0)
      .def_property(
          "position_m", [](const FlatOutput& f) { return Vec3(f.position_m); },
          [](FlatOutput& f, py::handle v) {
            f.position_m = to_fixed<3>(v, "FlatOutput.position_m");
          },
          "Position, m.")
      .def_property(
          "velocity_m_s", [](const FlatOutput& f) { return Vec3(f.velocity_m_s); },
          [](FlatOutput& f, py::handle v) {
            f.velocity_m_s = to_fixed<3>(v, "FlatOutput.velocity_m_s");
          },
          "Velocity, m/s.")
      .def_property(
          "acceleration_m_s2", [](const FlatOutput& f) { return Vec3(f.acceleration_m_s2); },
          [](FlatOutput& f, py::handle v) {
            f.acceleration_m_s2 = to_fixed<3>(v, "FlatOutput.acceleration_m_s2");
          },
          "Acceleration, m/s^2.")
      .def_property(
          "jerk_m_s3", [](const FlatOutput& f) { return Vec3(f.jerk_m_s3); },
          [](FlatOutput& f, py::handle v) { f.jerk_m_s3 = to_fixed<3>(v, "FlatOutput.jerk_m_s3"); },
          "Jerk, m/s^3.")
      .def_property(
          "snap_m_s4", [](const FlatOutput& f) { return Vec3(f.snap_m_s4); },
          [](FlatOutput& f, py::handle v) { f.snap_m_s4 = to_fixed<3>(v, "FlatOutput.snap_m_s4"); },
          "Snap, m/s^4.")
      .def_readwrite("yaw_rad", &FlatOutput::yaw_rad, "Yaw (heading), rad.")
      .def_readwrite("yaw_rate_rad_s", &FlatOutput::yaw_rate_rad_s, "Yaw rate, rad/s.")
      .def_readwrite("yaw_acceleration_rad_s2", &FlatOutput::yaw_acceleration_rad_s2,
                     "Yaw acceleration, rad/s^2.");

  py::class_<Trajectory>(
      pl, "Trajectory",
      "Piecewise degree-7 polynomials of x, y, z (m) and yaw (rad), time from 0 to duration_s.\n"
      "Times outside are clamped: the trajectory never extrapolates.")
      .def(py::init(&trajectory_of), py::arg("segment_durations_s"), py::arg("coefficients"),
           "From segment durations (s) and an (n, 8, 4) array: [i, k, axis] = coefficient of "
           "tau^k (tau in s from segment i's start) of x, y, z, yaw.")
      .def_property_readonly("duration_s", &Trajectory::duration_s, "Total duration, s.")
      .def_property_readonly(
          "num_segments", [](const Trajectory& t) { return t.segments().size(); },
          "Number of polynomial segments.")
      .def_property_readonly(
          "knot_times_s",
          [](const Trajectory& t) {
            const std::vector<double>& k = t.knot_times_s();
            return py::array_t<double>(static_cast<py::ssize_t>(k.size()), k.data());
          },
          "Segment start times and the end time (num_segments + 1,), s.")
      .def_property_readonly("coefficients", &coefficients_of,
                             "A copy of the coefficients (num_segments, 8, 4), as the "
                             "constructor takes them.")
      .def("at", &Trajectory::at, py::arg("t_s"),
           "FlatOutput at time t_s (s, clamped to [0, duration_s]).")
      .def("evaluate", &Trajectory::evaluate, py::arg("t_s"), py::arg("order"),
           "The order-th time derivative (0..7) of [x, y, z, yaw] at t_s (s), shape (4,).")
      .def("sample", &sample, py::arg("times_s"),
           "The flat outputs at many times (1-D array, s) as a dict of arrays named like\n"
           "FlatOutput's fields: position_m ... snap_m_s4 (N, 3), yaw_rad ... (N,).")
      .def("__repr__", [](const Trajectory& t) {
        return "<Trajectory: " + std::to_string(t.segments().size()) + " segments, " +
               std::to_string(t.duration_s()) + " s>";
      });

  pl.def(
      "plan_min_snap",
      [](py::handle waypoints, py::handle times, const MinSnapOptions& options) {
        const std::vector<Waypoint> w = waypoints_of(waypoints, "plan_min_snap");
        const std::vector<double> t = doubles_of(times, "plan_min_snap: segment_times_s");
        return planning::plan_min_snap(w, t, options);
      },
      py::arg("waypoints"), py::arg("segment_times_s"), py::arg("options") = MinSnapOptions{},
      "The minimum-snap Trajectory through waypoints (Waypoint list or (N, 3|4) array), segment\n"
      "i lasting segment_times_s[i] (s). ValueError naming the waypoint or segment otherwise.");

  pl.def(
      "min_snap_cost",
      [](py::handle waypoints, py::handle times, double yaw_weight, const MinSnapOptions& options) {
        const std::vector<Waypoint> w = waypoints_of(waypoints, "min_snap_cost");
        const std::vector<double> t = doubles_of(times, "min_snap_cost: segment_times_s");
        const planning::SnapCost c = planning::min_snap_cost(w, t, yaw_weight, options);
        return py::make_tuple(
            c.cost,
            py::array_t<double>(static_cast<py::ssize_t>(c.gradient.size()), c.gradient.data()));
      },
      py::arg("waypoints"), py::arg("segment_times_s"), py::arg("yaw_weight") = 1.0,
      py::arg("options") = MinSnapOptions{},
      "(cost, gradient): the optimal integral of squared snap over x, y, z plus yaw_weight times\n"
      "yaw's (m^2/s^7), and its derivative by each segment time (per segment).");

  const TimeAllocationOptions allocation_defaults;
  py::class_<TimeAllocationOptions>(pl, "TimeAllocationOptions",
                                    "Options of the segment-time allocation.")
      .def(py::init([](double speed, double yaw_rate, double yaw_weight, double tolerance,
                       int iterations, const MinSnapOptions& min_snap) {
             TimeAllocationOptions o;
             o.nominal_speed_m_s = speed;
             o.nominal_yaw_rate_rad_s = yaw_rate;
             o.yaw_weight = yaw_weight;
             o.gradient_tolerance = tolerance;
             o.max_iterations = iterations;
             o.min_snap = min_snap;
             return o;
           }),
           py::arg("nominal_speed_m_s") = allocation_defaults.nominal_speed_m_s,
           py::arg("nominal_yaw_rate_rad_s") = allocation_defaults.nominal_yaw_rate_rad_s,
           py::arg("yaw_weight") = allocation_defaults.yaw_weight,
           py::arg("gradient_tolerance") = allocation_defaults.gradient_tolerance,
           py::arg("max_iterations") = allocation_defaults.max_iterations,
           py::arg("min_snap") = allocation_defaults.min_snap)
      .def_readwrite("nominal_speed_m_s", &TimeAllocationOptions::nominal_speed_m_s,
                     "Speed of the initial guess, m/s.")
      .def_readwrite("nominal_yaw_rate_rad_s", &TimeAllocationOptions::nominal_yaw_rate_rad_s,
                     "Yaw rate of the initial guess, rad/s.")
      .def_readwrite("yaw_weight", &TimeAllocationOptions::yaw_weight,
                     "Weight of yaw's snap cost against position's, m^2/rad^2.")
      .def_readwrite("gradient_tolerance", &TimeAllocationOptions::gradient_tolerance,
                     "Converged when max |dF/d ln T_i| <= this times F.")
      .def_readwrite("max_iterations", &TimeAllocationOptions::max_iterations)
      .def_readwrite("min_snap", &TimeAllocationOptions::min_snap);

  py::class_<TimeAllocation>(pl, "TimeAllocation",
                             "How a segment-time allocation ended: the times (s) and the costs.")
      .def_property_readonly(
          "segment_times_s",
          [](const TimeAllocation& a) {
            return py::array_t<double>(static_cast<py::ssize_t>(a.segment_times_s.size()),
                                       a.segment_times_s.data());
          },
          "The best segment times found, s.")
      .def_readonly("snap_cost", &TimeAllocation::snap_cost, "J*(T) at the result.")
      .def_readonly("total_cost", &TimeAllocation::total_cost, "F = J*(T) + rho sum(T).")
      .def_readonly("initial_total_cost", &TimeAllocation::initial_total_cost,
                    "F at the initial guess.")
      .def_readonly("relative_gradient", &TimeAllocation::relative_gradient,
                    "max |dF/d ln T_i| / F at the result.")
      .def_readonly("iterations", &TimeAllocation::iterations)
      .def_readonly("converged", &TimeAllocation::converged);

  pl.def(
      "optimize_segment_times",
      [](py::handle waypoints, double rho, const TimeAllocationOptions& options) {
        const std::vector<Waypoint> w = waypoints_of(waypoints, "allocate_segment_times");
        py::gil_scoped_release release;
        return planning::optimize_segment_times(w, rho, options);
      },
      py::arg("waypoints"), py::arg("rho"), py::arg("options") = TimeAllocationOptions{},
      "TimeAllocation minimising snap cost + rho * total time (rho in cost units per s: larger,\n"
      "faster). GIL released.");

  pl.def(
      "allocate_segment_times",
      [](py::handle waypoints, double rho, const TimeAllocationOptions& options) {
        const std::vector<Waypoint> w = waypoints_of(waypoints, "allocate_segment_times");
        std::vector<double> times_s;
        {
          py::gil_scoped_release release;
          times_s = planning::allocate_segment_times(w, rho, options);
        }
        return py::array_t<double>(static_cast<py::ssize_t>(times_s.size()), times_s.data());
      },
      py::arg("waypoints"), py::arg("rho"), py::arg("options") = TimeAllocationOptions{},
      "optimize_segment_times(...).segment_times_s: segment times (s) for plan_min_snap.");

  py::class_<FlatState>(pl, "FlatState",
                        "What the flat outputs fix for a rigid-body multirotor: attitude, body "
                        "rates, thrust, torques, rotor thrusts and speeds (SI units, read-only).")
      .def_property_readonly(
          "q_WB", [](const FlatState& s) { return Vec4(s.q_WB); }, "Attitude [w, x, y, z], w >= 0.")
      .def_property_readonly(
          "R_WB", [](const FlatState& s) { return Mat3(s.R_WB); },
          "Rotation matrix body to world (3, 3).")
      .def_property_readonly(
          "angular_velocity_B_rad_s",
          [](const FlatState& s) { return Vec3(s.angular_velocity_B_rad_s); }, "Body rates, rad/s.")
      .def_property_readonly(
          "angular_acceleration_B_rad_s2",
          [](const FlatState& s) { return Vec3(s.angular_acceleration_B_rad_s2); },
          "Body angular acceleration, rad/s^2.")
      .def_property_readonly(
          "thrust_per_mass_m_s2", [](const FlatState& s) { return s.thrust_per_mass_m_s2; },
          "c = |a + g e3|, m/s^2.")
      .def_property_readonly(
          "thrust_N", [](const FlatState& s) { return s.thrust_N; }, "Collective thrust m c, N.")
      .def_property_readonly(
          "thrust_rate_N_s", [](const FlatState& s) { return s.thrust_rate_N_s; },
          "Rate of the collective thrust, N/s.")
      .def_property_readonly(
          "torque_B_Nm", [](const FlatState& s) { return Vec3(s.torque_B_Nm); },
          "Body torques the rotors give: J w' + w x J w (less the drag moments with drag), N m.")
      .def_property_readonly(
          "generalized_force", [](const FlatState& s) { return Vec4(s.generalized_force); },
          "[thrust_N, torque_B_Nm], the allocation's input.")
      .def_property_readonly(
          "rotor_thrusts_N", [](const FlatState& s) { return copy_of(s.rotor_thrusts_N); },
          "Rotor thrusts giving generalized_force exactly (not clamped), N.")
      .def_property_readonly(
          "rotor_speeds_rad_s", [](const FlatState& s) { return copy_of(s.rotor_speeds_rad_s); },
          "Rotor speeds of the thrust-first allocation, clamped to the limits, rad/s.")
      .def_property_readonly(
          "allocation_saturated", [](const FlatState& s) { return s.allocation_saturated; },
          "True when the rotor speeds were clamped.");

  pl.def(
      "flat_state",
      [](const FlatOutput& f, const ModelPtr& model, double gravity_m_s2, bool body_drag,
         bool rotor_drag) {
        return planning::flat_state(f, model_of(model, "flat_state"), gravity_m_s2,
                                    planning::FlatDragTerms{body_drag, rotor_drag});
      },
      // 9.81: the C++ default of flat_state.
      py::arg("flat_output"), py::arg("model"), py::arg("gravity_m_s2") = 9.81,
      py::arg("body_drag") = false, py::arg("rotor_drag") = false,
      "FlatState of a FlatOutput for `model` (gravity along -z, m/s^2), with the model's frame\n"
      "drag and rotor drag when asked (docs/planning.md). ValueError in free fall, with the\n"
      "thrust along the heading, or when the drag's fixed point does not converge.");

  py::class_<FeasibilityLimits>(pl, "FeasibilityLimits",
                                "Limits of check_feasibility besides the rotor speed limits.")
      .def(py::init([](double tilt, double rate, double gravity, bool body_drag, bool rotor_drag) {
             FeasibilityLimits l;
             l.max_tilt_rad = tilt;
             l.max_body_rate_rad_s = rate;
             l.gravity_m_s2 = gravity;
             l.drag = {body_drag, rotor_drag};
             return l;
           }),
           py::arg("max_tilt_rad") = FeasibilityLimits{}.max_tilt_rad,
           py::arg("max_body_rate_rad_s") = FeasibilityLimits{}.max_body_rate_rad_s,
           py::arg("gravity_m_s2") = FeasibilityLimits{}.gravity_m_s2, py::arg("body_drag") = false,
           py::arg("rotor_drag") = false)
      .def_readwrite("max_tilt_rad", &FeasibilityLimits::max_tilt_rad,
                     "Largest angle between body z and world z, rad.")
      .def_readwrite("max_body_rate_rad_s", &FeasibilityLimits::max_body_rate_rad_s,
                     "Largest |w_B|, rad/s.")
      .def_readwrite("gravity_m_s2", &FeasibilityLimits::gravity_m_s2, "m/s^2")
      .def_property(
          "body_drag", [](const FeasibilityLimits& l) { return l.drag.body_drag; },
          [](FeasibilityLimits& l, bool on) { l.drag.body_drag = on; },
          "The flat states checked include the model's frame drag.")
      .def_property(
          "rotor_drag", [](const FeasibilityLimits& l) { return l.drag.rotor_drag; },
          [](FeasibilityLimits& l, bool on) { l.drag.rotor_drag = on; },
          "The flat states checked include the model's rotor drag.");

  py::enum_<FeasibilityViolation>(pl, "FeasibilityViolation", "What made a trajectory infeasible.")
      .value("NONE", FeasibilityViolation::kNone)
      .value("ROTOR_SPEED_ABOVE_MAX", FeasibilityViolation::kRotorSpeedAboveMax)
      .value("ROTOR_SPEED_BELOW_MIN", FeasibilityViolation::kRotorSpeedBelowMin)
      .value("TILT", FeasibilityViolation::kTilt)
      .value("BODY_RATE", FeasibilityViolation::kBodyRate)
      .value("SINGULAR", FeasibilityViolation::kSingular, "Free fall or thrust along the heading.");

  py::class_<FeasibilityReport>(pl, "FeasibilityReport",
                                "The first infeasible sample of check_feasibility, if any.")
      .def_readonly("feasible", &FeasibilityReport::feasible)
      .def_readonly("time_s", &FeasibilityReport::time_s,
                    "Time of the first infeasible sample, s (0 when feasible).")
      .def_readonly("violation", &FeasibilityReport::violation)
      .def_readonly("rotor", &FeasibilityReport::rotor, "The rotor for a rotor speed (else -1).")
      .def_readonly("value", &FeasibilityReport::value,
                    "The offending value: rad/s (rotor speed, body rate) or rad (tilt).")
      .def_readonly("limit", &FeasibilityReport::limit, "The limit it crosses, same units.")
      .def_readonly("samples", &FeasibilityReport::samples, "Samples evaluated.")
      .def_readonly("message", &FeasibilityReport::message, "Empty when feasible.")
      .def("__repr__", [](const FeasibilityReport& r) {
        return r.feasible
                   ? "<FeasibilityReport: feasible, " + std::to_string(r.samples) + " samples>"
                   : "<FeasibilityReport: " + r.message + ">";
      });

  pl.def(
      "check_feasibility",
      [](const Trajectory& trajectory, const ModelPtr& model, const FeasibilityLimits& limits,
         double sample_dt_s) {
        const VehicleModel& m = model_of(model, "check_feasibility");
        py::gil_scoped_release release;
        return planning::check_feasibility(trajectory, m, limits, sample_dt_s);
      },
      py::arg("trajectory"), py::arg("model"), py::arg("limits"), py::arg("sample_dt_s"),
      "FeasibilityReport of the trajectory sampled every sample_dt_s (s) and at its end: rotor\n"
      "speeds within the model's limits, tilt and body rate within `limits`. GIL released.");

  pl.def("time_scaled", &planning::time_scaled, py::arg("trajectory"), py::arg("factor"),
         "The same path flown `factor` times slower (< 1: faster): durations x factor, the k-th "
         "derivative / factor^k.");

  pl.def(
      "feasible_time_scale",
      [](const Trajectory& trajectory, const ModelPtr& model, const FeasibilityLimits& limits,
         double sample_dt_s, double relative_tolerance, double max_factor) {
        const VehicleModel& m = model_of(model, "feasible_time_scale");
        py::gil_scoped_release release;
        return planning::feasible_time_scale(trajectory, m, limits, sample_dt_s, relative_tolerance,
                                             max_factor);
      },
      py::arg("trajectory"), py::arg("model"), py::arg("limits"), py::arg("sample_dt_s"),
      // The C++ defaults of feasible_time_scale.
      py::arg("relative_tolerance") = 1e-3, py::arg("max_factor") = 1e3,
      "The smallest factor >= 1 (within relative_tolerance) for which time_scaled(trajectory,\n"
      "factor) passes check_feasibility; ValueError if max_factor does not. GIL released.");
}

}  // namespace

void bind_planning(py::module_& m) {
  py::module_ pl = m.def_submodule(
      "planning",
      "Trajectory planning (docs/planning.md): minimum-snap trajectories through waypoints,\n"
      "segment-time allocation, differential flatness, feasibility and time scaling, and the\n"
      "time-optimal lap of a track.");
  bind_planning_module(pl);
  bind_time_optimal(pl);
  // A pybind11 submodule is only an attribute of its parent; registered under the package's
  // name it also answers `import dronetwin.planning` and `from dronetwin.planning import ...`.
  const std::string core_name = py::str(m.attr("__name__"));
  const std::string package = core_name.substr(0, core_name.rfind('.'));
  py::module_::import("sys").attr("modules")[py::str(package + ".planning")] = pl;

  // Top level, beside WaypointReference (its base Reference is bound by bind_control).
  py::class_<TrajectoryReference, Reference, std::shared_ptr<TrajectoryReference>>(
      m, "TrajectoryReference",
      "A planning.Trajectory as a reference, started at start_time_s (s): position to snap, yaw\n"
      "to yaw acceleration. Before the start and after the end it holds the first or last point\n"
      "at rest.")
      .def(py::init([](const Trajectory& trajectory, double start_time_s) {
             return std::make_shared<TrajectoryReference>(trajectory, start_time_s);
           }),
           py::arg("trajectory"), py::arg("start_time_s") = 0.0)
      .def_property_readonly(
          "trajectory", [](const TrajectoryReference& r) { return r.trajectory(); },
          "A copy of the planned Trajectory.")
      .def_property_readonly("start_time_s", &TrajectoryReference::start_time_s,
                             "When the trajectory starts, s.")
      .def_property_readonly("end_time_s", &TrajectoryReference::end_time_s,
                             "When it ends (start_time_s + duration_s), s.");
}

}  // namespace dronetwin::python
