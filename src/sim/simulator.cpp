#include "dronetwin/sim/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/ground.hpp"
#include "dronetwin/dynamics/vehicle_dynamics.hpp"
#include "dronetwin/integrators/integrator.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/model/allocation.hpp"
#include "dronetwin/sim/state_checks.hpp"

namespace dronetwin {

namespace {
constexpr const char* kBlockNames[4] = {"position", "velocity", "quaternion", "angular_velocity"};

void require_finite_vec(const Vec3& v, const char* field) {
  require(v.allFinite(), "simulation config: ", field, ": expected finite numbers, got [",
          v.transpose(), "]");
}
void validate_wind(const WindSettings& w) {
  const WindShear& sh = w.shear;
  require(std::isfinite(sh.roughness_length_m) && sh.roughness_length_m > 0.0,
          "simulation config: wind.shear.roughness_length_m: expected > 0, got ",
          sh.roughness_length_m);
  require(
      std::isfinite(sh.reference_height_m) && sh.reference_height_m > 2.0 * sh.roughness_length_m,
      "simulation config: wind.shear.reference_height_m: expected above twice the roughness "
      "length (",
      2.0 * sh.roughness_length_m, " m), got ", sh.reference_height_m);
  const double w20 = w.turbulence.wind_at_20ft_m_s;
  require(std::isfinite(w20) && w20 >= 0.0,
          "simulation config: wind.turbulence.wind_at_20ft_m_s: expected a speed >= 0, got ", w20);
  require(w.num_gusts >= 0 && w.num_gusts <= kMaxGusts,
          "simulation config: wind.num_gusts: expected 0 .. ", kMaxGusts, ", got ", w.num_gusts);
  for (int i = 0; i < w.num_gusts; ++i) {
    const Gust& g = w.gusts[static_cast<std::size_t>(i)];
    require(std::isfinite(g.start_s), "simulation config: wind.gusts[", i,
            "].start_s: expected a finite time, got ", g.start_s);
    require(std::isfinite(g.duration_s) && g.duration_s > 0.0, "simulation config: wind.gusts[", i,
            "].duration_s: expected > 0, got ", g.duration_s);
    require(g.amplitude_W_m_s.allFinite(), "simulation config: wind.gusts[", i,
            "].amplitude_m_s: expected finite numbers, got [", g.amplitude_W_m_s.transpose(), "]");
  }
}

void validate_faults(const FaultSettings& f) {
  require(f.num_rotor_faults >= 0 && f.num_rotor_faults <= kMaxRotorFaults,
          "simulation config: faults: expected 0 .. ", kMaxRotorFaults, " rotor faults, got ",
          f.num_rotor_faults);
  for (int j = 0; j < f.num_rotor_faults; ++j) {
    const RotorFault& r = f.rotor[static_cast<std::size_t>(j)];
    const auto kind = static_cast<std::size_t>(r.kind);
    require(kind < kRotorFaultNames.size(), "simulation config: faults[", j,
            "].type: not a fault type (", kind, ")");
    require(r.rotor >= 0 && r.rotor < kMaxRotors, "simulation config: faults[", j,
            "].rotor: expected a rotor index, got ", r.rotor);
    require(std::isfinite(r.start_s), "simulation config: faults[", j,
            "].start_s: expected a finite time, got ", r.start_s);
    require(std::isfinite(r.effectiveness) && r.effectiveness >= 0.0 && r.effectiveness <= 1.0,
            "simulation config: faults[", j, "].effectiveness: expected a fraction in [0, 1], got ",
            r.effectiveness);
  }
}

void validate_battery(const BatterySettings& settings) {
  const BatteryPack& b = settings.pack;
  const auto positive = [](double v, const char* field, const char* unit) {
    require(std::isfinite(v) && v > 0.0, "simulation config: battery.", field, ": expected > 0 ",
            unit, ", got ", v);
  };
  require(b.cells_in_series >= 1 && b.cells_in_series <= 32,
          "simulation config: battery.cells_in_series: expected 1 .. 32, got ", b.cells_in_series);
  positive(b.capacity_Ah, "capacity_Ah", "A h");
  positive(b.motor_speed_constant_rad_per_V_s, "motor_speed_constant_rad_per_V_s", "rad/(V s)");
  for (int k = 0; k < kOcvPoints; ++k) {
    const double v = b.ocv_cell_V[static_cast<std::size_t>(k)];
    require(std::isfinite(v) && v > 0.0, "simulation config: battery.ocv_cell_V[", k,
            "]: expected a voltage > 0, got ", v);
    if (k == 0) continue;
    // require() evaluates every argument, so the previous value is read only from k = 1 on.
    const double previous = b.ocv_cell_V[static_cast<std::size_t>(k - 1)];
    require(v >= previous, "simulation config: battery.ocv_cell_V[", k,
            "]: expected the voltage not to fall as the charge rises (", v, " after ", previous,
            ")");
  }
  const auto non_negative = [](double v, const char* field) {
    require(std::isfinite(v) && v >= 0.0, "simulation config: battery.", field,
            ": expected >= 0, got ", v);
  };
  // R0 > 0 bounds the current at E / (2 R0) whatever the power asked.
  positive(b.series_resistance_ohm, "series_resistance_ohm", "ohm");
  non_negative(b.rc_resistance_ohm, "rc_resistance_ohm");
  non_negative(b.rc_capacitance_F, "rc_capacitance_F");
  non_negative(b.cutoff_voltage_V, "cutoff_voltage_V");
  require(std::isfinite(b.efficiency) && b.efficiency > 0.0 && b.efficiency <= 1.0,
          "simulation config: battery.efficiency: expected a fraction in (0, 1], got ",
          b.efficiency);
  require(std::isfinite(b.initial_soc) && b.initial_soc > 0.0 && b.initial_soc <= 1.0,
          "simulation config: battery.initial_soc: expected a fraction in (0, 1], got ",
          b.initial_soc);
}

void validate_payload(const PayloadSettings& settings) {
  const SlungPayload& p = settings.payload;
  const auto check = [](double v, bool zero_allowed, const char* field) {
    require(std::isfinite(v) && (v > 0.0 || (zero_allowed && v == 0.0)),
            "simulation config: payload.", field, ": expected ", zero_allowed ? ">= 0" : "> 0",
            ", got ", v);
  };
  check(p.mass_kg, false, "mass_kg");
  check(p.tether_length_m, false, "tether_length_m");
  check(p.drag_area_m2, true, "drag_area_m2");
  check(p.air_density_kg_m3, true, "air_density_kg_m3");
  require(std::isfinite(settings.initial_swing1_rad) && std::isfinite(settings.initial_swing2_rad),
          "simulation config: payload.initial_swing_rad: expected finite angles, got [",
          settings.initial_swing1_rad, ", ", settings.initial_swing2_rad, "]");
}

}  // namespace

/// Lost-effectiveness faults in the order they begin (ties in file order): models[k] and
/// kernels[k] have the first k + 1 of them applied, each scaling its rotor's thrust polynomial.
struct FaultedForces {
  std::vector<int> order;
  std::vector<VehicleModelTpl<double>> models;
  std::vector<ForceKernel<double>> kernels;
};

void validate_fault_rotors(const FaultSettings& faults, int num_rotors, std::string_view vehicle,
                           std::string_view prefix) {
  for (int j = 0; j < faults.num_rotor_faults; ++j) {
    const int rotor = faults.rotor[static_cast<std::size_t>(j)].rotor;
    require(rotor < num_rotors, prefix, "faults[", j, "].rotor: expected 0 .. ", num_rotors - 1,
            " (rotors of '", vehicle, "'), got ", rotor);
  }
}

void validate(const SimConfig& c) {
  require(std::isfinite(c.dt_s) && c.dt_s > 0.0 && c.dt_s <= 0.1,
          "simulation config: dt_s: expected a step in (0, 0.1] s, got ", c.dt_s);
  require_finite_vec(c.environment.gravity_W_m_s2, "environment.gravity");
  require_finite_vec(c.environment.wind_W_m_s, "environment.wind");
  validate_wind(c.wind);
  validate_faults(c.faults);
  validate_battery(c.battery);
  validate_payload(c.payload);
  const OuParameters& p = c.noise.parameters;
  const double drift_scale = p.drift == OuDrift::kPerSample ? 1.0 : c.dt_s;
  for (int k = 0; k < 4; ++k) {
    const auto& th = p.theta[static_cast<std::size_t>(k)];
    const auto& sg = p.sigma[static_cast<std::size_t>(k)];
    require(
        std::isfinite(th.a) && std::isfinite(th.b) && std::isfinite(sg.a) && std::isfinite(sg.b),
        "simulation config: noise.", kBlockNames[k], ": expected finite theta and sigma");
    // The per-step map is I - s Theta; its eigenvalues are 1 - s a and 1 - s (a + N b).
    // The process is stable (has a stationary distribution) when both lie in (-1, 1).
    const double e1 = 1.0 - drift_scale * th.a;
    const double e2 = 1.0 - drift_scale * (th.a + kOuBlockSize[static_cast<std::size_t>(k)] * th.b);
    require(std::abs(e1) < 1.0 && std::abs(e2) < 1.0, "simulation config: noise.theta.",
            kBlockNames[k], ": the OU process is unstable (per-step decay factors ", e1, ", ", e2,
            " must lie in (-1, 1))");
  }
  require(std::isfinite(c.ground.crash_speed_m_s) && c.ground.crash_speed_m_s > 0.0,
          "simulation config: ground.crash_speed_m_s: expected > 0, got ",
          c.ground.crash_speed_m_s);
  require(std::isfinite(c.ground.crash_tilt_rad) && c.ground.crash_tilt_rad > 0.0,
          "simulation config: ground.crash_tilt_rad: expected > 0, got ", c.ground.crash_tilt_rad);
  require(std::isfinite(c.ground.friction_coefficient) && c.ground.friction_coefficient >= 0.0,
          "simulation config: ground.friction_coefficient: expected >= 0, got ",
          c.ground.friction_coefficient);
  require(c.divergence.max_position_m > 0.0 && c.divergence.max_speed_m_s > 0.0 &&
              c.divergence.max_angular_speed_rad_s > 0.0,
          "simulation config: divergence: limits must be positive");
}

Simulator::Simulator(std::shared_ptr<const VehicleModel> model, SimConfig config)
    : model_(std::move(model)), config_(std::move(config)) {
  require(model_ != nullptr, "Simulator: model is null");
  validate(config_);
  motors_ = discretize_motors(*model_, config_.dt_s);
  validate_fault_rotors(config_.faults, model_->num_rotors(), model_->name(),
                        "simulation config: ");
  kernel_ =
      std::make_shared<const ForceKernel<double>>(*model_, ForceTerms::of(config_.disturbances));
  build_fault_forces();
  data_.state_noise = OrnsteinUhlenbeck(config_.noise.parameters, config_.dt_s);
  data_.derivative_noise = OrnsteinUhlenbeck(config_.noise.parameters, config_.dt_s);
  reset(hover_state(Vec3::Zero()));
}

StateVector Simulator::hover_state(const Vec3& position_W, double yaw_rad) {
  require(position_W.allFinite(), "hover_state: position: expected finite numbers, got [",
          position_W.transpose(), "]");
  require(std::isfinite(yaw_rad), "hover_state: yaw_rad: expected a finite number, got ", yaw_rad);
  StateVector x = StateVector::Zero();
  x.segment<3>(state_index::kPosition) = position_W;
  x.segment<4>(state_index::kQuaternion) = math::from_euler(0.0, 0.0, yaw_rad);
  return x;
}

void Simulator::check_rotor_vector(const RotorVector& v, const char* what) const {
  require(v.size() == model_->num_rotors(), what, ": expected ", model_->num_rotors(),
          " values (one per rotor of '", model_->name(), "'), got ", v.size());
  for (Eigen::Index i = 0; i < v.size(); ++i)
    require(std::isfinite(v[i]), what, "[", i, "]: expected a finite number, got ", v[i]);
}

void Simulator::reset(const StateVector& state) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::reset");
  reset(state, RotorVector::Zero(model_->num_rotors()));
}

