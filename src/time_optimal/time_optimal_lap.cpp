// The time-optimal lap by multiple shooting on Ceres (the method is described in
// time_optimal_lap.hpp). Residual blocks, all constraints of a feasibility least squares:
//   DefectCost     x_{k+1} - Phi(x_k, u(v_k), T_j / n_j), scaled    (13 per interval)
//   GateCost       p_k - the gate point of sigma                     (3 per gate)
//   PeriodicCost   x_N - P x_0 (P flips the quaternion's sign when the warm start does)
//   TotalTimeCost  sum_j T_j - the target lap time                   (stage 2)
#include "dronetwin/time_optimal/time_optimal_lap.hpp"

#include <ceres/ceres.h>
#include <ceres/jet.h>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>

#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/control/se3.hpp"
#include "dronetwin/control/trajectory_reference.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/force_kernel.hpp"
#include "dronetwin/dynamics/rigid_body.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/planning/flatness.hpp"
#include "dronetwin/planning/min_snap.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "dronetwin/world/gate.hpp"

namespace dronetwin {

namespace {

constexpr int kNx = kStateSize;
/// Controls per interval: collective thrust and body moments.
constexpr int kControls = 4;
/// How close to a thrust limit controls_of() places a rotor (as a fraction of the half range):
/// the inverse tanh of the edge is finite and its slope not yet negligible for the solver.
constexpr double kTanhEdge = 1.0 - 1e-6;
// Jet directions of one interval: the state at its start, the controls, the interval length.
constexpr int kDirections = kNx + kControls + 1;
using Jet = ceres::Jet<double, kDirections>;
constexpr int kDtDirection = kNx + kControls;

/// Constraint scaling: position m, velocity m/s, quaternion 1, body rate per 10 rad/s (rates
/// run to tens of rad/s; a tenth of one is as small as a centimetre).
double state_scale(int i) { return i >= state_index::kAngularVelocity ? 0.1 : 1.0; }

/// One physics step of the simulator with the rotor speeds held (force_kernel.hpp's
/// held_rotor_step), in `substeps` RK4 steps of dt / substeps, for a dt that is an unknown.
template <class S>
StateVectorT<S> physics_step(const ForceKernel<S>& kernel, const StateVectorT<S>& x,
                             const S* speeds_rad_s, const S& dt_s, int substeps,
                             const Vec3& gravity_W) {
  HeldRotorTerms<S> held;
  kernel.prepare(speeds_rad_s, held);
  const Vec3 still_air = Vec3::Zero();
  const S h = dt_s / static_cast<double>(substeps);
  StateVectorT<S> y = x;
  for (int s = 0; s < substeps; ++s) {
    const StateVectorT<S> k1 = kernel.derivative(held, y, still_air, gravity_W);
    const StateVectorT<S> k2 =
        kernel.derivative(held, StateVectorT<S>(y + (0.5 * h) * k1), still_air, gravity_W);
    const StateVectorT<S> k3 =
        kernel.derivative(held, StateVectorT<S>(y + (0.5 * h) * k2), still_air, gravity_W);
    const StateVectorT<S> k4 =
        kernel.derivative(held, StateVectorT<S>(y + h * k3), still_air, gravity_W);
    y = y + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4);
    normalize_quaternion(y);
  }
  return y;
}

/// What every residual block shares: the model's kernels and the control parametrisation.
struct Shared {
  Shared(const VehicleModel& model, const TimeOptimalOptions& o)
      : kernel(model, ForceTerms::of(o.switches)),
        jet_kernel(model.cast<Jet>(), ForceTerms::of(o.switches)),
        gravity_W(0.0, 0.0, -o.gravity_m_s2),
        num_rotors(model.num_rotors()),
        substeps(o.substeps) {
    for (int r = 0; r < num_rotors; ++r) {
      const RotorParamsTpl<double>& p = model.rotor(r);
      coefficients[r] = p.thrust_coefficients;
      min_speed[r] = p.min_speed_rad_s;
      max_speed[r] = p.max_speed_rad_s;
      const double lo = p.thrust(p.min_speed_rad_s), hi = p.thrust(p.max_speed_rad_s);
      thrust_mid[r] = 0.5 * (lo + hi);
      thrust_half_range[r] = 0.5 * (hi - lo);
    }
    // The controls are the wrench [T, tau_x, tau_y, tau_z], each over a scale of its own; the
    // rotor thrusts are the allocation's pseudo-inverse of it, passed through a tanh onto each
    // rotor's thrust range (smooth limits: inside them for every wrench).
    const auto& A = model.allocation_matrix();
    const auto& P = model.allocation_pseudo_inverse();
    double mid = 0.0;
    for (int r = 0; r < num_rotors; ++r) mid += thrust_mid[r] / num_rotors;
    for (int i = 0; i < kControls; ++i) {
      double row = 0.0;
      for (int r = 0; r < num_rotors; ++r) {
        allocation(i, r) = A(i, r);
        pinv(r, i) = P(r, i);
        row = std::max(row, std::abs(A(i, r)));
      }
      wrench_scale[i] = row * mid;
    }
  }
  /// The rotor speeds of one interval's controls (the scaled wrench).
  template <class S>
  void speeds(const S* p, S* out) const {
    using std::tanh;
    for (int r = 0; r < num_rotors; ++r) {
      S f = S(0.0);
      for (int i = 0; i < kControls; ++i) f = f + (pinv(r, i) * wrench_scale[i]) * p[i];
      f = thrust_mid[r] + thrust_half_range[r] * tanh((f - thrust_mid[r]) / thrust_half_range[r]);
      out[r] = inverse_thrust_polynomial<S>(coefficients[r], min_speed[r], max_speed[r], f);
    }
  }
  /// The controls of rotor speeds (their thrusts clamped just inside the range, where the tanh
  /// is invertible).
  void controls_of(const RotorVector& w, double* p) const {
    double f[kMaxRotors];
    for (int r = 0; r < num_rotors; ++r) {
      const double x =
          (thrust_polynomial(coefficients[r], w[r]) - thrust_mid[r]) / thrust_half_range[r];
      f[r] =
          thrust_mid[r] + thrust_half_range[r] * std::atanh(std::clamp(x, -kTanhEdge, kTanhEdge));
    }
    for (int i = 0; i < kControls; ++i) {
      double u = 0.0;
      for (int r = 0; r < num_rotors; ++r) u += allocation(i, r) * f[r];
      p[i] = u / wrench_scale[i];
    }
  }
  Eigen::Matrix<double, kControls, kMaxRotors> allocation =
      Eigen::Matrix<double, kControls, kMaxRotors>::Zero();
  Eigen::Matrix<double, kMaxRotors, kControls> pinv =
      Eigen::Matrix<double, kMaxRotors, kControls>::Zero();
  Eigen::Matrix<double, kControls, 1> wrench_scale = Eigen::Matrix<double, kControls, 1>::Ones();
  ForceKernel<double> kernel;
  ForceKernel<Jet> jet_kernel;
  Vec3 gravity_W;
  int num_rotors;
  int substeps;
  std::array<std::array<double, 3>, kMaxRotors> coefficients{};
  double min_speed[kMaxRotors] = {}, max_speed[kMaxRotors] = {};
  double thrust_mid[kMaxRotors] = {}, thrust_half_range[kMaxRotors] = {};
};

/// A constraint block: its residual is the constraint c itself (a feasibility problem), and
/// constraint() evaluates c alone for the violation check.
class ConstraintCost : public ceres::CostFunction {
 public:
  virtual void constraint(double const* const* parameters, double* c) const = 0;
};

/// x_{k+1} - Phi(x_k, u_k, T_j / n_j), scaled. Blocks: x_k (13), the controls v_k (4: u_k =
/// Shared::speeds(v_k)), tau_j (1: T_j = T0_j exp(tau_j)), x_{k+1}.
class DefectCost final : public ConstraintCost {
 public:
  DefectCost(const Shared& shared, int intervals_in_segment, double warm_time_s)
      : shared_(shared), dt0_s_(warm_time_s / intervals_in_segment) {
    set_num_residuals(kNx);
    *mutable_parameter_block_sizes() = {kNx, kControls, 1, kNx};
  }

