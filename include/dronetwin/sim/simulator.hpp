#pragma once
// Simulator: one vehicle, steppable on demand, deterministic.
//
// It owns the run settings (SimConfig), the mutable data (SimData: rigid-body state, rotor speeds
// and references, time, noise processes, random streams, wind, contact) and shares the immutable
// VehicleModel. Copying a Simulator copies the data and shares the model: cheap, and copies can
// be stepped on different threads. Nothing in it is global.
//
//   auto model = std::make_shared<const VehicleModel>(load_vehicle_model("models/qdrone2.yaml"));
//   Simulator sim(model, SimConfig{});
//   sim.reset(Simulator::hover_state(Vec3(0, 0, 1)));
//   sim.set_rotor_speed_reference(model->hover_speeds_rad_s());   // actuate
//   for (int k = 0; k < 1000; ++k) sim.step();                    // 1 s at 1 kHz
//   StateVector x = sim.measured_state();                         // sense
//
// One physics step (thesis Alg. 1-2, notes #25): forces from the current rotor speeds, rigid
// body integrated over dt with the speeds held, quaternion renormalised, ground contact resolved,
// motors advanced toward the reference, noise advanced, divergence checked. A new reference
// therefore acts on the forces from the next step on.
//
// The forces come from the one force kernel (dynamics/force_kernel.hpp): its per-model constants
// are built when the simulator is (and when the switches change) and shared by its copies; each
// step prepares the rotor-speed dependent terms once and evaluates them at the RK4 stages.
//
// Threads: one simulator, one thread at a time (copies are independent and may run on separate
// threads). step(n), reset() and the setters detect a call from a second thread while another is
// running and throw SimulationError (Python RuntimeError) instead of mixing the two; the
// single-step step() notices another thread's step(n), run or reset (one relaxed load).
//
// Wind (docs/wind.md): the air velocity of a step is SimData::wind_W_m_s, held over the step:
// the mean wind of SimConfig::environment, sheared to the height at the step's start, plus the
// 1 - cos gusts at its start time, plus Dryden turbulence along the mean wind's axes. An accepted
// step advances the turbulence with the height and airspeed of its start, then the wind is
// recomputed for the next step.
//
// Faults (faults/rotor_fault.hpp): from its start a lost-effectiveness fault swaps in a force
// kernel with that rotor's thrust scaled (prebuilt, so the step does not allocate), a stopped
// rotor's reference becomes zero and a stuck rotor keeps its speed. The controller is not told.
//
// Battery (power/battery.hpp): an accepted step draws the current of its rotor speeds' shaft
// power from the pack; the pack it leaves caps the rotor speed references the motors head for
// next at w = K_V V(w), and a cut-off pack stops the motors.
//
// Payload (payload/slung_payload.hpp): the payload's position and velocity are integrated with
// the vehicle's state in the same RK4 step, the cable's tension coupling the two; after the step
// the cable is settled (length l kept, a slack cable jerking taut) and a payload reaching the
// ground stops on it. reset() hangs it at rest below the vehicle.
//
// Other vehicles (fleet/fleet.hpp): set_interaction() adds an air velocity to the wind and a
// wrench to the rotors', held over the following steps; a Fleet sets both from the others' wakes
// before every step.
//
// Scene: with set_scene() a step whose motion brings the model's collision shape into a gate's
// frame or an obstacle (world/collision.hpp) is refused like a diverged one, with status
// kCollided and a failure_message() naming the object.
//
// Trap: a step that produces a non-finite or out-of-bounds state commits nothing (state, rotor
// speeds, contact, noise and time stay as they were); the simulator enters the failed state
// (status() and failure_message() say why) and step() throws until reset().

#include <array>
#include <memory>
#include <string>
#include <string_view>

#include "dronetwin/core/single_thread.hpp"
#include "dronetwin/core/types.hpp"
#include "dronetwin/dynamics/force_kernel.hpp"
#include "dronetwin/dynamics/ground.hpp"
#include "dronetwin/dynamics/motor.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/model/allocation.hpp"
#include "dronetwin/model/vehicle_model.hpp"
#include "dronetwin/noise/ornstein_uhlenbeck.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/sim/sim_config.hpp"
#include "dronetwin/world/collision.hpp"
#include "dronetwin/world/track.hpp"