void Simulator::reset(const StateVector& state, const RotorVector& rotor_speeds_rad_s) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::reset");
  check_rotor_vector(rotor_speeds_rad_s, "reset: rotor speeds");
  set_state(state);
  data_.time_s = 0.0;
  data_.step_count = 0;
  data_.rotor_speed_rad_s = rotor_speeds_rad_s;
  for (int i = 0; i < model_->num_rotors(); ++i)
    data_.rotor_speed_rad_s[i] = clamp_speed(model_->rotor(i), rotor_speeds_rad_s[i]);
  data_.rotor_speed_reference_rad_s = data_.rotor_speed_rad_s;
  data_.state_noise.reset();
  data_.derivative_noise.reset();
  update_measured_state();
  data_.rng.reseed(config_.seed);
  // Developed turbulence from the first step (drawn whether or not it is on, so that switching
  // it on mid-run meets developed gusts too).
  data_.turbulence_rng.reseed(turbulence_stream_seed(config_.seed));
  data_.turbulence = dryden_start(data_.turbulence_rng);
  data_.active_faults = 0;
  data_.stuck_speed_rad_s = {};
  data_.battery = battery_start(config_.battery.pack);
  data_.payload =
      payload_start(config_.payload, data_.state.segment<3>(state_index::kPosition),
                    data_.state.segment<3>(state_index::kVelocity), config_.ground.enabled);
  data_.contact = ContactState{};
  if (config_.ground.enabled && data_.state[state_index::kPosition + 2] <= 0.0) {
    data_.contact.in_contact = true;
  }
  data_.interaction_flow_W_m_s.setZero();
  data_.interaction_wrench_B.setZero();
  data_.status = StepStatus::kOk;
  data_.failure = StepFailure{};
  update_wind();
}