  void constraint(double const* const* p, double* c) const override {
    const Eigen::Map<const StateVector> x(p[0]), next(p[3]);
    const double dt_s = dt0_s_ * std::exp(p[2][0]);
    double speeds[kMaxRotors];
    shared_.speeds(p[1], speeds);
    const StateVector phi =
        physics_step<double>(shared_.kernel, x, speeds, dt_s, shared_.substeps, shared_.gravity_W);
    for (int i = 0; i < kNx; ++i) c[i] = (next[i] - phi[i]) / state_scale(i);
  }

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    if (jacobians == nullptr) {
      constraint(p, residuals);
      return true;
    }
    StateVectorT<Jet> x;
    for (int i = 0; i < kNx; ++i) x[i] = Jet(p[0][i], i);
    Jet speeds[kMaxRotors];
    Jet controls[kControls];
    for (int c = 0; c < kControls; ++c) controls[c] = Jet(p[1][c], kNx + c);
    shared_.speeds(controls, speeds);
    const Jet dt_s = dt0_s_ * exp(Jet(p[2][0], kDtDirection));
    const StateVectorT<Jet> phi =
        physics_step<Jet>(shared_.jet_kernel, x, speeds, dt_s, shared_.substeps, shared_.gravity_W);
    for (int i = 0; i < kNx; ++i) {
      const double s = 1.0 / state_scale(i);
      residuals[i] = (p[3][i] - phi[i].a) * s;
      if (jacobians[0] != nullptr)
        for (int j = 0; j < kNx; ++j) jacobians[0][i * kNx + j] = -s * phi[i].v[j];
      if (jacobians[1] != nullptr)
        for (int c = 0; c < kControls; ++c)
          jacobians[1][i * kControls + c] = -s * phi[i].v[kNx + c];
      if (jacobians[2] != nullptr) jacobians[2][i] = -s * phi[i].v[kDtDirection];
      if (jacobians[3] != nullptr)
        for (int j = 0; j < kNx; ++j) jacobians[3][i * kNx + j] = i == j ? s : 0.0;
    }
    return true;
  }

 private:
  const Shared& shared_;
  double dt0_s_;  // the warm start's interval in this segment
};

/// p_k - (c + s_1 a y_g + s_2 b z_g), s_i = sin(sigma_i): the node in the gate's plane, inside
/// the shrunk opening for every sigma. Blocks: x_k (13), sigma (2).
class GateCost final : public ConstraintCost {
 public:
  GateCost(const Gate& gate, double margin_m)
      : center_(gate.center_m),
        half_width_axis_(gate.width_axis() * (0.5 * gate.width_m - margin_m)),
        half_height_axis_(gate.up_axis() * (0.5 * gate.height_m - margin_m)) {
    set_num_residuals(3);
    *mutable_parameter_block_sizes() = {kNx, 2};
  }

