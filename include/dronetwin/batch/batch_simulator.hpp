#pragma once
// BatchSimulator<T>: N vehicles of one airframe stepped together, for reinforcement learning,
// Monte-Carlo studies and sweeps. Every lane is the Simulator's vehicle (the same force kernel,
// integrator, motor lag and ground contact; in double a lane equals a Simulator run to round-off,
// tests/batch), with its own state, rotor speeds, wind and parameters.
//
//   auto model = std::make_shared<const VehicleModel>(load_vehicle_model("models/qdrone2.yaml"));
//   BatchSimulator<double> batch(model, SimConfig{}, 4096, /*num_threads=*/2);
//   batch.set_parameter(ModelParameter::kMass, 17, 1.6);      // lane 17 is heavier
//   for (int lane = 0; lane < batch.size(); ++lane)
//     batch.reset(lane, Simulator::hover_state({0, 0, 1}), model->hover_speeds_rad_s());
//   batch.step(1000);                                          // 1 s for every vehicle
//   double z = batch.state_at(state_index::kPosition + 2, 17);
//
// Layout: structure of arrays. Element k of lane l's state is state_data()[k * stride() + l],
// stride() >= size() a multiple of the pack width (padded: batch_stride()); rotor speeds,
// references and wind likewise.
// The arrays are plain memory the caller may read and write between steps (Python views them as
// (N, 13) arrays); a step checks what it reads and refuses a lane whose inputs are not valid.
//
// How a step runs: lanes are grouped in packs of kLanes (core/simd.hpp); the force kernel is
// instantiated on the pack, so one instruction steps kLanes vehicles, each with the parameters of
// its lane (ForceKernel<Pack<T, kLanes>>, one per pack, rebuilt when a parameter changes). Chunks
// of packs are spread over a persistent thread pool. Branches on the state become per-lane
// selects: motor rise/fall and clamping, the validity checks; ground contact takes the
// Simulator's own contact rule for the lanes that touch the ground (an exact per-lane path, rare
// in flight). step(n) keeps each pack in registers for all n steps. step(n, inner_loop) runs a
// batched controller (batch_se3.hpp, batch_pid.hpp, batch_body_rate.hpp) before every physics
// step, in the same loop.
//
// Per lane status: a lane whose step fails (non-finite, diverged, a zero quaternion, or invalid
// inputs written into the arrays) keeps its last good state, stops, and reports why in
// status(lane); the other lanes go on. reset(lane, ...) revives it. Nothing throws in the loop.
//
// Determinism: a lane's result depends only on its own inputs, never on N, its position in the
// batch, the pack width or the number of threads (tests/batch: bitwise across 1 and 2 threads and
// batch sizes 1, 7 and 1024).
//
// Noise (config.noise.enabled): each lane carries the Simulator's OU state noise (Eq. 3.5) and
// exposes state + noise as measured_state_data(). Its normals come from a counter-based stream
// (noise/counter_normal.hpp): draw j of the lane's step k is a function of (seed, lane, k, j)
// only, so it does not depend on N, threads or how steps are grouped into step(n) calls. The
// stream is not the Simulator's xoshiro stream: same process, different numbers. set_seed() gives
// a lane its own seed (a new episode); reset() restarts the lane's noise at zero and its stream
// at step 0, so a reset without a new seed replays the same noise, as Simulator::reset() does.
// The derivative noise (the Simulator's second OU process, on the measured state derivative) is
// advanced in the steps where an inner loop reads the derivative (draws 16-28 of the step).
//
// Wind: wind_data() holds each lane's wind, constant over a step. With a wind field
// (config.wind: shear, gusts, turbulence; dynamics/wind_field.hpp) it holds each lane's mean wind
// and every step flies in the Simulator's wind for the lane's height and time, computed lane by
// lane in double; each lane's turbulence has its own stream, seeded from (seed, lane) as
// turbulence_stream_seed(counter_stream_key(seed, lane)), restarted (developed) by reset() and
// set_seed(). A lane then equals a Simulator whose seed is counter_stream_key(seed, lane)
// (noise off). The field costs a per-lane scalar pass per step (docs/performance.md).
//
// Rotor faults (config.faults; faults/rotor_fault.hpp): every lane carries the config's faults on
// its own clock (from its reset), as a Simulator would: a lost-effectiveness fault swaps the
// lane's thrust polynomial in its pack's kernel (rebuilt at the step a lane's fault begins), a
// stop drives its rotor's reference to zero, a stuck motor holds its speed. In double a lane
// equals a Simulator with the same faults to round-off (tests/batch/batch_faults_test.cpp).
//
// Battery (config.battery; power/battery.hpp): every lane drains its own pack, full again at its
// reset. As in the Simulator, a step's current comes from the speeds the lane flew with, and the
// pack it leaves caps the speeds its motors head for next; lane by lane in double, with the
// lane's own rotors (its parameters and its lost-effectiveness faults). In double a lane equals a
// Simulator with the same pack to round-off (tests/batch/batch_battery_test.cpp).
//
// Trap: one BatchSimulator is stepped by one thread at a time (it says so, SimulationError, if
// two try); its own pool does the parallel work.