void Simulator::reseed(std::uint64_t seed) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::reseed");
  config_.seed = seed;
  reset(data_.state, data_.rotor_speed_rad_s);
}

void Simulator::set_state(const StateVector& state) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::set_state");
  require_start_state(state, config_.ground.enabled, "");
  if (config_.payload.enabled) {
    // The payload goes with the vehicle: same offset, same relative velocity.
    using namespace state_index;
    PayloadState& payload = data_.payload;
    payload.position_W_m += state.segment<3>(kPosition) - data_.state.segment<3>(kPosition);
    payload.velocity_W_m_s += state.segment<3>(kVelocity) - data_.state.segment<3>(kVelocity);
    if (config_.ground.enabled && payload.position_W_m.z() <= 0.0) rest_on_ground(payload);
  }
  data_.state = state;
  normalize_quaternion(data_.state);
  update_measured_state();
  update_wind();
}

void Simulator::refresh_measured_state() {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::refresh_measured_state");
  update_measured_state();
  update_wind();
}

void Simulator::set_interaction(const Vec3& flow_W_m_s, const Vector6<double>& wrench_B) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::set_interaction");
  require(flow_W_m_s.allFinite(), "set_interaction: flow: expected finite numbers, got [",
          flow_W_m_s.transpose(), "] m/s");
  require(wrench_B.allFinite(), "set_interaction: wrench: expected finite numbers, got [",
          wrench_B.transpose(), "]");
  data_.interaction_flow_W_m_s = flow_W_m_s;
  data_.interaction_wrench_B = wrench_B;
  update_wind();
}