  void constraint(double const* const* p, double* c) const override {
    for (int i = 0; i < 3; ++i)
      c[i] = p[0][i] - center_[i] - std::sin(p[1][0]) * half_width_axis_[i] -
             std::sin(p[1][1]) * half_height_axis_[i];
  }

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    constraint(p, residuals);
    if (jacobians != nullptr) {
      if (jacobians[0] != nullptr) {
        std::fill(jacobians[0], jacobians[0] + 3 * kNx, 0.0);
        for (int i = 0; i < 3; ++i) jacobians[0][i * kNx + i] = 1.0;
      }
      if (jacobians[1] != nullptr) {
        for (int i = 0; i < 3; ++i) {
          jacobians[1][2 * i] = -std::cos(p[1][0]) * half_width_axis_[i];
          jacobians[1][2 * i + 1] = -std::cos(p[1][1]) * half_height_axis_[i];
        }
      }
    }
    return true;
  }

 private:
  Vec3 center_, half_width_axis_, half_height_axis_;
};

/// x_N - P x_0, scaled, P = the identity with the quaternion's sign `quaternion_sign`.
/// Blocks: x_0, x_N.
class PeriodicCost final : public ConstraintCost {
 public:
  explicit PeriodicCost(double quaternion_sign) {
    set_num_residuals(kNx);
    *mutable_parameter_block_sizes() = {kNx, kNx};
    for (int i = 0; i < kNx; ++i) {
      const bool q = i >= state_index::kQuaternion && i < state_index::kAngularVelocity;
      sign_[i] = q ? quaternion_sign : 1.0;
    }
  }

  void constraint(double const* const* p, double* c) const override {
    for (int i = 0; i < kNx; ++i) c[i] = (p[1][i] - sign_[i] * p[0][i]) / state_scale(i);
  }

  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    constraint(p, residuals);
    if (jacobians != nullptr) {
      for (int b = 0; b < 2; ++b) {
        if (jacobians[b] == nullptr) continue;
        std::fill(jacobians[b], jacobians[b] + kNx * kNx, 0.0);
        for (int i = 0; i < kNx; ++i)
          jacobians[b][i * kNx + i] = (b == 0 ? -sign_[i] : 1.0) / state_scale(i);
      }
    }
    return true;
  }

 private:
  double sign_[kNx];
};

/// sum_j T0_j exp(tau_j) - target, s: the lap's time. Blocks: tau_j (1 each).
class TotalTimeCost final : public ConstraintCost {
 public:
  TotalTimeCost(std::vector<double> warm_times_s, const double* target_s)
      : warm_times_s_(std::move(warm_times_s)), target_s_(target_s) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->assign(warm_times_s_.size(), 1);
  }
  void constraint(double const* const* p, double* c) const override {
    double total_s = 0.0;
    for (std::size_t j = 0; j < warm_times_s_.size(); ++j)
      total_s += warm_times_s_[j] * std::exp(p[j][0]);
    c[0] = total_s - *target_s_;
  }
  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    constraint(p, residuals);
    if (jacobians != nullptr) {
      for (std::size_t j = 0; j < warm_times_s_.size(); ++j)
        if (jacobians[j] != nullptr) jacobians[j][0] = warm_times_s_[j] * std::exp(p[j][0]);
    }
    return true;
  }

 private:
  std::vector<double> warm_times_s_;
  const double* target_s_;
};

void validate(const Track& track, const TimeOptimalOptions& o) {
  require(!track.gates.empty(), "time-optimal lap: track '", track.name, "' has no gates");
  require(track.closed && track.gates.size() >= 2,
          "time-optimal lap: a flying lap needs a closed track with at least 2 gates; track '",
          track.name, "' is ", track.closed ? "closed" : "open", " with ", track.gates.size(),
          " gate(s)");
  require(std::isfinite(o.gravity_m_s2) && o.gravity_m_s2 > 0.0,
          "time-optimal lap: gravity_m_s2: expected > 0, got ", o.gravity_m_s2);
  require(o.intervals >= 4 * static_cast<int>(track.gates.size()) && o.intervals <= 100000,
          "time-optimal lap: intervals: expected in [4 x gates = ", 4 * track.gates.size(),
          ", 100000], got ", o.intervals);
  if (!o.intervals_per_segment.empty()) {
    require(o.intervals_per_segment.size() == track.gates.size(),
            "time-optimal lap: intervals_per_segment: expected one count per segment (",
            track.gates.size(), " for the gates of '", track.name, "'), got ",
            o.intervals_per_segment.size());
    for (std::size_t j = 0; j < o.intervals_per_segment.size(); ++j)
      require(o.intervals_per_segment[j] >= 4 && o.intervals_per_segment[j] <= 100000,
              "time-optimal lap: intervals_per_segment[", j,
              "]: expected a count in [4, 100000], got ", o.intervals_per_segment[j]);
  }
  require(o.substeps >= 1 && o.substeps <= 100,
          "time-optimal lap: substeps: expected in [1, 100], got ", o.substeps);
  require(std::isfinite(o.gate_margin_m), "time-optimal lap: gate_margin_m: expected finite, got ",
          o.gate_margin_m);
  require(!o.warm_start_rhos.empty(), "time-optimal lap: warm_start_rhos: expected at least one");
  for (std::size_t i = 0; i < o.warm_start_rhos.size(); ++i)
    require(std::isfinite(o.warm_start_rhos[i]) && o.warm_start_rhos[i] > 0.0,
            "time-optimal lap: warm_start_rhos[", i, "]: expected > 0, got ", o.warm_start_rhos[i]);
  require(!o.warm_start_time_factors.empty(),
          "time-optimal lap: warm_start_time_factors: expected at least one");
  for (std::size_t i = 0; i < o.warm_start_time_factors.size(); ++i)
    require(std::isfinite(o.warm_start_time_factors[i]) && o.warm_start_time_factors[i] >= 0.1 &&
                o.warm_start_time_factors[i] <= 10.0,
            "time-optimal lap: warm_start_time_factors[", i, "]: expected in [0.1, 10], got ",
            o.warm_start_time_factors[i]);
  require(std::isfinite(o.constraint_tolerance) && o.constraint_tolerance > 0.0,
          "time-optimal lap: constraint_tolerance: expected > 0, got ", o.constraint_tolerance);
  require(o.max_outer_iterations >= 1 && o.max_inner_iterations >= 1,
          "time-optimal lap: max_outer_iterations and max_inner_iterations: expected >= 1, got ",
          o.max_outer_iterations, " and ", o.max_inner_iterations);
}

