#include "dronetwin/batch/batch_simulator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>

#include "dronetwin/batch/lane_allocation.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/motor.hpp"
#include "dronetwin/model/allocation.hpp"
#include "dronetwin/noise/counter_normal.hpp"
#include "dronetwin/sim/state_checks.hpp"

namespace dronetwin {

// ---- AlignedArray ----------------------------------------------------------------------------

template <class T>
AlignedArray<T>::AlignedArray(std::size_t n, T value) : size_(n) {
  constexpr std::size_t kAlign = 64;
  const std::size_t bytes = ((n * sizeof(T) + kAlign - 1) / kAlign) * kAlign;
  data_ = static_cast<T*>(std::aligned_alloc(kAlign, bytes == 0 ? kAlign : bytes));
  if (data_ == nullptr) throw std::bad_alloc();
  for (std::size_t i = 0; i < n; ++i) data_[i] = value;
}

template <class T>
AlignedArray<T>& AlignedArray<T>::operator=(AlignedArray&& o) noexcept {
  if (this != &o) {
    std::free(data_);
    data_ = std::exchange(o.data_, nullptr);
    size_ = std::exchange(o.size_, 0);
  }
  return *this;
}

template <class T>
AlignedArray<T>::~AlignedArray() {
  std::free(data_);
}

// ---- construction and per-lane access --------------------------------------------------------

template <class T>
int batch_stride(int num_vehicles, const char* what) {
  require(num_vehicles >= 1 && num_vehicles <= kMaxBatchVehicles, what,
          ": num_vehicles: expected 1 to ", kMaxBatchVehicles, ", got ", num_vehicles);
  // Whole cache lines, and an odd number of them. The L1 set of an address is its bits 6-11 (64
  // sets of 64-byte lines: a 4096-byte period), so with rows of a power-of-two size (1024 floats
  // are 4096 bytes) element k of a pack sits in the same set for every k: the ~24 rows a pack
  // reads and writes compete for one set's 8-12 ways and evict each other, in every call. Rows of
  // an odd number of lines put consecutive rows in different sets. At most two lines a row.
  constexpr int kLineBytes = 64;
  static_assert(kLineBytes % (kBatchLanes<T> * static_cast<int>(sizeof(T))) == 0,
                "a pack must divide a cache line");
  constexpr int kPerLine = kLineBytes / static_cast<int>(sizeof(T));
  const int lines = (num_vehicles + kPerLine - 1) / kPerLine;
  return (lines % 2 == 0 ? lines + 1 : lines) * kPerLine;
}
template int batch_stride<double>(int, const char*);
template int batch_stride<float>(int, const char*);

namespace {

/// Pack P from lanes base .. base + W of an array (the arrays are padded to whole packs).
template <class P, class T>
DRONETWIN_HOT_INLINE P load(const T* a) {
  return P(a, stdx::vector_aligned);
}
template <class P, class T>
DRONETWIN_HOT_INLINE void store(const P& p, T* a) {
  p.copy_to(a, stdx::vector_aligned);
}

/// The parameters of W lanes, one value per lane, as one model of packs. Geometry, spins and
/// speed limits are the airframe's and shared (lane 0's, the same in every lane).
template <class P, std::size_t W>
VehicleModelTpl<P> zip_lanes(const std::array<VehicleParametersTpl<double>, W>& lanes) {
  VehicleParametersTpl<P> q;
  using V = typename P::value_type;
  const VehicleParametersTpl<double>& first = lanes[0];
  auto pack = [&](auto field) { return pack_from<P>([&](int l) { return field(lanes[l]); }); };
  q.num_rotors = first.num_rotors;
  for (std::size_t i = 0; i < kMaxRotors; ++i) {
    RotorParamsTpl<P>& r = q.rotors[i];
    const RotorParams& r0 = first.rotors[i];
    r.position_m = r0.position_m.template cast<V>();
    r.axis = r0.axis.template cast<V>();
    r.spin = r0.spin;
    r.min_speed_rad_s = static_cast<V>(r0.min_speed_rad_s);
    r.max_speed_rad_s = static_cast<V>(r0.max_speed_rad_s);
    for (std::size_t k = 0; k < 3; ++k)
      r.thrust_coefficients[k] =
          pack([&](const auto& p) { return p.rotors[i].thrust_coefficients[k]; });
    r.yaw_moment_per_thrust_m =
        pack([&](const auto& p) { return p.rotors[i].yaw_moment_per_thrust_m; });
    r.rotor_drag_coefficient =
        pack([&](const auto& p) { return p.rotors[i].rotor_drag_coefficient; });
    r.rolling_moment_coefficient =
        pack([&](const auto& p) { return p.rotors[i].rolling_moment_coefficient; });
    r.drag_moment_coefficient =
        pack([&](const auto& p) { return p.rotors[i].drag_moment_coefficient; });
    r.ground_effect_coefficient =
        pack([&](const auto& p) { return p.rotors[i].ground_effect_coefficient; });
    r.inertia_kgm2 = pack([&](const auto& p) { return p.rotors[i].inertia_kgm2; });
    r.time_constant_rise_s = pack([&](const auto& p) { return p.rotors[i].time_constant_rise_s; });
    r.time_constant_fall_s = pack([&](const auto& p) { return p.rotors[i].time_constant_fall_s; });
  }
  q.mass_kg = pack([](const auto& p) { return p.mass_kg; });
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      q.inertia_kgm2(a, b) = pack([&](const auto& p) { return p.inertia_kgm2(a, b); });
      q.body_drag_Ns_per_m(a, b) = pack([&](const auto& p) { return p.body_drag_Ns_per_m(a, b); });
    }
  }
  q.ground_effect_min_height_m = static_cast<V>(first.ground_effect_min_height_m);
  return VehicleModelTpl<P>(std::move(q));
}

