// Bindings of the simulation layer: run settings (SimConfig and its parts) and the Simulator.
//
// The simulator's state, measured state and rotor vectors are exposed as numpy views onto the C++
// memory (no copy; the view keeps the simulator alive). `state` and `rotor_speed_reference` are
// writable: writes act on the next step, like set_state / set_rotor_speed_reference without their
// checks (a non-finite value written there makes the next step fail with status NON_FINITE).

#include <pybind11/operators.h>

#include "bindings.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/sim/simulator.hpp"

namespace dronetwin::python {

namespace {

py::dict breakdown_dict(const WrenchBreakdown& b) {
  py::dict d;
  for (int k = 0; k < kNumTerms; ++k) {
    const Wrench<double>& w = b.terms[static_cast<std::size_t>(k)];
    Eigen::Matrix<double, 6, 1> fm;
    fm << w.force_B, w.moment_B;
    d[py::str(std::string(term_name(static_cast<Term>(k))))] = copy_of(fm);
  }
  const Wrench<double> t = b.total();
  Eigen::Matrix<double, 6, 1> fm;
  fm << t.force_B, t.moment_B;
  d["total"] = copy_of(fm);
  return d;
}

std::shared_ptr<const VehicleModel> const_model(const std::shared_ptr<VehicleModel>& m) {
  if (!m) throw py::value_error("model: expected a VehicleModel, got None");
  return m;
}

/// Simulator.step(n): chunks of steps with the GIL released, Ctrl-C checked between them (a
/// KeyboardInterrupt stops the loop after the current chunk; the simulator keeps every step taken).
StepResult step_interruptible(Simulator& s, std::int64_t n) {
  if (n < 0) throw py::value_error("Simulator.step(n): expected n >= 0, got " + std::to_string(n));
  const auto in_use = s.exclusive_use("Simulator.step");
  constexpr std::int64_t kChunk = 16384;  // ~4 ms of stepping between signal checks
  StepResult total;
  for (std::int64_t done = 0; done < n;) {
    const std::int64_t chunk = std::min(kChunk, n - done);
    StepResult r;
    {
      py::gil_scoped_release release;
      r = s.step(chunk);
    }
    total.steps_taken += r.steps_taken;
    done += chunk;
    if (!r.ok()) {
      total.status = r.status;
      break;
    }
    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
  }
  return total;
}

}  // namespace

void bind_sim(py::module_& m) {
  py::enum_<Integrator>(m, "Integrator", "Rigid-body integrator of the physics step.")
      .value("RK4", Integrator::kRk4, "Classic 4th-order Runge-Kutta (default).")
      .value("EULER", Integrator::kEuler, "Explicit Euler (1st order; for comparison).");

  py::enum_<StepStatus>(m, "StepStatus", "Outcome of a physics step.")
      .value("OK", StepStatus::kOk)
      .value("NON_FINITE", StepStatus::kNonFinite, "The integrated state had NaN or inf.")
      .value("DIVERGED", StepStatus::kDiverged,
             "Position, speed or rate beyond the divergence limits.")
      .value("INVALID_STATE", StepStatus::kInvalidState,
             "A state that cannot be integrated (a zero quaternion written into the view).")
      .value("INVALID_INPUT", StepStatus::kInvalidInput,
             "A batch lane's rotor-speed reference or wind was not finite.")
      .value("COLLIDED", StepStatus::kCollided,
             "The collision shape touched a gate's frame or an obstacle of the scene.")
      .value("CONTROLLER_FAILED", StepStatus::kControllerFailed,
             "The controller threw or returned non-finite output (ClosedLoop.failure_message).");

  py::enum_<Term>(m, "Term", "Force and moment terms of the model (wrench breakdown).")
      .value("THRUST", Term::kThrust)
      .value("YAW_REACTION", Term::kYawReaction)
      .value("ROTOR_DRAG", Term::kRotorDrag)
      .value("ROLLING_MOMENT", Term::kRollingMoment)
      .value("DRAG_MOMENT", Term::kDragMoment)
      .value("GROUND_EFFECT", Term::kGroundEffect)
      .value("GYROSCOPIC", Term::kGyroscopic)
      .value("BODY_DRAG", Term::kBodyDrag)
      .value("GRAVITY", Term::kGravity);

  py::class_<DisturbanceSwitches>(m, "DisturbanceSwitches",
                                  "Which disturbance terms apply (thrust, yaw reaction and gravity "
                                  "always do). Default: all on.")
      .def(py::init([](bool rotor_drag, bool rolling_moment, bool drag_moment, bool ground_effect,
                       bool gyroscopic, bool body_drag) {
             return DisturbanceSwitches{rotor_drag,    rolling_moment, drag_moment,
                                        ground_effect, gyroscopic,     body_drag};
           }),
           py::kw_only(), py::arg("rotor_drag") = true, py::arg("rolling_moment") = true,
           py::arg("drag_moment") = true, py::arg("ground_effect") = true,
           py::arg("gyroscopic") = true, py::arg("body_drag") = true)
      .def_static("none", &DisturbanceSwitches::none, "Every disturbance term off.")
      .def_readwrite("rotor_drag", &DisturbanceSwitches::rotor_drag)
      .def_readwrite("rolling_moment", &DisturbanceSwitches::rolling_moment)
      .def_readwrite("drag_moment", &DisturbanceSwitches::drag_moment)
      .def_readwrite("ground_effect", &DisturbanceSwitches::ground_effect)
      .def_readwrite("gyroscopic", &DisturbanceSwitches::gyroscopic)
      .def_readwrite("body_drag", &DisturbanceSwitches::body_drag)
      .def("__repr__", [](const DisturbanceSwitches& d) {
        const auto b = [](bool x) { return x ? std::string("True") : std::string("False"); };
        return "DisturbanceSwitches(rotor_drag=" + b(d.rotor_drag) +
               ", rolling_moment=" + b(d.rolling_moment) + ", drag_moment=" + b(d.drag_moment) +
               ", ground_effect=" + b(d.ground_effect) + ", gyroscopic=" + b(d.gyroscopic) +
               ", body_drag=" + b(d.body_drag) + ")";
      });

  py::class_<Environment>(m, "Environment", "Gravity and wind, world frame (z up).")
      .def(py::init<>())
      .def_readwrite("gravity_W_m_s2", &Environment::gravity_W_m_s2)
      .def_readwrite("wind_W_m_s", &Environment::wind_W_m_s);

  py::enum_<OuDrift>(m, "OuDrift", "Drift form of the Ornstein-Uhlenbeck noise.")
      .value("PER_SAMPLE", OuDrift::kPerSample, "-Theta Y per sample (thesis Eq. 3.5; default).")
      .value("CONTINUOUS", OuDrift::kContinuous, "-Theta Y dt (thesis Eq. 3.4, Euler-Maruyama).");

  py::class_<BlockCoefficients>(
      m, "BlockCoefficients",
      "One state block of Theta or Sigma: a on the diagonal plus b everywhere "
      "in the block (thesis Eq. 3.8-3.9).")
      .def(py::init([](double a, double b) {
             return BlockCoefficients{a, b};
           }),
           py::arg("a") = 0.0, py::arg("b") = 0.0)
      .def_readwrite("a", &BlockCoefficients::a)
      .def_readwrite("b", &BlockCoefficients::b);

  py::class_<OuParameters>(m, "OuParameters",
                           "Ornstein-Uhlenbeck noise parameters per state block (position, "
                           "velocity, quaternion, angular velocity).")
      .def(py::init<>())
      .def_static("thesis", &OuParameters::thesis, "Thesis Eq. 3.8-3.9.")
      .def_readwrite("theta", &OuParameters::theta)
      .def_readwrite("sigma", &OuParameters::sigma)
      .def_readwrite("drift", &OuParameters::drift);

  py::class_<NoiseConfig>(m, "NoiseConfig", "Measurement noise on the state and its derivative.")
      .def(py::init<>())
      .def_readwrite("enabled", &NoiseConfig::enabled)
      .def_readwrite("parameters", &NoiseConfig::parameters);

  py::class_<GroundConfig>(m, "GroundConfig", "Flat ground at z = 0.")
      .def(py::init<>())
      .def_readwrite("enabled", &GroundConfig::enabled)
      .def_readwrite("crash_speed_m_s", &GroundConfig::crash_speed_m_s)
      .def_readwrite("crash_tilt_rad", &GroundConfig::crash_tilt_rad)
      .def_readwrite("friction_coefficient", &GroundConfig::friction_coefficient,
                     "Coulomb friction of the landing gear (static = kinetic).");

  py::class_<DivergenceLimits>(m, "DivergenceLimits",
                               "A state beyond these bounds stops the run with status DIVERGED.")
      .def(py::init<>())
      .def_readwrite("max_position_m", &DivergenceLimits::max_position_m)
      .def_readwrite("max_speed_m_s", &DivergenceLimits::max_speed_m_s)
      .def_readwrite("max_angular_speed_rad_s", &DivergenceLimits::max_angular_speed_rad_s);

  py::class_<SimConfig>(
      m, "SimConfig",
      "Run settings of a Simulator (everything that is not the airframe).\n\n"
      "    cfg = dronetwin.SimConfig(dt_s=1e-3, seed=7, noise=True)\n"
      "    cfg.disturbances.ground_effect = False     # nested settings are edited in place")
      .def(py::init([](double dt_s, Integrator integrator, bool motor_dynamics, bool noise,
                       std::uint64_t seed) {
             SimConfig c;
             c.dt_s = dt_s;
             c.integrator = integrator;
             c.motor_dynamics = motor_dynamics;
             c.noise.enabled = noise;
             c.seed = seed;
             validate(c);
             return c;
           }),
           py::kw_only(), py::arg("dt_s") = 1.0e-3, py::arg("integrator") = Integrator::kRk4,
           py::arg("motor_dynamics") = true, py::arg("noise") = false, py::arg("seed") = 0,
           "Settings with the most used fields given by keyword; the rest at their defaults.")
      .def_readwrite("dt_s", &SimConfig::dt_s, "Physics step, s (thesis: 1 ms).")
      .def_readwrite("integrator", &SimConfig::integrator)
      .def_readwrite(
          "motor_dynamics", &SimConfig::motor_dynamics,
          "First-order motor lag (Eq. 2.43-2.45); off: speed = clamped reference at once.")
      .def_readwrite("disturbances", &SimConfig::disturbances)
      .def_readwrite("environment", &SimConfig::environment)
      .def_property(
          "faults", [](const SimConfig& c) { return fault_list_of(c.faults); },
          [](SimConfig& c, const std::vector<RotorFault>& f) { c.faults = fault_settings_of(f); },
          "Rotor faults (a list of RotorFault; assign a new list to change them).")
      .def_readwrite("battery", &SimConfig::battery,
                     "The battery (BatterySettings; off by default: an ideal supply).")
      .def_readwrite("payload", &SimConfig::payload,
                     "The slung payload (PayloadSettings; off by default).")
      .def_readwrite("wind", &SimConfig::wind,
                     "Shear, gusts and turbulence around environment.wind_W_m_s (WindSettings).")
      .def_readwrite("noise", &SimConfig::noise)
      .def_readwrite("ground", &SimConfig::ground)
      .def_readwrite("divergence", &SimConfig::divergence)
      .def_readwrite("seed", &SimConfig::seed, "Seed of the simulator's random stream (noise).")
      .def(
          "validate", [](const SimConfig& c) { validate(c); },
          "Raises ValueError naming the field when a setting is out of range.");

  py::class_<ContactState>(m, "ContactState", "Ground contact bookkeeping.")
      .def_readonly("in_contact", &ContactState::in_contact)
      .def_readonly("sliding", &ContactState::sliding)
      .def_readonly("crashed", &ContactState::crashed)
      .def_readonly("touchdowns", &ContactState::touchdowns)
      .def_readonly("last_touchdown_speed_m_s", &ContactState::last_touchdown_speed_m_s)
      .def_readonly("max_touchdown_speed_m_s", &ContactState::max_touchdown_speed_m_s);

  py::class_<StepResult>(m, "StepResult", "What step() did: a status and the steps taken.")
      .def_readonly("status", &StepResult::status)
      .def_readonly("steps_taken", &StepResult::steps_taken)
      .def_property_readonly("ok", &StepResult::ok)
      .def("__bool__", &StepResult::ok)
      .def("__repr__", [](const StepResult& r) {
        return "StepResult(status=" + std::string(status_name(r.status)) +
               ", steps_taken=" + std::to_string(r.steps_taken) + ")";
      });

  py::class_<Simulator>(
      m, "Simulator",
      "One vehicle, steppable on demand, deterministic (same seed and config: same run).\n\n"
      "    model = dronetwin.load_model('models/qdrone2.yaml')\n"
      "    sim = dronetwin.Simulator(model, dronetwin.SimConfig(seed=1))\n"
      "    sim.reset(dronetwin.Simulator.hover_state([0, 0, 1]), model.hover_speeds_rad_s())\n"
      "    sim.set_rotor_speed_reference(model.hover_speeds_rad_s())\n"
      "    sim.step(1000)                 # 1 s at 1 kHz; the GIL is released meanwhile\n"
      "    z = sim.state[2]               # `state` is a live view onto the C++ state\n\n"
      "State layout (thesis Eq. 2.20): [x, y, z, vx, vy, vz, qw, qx, qy, qz, wx, wy, wz]: world\n"
      "position and velocity (z up), q_WB, body rates. A step that would produce a non-finite or\n"
      "diverged state is not committed: step() returns a StepResult whose status says so, and\n"
      "further steps raise RuntimeError until reset().\n\n"
      "Copies (copy.copy / copy.deepcopy / copy()) are independent simulators sharing the model.")
      .def(py::init([](const std::shared_ptr<VehicleModel>& model, const SimConfig& config) {
             return Simulator(const_model(model), config);
           }),
           py::arg("model"), py::arg("config") = SimConfig{},
           "Starts at rest at the origin (on the ground) with the rotors stopped. ValueError for "
           "bad settings.")
      .def_static(
          "hover_state",
          [](py::handle position, double yaw) {
            return copy_of(
                Simulator::hover_state(to_fixed<3>(position, "hover_state: position"), yaw));
          },
          py::arg("position_m"), py::arg("yaw_rad") = 0.0,
          "A level state at rest at `position_m` with yaw `yaw_rad` (13 numbers).")
      .def_property_readonly(
          "model",
          [](const Simulator& s) { return std::const_pointer_cast<VehicleModel>(s.model_ptr()); })
      .def_property_readonly(
          "config", [](const Simulator& s) { return s.config(); }, "A copy of the run settings.")
      .def(
          "reset",
          [](Simulator& s, py::handle state, py::object rotor_speeds) {
            const StateVector x = to_fixed<kStateSize>(state, "reset: state");
            if (rotor_speeds.is_none()) {
              s.reset(x);
            } else {
              s.reset(x,
                      to_rotor_vector(rotor_speeds, s.model().num_rotors(), "reset: rotor_speeds"));
            }
          },
          py::arg("state"), py::arg("rotor_speeds_rad_s") = py::none(),
          "Restarts the run at time 0 with `state` and rotor speeds (default: stopped); the "
          "reference equals the speeds, noise is zeroed and the random stream reseeded.")
      .def("reseed", &Simulator::reseed, py::arg("seed"),
           "reset() with a new seed (kept in config).")
      .def(
          "set_state",
          [](Simulator& s, py::handle state) {
            s.set_state(to_fixed<kStateSize>(state, "set_state: state"));
          },
          py::arg("state"), "Overwrites the rigid-body state (checked; quaternion normalised).")
      .def(
          "set_rotor_speeds",
          [](Simulator& s, py::handle w) {
            s.set_rotor_speeds(to_rotor_vector(w, s.model().num_rotors(), "set_rotor_speeds"));
          },
          py::arg("speeds_rad_s"), "Overwrites the rotor speeds (clamped to the limits).")
      .def(
          "set_rotor_speed_reference",
          [](Simulator& s, py::handle w) {
            s.set_rotor_speed_reference(
                to_rotor_vector(w, s.model().num_rotors(), "set_rotor_speed_reference"));
          },
          py::arg("reference_rad_s"),
          "Rotor speed references, rad/s (float64 array of num_rotors numbers; ValueError for "
          "non-finite values or a wrong length, TypeError for another dtype).")
      .def(
          "set_generalized_force",
          [](Simulator& s, py::handle u, AllocationMethod allocation) {
            s.set_generalized_force(to_fixed<4>(u, "set_generalized_force"), allocation);
          },
          py::arg("u"), py::arg("allocation") = AllocationMethod::kExact,
          "Generalized force [T, tau_x, tau_y, tau_z] (N, N m), allocated with `allocation`\n"
          "(EXACT: thrust-first with saturation handling; THESIS: Eq. 2.31).")
      .def(
          "step",
          [](Simulator& s) {
            // The single step holds the simulator too: another Python thread in step(n) (GIL
            // released) or reset() then gets a RuntimeError instead of a mixed state.
            const auto in_use = s.exclusive_use("Simulator.step");
            return s.step();
          },
          "One physics step. Returns a StepResult (status OK, NON_FINITE or DIVERGED).")
      .def("step", &step_interruptible, py::arg("n"),
           "Up to n physics steps, stopping at the first failure; the GIL is released meanwhile.")
      .def_property_readonly("time_s", &Simulator::time_s)
      .def_property_readonly("step_count", &Simulator::step_count)
      .def_property_readonly(
          "state",
          [](py::object self) {
            Simulator& s = self.cast<Simulator&>();
            return view(s.mutable_data().state.data(), kStateSize, self, true);
          },
          "The true state, a writable float64 view (13,) onto the simulator's memory. Writes act "
          "on the next step (unchecked; measured_state catches up at the next step).")
      .def_property_readonly(
          "measured_state",
          [](py::object self) {
            const Simulator& s = self.cast<const Simulator&>();
            return view(s.measured_state().data(), kStateSize, self);
          },
          "state + OU noise (= state when noise is off), a read-only view (13,).")
      .def_property_readonly(
          "rotor_speeds_rad_s",
          [](py::object self) {
            const Simulator& s = self.cast<const Simulator&>();
            return view(s.rotor_speeds_rad_s().data(), s.model().num_rotors(), self);
          },
          "Achieved rotor speeds, a read-only view (num_rotors,).")
      .def_property_readonly(
          "rotor_speed_reference_rad_s",
          [](py::object self) {
            Simulator& s = self.cast<Simulator&>();
            return view(s.mutable_data().rotor_speed_reference_rad_s.data(), s.model().num_rotors(),
                        self, true);
          },
          "Rotor speed references, a writable view (num_rotors,): the zero-copy way to actuate.")
      .def(
          "state_derivative", [](const Simulator& s) { return copy_of(s.state_derivative()); },
          "f(state, rotor speeds) = [v_W, a_W, q_dot, w_dot_B] now (a new array).")
      .def(
          "measured_state_derivative",
          [](const Simulator& s) { return copy_of(s.measured_state_derivative()); },
          "state_derivative() + its own OU noise (a new array).")
      .def(
          "wrench_breakdown",
          [](const Simulator& s) { return breakdown_dict(s.wrench_breakdown()); },
          "Force and moment of each term now, body frame: {term: [Fx, Fy, Fz, Mx, My, Mz]} "
          "plus 'total'.")
      .def_property_readonly("contact", [](const Simulator& s) { return s.contact(); })
      .def_property_readonly("status", &Simulator::status)
      .def(
          "set_scene",
          [](Simulator& s, std::shared_ptr<Track> scene) {
            s.set_scene(std::shared_ptr<const Track>(std::move(scene)));
          },
          py::arg("scene"),
          "Gates and obstacles the vehicle may not touch (a Track, or None): a step into one is "
          "refused with status COLLIDED, failure_message naming the object.")
      .def_property_readonly("failure_message", &Simulator::failure_message)
      .def(
          "set_wind", [](Simulator& s, py::handle w) { s.set_wind(to_fixed<3>(w, "set_wind")); },
          py::arg("wind_W_m_s"),
          "Mean air velocity, world frame, m/s (at the shear's reference height when the wind is "
          "sheared), from the next step on.")
      .def(
          "set_interaction",
          [](Simulator& s, py::handle flow, py::handle wrench) {
            s.set_interaction(to_fixed<3>(flow, "set_interaction: flow_W_m_s"),
                              to_fixed<6>(wrench, "set_interaction: wrench_B"));
          },
          py::arg("flow_W_m_s"), py::arg("wrench_B"),
          "Other vehicles' influence from the next step on, until set again (reset clears it): "
          "an air velocity added to the wind (world frame, m/s) and a body wrench [F_B (N), "
          "M_B (N m)] added to the rotors' (downwash_effect computes both).")
      .def_property_readonly(
          "interaction",
          [](const Simulator& s) {
            return py::make_tuple(copy_of(s.data().interaction_flow_W_m_s),
                                  copy_of(s.data().interaction_wrench_B));
          },
          "(flow_W_m_s, wrench_B) now (copies), as set by set_interaction or a fleet.")
      .def(
          "set_faults",
          [](Simulator& s, const std::vector<RotorFault>& f) {
            s.set_faults(fault_settings_of(f));
          },
          py::arg("faults"),
          "Rotor faults (a list of RotorFault) from the next step on; those whose start has "
          "passed begin at once.")
      .def("set_battery", &Simulator::set_battery, py::arg("battery"),
           "The battery (BatterySettings) from the next step on; its state restarts at the "
           "pack's initial charge.")
      .def_property_readonly(
          "battery", [](const Simulator& s) { return s.battery(); },
          "The pack now (BatteryState, a copy): soc, voltage_V, current_A, depleted, ...")
      .def_property_readonly(
          "payload", [](const Simulator& s) { return s.payload(); },
          "The slung payload now (PayloadState, a copy).")
      .def("set_payload_state", &Simulator::set_payload_state, py::arg("payload"),
           "Places the payload (PayloadState): finite, within the tether length of the vehicle, "
           "not below the ground.")
      .def("payload_tension_N", &Simulator::payload_tension_N,
           "The cable's tension now, N (0 when slack or without a payload).")
      .def("swing_angles", &Simulator::swing_angles,
           "Eq. 3.33's swing angles and their rates now (SwingAngles).")
      .def("set_wind_field", &Simulator::set_wind_field, py::arg("wind"),
           "Shear, gusts and turbulence (WindSettings) from the next step on.")
      .def_property_readonly(
          "wind_W_m_s", [](const Simulator& s) { return copy_of(s.wind_W_m_s()); },
          "Air velocity at the vehicle now (mean, shear, gusts, turbulence), held over the next "
          "step, world frame, m/s.")
      .def("set_disturbances", &Simulator::set_disturbances, py::arg("switches"),
           "Switches disturbance terms on or off from the next step on (DisturbanceSwitches).")
      .def("set_noise_enabled", &Simulator::set_noise_enabled, py::arg("enabled"),
           "Turns the OU measurement noise on or off (measured_state is refreshed at once).")
      .def("refresh_measured_state", &Simulator::refresh_measured_state,
           "Recomputes measured_state after writing `state` directly.")
      .def(
          "copy", [](const Simulator& s) { return Simulator(s); },
          "An independent copy (same model, same data); step it anywhere.")
      .def("__copy__", [](const Simulator& s) { return Simulator(s); })
      .def(
          "__deepcopy__", [](const Simulator& s, py::dict) { return Simulator(s); },
          py::arg("memo"))
      .def("__repr__", [](const Simulator& s) {
        return "Simulator(model='" + s.model().name() + "', t=" + std::to_string(s.time_s()) +
               " s, status=" + std::string(status_name(s.status())) + ")";
      });
}

}  // namespace dronetwin::python