/// The waypoints of the warm start and the segments that make the lap: [first, last).
struct WarmStartPlan {
  std::vector<planning::Waypoint> waypoints;
  std::size_t first = 0, last = 0;
};

WarmStartPlan warm_start_plan(const Track& track) {
  WarmStartPlan plan;
  const double yaw = track.start_yaw_rad;
  const auto add = [&](const Vec3& p) { plan.waypoints.push_back({p, yaw, {}, {}}); };
  const std::size_t L = track.gates.size();
  // Three laps from the last gate, and the middle one: its ends are interior waypoints, so its
  // speed at the last gate is nearly the same at both ends (the flying lap's).
  add(track.gates.back().center_m);
  for (int lap = 0; lap < 3; ++lap)
    for (const Gate& g : track.gates) add(g.center_m);
  plan.first = L;
  plan.last = 2 * L;
  return plan;
}

/// The fastest full lap of a flown trajectory: when it starts (its passage of the last gate)
/// and its gate-to-gate times (segment j ends at gate j, as the periodic lap's).
struct FlownLap {
  double start_s = 0.0;
  std::vector<double> segment_s;
};

void validate_flown(const FlownTrajectory& f, int num_rotors) {
  const std::size_t n = f.times_s.size();
  require(n >= 2, "time-optimal lap: flown warm start: expected at least 2 samples, got ", n);
  require(f.states.size() == n && f.rotor_speeds_rad_s.size() == n,
          "time-optimal lap: flown warm start: expected ", n,
          " states and rotor speeds (one per time), got ", f.states.size(), " and ",
          f.rotor_speeds_rad_s.size());
  for (std::size_t i = 0; i < n; ++i) {
    require(std::isfinite(f.times_s[i]) && (i == 0 || f.times_s[i] > f.times_s[i - 1]),
            "time-optimal lap: flown warm start: times_s[", i,
            "]: expected finite and above the one before, got ", f.times_s[i]);
    require(f.states[i].allFinite(), "time-optimal lap: flown warm start: states[", i,
            "]: expected finite numbers");
    require(f.rotor_speeds_rad_s[i].size() == num_rotors && f.rotor_speeds_rad_s[i].allFinite(),
            "time-optimal lap: flown warm start: rotor_speeds_rad_s[", i, "]: expected ",
            num_rotors, " finite numbers, got ", f.rotor_speeds_rad_s[i].size());
  }
}

std::optional<FlownLap> find_fastest_lap(const Track& track, const FlownTrajectory& f) {
  // Every passage through a gate's opening, with its time (the plane crossing, interpolated).
  struct Passage {
    std::size_t gate;
    double t_s;
  };
  std::vector<Passage> passages;
  for (std::size_t i = 0; i + 1 < f.times_s.size(); ++i) {
    const Vec3 a = f.states[i].head<3>(), b = f.states[i + 1].head<3>();
    for (std::size_t g = 0; g < track.gates.size(); ++g) {
      const Gate& gate = track.gates[g];
      if (cross_gate(gate, a, b) != GateCrossing::kThrough) continue;
      const double da = gate.normal().dot(a - gate.center_m);
      const double db = gate.normal().dot(b - gate.center_m);
      const double s = da / (da - db);
      passages.push_back({g, f.times_s[i] + s * (f.times_s[i + 1] - f.times_s[i])});
    }
  }
  const std::size_t G = track.gates.size();
  std::optional<FlownLap> best;
  double best_lap_s = 0.0;
  for (std::size_t p = 0; p + G < passages.size(); ++p) {
    if (passages[p].gate != G - 1) continue;
    bool full = true;
    for (std::size_t g = 0; g < G; ++g) full = full && passages[p + 1 + g].gate == g;
    if (!full) continue;
    const double lap_s = passages[p + G].t_s - passages[p].t_s;
    if (best && lap_s >= best_lap_s) continue;
    best_lap_s = lap_s;
    FlownLap lap{passages[p].t_s, {}};
    for (std::size_t g = 0; g < G; ++g)
      lap.segment_s.push_back(passages[p + 1 + g].t_s - passages[p + g].t_s);
    best = lap;
  }
  return best;
}

FlownLap fastest_flown_lap(const Track& track, const FlownTrajectory& f) {
  std::optional<FlownLap> best = find_fastest_lap(track, f);
  require(best.has_value(), "time-optimal lap: flown warm start: no full lap through the ",
          track.gates.size(), " gates of '", track.name,
          "' (expected a passage of the last gate, then one of every gate in order)");
  return *best;
}