bool must_be_positive(ModelParameter p) {
  return p == ModelParameter::kMass || p == ModelParameter::kInertiaXX ||
         p == ModelParameter::kInertiaYY || p == ModelParameter::kInertiaZZ;
}

}  // namespace

template <class T>
BatchSimulator<T>::BatchSimulator(std::shared_ptr<const VehicleModel> model, SimConfig config,
                                  int num_vehicles, int num_threads)
    : model_(std::move(model)), config_(std::move(config)) {
  require(model_ != nullptr, "BatchSimulator: model is null");
  validate(config_);
  require(!config_.payload.enabled,
          "BatchSimulator: the slung payload (the config's `payload:`) is flown by Simulator "
          "only; set payload.enabled = false");
  stride_ = batch_stride<T>(num_vehicles, "BatchSimulator");
  terms_ = ForceTerms::of(config_.disturbances);
  num_vehicles_ = num_vehicles;
  num_packs_ = (num_vehicles + kLanes - 1) / kLanes;  // the lanes' packs, not the padding's
  pool_ = std::make_unique<ThreadPool>(num_threads);

  const auto n = static_cast<std::size_t>(stride_);
  state_ = AlignedArray<T>(n * kStateSize);
  rotor_speed_ = AlignedArray<T>(n * kMaxRotors);
  rotor_reference_ = AlignedArray<T>(n * kMaxRotors);
  wind_ = AlignedArray<T>(n * 3);
  status_.assign(n, static_cast<std::uint8_t>(StepStatus::kOk));
  saturated_.assign(n, 0);
  step_count_.assign(n, 0);
  contact_.assign(n, ContactState{});
  for (std::size_t l = 0; l < n; ++l) {
    for (int k = 0; k < 3; ++k)
      wind_[k * n + l] = static_cast<T>(config_.environment.wind_W_m_s[k]);
  }
  seed_.assign(n, config_.seed);
  noise_key_ = AlignedArray<std::uint64_t>(n);
  for (std::size_t l = 0; l < n; ++l) noise_key_[l] = counter_stream_key(config_.seed, l);
  if (config_.wind.varies()) {
    turbulence_.resize(n);
    turbulence_rng_.resize(n);
    for (std::size_t l = 0; l < n; ++l) restart_turbulence(l);
  }
  fault_active_.assign(n, 0);
  fault_stage_.assign(n, 0);
  battery_.assign(n, battery_start(config_.battery.pack));
  if (config_.battery.enabled) lane_model_.assign(n, VehicleModelTpl<double>(model_->parameters()));
  if (config_.faults.any()) {
    validate_fault_rotors(config_.faults, model_->num_rotors(), model_->name(), "BatchSimulator: ");
    stuck_speed_ = AlignedArray<T>(n * kMaxRotors);
    num_effectiveness_ = config_.faults.effectiveness_order(effectiveness_order_);
  }
  if (config_.noise.enabled) {
    noise_ = AlignedArray<T>(n * kStateSize);
    measured_ = AlignedArray<T>(n * kStateSize);
    derivative_noise_ = AlignedArray<T>(n * kStateSize);
  }

  for (int p = 0; p < kNumModelParameters; ++p)
    nominal_[static_cast<std::size_t>(p)] =
        parameter_value(model_->parameters(), static_cast<ModelParameter>(p));
  parameters_.resize(static_cast<std::size_t>(kNumModelParameters) * n);
  for (int p = 0; p < kNumModelParameters; ++p)
    for (std::size_t l = 0; l < n; ++l)
      parameters_[static_cast<std::size_t>(p) * n + l] = nominal_[static_cast<std::size_t>(p)];

  kernels_.reserve(static_cast<std::size_t>(num_packs_));
  decays_.resize(static_cast<std::size_t>(num_packs_));
  pack_dirty_.assign(static_cast<std::size_t>(num_packs_), 0);
  const ForceKernel<Lanes> nominal_kernel(model_->template cast<Lanes>(), terms_);
  for (int c = 0; c < num_packs_; ++c) {
    kernels_.push_back(nominal_kernel);
    rebuild_pack(c);
  }
  // Padding lanes (beyond size()) hover-free at rest like the others and never report.
  for (int lane = 0; lane < stride_; ++lane) {
    const std::size_t l = static_cast<std::size_t>(lane);
    state_[static_cast<std::size_t>(state_index::kQuaternion) * n + l] = T(1);
    contact_[l].in_contact = config_.ground.enabled;
  }
  if (config_.noise.enabled)
    for (std::size_t i = 0; i < n * kStateSize; ++i) measured_[i] = state_[i];
}

template <class T>
std::uint64_t BatchSimulator<T>::turbulence_seed(std::uint64_t seed, std::size_t lane) {
  return turbulence_stream_seed(counter_stream_key(seed, lane));
}

template <class T>
void BatchSimulator<T>::restart_turbulence(std::size_t l) {
  if (turbulence_.empty()) return;
  turbulence_rng_[l].reseed(turbulence_seed(seed_[l], l));
  turbulence_[l] = dryden_start(turbulence_rng_[l]);
}

template <class T>
LaneWind BatchSimulator<T>::lane_wind(std::size_t l, const Vec3& mean_W_m_s, double height_m,
                                      std::int64_t step) const {
  // As Simulator::update_wind, for the lane's mean wind, height, time and turbulence state.
  const WindSettings& w = config_.wind;
  LaneWind out;
  out.mean_W_m_s = mean_wind_at(mean_W_m_s, w.shear, height_m);
  out.wind_W_m_s = out.mean_W_m_s + gust_at(w, static_cast<double>(step) * config_.dt_s);
  if (w.turbulence.enabled) {
    out.scales = dryden_low_altitude(height_m, w.turbulence.wind_at_20ft_m_s);
    out.wind_W_m_s += turbulence_axes(out.mean_W_m_s) * dryden_gust(turbulence_[l], out.scales);
  }
  return out;
}