#include <cstdint>
#include <memory>
#include <vector>

#include "dronetwin/batch/thread_pool.hpp"
#include "dronetwin/core/simd.hpp"
#include "dronetwin/core/single_thread.hpp"
#include "dronetwin/dynamics/force_kernel.hpp"
#include "dronetwin/dynamics/ground.hpp"
#include "dronetwin/model/allocation.hpp"
#include "dronetwin/model/model_parameters.hpp"
#include "dronetwin/sim/simulator.hpp"

namespace dronetwin {

/// Lanes per pack: at least 4 doubles or 8 floats, wider where the build's registers are (8
/// doubles with AVX-512). Results do not depend on it.
template <class T>
inline constexpr int kBatchLanes = static_cast<int>(stdx::native_simd<T>::size() > 32 / sizeof(T)
                                                        ? stdx::native_simd<T>::size()
                                                        : 32 / sizeof(T));

/// Most vehicles one batch (and one batched controller) holds.
inline constexpr int kMaxBatchVehicles = 1 << 24;

/// Length of each per-lane array for `num_vehicles` lanes of T: an odd number of whole cache
/// lines (whole packs), so that the rows of one pack do not all fall in one L1 set
/// (docs/batch.md, "Layout"). Throws InvalidArgument naming `what` unless
/// 1 <= num_vehicles <= kMaxBatchVehicles.
template <class T>
int batch_stride(int num_vehicles, const char* what);

/// Memory for the batch's arrays, aligned for pack loads (64 bytes).
template <class T>
class AlignedArray {
 public:
  AlignedArray() = default;
  explicit AlignedArray(std::size_t n, T value = T(0));
  AlignedArray(const AlignedArray&) = delete;
  AlignedArray& operator=(const AlignedArray&) = delete;
  AlignedArray(AlignedArray&& o) noexcept : data_(o.data_), size_(o.size_) {
    o.data_ = nullptr;
    o.size_ = 0;
  }
  AlignedArray& operator=(AlignedArray&& o) noexcept;
  ~AlignedArray();
  T* data() { return data_; }
  const T* data() const { return data_; }
  std::size_t size() const { return size_; }
  T& operator[](std::size_t i) { return data_[i]; }
  const T& operator[](std::size_t i) const { return data_[i]; }

 private:
  T* data_ = nullptr;
  std::size_t size_ = 0;
};

/// A lane's wind for one step (BatchSimulator's wind field): the sheared mean, the air velocity
/// (mean, gusts, turbulence) and the Dryden scales at the lane's height.
struct LaneWind {
  Vec3 mean_W_m_s = Vec3::Zero();
  Vec3 wind_W_m_s = Vec3::Zero();
  DrydenScales scales;
};

/// An inner-loop controller the batch runs inside its step, once per physics step and pack, on
/// the lanes' measured states (state + noise): the SE(3) controller of batch/batch_se3.hpp, say.
/// It is called from the pool's threads, different packs at once, so it may write only its own
/// per-lane data for the lanes of `pack`.
template <class T>
class BatchInnerLoop {
 public:
  static constexpr int kLanes = kBatchLanes<T>;
  using Lanes = Pack<T, kLanes>;
  using Mask = typename Lanes::mask_type;
  virtual ~BatchInnerLoop() = default;
  /// Rotor-speed references for lanes pack * kLanes ... (pack + 1) * kLanes - 1 from their
  /// measured states (and, when uses_state_derivative(), their measured state derivatives;
  /// nullptr otherwise). A lane whose output is unusable (not finite) is set in `failed`; the
  /// batch then stops it with StepStatus::kControllerFailed. `running` marks the lanes that will
  /// step; only their references may change.
  virtual void references(int pack, const Mask& running, const StateVectorT<Lanes>& measured,
                          const StateVectorT<Lanes>* measured_derivative,
                          std::array<Lanes, kMaxRotors>& reference, Mask& failed) = 0;
  /// True when references() reads the measured state derivative (the batch then evaluates the
  /// force model once more per step, as ClosedLoop does for such a controller).
  virtual bool uses_state_derivative() const { return false; }
  /// Checked by BatchSimulator::step before it runs: the loop was built for this batch.
  virtual int size() const = 0;
  virtual int num_rotors() const = 0;
};

template <class T>
class BatchSimulator {
 public:
  static constexpr int kLanes = kBatchLanes<T>;
  using Lanes = Pack<T, kLanes>;