/// The flown trajectory at t, interpolated linearly between samples (the quaternion
/// renormalised); t is clamped to the flight.
std::pair<StateVector, RotorVector> flown_at(const FlownTrajectory& f, double t_s) {
  const auto upper = std::upper_bound(f.times_s.begin(), f.times_s.end(), t_s);
  const std::size_t i1 = std::clamp<std::size_t>(
      static_cast<std::size_t>(upper - f.times_s.begin()), 1, f.times_s.size() - 1);
  const std::size_t i0 = i1 - 1;
  const double w = std::clamp((t_s - f.times_s[i0]) / (f.times_s[i1] - f.times_s[i0]), 0.0, 1.0);
  StateVector x = (1.0 - w) * f.states[i0] + w * f.states[i1];
  if (f.states[i0]
          .segment<4>(state_index::kQuaternion)
          .dot(f.states[i1].segment<4>(state_index::kQuaternion)) < 0.0)
    x.segment<4>(state_index::kQuaternion) =
        (1.0 - w) * f.states[i0].segment<4>(state_index::kQuaternion) -
        w * f.states[i1].segment<4>(state_index::kQuaternion);
  x.segment<4>(state_index::kQuaternion).normalize();
  const RotorVector u = (1.0 - w) * f.rotor_speeds_rad_s[i0] + w * f.rotor_speeds_rad_s[i1];
  return {x, u};
}

/// The rotor speeds whose thrusts are the flight's mean thrusts over [a, b] (trapezoids over the
/// samples inside and the interpolated ends): held over the interval they give the flight's
/// impulse, where the speed at the middle misses every switch of the controls inside it.
RotorVector impulse_speeds(const FlownTrajectory& f, const VehicleModel& model, double a_s,
                           double b_s) {
  const int R = model.num_rotors();
  std::vector<double> t{a_s};
  for (double ts : f.times_s)
    if (ts > a_s && ts < b_s) t.push_back(ts);
  t.push_back(b_s);
  std::vector<double> impulse(static_cast<std::size_t>(R), 0.0);
  RotorVector prev = flown_at(f, t[0]).second;
  for (std::size_t i = 1; i < t.size(); ++i) {
    const RotorVector next = flown_at(f, t[i]).second;
    for (int r = 0; r < R; ++r)
      impulse[static_cast<std::size_t>(r)] +=
          0.5 * (t[i] - t[i - 1]) *
          (model.rotor(r).thrust(prev[r]) + model.rotor(r).thrust(next[r]));
    prev = next;
  }
  RotorVector w = prev;
  for (int r = 0; r < R; ++r)
    w[r] = model.rotor(r).speed_for_thrust(impulse[static_cast<std::size_t>(r)] / (b_s - a_s));
  return w;
}

planning::FeasibilityLimits rotor_limits_only(double gravity_m_s2) {
  planning::FeasibilityLimits limits;
  limits.max_tilt_rad = std::numbers::pi;
  limits.max_body_rate_rad_s = 1e6;
  limits.gravity_m_s2 = gravity_m_s2;
  return limits;
}

/// The fastest feasible minimum-snap lap and the three-lap plan it was cut from.
struct MinSnapPlan {
  MinSnapLap lap;
  planning::Trajectory three_laps;
};

MinSnapPlan min_snap_plan(const Track& track, const VehicleModel& model,
                          const TimeOptimalOptions& options) {
  const WarmStartPlan plan = warm_start_plan(track);
  planning::TimeAllocationOptions allocation;
  allocation.nominal_speed_m_s = 3.0;
  std::optional<MinSnapPlan> best;
  for (const double rho : options.warm_start_rhos) {
    const std::vector<double> times_s =
        planning::allocate_segment_times(plan.waypoints, rho, allocation);
    const planning::Trajectory full = planning::plan_min_snap(plan.waypoints, times_s);
    const planning::Trajectory lap(std::vector<planning::PolynomialSegment>(
        full.segments().begin() + static_cast<std::ptrdiff_t>(plan.first),
        full.segments().begin() + static_cast<std::ptrdiff_t>(plan.last)));
    const double scale = planning::feasible_time_scale(
        lap, model, rotor_limits_only(options.gravity_m_s2), 2e-3, 1e-4);
    const planning::Trajectory feasible = planning::time_scaled(lap, scale);
    if (!best || feasible.duration_s() < best->lap.lap_time_s)
      best = MinSnapPlan{MinSnapLap{feasible, feasible.duration_s(), scale},
                         planning::time_scaled(full, scale)};
  }
  return *best;
}

/// Records the state and rotor speeds every `every` physics steps.
class Recorder final : public LoopObserver {
 public:
  explicit Recorder(std::int64_t every) : every_(every) {}
  void observe(const ClosedLoop& loop) override {
    const Simulator& sim = loop.simulator();
    if (sim.step_count() % every_ != 0) return;
    flight.times_s.push_back(sim.time_s());
    flight.states.push_back(sim.state());
    flight.rotor_speeds_rad_s.push_back(sim.rotor_speeds_rad_s());
  }
  FlownTrajectory flight;

 private:
  std::int64_t every_;
};