template <class T>
Vec3 BatchSimulator<T>::air_velocity(int lane) const {
  const std::size_t l = lane_index(lane);
  const auto n = static_cast<std::size_t>(stride_);
  Vec3 mean;
  for (int k = 0; k < 3; ++k)
    mean[k] = static_cast<double>(wind_[static_cast<std::size_t>(k) * n + l]);
  const double h =
      static_cast<double>(state_[static_cast<std::size_t>(state_index::kPosition + 2) * n + l]);
  if (!config_.wind.varies() || !std::isfinite(h) || !mean.allFinite()) return mean;
  return lane_wind(l, mean, h, step_count_[l]).wind_W_m_s;
}

template <class T>
std::size_t BatchSimulator<T>::lane_index(int lane) const {
  require(lane >= 0 && lane < num_vehicles_, "BatchSimulator: lane ", lane,
          " is out of range (the batch has ", num_vehicles_, " vehicles)");
  return static_cast<std::size_t>(lane);
}

template <class T>
void BatchSimulator<T>::set_num_threads(int num_threads) {
  const SingleThreadGuard::Hold hold(guard_, "BatchSimulator::set_num_threads");
  pool_ = std::make_unique<ThreadPool>(num_threads);
}

template <class T>
void BatchSimulator<T>::rebuild_pack(int pack) {
  std::array<VehicleParametersTpl<double>, kLanes> lanes;
  const auto n = static_cast<std::size_t>(stride_);
  for (int l = 0; l < kLanes; ++l) {
    VehicleParametersTpl<double>& q = lanes[static_cast<std::size_t>(l)];
    q = model_->parameters();
    const std::size_t lane = static_cast<std::size_t>(pack * kLanes + l);
    for (int p = 0; p < kNumModelParameters; ++p) {
      const double v = parameters_[static_cast<std::size_t>(p) * n + lane];
      // Only changed values are written: rescaling rotors to an unchanged mean could move them by
      // a rounding step, and an untouched lane must be exactly the nominal vehicle.
      if (v != nominal_[static_cast<std::size_t>(p)])
        set_parameter_value(q, static_cast<ModelParameter>(p), v);
    }
    // The lost-effectiveness faults acting on the lane, scaled in the Simulator's order.
    for (std::size_t k = 0; k < fault_stage_[lane]; ++k) {
      const RotorFault& f = config_.faults.rotor[static_cast<std::size_t>(effectiveness_order_[k])];
      for (double& c : q.rotors[static_cast<std::size_t>(f.rotor)].thrust_coefficients)
        c *= f.effectiveness;
    }
    if (!lane_model_.empty()) lane_model_[lane] = VehicleModelTpl<double>(q);
  }
  kernels_[static_cast<std::size_t>(pack)] = ForceKernel<Lanes>(zip_lanes<Lanes>(lanes), terms_);
  MotorDecay& d = decays_[static_cast<std::size_t>(pack)];
  for (int i = 0; i < model_->num_rotors(); ++i) {
    const auto r = static_cast<std::size_t>(i);
    // In double, as the Simulator's discretize_motors(), then rounded to T.
    d.rise[r] = pack_from<Lanes>([&](int l) {
      return motor_decay(lanes[static_cast<std::size_t>(l)].rotors[r].time_constant_rise_s,
                         config_.dt_s);
    });
    d.fall[r] = pack_from<Lanes>([&](int l) {
      return motor_decay(lanes[static_cast<std::size_t>(l)].rotors[r].time_constant_fall_s,
                         config_.dt_s);
    });
  }
  pack_dirty_[static_cast<std::size_t>(pack)] = 0;
}

template <class T>
void BatchSimulator<T>::set_parameter(ModelParameter p, int lane, double value) {
  const SingleThreadGuard::Hold hold(guard_, "BatchSimulator::set_parameter");
  const std::size_t l = lane_index(lane);
  require(std::isfinite(value), "BatchSimulator::set_parameter: ", parameter_name(p), "[lane ",
          lane, "]: expected a finite number, got ", value);
  if (must_be_positive(p)) {
    require(value > 0.0, "BatchSimulator::set_parameter: ", parameter_name(p), "[lane ", lane,
            "]: expected > 0, got ", value);
  }
  if (is_motor_parameter(p)) {
    require(value >= 0.0, "BatchSimulator::set_parameter: ", parameter_name(p), "[lane ", lane,
            "]: expected >= 0 s, got ", value);
  }
  double& slot = parameters_[static_cast<std::size_t>(p) * static_cast<std::size_t>(stride_) + l];
  if (slot == value) return;
  slot = value;
  pack_dirty_[l / kLanes] = 1;
  any_dirty_ = true;
}

template <class T>
double BatchSimulator<T>::parameter(ModelParameter p, int lane) const {
  return parameters_[static_cast<std::size_t>(p) * static_cast<std::size_t>(stride_) +
                     lane_index(lane)];
}

template <class T>
void BatchSimulator<T>::reset(int lane, const StateVector& state) {
  reset(lane, state, RotorVector::Zero(model_->num_rotors()));
}