void Simulator::prepare_held(const ForceKernel<double>& kernel,
                             HeldRotorTerms<double>& held) const {
  kernel.prepare(data_.rotor_speed_rad_s, held);
  held.constant += data_.interaction_wrench_B;
}

void Simulator::update_wind() {
  const Vec3& mean_ref = config_.environment.wind_W_m_s;
  const WindSettings& w = config_.wind;
  const double height_m = data_.state[state_index::kPosition + 2];
  // A state written through mutable_data() may be non-finite; the next step reports it.
  if (!w.varies() || !std::isfinite(height_m)) {
    data_.wind_W_m_s = mean_ref + data_.interaction_flow_W_m_s;
    return;
  }
  const Vec3 mean = mean_wind_at(mean_ref, w.shear, height_m);
  Vec3 wind = mean + gust_at(w, data_.time_s);
  if (w.turbulence.enabled) {
    data_.turbulence_scales = dryden_low_altitude(height_m, w.turbulence.wind_at_20ft_m_s);
    wind += turbulence_axes(mean) * dryden_gust(data_.turbulence, data_.turbulence_scales);
  }
  data_.wind_W_m_s = wind + data_.interaction_flow_W_m_s;
}

void Simulator::update_measured_state() {
  data_.measured_state = data_.state;
  if (config_.noise.enabled) data_.measured_state += data_.state_noise.value();
}

void Simulator::set_noise_enabled(bool enabled) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::set_noise_enabled");
  config_.noise.enabled = enabled;
  update_measured_state();
}

void Simulator::set_rotor_speeds(const RotorVector& speeds_rad_s) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::set_rotor_speeds");
  check_rotor_vector(speeds_rad_s, "rotor speeds");
  for (int i = 0; i < model_->num_rotors(); ++i)
    data_.rotor_speed_rad_s[i] = clamp_speed(model_->rotor(i), speeds_rad_s[i]);
}

void Simulator::set_rotor_speed_reference(const RotorVector& reference_rad_s) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::set_rotor_speed_reference");
  check_rotor_vector(reference_rad_s, "rotor speed reference");
  data_.rotor_speed_reference_rad_s = reference_rad_s;
}

void Simulator::set_generalized_force(const GeneralizedForce& u, AllocationMethod method) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::set_generalized_force");
  for (int i = 0; i < 4; ++i)
    require(std::isfinite(u[i]), "generalized force [T, tau_x, tau_y, tau_z][", i,
            "]: expected a finite number, got ", u[i]);
  data_.rotor_speed_reference_rad_s = allocate(*model_, u, method).speeds_rad_s;
}