  /// `num_vehicles` lanes of `model` under `config` (as a Simulator's: dt, integrator, motor lag,
  /// disturbance switches, gravity, wind for every lane, ground, divergence limits), stepped by
  /// `num_threads` threads (the caller and num_threads - 1 workers). Every lane starts at rest on
  /// the ground at the origin, rotors stopped. Every lane's noise seed is config.seed. Throws
  /// InvalidArgument for a bad config or sizes.
  BatchSimulator(std::shared_ptr<const VehicleModel> model, SimConfig config, int num_vehicles,
                 int num_threads = 1);

  int size() const { return num_vehicles_; }
  /// Length of one element's array (size() rounded up to whole packs, then padded: batch_stride()):
  /// element k of lane l is at [k * stride() + l] of state_data() (and likewise for the rotor and
  /// wind arrays).
  int stride() const { return stride_; }
  int num_rotors() const { return model_->num_rotors(); }
  int num_threads() const { return pool_->num_threads(); }
  const VehicleModel& model() const { return *model_; }
  const SimConfig& config() const { return config_; }
  double dt_s() const { return config_.dt_s; }

  /// Steps every running lane `n` times (n >= 0). A lane that fails stops at its last good state
  /// (status(lane)); the others go on. Returns the number of lanes that are not ok afterwards.
  int step(std::int64_t n = 1);
  /// step(n) with `inner_loop` setting every running lane's rotor references from its measured
  /// state before each physics step (as ClosedLoop does at the physics rate). The references it
  /// writes stay in rotor_speed_reference_data() afterwards.
  int step(std::int64_t n, BatchInnerLoop<T>& inner_loop);

  /// Rotor references from generalized forces u = [T, tau_x, tau_y, tau_z] for every lane at
  /// once, through the nominal model's thrust-first allocation (model/allocation.hpp), each lane
  /// as set_generalized_force() would. `u` is structure of arrays: u[k * stride() + lane]. Lanes
  /// whose request the rotors could not meet (moments scaled or thrust clipped) are flagged in
  /// saturated_data(); a lane with a non-finite u is left unchanged and flagged 2.
  void set_generalized_forces(const T* u);
  const std::uint8_t* saturated_data() const { return saturated_.data(); }

  /// Puts lane `lane` at `state` (validated and normalised as Simulator::set_state) with rotor
  /// speeds and references `rotor_speeds_rad_s` (clamped; zero when omitted), contact and status
  /// cleared, its step count zero.
  void reset(int lane, const StateVector& state);
  void reset(int lane, const StateVector& state, const RotorVector& rotor_speeds_rad_s);

  StateVector state(int lane) const;
  /// state(lane) + its OU noise (equal to state(lane) when noise is off), as of the last step or
  /// reset.
  StateVector measured_state(int lane) const;
  /// Seed of lane `lane`'s noise stream (the key is mixed from the seed and the lane index). The
  /// stream's position is the lane's step count, so a new seed usually goes with a reset.
  void set_seed(int lane, std::uint64_t seed);
  std::uint64_t seed(int lane) const { return seed_[lane_index(lane)]; }
  bool noise_enabled() const { return config_.noise.enabled; }
  /// One state element of one lane, unchecked (for loops over lanes; state() checks the lane).
  T state_at(int element, int lane) const {
    return state_[static_cast<std::size_t>(element) * stride_ + lane];
  }
  RotorVector rotor_speeds(int lane) const;
  void set_rotor_speed_reference(int lane, const RotorVector& reference_rad_s);
  /// Rotor references from generalized forces u = [T, tau_x, tau_y, tau_z] through the nominal
  /// model's allocation (model/allocation.hpp).
  void set_generalized_force(int lane, const GeneralizedForce& u,
                             AllocationMethod method = AllocationMethod::kExact);
  /// The lane's mean wind (wind_data(); at the shear's reference height when config().wind
  /// shears it).
  void set_wind(int lane, const Vec3& wind_W_m_s);
  /// The air velocity at lane `lane`'s vehicle now (mean wind sheared, gusts, turbulence), held
  /// over its next step; its mean wind when config().wind does not vary.
  Vec3 air_velocity(int lane) const;

  /// Per-lane model parameters (names of model/model_parameters.hpp): a per-rotor coefficient is
  /// scaled in every rotor of the lane so that their mean becomes `value`, as `dronetwin fit`
  /// writes it. Throws InvalidArgument for a bad lane or a value that is not finite and positive
  /// where it must be (mass, inertia, time constants >= 0).
  void set_parameter(ModelParameter p, int lane, double value);
  double parameter(ModelParameter p, int lane) const;