template <class T>
void BatchSimulator<T>::reset(int lane, const StateVector& state,
                              const RotorVector& rotor_speeds_rad_s) {
  const SingleThreadGuard::Hold hold(guard_, "BatchSimulator::reset");
  const std::size_t l = lane_index(lane);
  require(rotor_speeds_rad_s.size() == model_->num_rotors(), "BatchSimulator::reset: lane ", lane,
          ": rotor speeds: expected ", model_->num_rotors(), " values, got ",
          rotor_speeds_rad_s.size());
  require_start_state(state, config_.ground.enabled, "BatchSimulator::reset: ", lane);
  for (Eigen::Index i = 0; i < rotor_speeds_rad_s.size(); ++i)
    require(std::isfinite(rotor_speeds_rad_s[i]), "BatchSimulator::reset: lane ", lane,
            ": rotor speeds[", i, "]: expected a finite number, got ", rotor_speeds_rad_s[i]);
  StateVector x = state;
  normalize_quaternion(x);
  const auto n = static_cast<std::size_t>(stride_);
  for (int k = 0; k < kStateSize; ++k)
    state_[static_cast<std::size_t>(k) * n + l] = static_cast<T>(x[k]);
  for (int i = 0; i < model_->num_rotors(); ++i) {
    const double w = clamp_speed(model_->rotor(i), rotor_speeds_rad_s[i]);
    rotor_speed_[static_cast<std::size_t>(i) * n + l] = static_cast<T>(w);
    rotor_reference_[static_cast<std::size_t>(i) * n + l] = static_cast<T>(w);
  }
  contact_[l] = ContactState{};
  contact_[l].in_contact = config_.ground.enabled && x[state_index::kPosition + 2] <= 0.0;
  if (config_.noise.enabled) {
    for (int k = 0; k < kStateSize; ++k) {
      noise_[static_cast<std::size_t>(k) * n + l] = T(0);
      derivative_noise_[static_cast<std::size_t>(k) * n + l] = T(0);
      measured_[static_cast<std::size_t>(k) * n + l] = state_[static_cast<std::size_t>(k) * n + l];
    }
  }
  status_[l] = static_cast<std::uint8_t>(StepStatus::kOk);
  step_count_[l] = 0;
  restart_turbulence(l);
  battery_[l] = battery_start(config_.battery.pack);  // a full pack
  // The faults begin again on the lane's new clock.
  fault_active_[l] = 0;
  if (fault_stage_[l] != 0) {
    fault_stage_[l] = 0;
    pack_dirty_[l / static_cast<std::size_t>(kLanes)] = 1;
    any_dirty_ = true;
  }
}

template <class T>
StateVector BatchSimulator<T>::state(int lane) const {
  const std::size_t l = lane_index(lane);
  StateVector x;
  for (int k = 0; k < kStateSize; ++k)
    x[k] = static_cast<double>(
        state_[static_cast<std::size_t>(k) * static_cast<std::size_t>(stride_) + l]);
  return x;
}

template <class T>
StateVector BatchSimulator<T>::measured_state(int lane) const {
  const std::size_t l = lane_index(lane);
  const T* m = measured_state_data();
  StateVector x;
  for (int k = 0; k < kStateSize; ++k)
    x[k] =
        static_cast<double>(m[static_cast<std::size_t>(k) * static_cast<std::size_t>(stride_) + l]);
  return x;
}

template <class T>
void BatchSimulator<T>::set_seed(int lane, std::uint64_t seed) {
  const SingleThreadGuard::Hold hold(guard_, "BatchSimulator::set_seed");
  const std::size_t l = lane_index(lane);
  seed_[l] = seed;
  noise_key_[l] = counter_stream_key(seed, l);
  restart_turbulence(l);
}

template <class T>
RotorVector BatchSimulator<T>::rotor_speeds(int lane) const {
  const std::size_t l = lane_index(lane);
  RotorVector w(model_->num_rotors());
  for (int i = 0; i < model_->num_rotors(); ++i)
    w[i] = static_cast<double>(
        rotor_speed_[static_cast<std::size_t>(i) * static_cast<std::size_t>(stride_) + l]);
  return w;
}

template <class T>
void BatchSimulator<T>::set_rotor_speed_reference(int lane, const RotorVector& reference_rad_s) {
  const SingleThreadGuard::Hold hold(guard_, "BatchSimulator::set_rotor_speed_reference");
  const std::size_t l = lane_index(lane);
  require(reference_rad_s.size() == model_->num_rotors(),
          "BatchSimulator::set_rotor_speed_reference: lane ", lane, ": expected ",
          model_->num_rotors(), " values, got ", reference_rad_s.size());
  for (int i = 0; i < model_->num_rotors(); ++i) {
    require(std::isfinite(reference_rad_s[i]), "BatchSimulator::set_rotor_speed_reference: lane ",
            lane, ": reference[", i, "]: expected a finite number, got ", reference_rad_s[i]);
    rotor_reference_[static_cast<std::size_t>(i) * static_cast<std::size_t>(stride_) + l] =
        static_cast<T>(reference_rad_s[i]);
  }
}

template <class T>
void BatchSimulator<T>::set_generalized_force(int lane, const GeneralizedForce& u,
                                              AllocationMethod method) {
  for (int i = 0; i < 4; ++i)
    require(std::isfinite(u[i]), "BatchSimulator::set_generalized_force: lane ", lane,
            ": [T, tau_x, tau_y, tau_z][", i, "]: expected a finite number, got ", u[i]);
  set_rotor_speed_reference(lane, allocate(*model_, u, method).speeds_rad_s);
}

template <class T>
void BatchSimulator<T>::set_wind(int lane, const Vec3& wind_W_m_s) {
  const SingleThreadGuard::Hold hold(guard_, "BatchSimulator::set_wind");
  const std::size_t l = lane_index(lane);
  require(wind_W_m_s.allFinite(), "BatchSimulator::set_wind: lane ", lane,
          ": expected finite numbers, got [", wind_W_m_s.transpose(), "]");
  for (int k = 0; k < 3; ++k)
    wind_[static_cast<std::size_t>(k) * static_cast<std::size_t>(stride_) + l] =
        static_cast<T>(wind_W_m_s[k]);
}

// ---- stepping --------------------------------------------------------------------------------

template <class T>
int BatchSimulator<T>::step(std::int64_t n) {
  const SingleThreadGuard::Hold hold(guard_, "BatchSimulator::step");
  return run_steps(n, nullptr);
}