namespace dronetwin {

enum class StepStatus {
  kOk,
  kNonFinite,         ///< the integrated state had NaN or inf
  kDiverged,          ///< position, speed or angular speed beyond SimConfig::divergence
  kControllerFailed,  ///< the controller flying it threw or returned non-finite output
  kInvalidState,      ///< a state that cannot be integrated (a zero quaternion)
  kInvalidInput,      ///< a batch lane's rotor-speed reference or wind was not finite
  kCollided,          ///< the collision shape touched an object of the scene (set_scene)
};

constexpr std::string_view status_name(StepStatus s) {
  switch (s) {
    case StepStatus::kOk:
      return "ok";
    case StepStatus::kNonFinite:
      return "non_finite";
    case StepStatus::kDiverged:
      return "diverged";
    case StepStatus::kControllerFailed:
      return "controller_failed";
    case StepStatus::kInvalidState:
      return "invalid_state";
    case StepStatus::kInvalidInput:
      return "invalid_input";
    case StepStatus::kCollided:
      return "collided";
  }
  return "unknown";
}

/// Why a step was refused, as numbers (SimData stays plain data); Simulator::failure_message()
/// turns it into text.
struct StepFailure {
  /// Time and step number the refused step would have reached.
  double time_s = 0.0;
  std::int64_t step = 0;
  /// |p|, |v|, |w| of the refused state (NaN when it was non-finite).
  double position_m = 0.0, speed_m_s = 0.0, angular_speed_rad_s = 0.0;
  /// Position the refused step would have reached, m.
  Vec3 at_m = Vec3::Zero();
  /// True when the state before the step was already invalid (non-finite, or a quaternion far
  /// from unit): written directly through mutable_data() or a Python view, not produced by a step.
  bool started_invalid = false;
  /// What the collision shape touched (kCollided): Track::gates or Track::obstacles and index.
  SceneContact contact;
};

/// The seed of the turbulence's stream (SimData::turbulence_rng) for the run seed `seed`: the seed
/// with a fixed mask ("wind" in ASCII) flipped, a bijection, so that it never equals the noise
/// stream's seed of the same run.
constexpr std::uint64_t turbulence_stream_seed(std::uint64_t seed) {
  return seed ^ 0x77696e64'00000000ull;
}

/// Everything that changes while a simulator runs. Plain data: no heap, copyable as bytes.
struct SimData {
  double time_s = 0.0;
  std::int64_t step_count = 0;
  StateVector state = StateVector::Zero();
  /// state + state noise, kept current by every step, reset, set_state and set_noise_enabled
  /// (equal to state when noise is off). Stored, not computed, so bindings can view it.
  StateVector measured_state = StateVector::Zero();
  RotorVector rotor_speed_rad_s;
  RotorVector rotor_speed_reference_rad_s;
  OrnsteinUhlenbeck state_noise;
  OrnsteinUhlenbeck derivative_noise;
  Random rng;
  /// Air velocity at the vehicle, world frame, m/s, held over the next step: the mean wind
  /// (sheared at the current height) plus the gusts at time_s plus the turbulence; the mean wind
  /// itself when SimConfig::wind is off. Kept current like measured_state.
  Vec3 wind_W_m_s = Vec3::Zero();
  /// Dryden filters (unit-variance states), advanced on every accepted step while turbulence is
  /// on, and the scales at the current height. Their random stream is separate from `rng`, so
  /// switching turbulence on leaves the OU noise's samples as they were.
  DrydenState turbulence;
  DrydenScales turbulence_scales;
  Random turbulence_rng;
  /// Bit j set once rotor fault j of SimConfig::faults has begun; the speed a stuck rotor keeps.
  std::uint32_t active_faults = 0;
  std::array<double, kMaxRotors> stuck_speed_rad_s{};
  /// The pack (SimConfig::battery): charge, RC voltage, the current of the last step and the
  /// terminal voltage under it, which caps the rotor speeds of the next.
  BatteryState battery;
  /// The slung payload (SimConfig::payload; unused when it is off).
  PayloadState payload;
  /// What other vehicles do to this one (set_interaction; a Fleet's downwash): an air velocity
  /// added to the wind, world frame, m/s, and a body wrench [F_B; M_B] added to the rotors' held
  /// one, both held until set again; zero after reset.
  Vec3 interaction_flow_W_m_s = Vec3::Zero();
  Vector6<double> interaction_wrench_B = Vector6<double>::Zero();
  ContactState contact;
  StepStatus status = StepStatus::kOk;
  StepFailure failure;
};

struct StepResult {
  StepStatus status = StepStatus::kOk;
  /// Steps actually taken (fewer than asked when the run failed).
  std::int64_t steps_taken = 0;
  bool ok() const { return status == StepStatus::kOk; }
};

/// The force kernels of lost-effectiveness faults (defined in simulator.cpp).
struct FaultedForces;

class Simulator {
 public:
  /// Validates `config` (InvalidArgument on bad settings); starts at rest at the origin with the
  /// rotors stopped (z = 0: on the ground).
  Simulator(std::shared_ptr<const VehicleModel> model, SimConfig config = {});

