// Bindings of the control layer: references, ControllerBase (subclassable in Python), the PID and
// SE(3) controllers, and ClosedLoop (with an in-memory recorder returning numpy arrays).
//
// A Python controller overrides `calculate_u(self, inp)` (returning [T, tau_x, tau_y, tau_z]) or
// `calculate_actuator_cmd(self, inp)` (returning rotor speed references). The C++ entry points
// keep their checks: a Python controller that returns NaN or the wrong length is reported with its
// name, never flown. Python callbacks take the GIL themselves, so ClosedLoop.run may release it.

#include <cstring>

#include "bindings.hpp"
#include "dronetwin/control/body_rate.hpp"
#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/control/controller_base.hpp"
#include "dronetwin/control/pid.hpp"
#include "dronetwin/control/reference.hpp"
#include "dronetwin/control/se3.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/nmpc/nmpc.hpp"

namespace dronetwin::python {

namespace {

// ---- Python-subclassable Reference ------------------------------------------------------------
/// What C++ holds when it copies a Python reference (ClosedLoop hands an NMPC a copy for its
/// The result of a Python override converted to T, or a TypeError that names the method and
/// says what it returned and what was expected (pybind11's own message names neither).
template <class T>
T result_of(const py::object& r, const char* method, const char* expected) {
  try {
    return r.cast<T>();
  } catch (const py::cast_error&) {
    throw py::type_error(std::string(method) + "() returned " + describe_object(r) + "; expected " +
                         expected);
  }
}

/// preview): a counted handle to the same Python object, called with the GIL.
class PythonReferenceHandle final : public Reference {
 public:
  explicit PythonReferenceHandle(py::object obj) : obj_(std::move(obj)) {}
  ~PythonReferenceHandle() override {
    py::gil_scoped_acquire gil;
    obj_ = py::object();
  }
  ReferencePoint at(double t_s) const override {
    py::gil_scoped_acquire gil;
    return result_of<ReferencePoint>(obj_.attr("at")(t_s), "Reference.at", "a ReferencePoint");
  }
  std::string describe() const override {
    py::gil_scoped_acquire gil;
    return result_of<std::string>(obj_.attr("describe")(), "Reference.describe", "a str");
  }
  std::unique_ptr<Reference> clone() const override {
    py::gil_scoped_acquire gil;
    return std::make_unique<PythonReferenceHandle>(obj_);
  }

 private:
  py::object obj_;
};

class PyReference : public Reference {
 public:
  ReferencePoint at(double t_s) const override {
    py::gil_scoped_acquire gil;
    if (py::function f = py::get_override(static_cast<const Reference*>(this), "at")) {
      return result_of<ReferencePoint>(f(t_s), "Reference.at", "a ReferencePoint");
    }
    throw py::type_error("Reference subclass does not implement at(self, t_s)");
  }
  std::string describe() const override {
    py::gil_scoped_acquire gil;
    if (py::function f = py::get_override(static_cast<const Reference*>(this), "describe")) {
      return result_of<std::string>(f(), "Reference.describe", "a str");
    }
    return "python reference";
  }
  std::unique_ptr<Reference> clone() const override {
    py::gil_scoped_acquire gil;
    return std::make_unique<PythonReferenceHandle>(py::cast(this));
  }
};

// ---- Python-subclassable ControllerBase -------------------------------------------------------
class PyController : public ControllerBase {
 public:
  using ControllerBase::ControllerBase;

  std::string_view name() const override {
    py::gil_scoped_acquire gil;
    if (py::function f = py::get_override(static_cast<const ControllerBase*>(this), "name")) {
      name_ = result_of<std::string>(f(), "ControllerBase.name", "a str");
    } else {
      name_ = py::str(py::cast(this).get_type().attr("__name__")).cast<std::string>();
    }
    return name_;
  }
  ControlLevel level() const override {
    py::gil_scoped_acquire gil;
    if (py::function f = py::get_override(static_cast<const ControllerBase*>(this), "level")) {
      return result_of<ControlLevel>(f(), "ControllerBase.level", "a ControlLevel");
    }
    // A Python class that implements only calculate_actuator_cmd commands the rotors itself.
    const bool has_u = static_cast<bool>(
        py::get_override(static_cast<const ControllerBase*>(this), "calculate_u"));
    const bool has_cmd = static_cast<bool>(
        py::get_override(static_cast<const ControllerBase*>(this), "calculate_actuator_cmd"));
    return has_cmd && !has_u ? ControlLevel::kRotorSpeed : ControlLevel::kGeneralizedForce;
  }
  std::unique_ptr<ControllerBase> clone() const override {
    throw InvalidArgument(detail::concat("controller '", std::string(name()),
                                         "' is written in Python and cannot be copied by C++; use "
                                         "copy.deepcopy in Python"));
  }
  void reset() override { PYBIND11_OVERRIDE(void, ControllerBase, reset, ); }
  std::vector<std::string> diagnostic_names() const override {
    py::gil_scoped_acquire gil;
    if (py::function f =
            py::get_override(static_cast<const ControllerBase*>(this), "diagnostic_names")) {
      return result_of<std::vector<std::string>>(f(), "ControllerBase.diagnostic_names",
                                                 "a list of str");
    }
    return ControllerBase::diagnostic_names();
  }
  void diagnostics(double* out) const override {
    py::gil_scoped_acquire gil;
    if (py::function f =
            py::get_override(static_cast<const ControllerBase*>(this), "diagnostics")) {
      const auto n = static_cast<int>(diagnostic_names().size());
      read_vector(f(), n, "diagnostics result", out);
    }
  }