template <class T>
int BatchSimulator<T>::step(std::int64_t n, BatchInnerLoop<T>& inner_loop) {
  const SingleThreadGuard::Hold hold(guard_, "BatchSimulator::step");
  require(inner_loop.size() == num_vehicles_, "BatchSimulator::step: the inner loop is for ",
          inner_loop.size(), " vehicles, the batch has ", num_vehicles_);
  require(inner_loop.num_rotors() == model_->num_rotors(),
          "BatchSimulator::step: the inner loop is for ", inner_loop.num_rotors(),
          " rotors, the batch's model has ", model_->num_rotors());
  return run_steps(n, &inner_loop);
}

template <class T>
int BatchSimulator<T>::run_steps(std::int64_t n, BatchInnerLoop<T>* inner_loop) {
  require(n >= 0, "BatchSimulator::step(n): expected n >= 0, got ", n);
  if (any_dirty_) {
    for (int c = 0; c < num_packs_; ++c)
      if (pack_dirty_[static_cast<std::size_t>(c)] != 0) rebuild_pack(c);
    any_dirty_ = false;
  }
  if (n > 0) {
    // Tasks of a few packs each: enough of them to balance two threads, few enough to keep the
    // hand-out cheap.
    constexpr int kPacksPerTask = 4;
    const int tasks = (num_packs_ + kPacksPerTask - 1) / kPacksPerTask;
    const bool extras = inner_loop != nullptr || config_.noise.enabled || config_.wind.varies() ||
                        config_.faults.any() || config_.battery.enabled;
    pool_->run(tasks, [this, n, inner_loop, extras](int task) {
      const int end = std::min(num_packs_, (task + 1) * kPacksPerTask);
      for (int c = task * kPacksPerTask; c < end; ++c) {
        if (extras)
          step_pack<true>(c, n, inner_loop);
        else
          step_pack<false>(c, n, inner_loop);
      }
    });
  }
  int failed = 0;
  for (int l = 0; l < num_vehicles_; ++l)
    failed += status_[static_cast<std::size_t>(l)] != static_cast<std::uint8_t>(StepStatus::kOk);
  return failed;
}

template <class T>
void BatchSimulator<T>::set_generalized_forces(const T* u) {
  const SingleThreadGuard::Hold hold(guard_, "BatchSimulator::set_generalized_forces");
  require(u != nullptr, "BatchSimulator::set_generalized_forces: u is null");
  using P = Lanes;
  const std::size_t stride = static_cast<std::size_t>(stride_);
  const int nr = model_->num_rotors();
  for (int pack = 0; pack < num_packs_; ++pack) {
    const std::size_t base = static_cast<std::size_t>(pack) * kLanes;
    // Unaligned loads: u is the caller's array.
    Vector4<P> request;
    for (int k = 0; k < 4; ++k) request[k] = P(u + k * stride + base, stdx::element_aligned);
    std::array<P, kMaxRotors> reference{};
    for (int i = 0; i < nr; ++i)
      reference[static_cast<std::size_t>(i)] = load<P>(&rotor_reference_[i * stride + base]);
    typename P::mask_type not_finite;
    allocate_lanes(*model_, request, typename P::mask_type(true), reference, not_finite,
                   &saturated_[base]);
    for (int i = 0; i < nr; ++i)
      store(reference[static_cast<std::size_t>(i)], &rotor_reference_[i * stride + base]);
    for (int l = 0; l < kLanes; ++l)
      if (not_finite[l]) saturated_[base + l] = 2;
  }
}

namespace {

/// Why a lane's step failed, as the Simulator says it (sim/state_checks.hpp). The pack's check
/// already failed the lane; a float lane whose state passes once widened to double still
/// failed in its own precision, and is reported as diverged.
StepStatus classify_failure(const StateVector& x, const DivergenceLimits& limits) {
  const StepStatus s = classify_state(x, limits);
  return s == StepStatus::kOk ? StepStatus::kDiverged : s;
}

template <class P>
StateVector lane_state(const StateVectorT<P>& x, int l) {
  StateVector out;
  for (int k = 0; k < kStateSize; ++k) out[k] = static_cast<double>(lane(x[k], l));
  return out;
}

}  // namespace