/// The three-lap minimum-snap plan with its segment times times `time_factor`, flown in the
/// simulator (the same force terms, no motor lag, 1 ms RK4 steps, recorded every 10 ms) by the
/// SE(3) controller with angular and drag feed-forward; none when the run fails or holds no full
/// lap through the openings. A flight obeys the dynamics (to the recording's interpolation),
/// where the plan's flat states and rotor speeds sampled at the nodes do not: the flatness model
/// leaves out the drag terms, and a rotor speed held over an interval is not the flat one that
/// varies within it. Below 1 the plan is faster than the rotors allow; the controller then
/// saturates and cuts the corners, and its lap is a faster warm start.
std::optional<FlownTrajectory> fly_min_snap(const Track& track,
                                            const std::shared_ptr<const VehicleModel>& model,
                                            const TimeOptimalOptions& options,
                                            const planning::Trajectory& plan, double time_factor) {
  SimConfig config;
  config.dt_s = 1e-3;
  config.integrator = Integrator::kRk4;
  config.motor_dynamics = false;
  config.disturbances = options.switches;
  config.environment.gravity_W_m_s2 = Vec3(0.0, 0.0, -options.gravity_m_s2);
  // Eq. 3.29's gains with config/controllers/se3.yaml's faster attitude damping
  // (docs/controllers.md).
  Se3Gains gains = Se3Gains::thesis();
  gains.attitude_d << 0.8, 0.8, 0.05;
  gains.mass_kg = model->mass_kg();
  gains.gravity_m_s2 = options.gravity_m_s2;
  Se3Options se3;
  se3.gravity_compensation = true;
  se3.nonnegative_thrust = true;
  se3.angular_feed_forward = true;
  se3.drag_feed_forward = true;
  const planning::Trajectory flown_plan = planning::time_scaled(plan, time_factor);
  Simulator sim(model, config);
  StateVector start = StateVector::Zero();
  const planning::FlatOutput first = flown_plan.at(0.0);
  start.segment<3>(state_index::kPosition) = first.position_m;
  start.segment<4>(state_index::kQuaternion) = math::from_euler(0.0, 0.0, first.yaw_rad);
  sim.reset(start, model->hover_speeds_rad_s(options.gravity_m_s2));
  Se3Controller controller(model, gains, se3);
  const TrajectoryReference reference(flown_plan);
  ClosedLoop loop(sim, controller, reference, 1000.0);
  Recorder recorder(10);
  const StepResult result = loop.run(flown_plan.duration_s(), &recorder);
  if (!result.ok() || !find_fastest_lap(track, recorder.flight)) return std::nullopt;
  return std::move(recorder.flight);
}

}  // namespace

MinSnapLap min_snap_lap(const Track& track, const VehicleModel& model,
                        const TimeOptimalOptions& options) {
  validate(track, options);
  return min_snap_plan(track, model, options).lap;
}