void Simulator::set_disturbances(const DisturbanceSwitches& switches) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::set_disturbances");
  config_.disturbances = switches;
  kernel_ = std::make_shared<const ForceKernel<double>>(*model_, ForceTerms::of(switches));
  build_fault_forces();
}

void Simulator::set_faults(const FaultSettings& faults) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::set_faults");
  validate_faults(faults);
  validate_fault_rotors(faults, model_->num_rotors(), model_->name());
  config_.faults = faults;
  data_.active_faults = 0;
  build_fault_forces();
}

void Simulator::set_battery(const BatterySettings& battery) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::set_battery");
  validate_battery(battery);
  config_.battery = battery;
  data_.battery = battery_start(battery.pack);
}

void Simulator::build_fault_forces() {
  const FaultSettings& f = config_.faults;
  std::array<int, kMaxRotorFaults> sorted{};
  const int count = f.effectiveness_order(sorted);
  if (count == 0) {
    faulted_.reset();
    return;
  }
  auto forces = std::make_shared<FaultedForces>();
  forces->order.assign(sorted.begin(), sorted.begin() + count);
  VehicleParametersTpl<double> p = model_->parameters();
  const ForceTerms terms = ForceTerms::of(config_.disturbances);
  for (const int j : forces->order) {
    const RotorFault& fault = f.rotor[static_cast<std::size_t>(j)];
    for (double& k : p.rotors[static_cast<std::size_t>(fault.rotor)].thrust_coefficients)
      k *= fault.effectiveness;
    forces->models.emplace_back(p);
    forces->kernels.emplace_back(forces->models.back(), terms);
  }
  faulted_ = std::move(forces);
}

std::size_t Simulator::effectiveness_stage(double time_s) const {
  if (faulted_ == nullptr) return 0;
  // The faults begin in `order`, so those acting now are its first n.
  std::size_t n = 0;
  for (const int j : faulted_->order)
    n += config_.faults.rotor[static_cast<std::size_t>(j)].active_at(time_s, config_.dt_s);
  return n;
}

const ForceKernel<double>& Simulator::active_kernel(double time_s) const {
  const std::size_t n = effectiveness_stage(time_s);
  return n == 0 ? *kernel_ : faulted_->kernels[n - 1];
}

const VehicleModelTpl<double>& Simulator::active_model(double time_s) const {
  const std::size_t n = effectiveness_stage(time_s);
  return n == 0 ? static_cast<const VehicleModelTpl<double>&>(*model_) : faulted_->models[n - 1];
}

void Simulator::set_scene(std::shared_ptr<const Track> scene) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::set_scene");
  scene_ = std::move(scene);
}

void Simulator::set_wind(const Vec3& wind_W_m_s) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::set_wind");
  require(wind_W_m_s.allFinite(), "wind: expected finite numbers, got [", wind_W_m_s.transpose(),
          "]");
  config_.environment.wind_W_m_s = wind_W_m_s;
  update_wind();
}

void Simulator::set_wind_field(const WindSettings& wind) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::set_wind_field");
  validate_wind(wind);
  config_.wind = wind;
  update_wind();
}

StepStatus Simulator::check_state(const StateVector& x) const {
  return classify_state(x, config_.divergence);
}

std::string Simulator::failure_message() const {
  const StepFailure& f = data_.failure;
  const DivergenceLimits& lim = config_.divergence;
  if (f.started_invalid && data_.status != StepStatus::kOk &&
      data_.status != StepStatus::kControllerFailed) {
    const double qn = data_.state.segment<4>(state_index::kQuaternion).norm();
    return detail::concat(
        "the state before step ", f.step, " (t = ", f.time_s, " s) was not valid: ",
        data_.state.allFinite() ? "" : "it has non-finite values (NaN or inf), ",
        "quaternion norm ", qn,
        "; it was written directly (mutable_data() or a Python state view), not produced by a "
        "step. Write finite values and a non-zero quaternion, or use set_state()");
  }
  switch (data_.status) {
    case StepStatus::kOk:
      return {};
    case StepStatus::kNonFinite:
      return detail::concat("state became non-finite at t = ", f.time_s, " s (step ", f.step, ")");
    case StepStatus::kDiverged:
      return detail::concat("state diverged at t = ", f.time_s, " s: |p| = ", f.position_m,
                            " m (limit ", lim.max_position_m, "), |v| = ", f.speed_m_s,
                            " m/s (limit ", lim.max_speed_m_s, "), |w| = ", f.angular_speed_rad_s,
                            " rad/s (limit ", lim.max_angular_speed_rad_s, ")");
    case StepStatus::kControllerFailed:
      return "the controller failed";
    case StepStatus::kInvalidState:
      return detail::concat("the state became invalid at t = ", f.time_s, " s (step ", f.step,
                            "): its quaternion is not a rotation");
    case StepStatus::kInvalidInput:
      return "an input was not finite";
    case StepStatus::kCollided:
      return detail::concat(
          "collided with ",
          scene_ ? describe_contact(*scene_, f.contact) : std::string("the scene"), " during step ",
          f.step, " (t = ", f.time_s - config_.dt_s, " to ", f.time_s, " s) near position [",
          f.at_m.transpose(), "] m");
  }
  return {};
}