// One pack of lanes, n steps, from the arrays and back. Flattened: GCC then inlines the whole
// kernel (Eigen's loops over packs and the pack operators) instead of calling out per operation,
// which is what makes the pack kernel faster than the scalar one (docs/batch.md).
template <class T>
template <bool kExtras>
DRONETWIN_FLATTEN void BatchSimulator<T>::step_pack(int pack, std::int64_t n,
                                                    BatchInnerLoop<T>* inner_loop) {
  using P = Lanes;
  using M = typename P::mask_type;
  using namespace state_index;
  const std::size_t stride = static_cast<std::size_t>(stride_);
  const std::size_t base = static_cast<std::size_t>(pack) * kLanes;
  const int nr = model_->num_rotors();
  const ForceKernel<P>& kernel = kernels_[static_cast<std::size_t>(pack)];
  const MotorDecay& decay = decays_[static_cast<std::size_t>(pack)];

  StateVectorT<P> x;
  for (int k = 0; k < kStateSize; ++k) x[k] = load<P>(&state_[k * stride + base]);
  std::array<P, kMaxRotors> speed{}, reference{};
  for (int i = 0; i < nr; ++i) {
    speed[static_cast<std::size_t>(i)] = load<P>(&rotor_speed_[i * stride + base]);
    reference[static_cast<std::size_t>(i)] = load<P>(&rotor_reference_[i * stride + base]);
  }
  Vector3<P> wind;
  for (int k = 0; k < 3; ++k) wind[k] = load<P>(&wind_[k * stride + base]);
  // With a wind field the array holds each lane's mean wind; `wind` becomes the air velocity of
  // each step.
  const bool wind_field = kExtras && config_.wind.varies();
  const Vector3<P> mean_wind = wind;
  std::array<LaneWind, kLanes> lane_winds{};

  // Which lanes run: ok so far, inside the batch, with valid inputs. A lane whose inputs were
  // written invalid (through the arrays) stops here with a status and is not stepped.
  // Lane flags as masks (a mask has no generator constructor; a pack of 0/1 does).
  const auto mask_of = [&](auto&& flag) {
    return P([&](auto l) { return flag(base + l) ? T(1) : T(0); }) == P(T(1));
  };
  M running = mask_of([&](std::size_t l) {
    return l < static_cast<std::size_t>(num_vehicles_) &&
           status_[l] == static_cast<std::uint8_t>(StepStatus::kOk);
  });
  {
    M state_ok = M(true), input_ok = M(true);
    for (int k = 0; k < kStateSize; ++k) state_ok = state_ok && finite_lanes(x[k]);
    const P q2 = x[kQuaternion] * x[kQuaternion] + x[kQuaternion + 1] * x[kQuaternion + 1] +
                 x[kQuaternion + 2] * x[kQuaternion + 2] + x[kQuaternion + 3] * x[kQuaternion + 3];
    state_ok = state_ok && q2 >= P(T(0.25)) && q2 <= P(T(4));
    for (int i = 0; i < nr; ++i) {
      input_ok = input_ok && finite_lanes(reference[static_cast<std::size_t>(i)]) &&
                 finite_lanes(speed[static_cast<std::size_t>(i)]);
    }
    for (int k = 0; k < 3; ++k) input_ok = input_ok && finite_lanes(wind[k]);
    const M refused = running && !(state_ok && input_ok);
    if (stdx::any_of(refused)) {
      for (int l = 0; l < kLanes; ++l) {
        if (!refused[l]) continue;
        status_[base + l] = static_cast<std::uint8_t>(state_ok[l] ? StepStatus::kInvalidInput
                                                                  : StepStatus::kInvalidState);
      }
      running = running && !refused;
    }
  }

  const Vector3<T> gravity = config_.environment.gravity_W_m_s2.template cast<T>();
  const DivergenceLimits& lim = config_.divergence;
  const P max_p2(static_cast<T>(lim.max_position_m * lim.max_position_m));
  const P max_v2(static_cast<T>(lim.max_speed_m_s * lim.max_speed_m_s));
  const P max_w2(static_cast<T>(lim.max_angular_speed_rad_s * lim.max_angular_speed_rad_s));
  const bool ground = config_.ground.enabled;
  M in_contact = mask_of([&](std::size_t l) { return contact_[l].in_contact; });
  // Steps each lane takes: n, or up to its failure.
  std::array<std::int64_t, kLanes> taken{};
  for (int l = 0; l < kLanes; ++l) taken[static_cast<std::size_t>(l)] = running[l] ? n : 0;
  std::array<ContactState, kLanes> contact_after{};

  // OU state noise (Eq. 3.5) on a counter-based stream per lane: draw j of the lane's step k is
  // counter_normal(key, k * kCounterDrawsPerStep + j), whatever the pack, thread or call.
  using U = Pack<std::uint64_t, kLanes>;
  const bool noise = kExtras && config_.noise.enabled;
  StateVectorT<P> y;
  U key(0), first_draw(0);
  struct BlockPacks {
    P theta_a, theta_b, sigma_a, sigma_b;
  };
  std::array<BlockPacks, 4> blocks{};
  P drift_scale(T(0)), sqrt_dt(T(0));
  if (noise) {
    for (int k = 0; k < kStateSize; ++k) y[k] = load<P>(&noise_[k * stride + base]);
    key = U(&noise_key_[base], stdx::vector_aligned);
    first_draw = U([&](auto l) {
      return static_cast<std::uint64_t>(step_count_[base + l]) * kCounterDrawsPerStep;
    });
    const OuParameters& ou = config_.noise.parameters;
    for (std::size_t b = 0; b < 4; ++b)
      blocks[b] = {P(static_cast<T>(ou.theta[b].a)), P(static_cast<T>(ou.theta[b].b)),
                   P(static_cast<T>(ou.sigma[b].a)), P(static_cast<T>(ou.sigma[b].b))};
    // As OrnsteinUhlenbeck's constructor: sqrt(dt) and the drift scale in double, then T.
    drift_scale = P(static_cast<T>(ou.drift == OuDrift::kPerSample ? 1.0 : config_.dt_s));
    sqrt_dt = P(static_cast<T>(std::sqrt(config_.dt_s)));
  }
  // Advances an OU process of the committed lanes by one step, with draws offset .. offset + 12
  // of the lanes' step s.
  const auto advance_noise = [&](StateVectorT<P>& process, std::int64_t s, std::uint64_t offset,
                                 const M& commit) {
    std::array<Pack<double, kLanes>, kStateSize> normals;
    counter_normals_pack<kLanes, kStateSize>(
        key, first_draw + U(static_cast<std::uint64_t>(s) * kCounterDrawsPerStep + offset),
        normals);
    std::array<P, kStateSize> xi;
    for (std::size_t j = 0; j < kStateSize; ++j) xi[j] = stdx::static_simd_cast<P>(normals[j]);
    StateVectorT<P> next = process;
    for (std::size_t b = 0; b < 4; ++b) {
      const BlockPacks& c = blocks[b];
      const int o = kOuBlockOffset[b];
      P* yb = next.data() + o;
      const P* xb = xi.data() + o;
      if (kOuBlockSize[b] == 4)
        ou_update_block<4>(yb, xb, c.theta_a, c.theta_b, c.sigma_a, c.sigma_b, drift_scale,
                           sqrt_dt);
      else
        ou_update_block<3>(yb, xb, c.theta_a, c.theta_b, c.sigma_a, c.sigma_b, drift_scale,
                           sqrt_dt);
    }
    for (int k = 0; k < kStateSize; ++k) stdx::where(commit, process[k]) = next[k];
  };
  // The measured state derivative, for an inner loop that reads it (and its own OU process).
  const bool wants_derivative =
      kExtras && inner_loop != nullptr && inner_loop->uses_state_derivative();
  StateVectorT<P> yd;
  if (noise && wants_derivative)
    for (int k = 0; k < kStateSize; ++k) yd[k] = load<P>(&derivative_noise_[k * stride + base]);

  // Rotor faults: the faults acting on each lane's step (its own clock), as
  // FaultSettings::active_at(time of the step's start).
  const FaultSettings& faults = config_.faults;
  const bool has_faults = kExtras && faults.any();
  const bool battery = kExtras && config_.battery.enabled;
  std::array<std::uint32_t, kLanes> active{};

  for (std::int64_t s = 0; s < n; ++s) {
    if (stdx::none_of(running)) break;
    if (has_faults) {
      bool restage = false;
      for (int l = 0; l < kLanes; ++l) {
        if (!running[l]) continue;
        const auto li = static_cast<std::size_t>(l);
        const double t = static_cast<double>(step_count_[base + li] + s) * config_.dt_s;
        active[li] = faults.active_at(t, config_.dt_s);
        // Those acting are a prefix of the start order (Simulator::effectiveness_stage).
        std::uint8_t stage = 0;
        for (int k = 0; k < num_effectiveness_; ++k)
          stage = static_cast<std::uint8_t>(
              stage + ((active[li] >> effectiveness_order_[static_cast<std::size_t>(k)]) & 1u));
        if (stage != fault_stage_[base + li]) {
          fault_stage_[base + li] = stage;
          restage = true;
        }
      }
      // In place: `kernel` refers to this pack's entry; no other thread touches the pack.
      if (restage) rebuild_pack(pack);
    }
    // Wind field: each running lane's air velocity for this step (the inner loop's state
    // derivative included) from its mean wind (the wind array), height, time and turbulence,
    // lane by lane in double (Simulator::update_wind).
    if (wind_field) {
      for (int l = 0; l < kLanes; ++l) {
        if (!running[l]) continue;
        const auto li = static_cast<std::size_t>(l);
        const Vec3 mean(static_cast<double>(mean_wind[0][l]), static_cast<double>(mean_wind[1][l]),
                        static_cast<double>(mean_wind[2][l]));
        lane_winds[li] = lane_wind(base + li, mean, static_cast<double>(x[kPosition + 2][l]),
                                   step_count_[base + li] + s);
        for (int k = 0; k < 3; ++k) wind[k][l] = static_cast<T>(lane_winds[li].wind_W_m_s[k]);
      }
    }
    if (kExtras && inner_loop != nullptr) {
      // The controller sees what a sensor would: state + noise (ClosedLoop's measured_state()).
      StateVectorT<P> measured = x;
      if (noise)
        for (int k = 0; k < kStateSize; ++k) measured[k] = x[k] + y[k];
      StateVectorT<P> derivative;
      if (wants_derivative) {
        // As Simulator::measured_state_derivative(): f(x) at the current rotor speeds + noise.
        HeldRotorTerms<P> held;
        kernel.prepare(speed, held);
        derivative = kernel.derivative(held, x, wind, gravity);
        if (noise)
          for (int k = 0; k < kStateSize; ++k) derivative[k] = derivative[k] + yd[k];
      }
      M controller_failed(false);
      inner_loop->references(pack, running, measured, wants_derivative ? &derivative : nullptr,
                             reference, controller_failed);
      controller_failed = controller_failed && running;
      if (stdx::any_of(controller_failed)) {
        for (int l = 0; l < kLanes; ++l) {
          if (!controller_failed[l]) continue;
          status_[base + l] = static_cast<std::uint8_t>(StepStatus::kControllerFailed);
          taken[static_cast<std::size_t>(l)] = s;
        }
        running = running && !controller_failed;
        if (stdx::none_of(running)) break;
      }
    }
    StateVectorT<P> next =
        held_rotor_step(kernel, config_.integrator, x, speed, wind, gravity, config_.dt_s);
    // Ground contact: the Simulator's rule, lane by lane, for lanes touching the ground or
    // leaving it (rare in flight; the test is two compares per lane).
    M contact_changed = M(false);
    if (ground) {
      const P& z = next[kPosition + 2];
      const P& vz = next[kVelocity + 2];
      const M touching = z < P(T(0)) || (z == P(T(0)) && vz <= P(T(0)));
      contact_changed = running && (touching || in_contact);
      if (stdx::any_of(contact_changed)) {
        for (int l = 0; l < kLanes; ++l) {
          if (!contact_changed[l]) continue;
          const StateVector before = lane_state(x, l);
          StateVector after = lane_state(next, l);
          ContactState c = contact_[base + l];
          resolve_ground_contact(config_.ground, before, config_.dt_s, after, c);
          for (int k = 0; k < kStateSize; ++k) next[k][l] = static_cast<T>(after[k]);
          contact_after[static_cast<std::size_t>(l)] = c;
        }
      }
    }
    // Validity, as Simulator::check_state: squared norms against squared limits.
    const P p2 = next[0] * next[0] + next[1] * next[1] + next[2] * next[2];
    const P v2 = next[3] * next[3] + next[4] * next[4] + next[5] * next[5];
    const P q2 = next[6] * next[6] + next[7] * next[7] + next[8] * next[8] + next[9] * next[9];
    const P w2 = next[10] * next[10] + next[11] * next[11] + next[12] * next[12];
    const M ok = p2 <= max_p2 && v2 <= max_v2 && w2 <= max_w2 && q2 <= P(T(4)) && q2 >= P(T(0.25));
    const M commit = running && ok;
    const M failed = running && !ok;
    // Turbulence of the committed lanes, with the height (in the scales) and airspeed of the
    // step's start, as the Simulator advances it.
    if (wind_field && config_.wind.turbulence.enabled) {
      for (int l = 0; l < kLanes; ++l) {
        if (!commit[l]) continue;
        const auto li = static_cast<std::size_t>(l);
        const Vec3 v(static_cast<double>(x[kVelocity][l]), static_cast<double>(x[kVelocity + 1][l]),
                     static_cast<double>(x[kVelocity + 2][l]));
        (void)dryden_step(turbulence_[base + li], lane_winds[li].scales,
                          (v - lane_winds[li].mean_W_m_s).norm(), config_.dt_s,
                          turbulence_rng_[base + li]);
      }
    }
    if (stdx::any_of(failed)) {
      for (int l = 0; l < kLanes; ++l) {
        if (!failed[l]) continue;
        status_[base + l] =
            static_cast<std::uint8_t>(classify_failure(lane_state(next, l), config_.divergence));
        taken[static_cast<std::size_t>(l)] = s;
      }
    }
    for (int k = 0; k < kStateSize; ++k) stdx::where(commit, x[k]) = next[k];
    if (stdx::any_of(contact_changed)) {
      for (int l = 0; l < kLanes; ++l) {
        if (!contact_changed[l] || !commit[l]) continue;
        contact_[base + l] = contact_after[static_cast<std::size_t>(l)];
        in_contact[l] = contact_[base + l].in_contact;
      }
    }
    // Motor faults, per rotor: lanes whose rotor is stopped (reference zero) or stuck (speed
    // held at what it was when the fault began, recorded at that step, whose forces used it).
    std::array<M, kMaxRotors> stopped{}, stuck{};
    if (has_faults) {
      for (int j = 0; j < faults.num_rotor_faults; ++j) {
        const RotorFault& f = faults.rotor[static_cast<std::size_t>(j)];
        if (f.kind == RotorFaultKind::kEffectiveness) continue;
        const auto r = static_cast<std::size_t>(f.rotor);
        const M on =
            commit && mask_of([&](std::size_t l) { return ((active[l - base] >> j) & 1u) != 0; });
        if (f.kind == RotorFaultKind::kStop) {
          stopped[r] = stopped[r] || on;
          continue;
        }
        stuck[r] = stuck[r] || on;
        for (int l = 0; l < kLanes; ++l)
          if (on[l] && ((fault_active_[base + l] >> j) & 1u) == 0)
            stuck_speed_[r * stride + base + l] = speed[r][l];
      }
    }
    // Battery: each committed lane's pack is drawn by the speeds the step flew with, then caps
    // the references (stopped rotors' at zero), lane by lane in double as Simulator::step.
    P cap(std::numeric_limits<T>::max());
    if (battery) {
      const BatteryPack& bp = config_.battery.pack;
      for (int l = 0; l < kLanes; ++l) {
        if (!commit[l]) continue;
        const std::size_t lane = base + static_cast<std::size_t>(l);
        RotorVector flown(nr), target(nr);
        for (int i = 0; i < nr; ++i) {
          const auto r = static_cast<std::size_t>(i);
          flown[i] = static_cast<double>(speed[r][l]);
          target[i] = has_faults && stopped[r][l] ? 0.0 : static_cast<double>(reference[r][l]);
        }
        const VehicleModelTpl<double>& lm = lane_model_[lane];
        BatteryState& b = battery_[lane];
        advance_battery(bp, config_.dt_s,
                        battery_current_A(bp, b, rotor_shaft_power_W(lm, flown) / bp.efficiency),
                        b);
        cap[l] = static_cast<T>(battery_speed_cap_rad_s(lm, bp, b, target));
      }
    }
    // Motors (Eq. 2.45), after the step as in the Simulator.
    for (int i = 0; i < nr; ++i) {
      const auto r = static_cast<std::size_t>(i);
      const RotorParams& rotor = model_->rotor(i);
      P target = reference[r];
      if (has_faults) stdx::where(stopped[r], target) = P(T(0));
      if (battery) stdx::where(cap < target, target) = cap;
      const P ref = scalar::clamp(target, P(static_cast<T>(rotor.min_speed_rad_s)),
                                  P(static_cast<T>(rotor.max_speed_rad_s)));
      const P w = config_.motor_dynamics
                      ? motor_speed_after(decay.rise[r], decay.fall[r], ref, speed[r])
                      : ref;
      stdx::where(commit, speed[r]) = w;
      if (has_faults && stdx::any_of(stuck[r]))
        stdx::where(stuck[r], speed[r]) = load<P>(&stuck_speed_[r * stride + base]);
    }
    if (has_faults)
      for (int l = 0; l < kLanes; ++l)
        if (commit[l]) fault_active_[base + l] = active[static_cast<std::size_t>(l)];
    if (noise) {
      advance_noise(y, s, 0, commit);
      if (wants_derivative) advance_noise(yd, s, 16, commit);
    }
    running = commit;
  }

  for (int k = 0; k < kStateSize; ++k) store(x[k], &state_[k * stride + base]);
  for (int i = 0; i < nr; ++i)
    store(speed[static_cast<std::size_t>(i)], &rotor_speed_[i * stride + base]);
  // The inner loop changed the references of running lanes only (BatchInnerLoop::references).
  if (kExtras && inner_loop != nullptr)
    for (int i = 0; i < nr; ++i)
      store(reference[static_cast<std::size_t>(i)], &rotor_reference_[i * stride + base]);
  for (int l = 0; l < kLanes; ++l) step_count_[base + l] += taken[static_cast<std::size_t>(l)];
  if (noise && wants_derivative)
    for (int k = 0; k < kStateSize; ++k) store(yd[k], &derivative_noise_[k * stride + base]);
  if (noise) {
    for (int k = 0; k < kStateSize; ++k) {
      store(y[k], &noise_[k * stride + base]);
      store(P(x[k] + y[k]), &measured_[k * stride + base]);
    }
  }
}

template class BatchSimulator<double>;
template class BatchSimulator<float>;
template class AlignedArray<double>;
template class AlignedArray<float>;
template class AlignedArray<std::uint64_t>;

}  // namespace dronetwin