namespace {

/// Stage 1 slows a flight by 1.25 at a time up to this factor before giving it up.
constexpr double kMaxStageOneScale = 2.0;

std::optional<TimeOptimalLap> solve_from(const Track& track, const VehicleModel& model,
                                         const TimeOptimalOptions& options, double margin_m,
                                         const FlownTrajectory& flown, const MinSnapLap& min_snap);

TimeOptimalLap solve(const Track& track, const VehicleModel& model,
                     const TimeOptimalOptions& options, const FlownTrajectory* given) {
  const auto started = std::chrono::steady_clock::now();
  validate(track, options);
  if (given != nullptr) validate_flown(*given, model.num_rotors());
  const double margin_m = options.gate_margin_m >= 0.0
                              ? options.gate_margin_m
                              : model.collision_shape().bounding_radius_m();
  for (std::size_t g = 0; g < track.gates.size(); ++g) {
    const Gate& gate = track.gates[g];
    require(std::min(gate.width_m, gate.height_m) > 2.0 * margin_m, "time-optimal lap: gate ", g,
            " ('", gate.name, "') opening ", gate.width_m, " m x ", gate.height_m,
            " m: expected wider than twice the margin of ", margin_m, " m");
  }

  const MinSnapPlan plan = min_snap_plan(track, model, options);
  std::vector<FlownTrajectory> flights;
  if (given != nullptr) {
    flights.push_back(*given);
  } else {
    const auto shared_model = std::make_shared<const VehicleModel>(model);
    for (const double factor : options.warm_start_time_factors)
      if (std::optional<FlownTrajectory> f =
              fly_min_snap(track, shared_model, options, plan.three_laps, factor))
        flights.push_back(std::move(*f));
    require(!flights.empty(),
            "time-optimal lap: the SE(3) controller flies no full lap of the minimum-snap plan "
            "of '",
            track.name, "' at any of warm_start_time_factors; give a flown warm start");
  }
  std::optional<TimeOptimalLap> best;
  int outer = 0, inner = 0;
  for (const FlownTrajectory& flown : flights) {
    std::optional<TimeOptimalLap> lap =
        solve_from(track, model, options, margin_m, flown, plan.lap);
    if (!lap) continue;
    outer += lap->outer_iterations;
    inner += lap->inner_iterations;
    if (!best || lap->lap_time_s < best->lap_time_s) best = std::move(lap);
  }
  require(best.has_value(), "time-optimal lap: no feasible lap from ",
          given != nullptr ? "the flown warm start" : "any flight of the minimum-snap plan",
          " up to ", kMaxStageOneScale, " times its segment times; check the model's rotor limits");
  best->outer_iterations = outer;
  best->inner_iterations = inner;
  best->solve_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return *best;
}

/// The lap solved from one flight (see the top of time_optimal_lap.hpp); none when stage 1
/// finds no feasible lap up to kMaxStageOneScale times its segment times.
std::optional<TimeOptimalLap> solve_from(const Track& track, const VehicleModel& model,
                                         const TimeOptimalOptions& options, double margin_m,
                                         const FlownTrajectory& flown, const MinSnapLap& min_snap) {
  TimeOptimalLap out(min_snap);
  out.gate_margin_m = margin_m;
  const FlownLap flown_lap = fastest_flown_lap(track, flown);
  out.warm_start_lap_time_s = 0.0;
  for (double t : flown_lap.segment_s) out.warm_start_lap_time_s += t;
  const double warm_total_s = out.warm_start_lap_time_s;
  const int R = model.num_rotors();
  const int segments = static_cast<int>(flown_lap.segment_s.size());

  // Intervals per segment in proportion to the warm start's times.
  std::vector<int> intervals;
  if (!options.intervals_per_segment.empty()) {
    intervals = options.intervals_per_segment;
  } else {
    for (int j = 0; j < segments; ++j) {
      const double share =
          flown_lap.segment_s[static_cast<std::size_t>(j)] / warm_total_s * options.intervals;
      intervals.push_back(std::max(4, static_cast<int>(std::lround(share))));
    }
  }
  int N = 0;
  for (const int n : intervals) N += n;
  std::vector<int> segment_of(static_cast<std::size_t>(N));
  std::vector<double> warm_time(static_cast<std::size_t>(N + 1));
  const std::vector<double>& T0 = flown_lap.segment_s;
  {
    int k = 0;
    double knot_s = 0.0;
    for (int j = 0; j < segments; ++j) {
      const auto J = static_cast<std::size_t>(j);
      for (int i = 0; i < intervals[J]; ++i, ++k) {
        segment_of[static_cast<std::size_t>(k)] = j;
        warm_time[static_cast<std::size_t>(k)] =
            knot_s + T0[J] * i / static_cast<double>(intervals[J]);
      }
      knot_s += T0[J];
    }
    warm_time[static_cast<std::size_t>(N)] = warm_total_s;
    int node = 0;
    for (int j = 0; j < segments; ++j) {
      node += intervals[static_cast<std::size_t>(j)];
      out.gate_nodes.push_back(node);
    }
  }

  // Unknowns: the states, the controls (Shared::speeds keeps every rotor inside its limits
  // without Ceres's box bounds, on which a projected Levenberg-Marquardt step stalls), tau (the
  // segment times' log-scale) and sigma (the gate crossings, 0: through the centre).
  std::vector<StateVector> x(static_cast<std::size_t>(N + 1));
  std::vector<Eigen::Vector4d> v(static_cast<std::size_t>(N), Eigen::Vector4d::Zero());
  std::vector<double> tau(static_cast<std::size_t>(segments), 0.0);
  std::vector<Eigen::Vector2d> sigma(track.gates.size(), Eigen::Vector2d::Zero());
  const Shared shared(model, options);

  // The flown lap `scale` times slower: its states at the nodes with velocities and rates over
  // scale, its rotor speeds at the intervals' middles.
  const auto initialise = [&](double scale) {
    for (int k = 0; k <= N; ++k) {
      const auto K = static_cast<std::size_t>(k);
      StateVector& xk = x[K];
      xk = flown_at(flown, flown_lap.start_s + warm_time[K]).first;
      xk.segment<3>(state_index::kVelocity) /= scale;
      xk.segment<3>(state_index::kAngularVelocity) /= scale;
      // Keep the quaternion's sign continuous from node to node.
      if (k > 0 && xk.segment<4>(state_index::kQuaternion)
                           .dot(x[K - 1].segment<4>(state_index::kQuaternion)) < 0.0)
        xk.segment<4>(state_index::kQuaternion) *= -1.0;
      if (k < N) {
        shared.controls_of(impulse_speeds(flown, model, flown_lap.start_s + warm_time[K],
                                          flown_lap.start_s + warm_time[K + 1]),
                           v[K].data());
      }
    }
    for (double& t : tau) t = std::log(scale);
    for (Eigen::Vector2d& g : sigma) g.setZero();
  };
  initialise(1.0);

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::ProductManifold<ceres::EuclideanManifold<6>, ceres::QuaternionManifold,
                         ceres::EuclideanManifold<3>>
      state_manifold{ceres::EuclideanManifold<6>(), ceres::QuaternionManifold(),
                     ceres::EuclideanManifold<3>()};
  struct Block {
    const ConstraintCost* cost;
    std::vector<double*> parameters;
  };
  std::vector<Block> constraints;
  const auto add_constraint = [&](ConstraintCost* cost, std::vector<double*> parameters) {
    problem.AddResidualBlock(cost, nullptr, parameters);
    constraints.push_back({cost, std::move(parameters)});
  };
  for (int k = 0; k < N; ++k) {
    const auto K = static_cast<std::size_t>(k);
    const auto J = static_cast<std::size_t>(segment_of[K]);
    add_constraint(new DefectCost(shared, intervals[J], T0[J]),
                   {x[K].data(), v[K].data(), &tau[J], x[K + 1].data()});
  }
  for (std::size_t g = 0; g < track.gates.size(); ++g) {
    // Gate g is crossed at the end of segment g; the lap's end node is a copy of its start
    // node, so its last gate goes on node 0.
    const auto at =
        g + 1 == track.gates.size() ? std::size_t{0} : static_cast<std::size_t>(out.gate_nodes[g]);
    add_constraint(new GateCost(track.gates[g], margin_m), {x[at].data(), sigma[g].data()});
  }
  {
    const double sign =
        x[0].segment<4>(state_index::kQuaternion)
                    .dot(x[static_cast<std::size_t>(N)].segment<4>(state_index::kQuaternion)) < 0.0
            ? -1.0
            : 1.0;
    add_constraint(new PeriodicCost(sign), {x[0].data(), x[static_cast<std::size_t>(N)].data()});
  }
  for (auto& xk : x) problem.SetManifold(xk.data(), &state_manifold);

  ceres::Solver::Options solver;
  solver.minimizer_type = ceres::TRUST_REGION;
  solver.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver.sparse_linear_algebra_library_type =
      ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) ? ceres::SUITE_SPARSE
                                                                            : ceres::EIGEN_SPARSE;
  solver.num_threads = 1;
  solver.max_num_iterations = options.max_inner_iterations;
  solver.function_tolerance = 1e-16;
  solver.gradient_tolerance = 1e-16;
  solver.parameter_tolerance = 1e-14;
  solver.logging_type = ceres::SILENT;