 protected:
  GeneralizedForce do_calculate_u(const ControlInput& in) override {
    {
      py::gil_scoped_acquire gil;
      if (py::function f =
              py::get_override(static_cast<const ControllerBase*>(this), "calculate_u")) {
        const py::object r = f(in);
        return to_fixed<4>(r, "calculate_u result");
      }
    }
    return ControllerBase::do_calculate_u(in);
  }
  RotorVector do_calculate_actuator_cmd(const ControlInput& in) override {
    {
      py::gil_scoped_acquire gil;
      if (py::function f = py::get_override(static_cast<const ControllerBase*>(this),
                                            "calculate_actuator_cmd")) {
        const py::object r = f(in);
        return to_rotor_vector(r, model().num_rotors(), "calculate_actuator_cmd result");
      }
    }
    return ControllerBase::do_calculate_actuator_cmd(in);
  }

 private:
  mutable std::string name_;
};

/// Checks for Ctrl-C every few thousand instants of a run flown with the GIL released: a pending
/// KeyboardInterrupt stops the run (the exception propagates out of ClosedLoop::run).
struct SignalCheck {
  std::int64_t calls = 0;
  void tick() {
    if (++calls % 4096 != 0) return;
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
  }
};

/// ClosedLoop.run(): only the signal checks.
struct InterruptibleRun final : LoopObserver {
  SignalCheck signals;
  void observe(const ClosedLoop&) override { signals.tick(); }
};

/// Records a closed-loop run into preallocated numpy arrays (one row at t = 0 and after every
/// `every`-th step) through ClosedLoop::run(), with the GIL released while stepping. A failed run
/// keeps its rows (and the last good state) and says why in status and failure_message.
py::dict record(ClosedLoop& loop, double duration_s, std::int64_t every) {
  const Simulator& sim = loop.simulator();
  if (!(duration_s >= 0.0) || !std::isfinite(duration_s))
    throw py::value_error("record: duration_s must be finite and >= 0, got " +
                          std::to_string(duration_s));
  if (every < 1)
    throw py::value_error("record: every_n_steps must be >= 1, got " + std::to_string(every));
  const double dt = sim.config().dt_s;
  const std::int64_t steps = ClosedLoop::steps_for(duration_s, dt);
  // A row per every-th step, plus t = 0 and a possible last good state of a failed run.
  const py::ssize_t rows = static_cast<py::ssize_t>(steps / every + 2);
  const py::ssize_t nr = sim.model().num_rotors();
  py::array_t<double> t({rows}), x({rows, py::ssize_t{kStateSize}}),
      xm({rows, py::ssize_t{kStateSize}}), w({rows, nr}), wref({rows, nr}),
      ref({rows, py::ssize_t{4}}), u({rows, py::ssize_t{4}}), sat({rows});
  const ControllerBase& controller = loop.controller();
  const std::vector<std::string> diag_names = controller.diagnostic_names();
  const auto nd = static_cast<py::ssize_t>(diag_names.size());
  py::array_t<double> diag({rows, nd});

  struct Recorder final : LoopObserver {
    double *pt, *px, *pxm, *pw, *pwr, *pref, *pu, *psat, *pdiag;
    py::ssize_t nr, nd, filled = 0;
    std::int64_t start_step, every, logged_step = -1;
    SignalCheck signals;
    void observe(const ClosedLoop& l) override {
      if ((l.simulator().step_count() - start_step) % every == 0) row(l);
      signals.tick();
    }
    void finish(const ClosedLoop& l, const StepResult& r) override {
      if (!r.ok() && logged_step != l.simulator().step_count()) row(l);
    }
    void row(const ClosedLoop& l) {
      const Simulator& s = l.simulator();
      const py::ssize_t k = filled++;
      pt[k] = s.time_s();
      std::memcpy(px + k * kStateSize, s.state().data(), sizeof(double) * kStateSize);
      std::memcpy(pxm + k * kStateSize, s.measured_state().data(), sizeof(double) * kStateSize);
      std::memcpy(pw + k * nr, s.rotor_speeds_rad_s().data(),
                  sizeof(double) * static_cast<std::size_t>(nr));
      std::memcpy(pwr + k * nr, s.rotor_speed_reference_rad_s().data(),
                  sizeof(double) * static_cast<std::size_t>(nr));
      const ReferencePoint p = l.reference().at(s.time_s());
      pref[4 * k + 0] = p.position_m.x();
      pref[4 * k + 1] = p.position_m.y();
      pref[4 * k + 2] = p.position_m.z();
      pref[4 * k + 3] = p.yaw_rad;
      for (int i = 0; i < 4; ++i) pu[4 * k + i] = l.last_command()[i];
      psat[k] = l.last_allocation().saturated ? 1.0 : 0.0;
      if (nd > 0) l.controller().diagnostics(pdiag + k * nd);
      logged_step = s.step_count();
    }
  } recorder;
  recorder.pt = t.mutable_data();
  recorder.px = x.mutable_data();
  recorder.pxm = xm.mutable_data();
  recorder.pw = w.mutable_data();
  recorder.pwr = wref.mutable_data();
  recorder.pref = ref.mutable_data();
  recorder.pu = u.mutable_data();
  recorder.psat = sat.mutable_data();
  recorder.pdiag = diag.mutable_data();
  recorder.nr = nr;
  recorder.nd = nd;
  recorder.start_step = sim.step_count();
  recorder.every = every;
  StepResult result;
  {
    py::gil_scoped_release release;
    result = loop.run(duration_s, &recorder);
  }
  const py::ssize_t filled = recorder.filled;
  py::dict d;
  const auto trim = [&](py::array_t<double>& a) -> py::object {
    if (filled == rows) return a;
    return a[py::slice(0, filled, 1)];
  };
  d["t"] = trim(t);
  d["state"] = trim(x);
  d["measured_state"] = trim(xm);
  d["rotor_speeds_rad_s"] = trim(w);
  d["rotor_speed_reference_rad_s"] = trim(wref);
  d["reference"] = trim(ref);
  d["u"] = trim(u);
  d["saturated"] = trim(sat);
  d["diagnostics"] = trim(diag);
  d["diagnostic_names"] = diag_names;
  d["dt_s"] = dt;
  d["status"] = result.status;
  d["failure_message"] = result.status == StepStatus::kControllerFailed ? loop.failure_message()
                                                                        : sim.failure_message();
  d["state_columns"] =
      py::make_tuple("x", "y", "z", "vx", "vy", "vz", "qw", "qx", "qy", "qz", "wx", "wy", "wz");
  return d;
}

}  // namespace

void bind_control(py::module_& m) {
  py::class_<ReferencePoint>(m, "ReferencePoint",
                             "The desired flat output at one instant, with its derivatives.")
      .def(py::init([](py::handle p, py::handle v, py::handle a, double yaw, double yaw_rate) {
             ReferencePoint r;
             r.position_m = to_fixed<3>(p, "ReferencePoint.position_m");
             if (!v.is_none()) r.velocity_m_s = to_fixed<3>(v, "ReferencePoint.velocity_m_s");
             if (!a.is_none())
               r.acceleration_m_s2 = to_fixed<3>(a, "ReferencePoint.acceleration_m_s2");
             r.yaw_rad = yaw;
             r.yaw_rate_rad_s = yaw_rate;
             return r;
           }),
           py::arg("position_m"), py::arg("velocity_m_s") = py::none(),
           py::arg("acceleration_m_s2") = py::none(), py::arg("yaw_rad") = 0.0,
           py::arg("yaw_rate_rad_s") = 0.0)
      .def_readwrite("position_m", &ReferencePoint::position_m)
      .def_readwrite("velocity_m_s", &ReferencePoint::velocity_m_s)
      .def_readwrite("acceleration_m_s2", &ReferencePoint::acceleration_m_s2)
      .def_readwrite("yaw_rad", &ReferencePoint::yaw_rad)
      .def_readwrite("yaw_rate_rad_s", &ReferencePoint::yaw_rate_rad_s)
      .def_readwrite("jerk_m_s3", &ReferencePoint::jerk_m_s3)
      .def_readwrite("snap_m_s4", &ReferencePoint::snap_m_s4)
      .def_readwrite("yaw_acceleration_rad_s2", &ReferencePoint::yaw_acceleration_rad_s2);

  py::class_<Reference, PyReference, std::shared_ptr<Reference>>(
      m, "Reference",
      "A trajectory to track: at(t) gives the ReferencePoint at time t (s). Subclass it in Python\n"
      "by overriding `at(self, t_s)` (and optionally `describe(self)`).")
      .def(py::init<>())
      .def("at", &Reference::at, py::arg("t_s"), "The ReferencePoint at time t_s (s).")
      .def("describe", &Reference::describe, "One line saying what the reference is.")
      .def("__repr__", [](const Reference& r) { return "<" + r.describe() + ">"; });

  py::class_<SetpointReference, Reference, std::shared_ptr<SetpointReference>>(
      m, "SetpointReference", "Hold one position and yaw.")
      .def(py::init([](py::handle p, double yaw) {
             return std::make_shared<SetpointReference>(
                 to_fixed<3>(p, "SetpointReference: position_m"), yaw);
           }),
           py::arg("position_m"), py::arg("yaw_rad") = 0.0);

  py::class_<PiecewiseConstantReference::Segment>(m, "PiecewiseSegment",
                                                  "A step of a piecewise-constant reference.")
      .def(py::init([](double start, py::handle p, double yaw) {
             return PiecewiseConstantReference::Segment{
                 start, to_fixed<3>(p, "PiecewiseSegment: position_m"), yaw};
           }),
           py::arg("start_s"), py::arg("position_m"), py::arg("yaw_rad") = 0.0)
      .def_readwrite("start_s", &PiecewiseConstantReference::Segment::start_s)
      .def_readwrite("position_m", &PiecewiseConstantReference::Segment::position_m)
      .def_readwrite("yaw_rad", &PiecewiseConstantReference::Segment::yaw_rad);

  py::class_<PiecewiseConstantReference, Reference, std::shared_ptr<PiecewiseConstantReference>>(
      m, "PiecewiseConstantReference", "Position and yaw steps (zero-order hold).")
      .def(py::init([](std::vector<PiecewiseConstantReference::Segment> s) {
             return std::make_shared<PiecewiseConstantReference>(std::move(s));
           }),
           py::arg("segments"))
      .def_static(
          "thesis_pulse",
          [] {
            return std::make_shared<PiecewiseConstantReference>(
                PiecewiseConstantReference::thesis_pulse());
          },
          "The pulse of thesis Eq. 3.14.")
      .def_property_readonly("segments", &PiecewiseConstantReference::segments);

  py::class_<CircleReference, Reference, std::shared_ptr<CircleReference>>(
      m, "CircleReference", "Circle of thesis Eq. 3.28 (default: radius 2 m, period 7 s, z = 1 m).")
      .def(py::init([](py::handle c, double r, double period, double yaw) {
             return std::make_shared<CircleReference>(to_fixed<3>(c, "CircleReference: center_m"),
                                                      r, period, yaw);
           }),
           py::arg("center_m") = Vec3(0, 0, 1), py::arg("radius_m") = 2.0,
           py::arg("period_s") = 7.0, py::arg("yaw_rad") = 0.0);

  py::class_<FigureEightReference, Reference, std::shared_ptr<FigureEightReference>>(
      m, "FigureEightReference",
      "Figure eight of thesis Eq. 3.25 (0.8 m x 0.6 m, 60 s, z = 1.2 m).")
      .def(py::init([](py::handle c, double ax, double ay, double period) {
             return std::make_shared<FigureEightReference>(
                 to_fixed<3>(c, "FigureEightReference: center_m"), ax, ay, period);
           }),
           py::arg("center_m") = Vec3(0, 0, 1.2), py::arg("amplitude_x_m") = 0.8,
           py::arg("amplitude_y_m") = 0.6, py::arg("period_s") = 60.0);

  py::class_<WaypointReference::Waypoint>(m, "Waypoint", "A timed waypoint.")
      .def(py::init([](double t, py::handle p, double yaw) {
             return WaypointReference::Waypoint{t, to_fixed<3>(p, "Waypoint: position_m"), yaw};
           }),
           py::arg("time_s"), py::arg("position_m"), py::arg("yaw_rad") = 0.0)
      .def_readwrite("time_s", &WaypointReference::Waypoint::time_s)
      .def_readwrite("position_m", &WaypointReference::Waypoint::position_m)
      .def_readwrite("yaw_rad", &WaypointReference::Waypoint::yaw_rad);

  py::class_<WaypointReference, Reference, std::shared_ptr<WaypointReference>>(
      m, "WaypointReference", "Minimum-jerk segments through timed waypoints.")
      .def(py::init([](std::vector<WaypointReference::Waypoint> w) {
             return std::make_shared<WaypointReference>(std::move(w));
           }),
           py::arg("waypoints"));

  py::class_<ControlInput>(m, "ControlInput",
                           "What a controller sees at one control step: time, measured state, its "
                           "derivative, and the reference.")
      .def(py::init<>())
      .def_readwrite("time_s", &ControlInput::time_s)
      .def_readwrite("state", &ControlInput::state, "Measured X (13,).")
      .def_readwrite("state_derivative", &ControlInput::state_derivative, "Measured X_dot (13,).")
      .def_readwrite("reference", &ControlInput::reference);

  py::enum_<ControlLevel>(m, "ControlLevel", "What a controller outputs.")
      .value("GENERALIZED_FORCE", ControlLevel::kGeneralizedForce,
             "calculate_u: [T, tau_x, tau_y, tau_z]; dronetwin allocates.")
      .value("ROTOR_SPEED", ControlLevel::kRotorSpeed, "calculate_actuator_cmd: rotor speeds.");

  py::class_<ControllerBase, PyController>(
      m, "ControllerBase",
      "Base of every controller (thesis Sec. 3.5). Subclass it in Python:\n\n"
      "    class Hover(dronetwin.ControllerBase):\n"
      "        def __init__(self, model):\n"
      "            super().__init__(model)\n"
      "        def calculate_u(self, inp):           # -> [T, tau_x, tau_y, tau_z]\n"
      "            return [self.model.mass_kg * 9.81, 0.0, 0.0, 0.0]\n\n"
      "or override calculate_actuator_cmd(self, inp) to return rotor speeds (rad/s). Optional:\n"
      "name(self) -> str, reset(self). A ClosedLoop runs it at its control rate on the measured\n"
      "state; the output is checked (finite, right length) before it is flown.")
      .def(py::init([](const std::shared_ptr<VehicleModel>& model, AllocationMethod allocation) {
             if (!model)
               throw py::value_error("ControllerBase: model must be a VehicleModel, got None");
             return new PyController(model, allocation);
           }),
           py::arg("model"), py::arg("allocation") = AllocationMethod::kExact)
      .def(
          "name", [](const ControllerBase& c) { return std::string(c.name()); },
          "The controller's name in logs and messages (Python subclasses: the class name unless "
          "overridden).")
      .def("level", &ControllerBase::level,
           "ControlLevel: GENERALIZED_FORCE (calculate_u) or ROTOR_SPEED (calculate_actuator_cmd).")
      .def("reset", &ControllerBase::reset, "Clears internal memory before a new run.")
      .def("diagnostic_names", &ControllerBase::diagnostic_names,
           "Names of the per-update values the controller reports (logged as ctrl_<name>).")
      .def(
          "diagnostics",
          [](const ControllerBase& c) {
            const std::vector<std::string> names = c.diagnostic_names();
            std::vector<double> v(names.size(), 0.0);
            if (!v.empty()) c.diagnostics(v.data());
            py::dict d;
            for (std::size_t i = 0; i < names.size(); ++i) d[py::str(names[i])] = v[i];
            return d;
          },
          "The diagnostics of the most recent update as {name: value} (NaN: not applicable).")
      .def("calculate_u", &ControllerBase::calculate_u, py::arg("inp"),
           "Generalized force [T, tau_x, tau_y, tau_z] for `inp` (checked).")
      .def("calculate_actuator_cmd", &ControllerBase::calculate_actuator_cmd, py::arg("inp"),
           "Rotor speed references for `inp` (allocated for generalized-force controllers).")
      .def_property_readonly("model",
                             [](const ControllerBase& c) {
                               return std::const_pointer_cast<VehicleModel>(c.model_ptr());
                             })
      .def_property("allocation", &ControllerBase::allocation, &ControllerBase::set_allocation)
      .def_property_readonly("last_allocation",
                             [](const ControllerBase& c) { return c.last_allocation(); });

  py::enum_<PidYawLoop>(m, "PidYawLoop")
      .value("THESIS", PidYawLoop::kThesis, "As printed (Eq. 3.19).")
      .value("RATE", PidYawLoop::kRate, "The inner yaw loop is a rate loop.");

  py::class_<PidGains>(m, "PidGains", "Gains of the cascaded PID (thesis Eq. 3.15-3.22).")
      .def(py::init<>())
      .def_static("thesis_simulation", &PidGains::thesis_simulation, "Thesis Eq. 3.21.")
      .def_static("thesis_hardware", &PidGains::thesis_hardware, "Thesis Eq. 3.22.")
      .def_readwrite("outer_p", &PidGains::outer_p)
      .def_readwrite("outer_d", &PidGains::outer_d)
      .def_readwrite("outer_i", &PidGains::outer_i)
      .def_readwrite("inner_p", &PidGains::inner_p)
      .def_readwrite("inner_d1", &PidGains::inner_d1)
      .def_readwrite("inner_d2", &PidGains::inner_d2)
      .def_readwrite("mass_kg", &PidGains::mass_kg)
      .def_readwrite("gravity_m_s2", &PidGains::gravity_m_s2);

  py::class_<PidOptions>(m, "PidOptions", "Modifications of the printed PID (docs/controllers.md).")
      .def(py::init<>())
      .def_readwrite("max_tilt_rad", &PidOptions::max_tilt_rad)
      .def_readwrite("integral_limit", &PidOptions::integral_limit)
      .def_readwrite("conditional_integration", &PidOptions::conditional_integration)
      .def_readwrite("yaw_error_wrap", &PidOptions::yaw_error_wrap)
      .def_readwrite("velocity_feedforward", &PidOptions::velocity_feedforward)
      .def_readwrite("yaw_frame_mapping", &PidOptions::yaw_frame_mapping)
      .def_readwrite("yaw_loop", &PidOptions::yaw_loop)
      .def_readwrite("acceleration_feed_forward", &PidOptions::acceleration_feed_forward,
                     "Tilt and thrust feed-forward of the reference's acceleration.")
      .def_readwrite("angular_feed_forward", &PidOptions::angular_feed_forward,
                     "Body-rate, angular-acceleration and torque feed-forward of the reference's "
                     "flat attitude (from its jerk and snap).")
      .def_readwrite("drag_feed_forward", &PidOptions::drag_feed_forward,
                     "Cancel the model's drag at the reference velocity through the acceleration "
                     "feed-forward.");

  py::class_<CascadedPid, ControllerBase>(m, "CascadedPid", "Cascaded PID (thesis Eq. 3.15-3.20).")
      .def(py::init([](const std::shared_ptr<VehicleModel>& model, const PidGains& g,
                       const PidOptions& o, double period,
                       AllocationMethod a) { return new CascadedPid(model, g, o, period, a); }),
           py::arg("model"), py::arg("gains"), py::arg("options") = PidOptions{},
           py::arg("control_period_s") = 1.0e-3, py::arg("allocation") = AllocationMethod::kExact)
      .def_property_readonly(
          "gains", [](const CascadedPid& c) { return c.gains(); }, "A copy of the gains.")
      .def_property_readonly(
          "options", [](const CascadedPid& c) { return c.options(); }, "A copy of the options.")
      .def_property_readonly("integral", [](const CascadedPid& c) { return Vec4(c.integral()); });

  py::class_<Se3Gains>(m, "Se3Gains", "Gains of the SE(3) controller (thesis Eq. 3.29).")
      .def(py::init<>())
      .def_static("thesis", &Se3Gains::thesis)
      .def_readwrite("position_p", &Se3Gains::position_p)
      .def_readwrite("position_d", &Se3Gains::position_d)
      .def_readwrite("attitude_p", &Se3Gains::attitude_p)
      .def_readwrite("attitude_d", &Se3Gains::attitude_d)
      .def_readwrite("mass_kg", &Se3Gains::mass_kg)
      .def_readwrite("gravity_m_s2", &Se3Gains::gravity_m_s2);

  py::class_<Se3Options>(m, "Se3Options", "Modifications of the printed SE(3) controller.")
      .def(py::init<>())
      .def_readwrite("gravity_compensation", &Se3Options::gravity_compensation)
      .def_readwrite("max_tilt_rad", &Se3Options::max_tilt_rad)
      .def_readwrite("nonnegative_thrust", &Se3Options::nonnegative_thrust)
      .def_readwrite("min_thrust_N", &Se3Options::min_thrust_N)
      .def_readwrite("angular_feed_forward", &Se3Options::angular_feed_forward,
                     "Body-rate and angular-acceleration feed-forward from the reference's jerk "
                     "and snap (off as printed).")
      .def_readwrite("drag_feed_forward", &Se3Options::drag_feed_forward,
                     "Add the force that cancels the model's drag at the reference velocity "
                     "(off as printed).");

  py::class_<Se3Controller, ControllerBase>(
      m, "Se3Controller", "Geometric tracking control on SE(3) (thesis Eq. 3.26-3.29).")
      .def(py::init([](const std::shared_ptr<VehicleModel>& model, const Se3Gains& g,
                       const Se3Options& o,
                       AllocationMethod a) { return new Se3Controller(model, g, o, a); }),
           py::arg("model"), py::arg("gains"), py::arg("options") = Se3Options{},
           py::arg("allocation") = AllocationMethod::kExact)
      .def_property_readonly(
          "gains", [](const Se3Controller& c) { return c.gains(); }, "A copy of the gains.")
      .def_property_readonly(
          "options", [](const Se3Controller& c) { return c.options(); }, "A copy of the options.");

  py::class_<BodyRateGains>(m, "BodyRateGains",
                            "K_w per body axis, 1/s (default [20, 20, 10]: time constants of "
                            "each rate's first-order response).")
      .def(py::init<>())
      .def_readwrite("rate_p", &BodyRateGains::rate_p);

  py::class_<BodyRateController, ControllerBase>(
      m, "BodyRateController",
      "Collective thrust + body rates (CTBR): tau = J K_w (w_cmd - w) + w x J w. The command "
      "comes from set_command(thrust_N, rates_rad_s); the loop's reference is not used.")
      .def(py::init([](const std::shared_ptr<VehicleModel>& model, const BodyRateGains& g,
                       AllocationMethod a) { return new BodyRateController(model, g, a); }),
           py::arg("model"), py::arg("gains") = BodyRateGains{},
           py::arg("allocation") = AllocationMethod::kExact)
      .def(
          "set_command",
          [](BodyRateController& c, double thrust_N, py::handle rates) {
            c.set_command(thrust_N, to_fixed<3>(rates, "BodyRateController.set_command: rates"));
          },
          py::arg("thrust_N"), py::arg("rates_rad_s"),
          "The CTBR command: collective thrust (N, >= 0) and body rates (rad/s); held until the "
          "next call.")
      .def_property_readonly("thrust_command_N", &BodyRateController::thrust_command_N)
      .def_property_readonly("rate_command_rad_s",
                             [](const BodyRateController& c) { return c.rate_command_rad_s(); });

  py::enum_<NmpcLinearSolver>(m, "NmpcLinearSolver")
      .value("DENSE_QR", NmpcLinearSolver::kDenseQr)
      .value("DENSE_NORMAL_CHOLESKY", NmpcLinearSolver::kDenseNormalCholesky);
  py::enum_<NmpcTermination>(m, "NmpcTermination", "How an NMPC solve ended.")
      .value("NOT_RUN", NmpcTermination::kNotRun)
      .value("CONVERGED", NmpcTermination::kConverged)
      .value("ITERATION_CAP", NmpcTermination::kIterationCap,
             "Iteration cap or time budget; best iterate kept.")
      .value("FAILURE", NmpcTermination::kFailure,
             "Solver failure, non-finite plan or injected failure.");
  py::enum_<NmpcMode>(m, "NmpcMode", "What the NMPC flies.")
      .value("PLAN", NmpcMode::kPlan, "The plan of the latest solve.")
      .value("PREVIOUS_PLAN", NmpcMode::kPreviousPlan, "Fallback: the last good plan, shifted.")
      .value("SE3", NmpcMode::kSe3, "Fallback: SE(3) position control.");

  py::class_<NmpcOptions>(m, "NmpcOptions",
                          "NMPC settings (docs/controllers.md): horizon, Eq. 3.24 weights, bounds, "
                          "solver limits, inner SE(3) gains.")
      .def(py::init<>())
      .def_readwrite("horizon_steps", &NmpcOptions::horizon_steps, "N (thesis: 100).")
      .def_readwrite("step_s", &NmpcOptions::step_s, "Shooting interval and re-solve period, s.")
      .def_readwrite("input_blocks", &NmpcOptions::input_blocks, "Move-blocking lengths (steps).")
      .def_readwrite("state_weights", &NmpcOptions::state_weights, "diag(Q), 13 values (Eq. 3.24).")
      .def_readwrite("input_weights", &NmpcOptions::input_weights, "diag(R), 6 values (Eq. 3.24).")
      .def_readwrite("terminal_weight_scale", &NmpcOptions::terminal_weight_scale)
      .def_readwrite("tilt_penalty_weight", &NmpcOptions::tilt_penalty_weight)
      .def_readwrite("min_thrust_N", &NmpcOptions::min_thrust_N)
      .def_readwrite("max_thrust_N", &NmpcOptions::max_thrust_N)
      .def_readwrite("max_tilt_rad", &NmpcOptions::max_tilt_rad)
      .def_readwrite("max_moment_Nm", &NmpcOptions::max_moment_Nm)
      .def_readwrite("inner_feed_forward", &NmpcOptions::inner_feed_forward,
                     "Feed the plan's body rates and angular acceleration to the inner loop.")
      .def_readwrite("disturbance_gain", &NmpcOptions::disturbance_gain)
      .def_readwrite("max_disturbance_m_s2", &NmpcOptions::max_disturbance_m_s2)
      .def_readwrite("moment_observer_time_constant_s",
                     &NmpcOptions::moment_observer_time_constant_s)
      .def_readwrite("max_moment_disturbance_Nm", &NmpcOptions::max_moment_disturbance_Nm)
      .def_readwrite("max_iterations", &NmpcOptions::max_iterations)
      .def_readwrite("max_solve_time_s", &NmpcOptions::max_solve_time_s)
      .def_readwrite("function_tolerance", &NmpcOptions::function_tolerance)
      .def_readwrite("linear_solver", &NmpcOptions::linear_solver)
      .def_readwrite("se3", &NmpcOptions::se3)
      .def("validate", &NmpcOptions::validate, "ValueError naming a bad option.");

  py::class_<NmpcSolveStats>(m, "NmpcSolveStats", "Statistics of one NMPC solve.")
      .def_readonly("solve_index", &NmpcSolveStats::solve_index)
      .def_readonly("time_s", &NmpcSolveStats::time_s)
      .def_readonly("iterations", &NmpcSolveStats::iterations)
      .def_readonly("initial_cost", &NmpcSolveStats::initial_cost)
      .def_readonly("final_cost", &NmpcSolveStats::final_cost)
      .def_readonly("solve_time_s", &NmpcSolveStats::solve_time_s, "Wall clock (not reproducible).")
      .def_readonly("termination", &NmpcSolveStats::termination)
      .def_readonly("mode", &NmpcSolveStats::mode)
      .def_readonly("consecutive_failures", &NmpcSolveStats::consecutive_failures)
      .def_readonly("total_failures", &NmpcSolveStats::total_failures);

  py::class_<NmpcController, ControllerBase>(
      m, "NmpcController",
      "Outer-loop NMPC of the Eq. 3.23 model solved with Ceres every step_s, over an SE(3)\n"
      "attitude loop run at every call (docs/controllers.md). The plan of the latest solve is\n"
      "available for plotting: predicted_states() ((N+1) x 13) from plan_start_time_s().")
      .def(
          py::init([](const std::shared_ptr<VehicleModel>& model, const NmpcOptions& o, double rate,
                      AllocationMethod a) { return new NmpcController(model, o, rate, a); }),
          py::arg("model"), py::arg("options") = NmpcOptions{}, py::arg("call_rate_hz") = 1000.0,
          py::arg("allocation") = AllocationMethod::kExact,
          "`call_rate_hz`: the ClosedLoop's control rate (a whole multiple of 1 / step_s).")
      .def_property_readonly("options", [](const NmpcController& c) { return c.options(); })
      .def_property_readonly("calls_per_solve", &NmpcController::calls_per_solve)
      .def(
          "last_solve", [](const NmpcController& c) { return c.last_solve(); },
          "NmpcSolveStats of the most recent solve.")
      .def_property_readonly("mode", &NmpcController::mode)
      .def(
          "predicted_states",
          [](const NmpcController& c) { return Eigen::MatrixXd(c.predicted_states()); },
          "States x_0..x_N of the latest successful plan ((N+1) x 13; empty before one).")
      .def(
          "predicted_inputs",
          [](const NmpcController& c) { return Eigen::MatrixXd(c.predicted_inputs()); },
          "Inputs u_0..u_{N-1} ([F_W, M_B], N x 6).")
      .def_property_readonly("plan_start_time_s", &NmpcController::plan_start_time_s)
      .def_property_readonly("disturbance_estimate",
                             [](const NmpcController& c) { return Vec3(c.disturbance_estimate()); })
      .def_property_readonly("commanded_force",
                             [](const NmpcController& c) { return Vec3(c.commanded_force()); })
      .def_property_readonly(
          "moment_disturbance_estimate",
          [](const NmpcController& c) { return Vec3(c.moment_disturbance_estimate()); })
      .def("inject_solve_failures", &NmpcController::inject_solve_failures, py::arg("first"),
           py::arg("count"), "Testing hook: treat solves first..first+count-1 as failed.");

  py::class_<ClosedLoop>(
      m, "ClosedLoop",
      "Flies a controller on a simulator along a reference (thesis Eq. 3.11): the controller runs\n"
      "every 1/control_rate_hz on the measured state, its command is held in between.\n\n"
      "    loop = dronetwin.ClosedLoop(sim, controller, reference, control_rate_hz=500)\n"
      "    log = loop.record(10.0)        # numpy arrays: t, state, reference, u, ...\n\n"
      "The loop keeps the simulator, controller and reference alive.")
      .def(py::init<Simulator&, ControllerBase&, const Reference&, double>(), py::arg("sim"),
           py::arg("controller"), py::arg("reference"), py::arg("control_rate_hz"),
           py::keep_alive<1, 2>(), py::keep_alive<1, 3>(), py::keep_alive<1, 4>())
      .def("update", &ClosedLoop::update,
           "Runs the controller if this step is a control instant (idempotent). True if it ran.")
      .def("step", &ClosedLoop::step, "update(), one physics step, real-time pacing if enabled.")
      .def(
          "run",
          [](ClosedLoop& l, double duration_s) {
            InterruptibleRun signals;
            return l.run(duration_s, &signals);
          },
          py::arg("duration_s"), py::call_guard<py::gil_scoped_release>(),
          "Steps for duration_s of simulated time (GIL released; Python controllers retake it).\n"
          "A failing controller ends the run with status CONTROLLER_FAILED (failure_message).")
      .def_property_readonly("failure_message", &ClosedLoop::failure_message,
                             "Why the last run() or record() ended with CONTROLLER_FAILED.")
      .def(
          "record",
          [](ClosedLoop& loop, double duration_s, std::int64_t every) {
            return record(loop, duration_s, every);
          },
          py::arg("duration_s"), py::arg("every_n_steps") = 1,
          "Like run(), recording a row at the start and after every every_n_steps-th step:\n"
          "a dict of numpy arrays t (K,), state and measured_state (K, 13), rotor_speeds_rad_s\n"
          "and rotor_speed_reference_rad_s (K, N), reference (K, 4: x, y, z, yaw), u (K, 4: the\n"
          "generalized force of the command in effect), saturated (K,), plus status and\n"
          "failure_message and state_columns; diagnostics (K, D) with diagnostic_names for\n"
          "controllers that report them (an NMPC's solve statistics; Python controllers may\n"
          "implement diagnostic_names(self) and diagnostics(self)).")
      .def_property("real_time", &ClosedLoop::real_time, &ClosedLoop::set_real_time)
      .def_property_readonly("achieved_real_time_factor", &ClosedLoop::achieved_real_time_factor)
      .def_property_readonly("steps_per_control", &ClosedLoop::steps_per_control)
      .def_property_readonly("last_input", [](const ClosedLoop& l) { return l.last_input(); })
      .def_property_readonly("last_command",
                             [](const ClosedLoop& l) { return Vec4(l.last_command()); })
      .def_property_readonly("last_rotor_command",
                             [](const ClosedLoop& l) { return copy_of(l.last_rotor_command()); })
      .def_property_readonly("control_updates", &ClosedLoop::control_updates)
      .def_property_readonly("saturated_updates", &ClosedLoop::saturated_updates);

  m.def(
      "yaw_of",
      [](py::handle q) {
        const Vec4 qq = to_fixed<4>(q, "yaw_of: quaternion");
        return std::atan2(2.0 * (qq[0] * qq[3] + qq[1] * qq[2]),
                          1.0 - 2.0 * (qq[2] * qq[2] + qq[3] * qq[3]));
      },
      py::arg("q_wxyz"), "ZYX yaw (rad) of a quaternion [w, x, y, z] (atan2 form).");
}

}  // namespace dronetwin::python