StepResult Simulator::step() {
  guard_.check("Simulator::step");
  return step_unchecked();
}

StepResult Simulator::step_unchecked() {
  if (data_.status != StepStatus::kOk) {
    throw SimulationError("Simulator::step: the run failed earlier (" + failure_message() +
                          "); call reset() first");
  }
  // Rotor speeds are held over the step: do their part of the force model once.
  PayloadState payload = data_.payload;
  StateVector next;
  if (config_.payload.enabled) {
    next = step_with_payload(payload);
  } else {
    // held_rotor_step() of the force kernel, with the other vehicles' wrench added to the held
    // one (zero without them).
    const ForceKernel<double>& kernel = active_kernel(data_.time_s);
    prepare_held(kernel, held_);
    const Vec3& g = config_.environment.gravity_W_m_s2;
    next = integrate_step(config_.integrator, data_.state, config_.dt_s, [&](const StateVector& y) {
      return kernel.derivative(held_, y, data_.wind_W_m_s, g);
    });
    normalize_quaternion(next);
  }
  // Contact is resolved on a copy: a refused step must not change it (nor anything else).
  ContactState contact = data_.contact;
  resolve_ground_contact(config_.ground, data_.state, config_.dt_s, next, contact);

  StepStatus status = check_state(next);
  if (status == StepStatus::kOk && config_.payload.enabled &&
      !(payload.position_W_m.allFinite() && payload.velocity_W_m_s.allFinite()))
    status = StepStatus::kNonFinite;
  SceneContact scene_contact;
  if (status == StepStatus::kOk && scene_ != nullptr) {
    scene_contact = find_scene_contact(*scene_, model_->collision_shape(), data_.state, next);
    if (scene_contact) status = StepStatus::kCollided;
  }
  if (status != StepStatus::kOk) {
    using namespace state_index;
    data_.status = status;
    data_.failure.time_s = data_.time_s + config_.dt_s;
    data_.failure.step = data_.step_count + 1;
    data_.failure.position_m = next.segment<3>(kPosition).norm();
    data_.failure.speed_m_s = next.segment<3>(kVelocity).norm();
    data_.failure.angular_speed_rad_s = next.segment<3>(kAngularVelocity).norm();
    data_.failure.at_m = next.segment<3>(kPosition);
    data_.failure.contact = scene_contact;
    const double q2 = data_.state.segment<4>(kQuaternion).squaredNorm();
    data_.failure.started_invalid = !data_.state.allFinite() || !(q2 >= 0.25 && q2 <= 4.0);
    return {status, 0};
  }
  const VehicleModel& m = *model_;
  if (config_.wind.turbulence.enabled) {
    // Height (in the scales) and airspeed of the step's start, held over the step.
    const Vec3 mean = mean_wind_at(config_.environment.wind_W_m_s, config_.wind.shear,
                                   data_.state[state_index::kPosition + 2]);
    const double airspeed_m_s = (data_.state.segment<3>(state_index::kVelocity) - mean).norm();
    (void)dryden_step(data_.turbulence, data_.turbulence_scales, airspeed_m_s, config_.dt_s,
                      data_.turbulence_rng);
  }
  data_.state = next;
  data_.contact = contact;
  data_.payload = payload;
  // Faults of the motors: a stopped rotor is driven to zero, a stuck one keeps the speed it had
  // when its fault began (recorded at that step, whose forces used it).
  const FaultSettings& faults = config_.faults;
  RotorVector reference = data_.rotor_speed_reference_rad_s;
  std::uint32_t active = 0;
  if (faults.any()) {
    active = faults.active_at(data_.time_s, config_.dt_s);
    for (int j = 0; j < faults.num_rotor_faults; ++j) {
      const RotorFault& f = faults.rotor[static_cast<std::size_t>(j)];
      if ((active & (1u << j)) == 0) continue;
      if (f.kind == RotorFaultKind::kStop) reference[f.rotor] = 0.0;
      if (f.kind == RotorFaultKind::kStuck && (data_.active_faults & (1u << j)) == 0)
        data_.stuck_speed_rad_s[static_cast<std::size_t>(f.rotor)] =
            data_.rotor_speed_rad_s[f.rotor];
    }
  }
  if (config_.battery.enabled) {
    // The step's current comes from the speeds it flew with (held over it); the pack it leaves
    // caps the speeds the motors head for next.
    const BatteryPack& pack = config_.battery.pack;
    const double power_W =
        rotor_shaft_power_W(active_model(data_.time_s), data_.rotor_speed_rad_s) / pack.efficiency;
    advance_battery(pack, config_.dt_s, battery_current_A(pack, data_.battery, power_W),
                    data_.battery);
    const double cap_rad_s =
        battery_speed_cap_rad_s(active_model(data_.time_s), pack, data_.battery, reference);
    for (int i = 0; i < m.num_rotors(); ++i) reference[i] = std::min(reference[i], cap_rad_s);
  }
  if (config_.motor_dynamics) {
    advance_motors(m, motors_, reference, data_.rotor_speed_rad_s);
  } else {
    for (int i = 0; i < m.num_rotors(); ++i)
      data_.rotor_speed_rad_s[i] = clamp_speed(m.rotor(i), reference[i]);
  }
  if (faults.any()) {
    for (int j = 0; j < faults.num_rotor_faults; ++j) {
      const RotorFault& f = faults.rotor[static_cast<std::size_t>(j)];
      if ((active & (1u << j)) != 0 && f.kind == RotorFaultKind::kStuck)
        data_.rotor_speed_rad_s[f.rotor] =
            data_.stuck_speed_rad_s[static_cast<std::size_t>(f.rotor)];
    }
    data_.active_faults = active;
  }
  if (config_.noise.enabled) {
    data_.state_noise.step(data_.rng);
    data_.derivative_noise.step(data_.rng);
  }
  update_measured_state();
  ++data_.step_count;
  data_.time_s = static_cast<double>(data_.step_count) * config_.dt_s;
  update_wind();
  return {StepStatus::kOk, 1};
}