  std::vector<double> c(static_cast<std::size_t>(kNx));
  const auto violation = [&] {
    double worst = 0.0;
    for (const Block& b : constraints) {
      b.cost->constraint(b.parameters.data(), c.data());
      for (int i = 0; i < b.cost->num_residuals(); ++i)
        worst = std::max(worst, std::abs(c[static_cast<std::size_t>(i)]));
    }
    return worst;
  };
  const auto total_time = [&] {
    double t = 0.0;
    for (std::size_t j = 0; j < T0.size(); ++j) t += T0[j] * std::exp(tau[j]);
    return t;
  };
  const auto run = [&] {
    ceres::Solver::Summary summary;
    ceres::Solve(solver, &problem, &summary);
    ++out.outer_iterations;
    out.inner_iterations += static_cast<int>(summary.iterations.size());
    return violation() <= options.constraint_tolerance;
  };

  // Stage 1: a feasible lap from the flown one `scale` times slower, its segment times free (a
  // lap flown with rotor speeds that change within an interval is not feasible with them held
  // at its exact times); slowed by 1.25 at a time until one is found.
  double scale = 1.0;
  int solves = 0;
  for (;;) {
    initialise(scale);
    ++solves;
    if (run()) break;
    scale *= 1.25;
    if (scale > kMaxStageOneScale || solves >= options.max_outer_iterations) return std::nullopt;
  }
  // Stage 2: the total time a constraint; bisect it between the shortest feasible one found
  // (hi) and one found infeasible (lo), each solve starting from the best feasible lap flown
  // faster (velocities and rates over r, positions, attitudes and controls kept).
  struct Solution {
    std::vector<StateVector> x;
    std::vector<Eigen::Vector4d> v;
    std::vector<double> tau;
    std::vector<Eigen::Vector2d> sigma;
  };
  Solution best{x, v, tau, sigma};
  double hi = total_time(), lo = 0.0;
  double target_s = hi;
  add_constraint(new TotalTimeCost(T0, &target_s), [&] {
    std::vector<double*> p;
    for (double& t : tau) p.push_back(&t);
    return p;
  }());
  const auto attempt = [&](double total_s) {
    const double r = total_s / hi;
    x = best.x;
    v = best.v;
    sigma = best.sigma;
    for (std::size_t j = 0; j < tau.size(); ++j) tau[j] = best.tau[j] + std::log(r);
    for (StateVector& xk : x) {
      xk.segment<3>(state_index::kVelocity) /= r;
      xk.segment<3>(state_index::kAngularVelocity) /= r;
    }
    target_s = total_s;
    return run();
  };
  // Shrink by 0.8 until infeasible, then bisect.
  while (lo == 0.0 && solves < options.max_outer_iterations) {
    ++solves;
    const double trial = 0.8 * hi;
    if (attempt(trial)) {
      best = {x, v, tau, sigma};
      hi = trial;
    } else {
      lo = trial;
    }
  }
  while (hi - lo > options.scale_tolerance * hi && solves < options.max_outer_iterations) {
    ++solves;
    const double mid = 0.5 * (lo + hi);
    if (attempt(mid)) {
      best = {x, v, tau, sigma};
      hi = mid;
    } else {
      lo = mid;
    }
  }
  x = best.x;
  v = best.v;
  tau = best.tau;
  sigma = best.sigma;
  target_s = hi;
  out.max_violation = violation();
  out.converged = out.max_violation <= options.constraint_tolerance;
  out.lap_time_s = 0.0;
  out.segment_times_s.resize(T0.size());
  for (std::size_t j = 0; j < T0.size(); ++j) {
    out.segment_times_s[j] = T0[j] * std::exp(tau[j]);
    out.lap_time_s += out.segment_times_s[j];
  }
  out.states = x;
  out.rotor_speeds_rad_s.assign(static_cast<std::size_t>(N), RotorVector(R));
  for (int k = 0; k < N; ++k) {
    double w[kMaxRotors];
    shared.speeds(v[static_cast<std::size_t>(k)].data(), w);
    for (int r = 0; r < R; ++r) out.rotor_speeds_rad_s[static_cast<std::size_t>(k)][r] = w[r];
  }
  out.times_s.assign(static_cast<std::size_t>(N + 1), 0.0);
  for (int k = 0; k < N; ++k) {
    const auto J = static_cast<std::size_t>(segment_of[static_cast<std::size_t>(k)]);
    out.times_s[static_cast<std::size_t>(k + 1)] =
        out.times_s[static_cast<std::size_t>(k)] + out.segment_times_s[J] / intervals[J];
  }
  return out;
}

}  // namespace

TimeOptimalLap solve_time_optimal_lap(const Track& track, const VehicleModel& model,
                                      const TimeOptimalOptions& options) {
  return solve(track, model, options, nullptr);
}

TimeOptimalLap solve_time_optimal_lap(const Track& track, const VehicleModel& model,
                                      const TimeOptimalOptions& options,
                                      const FlownTrajectory& flown) {
  return solve(track, model, options, &flown);
}

}  // namespace dronetwin