  StepStatus status(int lane) const { return static_cast<StepStatus>(status_[lane_index(lane)]); }
  const std::uint8_t* status_data() const { return status_.data(); }
  std::int64_t step_count(int lane) const { return step_count_[lane_index(lane)]; }
  const std::int64_t* step_count_data() const { return step_count_.data(); }
  const ContactState& contact(int lane) const { return contact_[lane_index(lane)]; }
  /// The lane's pack (config().battery.enabled; otherwise a full pack that is never drawn).
  const BatteryState& battery(int lane) const { return battery_[lane_index(lane)]; }

  /// The arrays (structure of arrays, see the top of this file). Writable between steps.
  T* state_data() { return state_.data(); }
  const T* state_data() const { return state_.data(); }
  T* rotor_speed_data() { return rotor_speed_.data(); }
  T* rotor_speed_reference_data() { return rotor_reference_.data(); }
  T* wind_data() { return wind_.data(); }
  /// state + noise, same layout as state_data(); the state array itself when noise is off.
  const T* measured_state_data() const {
    return config_.noise.enabled ? measured_.data() : state_.data();
  }

  /// Changes the number of threads (rebuilds the pool; results are unchanged).
  void set_num_threads(int num_threads);
  /// The batch's threads, for work on its lanes between steps (an RL env's rewards and
  /// observations); not while a step runs.
  ThreadPool& thread_pool() { return *pool_; }

 private:
  std::size_t lane_index(int lane) const;
  void rebuild_pack(int pack);
  // Flattened (every call inlined): see the definition.
  // kExtras: noise or an inner loop may run. The plain instance (neither) keeps the physics
  // loop free of their state, which in one shared loop cost the open-loop step a third of its
  // speed (register pressure in the flattened loop).
  template <bool kExtras>
  DRONETWIN_FLATTEN void step_pack(int pack, std::int64_t n, BatchInnerLoop<T>* inner_loop);
  int run_steps(std::int64_t n, BatchInnerLoop<T>* inner_loop);
  void check_inputs(int pack);
  static std::uint64_t turbulence_seed(std::uint64_t seed, std::size_t lane);
  void restart_turbulence(std::size_t lane);
  LaneWind lane_wind(std::size_t lane, const Vec3& mean_W_m_s, double height_m,
                     std::int64_t step) const;

  std::shared_ptr<const VehicleModel> model_;
  SimConfig config_;
  ForceTerms terms_;
  int num_vehicles_ = 0;
  int num_packs_ = 0;
  int stride_ = 0;
  std::unique_ptr<ThreadPool> pool_;

  AlignedArray<T> state_, rotor_speed_, rotor_reference_, wind_;
  // OU state noise and state + noise (allocated when noise is on), per-lane stream keys.
  AlignedArray<T> noise_, measured_, derivative_noise_;
  AlignedArray<std::uint64_t> noise_key_;
  std::vector<std::uint64_t> seed_;
  std::vector<std::uint8_t> status_;
  std::vector<std::uint8_t> saturated_;
  std::vector<std::int64_t> step_count_;
  std::vector<ContactState> contact_;
  // Wind field (config().wind varies): each lane's Dryden filters and their stream.
  std::vector<DrydenState> turbulence_;
  std::vector<Random> turbulence_rng_;

  // Rotor faults: the lost-effectiveness faults in the order they begin (the Simulator's), and
  // per lane the faults acting on its last step, its kernel's effectiveness stage (how many of
  // `effectiveness_order_` it has), and each stuck rotor's held speed ([rotor * stride + lane]).
  std::array<int, kMaxRotorFaults> effectiveness_order_{};
  int num_effectiveness_ = 0;
  std::vector<std::uint32_t> fault_active_;
  std::vector<std::uint8_t> fault_stage_;
  AlignedArray<T> stuck_speed_;

  // Battery: each lane's pack, and (only with a battery) each lane's rotors as its kernel has
  // them, for the shaft power and the speed cap.
  std::vector<BatteryState> battery_;
  std::vector<VehicleModelTpl<double>> lane_model_;

  // Parameters: one value per parameter and lane; a pack whose lanes changed is rebuilt before
  // the next step.
  std::vector<double> parameters_;  // [parameter * stride + lane]
  std::array<double, kNumModelParameters> nominal_{};
  std::vector<ForceKernel<Lanes>> kernels_;
  struct MotorDecay {
    std::array<Lanes, kMaxRotors> rise{}, fall{};
  };
  std::vector<MotorDecay> decays_;
  std::vector<std::uint8_t> pack_dirty_;
  bool any_dirty_ = false;
  SingleThreadGuard guard_;
};

extern template class BatchSimulator<double>;
extern template class BatchSimulator<float>;

}  // namespace dronetwin