StepResult Simulator::step(std::int64_t n) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::step");
  require(n >= 0, "Simulator::step(n): expected n >= 0, got ", n);
  StepResult total;
  for (std::int64_t k = 0; k < n; ++k) {
    const StepResult r = step_unchecked();
    if (!r.ok()) {
      total.status = r.status;
      return total;
    }
    ++total.steps_taken;
  }
  return total;
}

CableCoupling Simulator::payload_coupling_now(const ForceKernel<double>& kernel,
                                              const HeldRotorTerms<double>& held,
                                              PayloadState& payload, bool& pulling) const {
  using namespace state_index;
  const SlungPayload& p = config_.payload.payload;
  const Vec3& g = config_.environment.gravity_W_m_s2;
  const double m_Q = active_model(data_.time_s).mass_kg();
  const StateVector xdot = kernel.derivative(held, data_.state, data_.wind_W_m_s, g);
  const auto coupling = [&](bool pull) {
    return cable_coupling(p, m_Q, pull, payload.on_ground, data_.state.segment<3>(kPosition),
                          data_.state.segment<3>(kVelocity), xdot.segment<3>(kVelocity),
                          payload.position_W_m, payload.velocity_W_m_s, data_.wind_W_m_s, g);
  };
  CableCoupling c = coupling(payload.taut);
  if (payload_lifts_off(p, payload, c.tension_N, data_.state.segment<3>(kPosition), g)) {
    payload.on_ground = false;
    c = coupling(payload.taut);
  }
  pulling = cable_pulls(payload, c.tension_N);
  if (!pulling) c = coupling(false);
  return c;
}