  const VehicleModel& model() const { return *model_; }
  const std::shared_ptr<const VehicleModel>& model_ptr() const { return model_; }
  const SimConfig& config() const { return config_; }

  /// A level state at rest at `position_W` (yaw `yaw_rad`).
  static StateVector hover_state(const Vec3& position_W, double yaw_rad = 0.0);

  /// Restarts the run: time 0, given state and rotor speeds (default: stopped), reference equal to
  /// the speeds, noise processes zeroed, random stream reseeded with config().seed, contact and
  /// failure cleared. The quaternion is normalised. Throws InvalidArgument for non-finite values,
  /// a zero quaternion or a wrong rotor count.
  void reset(const StateVector& state);
  void reset(const StateVector& state, const RotorVector& rotor_speeds_rad_s);
  /// reset() with a new seed (the config keeps it).
  void reseed(std::uint64_t seed);

  /// Overwrites the rigid-body state mid-run (time, noise and rotor speeds kept).
  void set_state(const StateVector& state);
  /// Overwrites the rotor speeds mid-run (clamped to the limits).
  void set_rotor_speeds(const RotorVector& speeds_rad_s);

  // ---- actuate ------------------------------------------------------------------------------
  /// Rotor speed references, rad/s, one per rotor. Non-finite or wrong size: InvalidArgument.
  void set_rotor_speed_reference(const RotorVector& reference_rad_s);
  /// Generalized forces [T, tau_x, tau_y, tau_z], allocated to rotor speed references with
  /// `method` (model/allocation.hpp).
  void set_generalized_force(const GeneralizedForce& u,
                             AllocationMethod method = AllocationMethod::kExact);

  // ---- step ---------------------------------------------------------------------------------
  StepResult step();
  /// Up to n steps; stops early at the first failure.
  StepResult step(std::int64_t n);

  // ---- sense --------------------------------------------------------------------------------
  double time_s() const { return data_.time_s; }
  std::int64_t step_count() const { return data_.step_count; }
  const StateVector& state() const { return data_.state; }
  /// state() + OU noise (equals state() when noise is off), as of the last step, reset,
  /// set_state or set_noise_enabled. Writing SimData::state directly leaves it stale until then.
  const StateVector& measured_state() const { return data_.measured_state; }
  /// f(state, rotor speeds): [v_W, a_W, q_dot, w_dot_B] at the current instant.
  StateVector state_derivative() const;
  /// state_derivative() + an independent OU noise process.
  StateVector measured_state_derivative() const;
  const RotorVector& rotor_speeds_rad_s() const { return data_.rotor_speed_rad_s; }
  const RotorVector& rotor_speed_reference_rad_s() const {
    return data_.rotor_speed_reference_rad_s;
  }
  /// Force and moment of each term at the current state and rotor speeds.
  WrenchBreakdown wrench_breakdown() const;
  const ContactState& contact() const { return data_.contact; }
  StepStatus status() const { return data_.status; }
  /// Why the run failed ("state diverged at t = ...: |v| = ... (limit ...)"); empty while ok.
  std::string failure_message() const;
  const SimData& data() const { return data_; }
  /// Direct access for bindings that expose the state as a view; call set_state() semantics
  /// yourself (finite values, unit quaternion).
  SimData& mutable_data() { return data_; }