StateVector Simulator::step_with_payload(PayloadState& payload) {
  using namespace state_index;
  using Augmented = Eigen::Matrix<double, kStateSize + 6, 1>;
  const ForceKernel<double>& kernel = active_kernel(data_.time_s);
  prepare_held(kernel, held_);
  bool pulling = false;
  (void)payload_coupling_now(kernel, held_, payload, pulling);
  const SlungPayload& p = config_.payload.payload;
  const Vec3& g = config_.environment.gravity_W_m_s2;
  const double m_Q = active_model(data_.time_s).mass_kg();
  const bool on_ground = payload.on_ground;
  const auto f = [&](const Augmented& y) {
    const StateVector x = y.head<kStateSize>();
    Augmented ydot;
    StateVector xdot = kernel.derivative(held_, x, data_.wind_W_m_s, g);
    const CableCoupling c =
        cable_coupling(p, m_Q, pulling, on_ground, x.segment<3>(kPosition), x.segment<3>(kVelocity),
                       xdot.segment<3>(kVelocity), y.segment<3>(kStateSize),
                       y.segment<3>(kStateSize + 3), data_.wind_W_m_s, g);
    xdot.segment<3>(kVelocity) += c.vehicle_acceleration_W_m_s2;
    ydot.head<kStateSize>() = xdot;
    if (on_ground) {
      ydot.segment<3>(kStateSize).setZero();
    } else {
      ydot.segment<3>(kStateSize) = y.segment<3>(kStateSize + 3);
    }
    ydot.segment<3>(kStateSize + 3) = c.payload_acceleration_W_m_s2;
    return ydot;
  };
  Augmented y;
  y << data_.state, payload.position_W_m, payload.velocity_W_m_s;
  const Augmented y1 = integrate_step(config_.integrator, y, config_.dt_s, f);
  StateVector next = y1.head<kStateSize>();
  normalize_quaternion(next);
  payload.position_W_m = y1.segment<3>(kStateSize);
  payload.velocity_W_m_s = y1.segment<3>(kStateSize + 3);
  Vec3 position = next.segment<3>(kPosition);
  Vec3 velocity = next.segment<3>(kVelocity);
  settle_cable(p, m_Q, pulling, config_.ground.enabled, position, velocity, payload);
  next.segment<3>(kPosition) = position;
  next.segment<3>(kVelocity) = velocity;
  return next;
}

double Simulator::payload_tension_N() const {
  if (!config_.payload.enabled) return 0.0;
  HeldRotorTerms<double> held;
  const ForceKernel<double>& kernel = active_kernel(data_.time_s);
  prepare_held(kernel, held);
  PayloadState payload = data_.payload;
  bool pulling = false;
  return payload_coupling_now(kernel, held, payload, pulling).tension_N;
}

SwingAngles Simulator::swing_angles() const {
  using namespace state_index;
  if (!config_.payload.enabled) return {};
  return dronetwin::swing_angles(data_.state.segment<3>(kPosition),
                                 data_.state.segment<3>(kVelocity), data_.payload);
}

void Simulator::set_payload_state(const PayloadState& payload) {
  const SingleThreadGuard::Hold hold(guard_, "Simulator::set_payload_state");
  require(config_.payload.enabled,
          "set_payload_state: this simulator has no payload (SimConfig::payload.enabled is false)");
  require(payload.position_W_m.allFinite(), "payload position: expected finite numbers, got [",
          payload.position_W_m.transpose(), "]");
  require(payload.velocity_W_m_s.allFinite(), "payload velocity: expected finite numbers, got [",
          payload.velocity_W_m_s.transpose(), "]");
  const double l = config_.payload.payload.tether_length_m;
  const double length =
      (payload.position_W_m - data_.state.segment<3>(state_index::kPosition)).norm();
  require(length <= l * (1.0 + 1e-9), "payload position: ", length,
          " m from the vehicle, beyond the tether length ", l, " m");
  require(!config_.ground.enabled || payload.position_W_m.z() >= 0.0,
          "payload position: z = ", payload.position_W_m.z(), " m is below the ground");
  PayloadState s = payload;
  s.taut = length >= l * (1.0 - 1e-9);
  s.on_ground = false;
  if (config_.ground.enabled && s.position_W_m.z() <= 0.0 && s.velocity_W_m_s.z() <= 0.0)
    rest_on_ground(s);
  data_.payload = s;
}

StateVector Simulator::state_derivative() const {
  HeldRotorTerms<double> held;
  const ForceKernel<double>& kernel = active_kernel(data_.time_s);
  prepare_held(kernel, held);
  StateVector xdot =
      kernel.derivative(held, data_.state, data_.wind_W_m_s, config_.environment.gravity_W_m_s2);
  if (config_.payload.enabled) {
    PayloadState payload = data_.payload;
    bool pulling = false;
    xdot.segment<3>(state_index::kVelocity) +=
        payload_coupling_now(kernel, held, payload, pulling).vehicle_acceleration_W_m_s2;
  }
  return xdot;
}

StateVector Simulator::measured_state_derivative() const {
  if (!config_.noise.enabled) return state_derivative();
  return state_derivative() + data_.derivative_noise.value();
}

WrenchBreakdown Simulator::wrench_breakdown() const {
  Environment env = config_.environment;
  env.wind_W_m_s = data_.wind_W_m_s;  // the wind at the vehicle now
  return dronetwin::wrench_breakdown(active_model(data_.time_s), config_.disturbances, env,
                                     data_.state, data_.rotor_speed_rad_s);
}

}  // namespace dronetwin