  // ---- run settings that may change mid-run -------------------------------------------------
  /// The mean wind (at the shear's reference height when sheared), from the next step on.
  void set_wind(const Vec3& wind_W_m_s);
  /// Shear, gusts and turbulence (validated as in validate(SimConfig)), from the next step on.
  /// The turbulence filters go on from their current state, which reset() draws developed.
  void set_wind_field(const WindSettings& wind);
  /// Rotor faults (validated as in the constructor), acting from the next step on: those whose
  /// start has passed begin at once (a stuck rotor keeps its speed then).
  void set_faults(const FaultSettings& faults);
  /// The battery (validated as in the constructor), from the next step on; the pack's state
  /// restarts at its initial charge.
  void set_battery(const BatterySettings& battery);
  const BatteryState& battery() const { return data_.battery; }
  /// The payload now (SimData::payload); meaningful when config().payload.enabled.
  const PayloadState& payload() const { return data_.payload; }
  /// Places the payload (validated: finite, within the tether length of the vehicle, not below
  /// the ground when it is on); taut when exactly at the tether's length.
  void set_payload_state(const PayloadState& payload);
  /// The cable's tension now, N (0 when slack or without a payload).
  double payload_tension_N() const;
  /// Eq. 3.33's swing angles and their rates now.
  SwingAngles swing_angles() const;
  /// The air velocity at the vehicle now (SimData::wind_W_m_s), world frame, m/s: the wind and
  /// the interaction's flow.
  const Vec3& wind_W_m_s() const { return data_.wind_W_m_s; }
  /// Other vehicles' influence from the next step on, until set again (reset() clears it): an
  /// air velocity added to the wind (world frame, m/s) and a body wrench [F_B (N); M_B (N m)]
  /// about the centre of mass added to the rotors' (dynamics/downwash.hpp computes both).
  /// InvalidArgument when not finite. Not in wrench_breakdown().
  void set_interaction(const Vec3& flow_W_m_s, const Vector6<double>& wrench_B);
  void set_disturbances(const DisturbanceSwitches& switches);
  void set_noise_enabled(bool enabled);
  /// Gates and obstacles the vehicle may not touch (null: none, the default). Kept over reset();
  /// copies of the simulator share it.
  void set_scene(std::shared_ptr<const Track> scene);
  const Track* scene() const { return scene_.get(); }
  /// Recomputes measured_state() from SimData::state and the noise (for code that wrote the state
  /// through mutable_data()).
  void refresh_measured_state();

  // ---- threads -----------------------------------------------------------------------------
  /// Marks the simulator in use by this thread for the returned object's lifetime (a loop that
  /// steps it many times takes it once). Throws SimulationError when another thread uses it.
  [[nodiscard]] SingleThreadGuard::Hold exclusive_use(const char* what) const {
    return SingleThreadGuard::Hold(guard_, what);
  }

 private:
  void check_rotor_vector(const RotorVector& v, const char* what) const;
  StepStatus check_state(const StateVector& x) const;
  StepResult step_unchecked();
  void update_measured_state();
  void update_wind();
  /// kernel.prepare() for the current rotor speeds, plus the interaction's wrench.
  void prepare_held(const ForceKernel<double>& kernel, HeldRotorTerms<double>& held) const;
  void build_fault_forces();
  /// One RK4 step of the vehicle and the payload together (SimConfig::payload on): the vehicle's
  /// next state; the payload's next state in `payload`.
  StateVector step_with_payload(PayloadState& payload);
  /// The cable's coupling at the current state for the mode a step starting now would hold
  /// (lift-off of a resting payload decided here too: `payload` is updated).
  CableCoupling payload_coupling_now(const ForceKernel<double>& kernel,
                                     const HeldRotorTerms<double>& held, PayloadState& payload,
                                     bool& pulling) const;
  /// How many lost-effectiveness faults act at `time_s`; the force kernel and model for them (the
  /// nominal ones without).
  std::size_t effectiveness_stage(double time_s) const;
  const ForceKernel<double>& active_kernel(double time_s) const;
  const VehicleModelTpl<double>& active_model(double time_s) const;

  std::shared_ptr<const VehicleModel> model_;
  SimConfig config_;
  MotorDiscretization motors_;
  /// The force kernel for the model and config().disturbances (shared by copies).
  std::shared_ptr<const ForceKernel<double>> kernel_;
  /// With lost-effectiveness faults: the kernels and models as they take effect (shared by
  /// copies; built with kernel_).
  std::shared_ptr<const FaultedForces> faulted_;
  /// Scratch of the current step (the rotor-speed dependent terms); not state.
  HeldRotorTerms<double> held_;
  std::shared_ptr<const Track> scene_;
  SimData data_;
  SingleThreadGuard guard_;
};

}  // namespace dronetwin
