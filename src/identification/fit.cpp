// Parameter identification with Ceres (fit.hpp): equation error, multiple-shooting output error
// and motor lag, reweighted per channel, with Ceres' covariance for the standard errors.
#include "dronetwin/identification/fit.hpp"

#include <ceres/ceres.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <sstream>

#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/force_kernel.hpp"
#include "dronetwin/dynamics/motor.hpp"
#include "dronetwin/identification/parameter_map.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {
namespace {

using Theta = ParameterMap::Theta;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---- data ------------------------------------------------------------------------------------

struct Split {
  std::vector<int> fit, holdout;  // interval start rows k (interval k -> k+1)
  std::size_t gaps = 0, contact_rows = 0, excluded_rows = 0;
  double median_dt_s = 0.0;
};

Split split_intervals(const FlightData& d, const FitOptions& o) {
  Split s;
  const std::size_t n = d.t_s.size();
  std::vector<double> dts;
  for (std::size_t k = 0; k + 1 < n; ++k) dts.push_back(d.t_s[k + 1] - d.t_s[k]);
  require(!dts.empty(), d.source, ": a fit needs at least two rows, the log has ", n);
  std::vector<double> sorted = dts;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2),
                   sorted.end());
  s.median_dt_s = sorted[sorted.size() / 2];
  for (char c : d.in_contact) s.contact_rows += c ? 1 : 0;
  std::vector<char> excluded(n, 0);
  for (std::size_t k = 0; k < n; ++k) {
    excluded[k] = d.state[k][2] < o.min_height_m ||
                  d.rotor_speed_rad_s[k].minCoeff() < o.min_rotor_speed_rad_s;
    s.excluded_rows += excluded[k] ? 1 : 0;
  }
  const double t_split =
      d.t_s.front() + (1.0 - o.holdout_fraction) * (d.t_s.back() - d.t_s.front());
  for (std::size_t k = 0; k + 1 < n; ++k) {
    if (dts[k] > o.max_gap_factor * s.median_dt_s) {
      ++s.gaps;
      continue;
    }
    if (d.in_contact[k] || d.in_contact[k + 1] || excluded[k] || excluded[k + 1]) continue;
    (d.t_s[k + 1] <= t_split ? s.fit : s.holdout).push_back(static_cast<int>(k));
  }
  return s;
}

// Windows of `len` consecutive usable intervals starting at interval indices from `intervals`
// (which must be contiguous row-wise), at most `max_count`, spread evenly.
std::vector<int> pick_windows(const std::vector<int>& intervals, int len, int max_count) {
  std::vector<int> starts;
  if (len <= 0 || max_count <= 0) return starts;
  for (std::size_t i = 0; i + static_cast<std::size_t>(len) <= intervals.size();) {
    const int k0 = intervals[i];
    if (intervals[i + static_cast<std::size_t>(len) - 1] == k0 + len - 1) {
      starts.push_back(k0);
      i += static_cast<std::size_t>(len);  // windows do not overlap
    } else {
      ++i;
    }
  }
  if (static_cast<int>(starts.size()) <= max_count) return starts;
  std::vector<int> picked;
  for (int j = 0; j < max_count; ++j) {
    picked.push_back(starts[static_cast<std::size_t>(
        (static_cast<double>(j) + 0.5) * static_cast<double>(starts.size()) / max_count)]);
  }
  return picked;
}

// ---- residual functors -----------------------------------------------------------------------

// Maps the free parameter block into the full theta (the others fixed at their values).
struct ThetaMap {
  std::vector<int> free;  // indices into theta of the free parameters, in block order
  Theta fixed{};
  template <class T>
  std::array<T, kNumModelParameters> full(const T* block) const {
    std::array<T, kNumModelParameters> th;
    for (int j = 0; j < kNumModelParameters; ++j)
      th[static_cast<std::size_t>(j)] = T(fixed[static_cast<std::size_t>(j)]);
    for (std::size_t i = 0; i < free.size(); ++i) th[static_cast<std::size_t>(free[i])] = block[i];
    return th;
  }
};

struct Weights {
  double linear = 1.0, angular = 1.0, position = 1.0, velocity = 1.0, attitude = 1.0, rate = 1.0,
         motor = 1.0;
};

// The flight's conditions every residual needs: the parameter map, which terms the log was flown
// with, and the air and gravity.
struct Physics {
  const ParameterMap* pm;
  DisturbanceSwitches switches;
  Environment environment;
  /// The force kernel of the model at theta (the fit's unknowns, double or Jet).
  template <class T>
  ForceKernel<T> kernel_at(const std::array<T, kNumModelParameters>& theta) const {
    return ForceKernel<T>(pm->model_at(theta.data()), ForceTerms::of(switches));
  }
};

// Equation error on a chunk of intervals: 6 residuals each.
struct EquationError {
  const Physics* physics;
  const FlightData* d;
  const ThetaMap* map;
  std::vector<int> intervals;
  Weights w;
  template <class T>
  bool operator()(T const* const* params, T* res) const {
    const ForceKernel<T> kernel = physics->kernel_at(map->full<T>(params[0]));
    const Environment& env = physics->environment;
    HeldRotorTerms<T> held;
    for (std::size_t i = 0; i < intervals.size(); ++i) {
      const auto k = static_cast<std::size_t>(intervals[i]);
      const double dt = d->t_s[k + 1] - d->t_s[k];
      kernel.prepare(d->rotor_speed_rad_s[k], held);  // speeds held over the interval
      const StateVectorT<T> f0 = kernel.derivative(held, d->state[k], env);
      const StateVectorT<T> f1 = kernel.derivative(held, d->state[k + 1], env);
      const bool accelerometer = !d->specific_force_W_m_s2.empty();
      for (int a = 0; a < 3; ++a) {
        const double dv =
            accelerometer
                ? 0.5 * (d->specific_force_W_m_s2[k][a] + d->specific_force_W_m_s2[k + 1][a]) +
                      env.gravity_W_m_s2[a]
                : (d->state[k + 1][3 + a] - d->state[k][3 + a]) / dt;
        res[6 * i + static_cast<std::size_t>(a)] =
            w.linear * (dv - T(0.5) * (f0[3 + a] + f1[3 + a]));
        if (d->has_body_rates) {
          const double dw = (d->state[k + 1][10 + a] - d->state[k][10 + a]) / dt;
          res[6 * i + 3 + static_cast<std::size_t>(a)] =
              w.angular * (dw - T(0.5) * (f0[10 + a] + f1[10 + a]));
        } else {
          res[6 * i + 3 + static_cast<std::size_t>(a)] = T(0.0);  // no rates logged: channel unused
        }
      }
    }
    return true;
  }
};

// Motor lag on a chunk of intervals: one residual per rotor (Eq. 2.45 with rise/fall switch).
struct MotorLag {
  const FlightData* d;
  const ThetaMap* map;
  const VehicleModel* model;
  double tau_rise_unit = 1.0, tau_fall_unit = 1.0;
  std::vector<int> intervals;
  Weights w;
  template <class T>
  bool operator()(T const* const* params, T* res) const {
    const auto th = map->full<T>(params[0]);
    const T tau_rise = th[static_cast<std::size_t>(ModelParameter::kTauRise)] * tau_rise_unit;
    const T tau_fall = th[static_cast<std::size_t>(ModelParameter::kTauFall)] * tau_fall_unit;
    const int nr = d->num_rotors;
    for (std::size_t i = 0; i < intervals.size(); ++i) {
      const auto k = static_cast<std::size_t>(intervals[i]);
      const double dt = d->t_s[k + 1] - d->t_s[k];
      const T decay_rise = motor_decay(tau_rise, dt), decay_fall = motor_decay(tau_fall, dt);
      for (int r = 0; r < nr; ++r) {
        const double w0 = d->rotor_speed_rad_s[k][r];
        const double ref = clamp_speed(model->rotor(r), d->rotor_reference_rad_s[k][r]);
        res[i * static_cast<std::size_t>(nr) + static_cast<std::size_t>(r)] =
            w.motor * (d->rotor_speed_rad_s[k + 1][r] -
                       motor_speed_after(decay_rise, decay_fall, ref, w0));  // Eq. 2.45
      }
    }
    return true;
  }
};

// Output error over one window of `len` intervals from row k0: 12 residuals per row reached.
struct OutputError {
  const Physics* physics;
  const FlightData* d;
  const ThetaMap* map;
  int k0 = 0, len = 0;
  Weights w;
  // Longer log intervals are integrated in substeps of at most this (the thesis physics step).
  static constexpr double kMaxSubstep_s = 1.0e-3;
  template <class T>
  bool operator()(T const* const* params, T* res) const {
    const ForceKernel<T> kernel = physics->kernel_at(map->full<T>(params[0]));
    const Environment& env = physics->environment;
    HeldRotorTerms<T> held;
    StateVectorT<T> x = d->state[static_cast<std::size_t>(k0)].template cast<T>();
    for (int j = 0; j < len; ++j) {
      const auto k = static_cast<std::size_t>(k0 + j);
      const double dt_total = d->t_s[k + 1] - d->t_s[k];
      const int sub = std::max(1, static_cast<int>(std::ceil(dt_total / kMaxSubstep_s - 1e-9)));
      const T h(dt_total / sub);
      kernel.prepare(d->rotor_speed_rad_s[k], held);
      const auto f = [&](const StateVectorT<T>& xs) { return kernel.derivative(held, xs, env); };
      for (int s = 0; s < sub; ++s) {  // RK4 with the rotor speeds held, as the simulator steps
        const StateVectorT<T> k1 = f(x);
        const StateVectorT<T> k2 = f(StateVectorT<T>(x + (h / T(2)) * k1));
        const StateVectorT<T> k3 = f(StateVectorT<T>(x + (h / T(2)) * k2));
        const StateVectorT<T> k4 = f(StateVectorT<T>(x + h * k3));
        x += (h / T(6)) * (k1 + T(2) * k2 + T(2) * k3 + k4);
        const T qn = x.template segment<4>(6).norm();
        x.template segment<4>(6) /= qn;
      }
      const StateVector& y = d->state[k + 1];
      T* r = res + 12 * static_cast<std::size_t>(j);
      for (int a = 0; a < 3; ++a) {
        r[a] = w.position * (x[a] - y[a]);
        r[3 + a] = w.velocity * (x[3 + a] - y[3 + a]);
        r[9 + a] = w.rate * (x[10 + a] - y[10 + a]);
      }
      // attitude: 2 vec(q_log^-1 (x) q_pred), sign chosen so the scalar part is positive
      const Vector4<T> qc(T(y[6]), T(-y[7]), T(-y[8]), T(-y[9]));
      const Vector4<T> e = math::multiply<T>(qc, Vector4<T>(x.template segment<4>(6)));
      const T sign = e[0] < T(0) ? T(-2) : T(2);
      for (int a = 0; a < 3; ++a) r[6 + a] = w.attitude * sign * e[1 + a];
    }
    return true;
  }
};

template <int kStride, class F>
ceres::CostFunction* make_cost_with_stride(F* f, int num_free, int num_residuals) {
  auto* c = new ceres::DynamicAutoDiffCostFunction<F, kStride>(f);
  c->AddParameterBlock(num_free);
  c->SetNumResiduals(num_residuals);
  return c;
}

// The Jet width (parameters differentiated per pass) follows the number of free parameters, so
// a 3-parameter fit does not pay for 16-wide Jets. Multiples of 4 keep Eigen's vectorised Jet
// arithmetic (an odd width such as 13 measured 50 % slower than 12); 17 parameters take 2 passes.
template <class F>
ceres::CostFunction* make_cost(F* f, int num_free, int num_residuals) {
  if (num_free <= 4) return make_cost_with_stride<4>(f, num_free, num_residuals);
  if (num_free <= 8) return make_cost_with_stride<8>(f, num_free, num_residuals);
  if (num_free <= 12) return make_cost_with_stride<12>(f, num_free, num_residuals);
  return make_cost_with_stride<16>(f, num_free, num_residuals);
}

constexpr int kChunk = 64;  // intervals per equation-error / motor residual block

// ---- the problem -----------------------------------------------------------------------------

struct Setup {
  const VehicleModel* model;
  const FlightData* d;
  const Physics* physics;
  ThetaMap map;
  bool use_eq = false, use_out = false, use_motor = false;
  int window_len = 0;
  double tau_rise_unit = 1.0, tau_fall_unit = 1.0;
};

struct Channels {  // sums of squares and counts per channel (unweighted)
  double lin = 0, ang = 0, pos = 0, vel = 0, att = 0, rate = 0, mot = 0;
  std::size_t n_eq = 0, n_out = 0, n_mot = 0;
};

// Unweighted residuals of every channel at `block`, on `intervals` and `windows`.
Channels evaluate(const Setup& s, const std::vector<double>& block,
                  const std::vector<int>& intervals, const std::vector<int>& windows, bool eq,
                  bool out, bool motor) {
  Channels c;
  const double* p[1] = {block.data()};
  if (eq) {
    EquationError f{s.physics, s.d, &s.map, intervals, Weights{}};
    std::vector<double> r(6 * intervals.size());
    f(p, r.data());
    for (std::size_t i = 0; i < intervals.size(); ++i) {
      for (int a = 0; a < 3; ++a) {
        c.lin += r[6 * i + static_cast<std::size_t>(a)] * r[6 * i + static_cast<std::size_t>(a)];
        c.ang +=
            r[6 * i + 3 + static_cast<std::size_t>(a)] * r[6 * i + 3 + static_cast<std::size_t>(a)];
      }
    }
    c.n_eq = 3 * intervals.size();
    if (!s.d->has_body_rates) c.ang = kNaN;
  }
  if (motor) {
    MotorLag f{s.d, &s.map, s.model, s.tau_rise_unit, s.tau_fall_unit, intervals, Weights{}};
    std::vector<double> r(static_cast<std::size_t>(s.d->num_rotors) * intervals.size());
    f(p, r.data());
    for (double v : r) c.mot += v * v;
    c.n_mot = r.size();
  }
  if (out) {
    for (int k0 : windows) {
      OutputError f{s.physics, s.d, &s.map, k0, s.window_len, Weights{}};
      std::vector<double> r(12 * static_cast<std::size_t>(s.window_len));
      f(p, r.data());
      for (int j = 0; j < s.window_len; ++j) {
        for (int a = 0; a < 3; ++a) {
          const auto b = 12 * static_cast<std::size_t>(j) + static_cast<std::size_t>(a);
          c.pos += r[b] * r[b];
          c.vel += r[b + 3] * r[b + 3];
          c.att += r[b + 6] * r[b + 6];
          c.rate += r[b + 9] * r[b + 9];
        }
      }
      c.n_out += 3 * static_cast<std::size_t>(s.window_len);
    }
  }
  return c;
}

double rms(double sum_sq, std::size_t n) {
  return n ? std::sqrt(sum_sq / static_cast<double>(n)) : kNaN;
}

ResidualStats stats_of(const Channels& c, std::size_t intervals) {
  ResidualStats r;
  r.intervals = intervals;
  r.linear_acceleration_m_s2 = rms(c.lin, c.n_eq);
  r.angular_acceleration_rad_s2 = rms(c.ang, c.n_eq);
  r.position_m = rms(c.pos, c.n_out);
  r.attitude_rad = rms(c.att, c.n_out);
  r.motor_speed_rad_s = rms(c.mot, c.n_mot);
  return r;
}

// 1 / RMS per channel. The RMS is floored at a resolution per channel (well below any real
// sensor's noise), so a noise-free synthetic log, whose residuals at the optimum are round-off,
// does not get weights of 1e15 that swamp the other channels and the covariance conditioning.
Weights weights_from(const Channels& c) {
  const auto inv = [](double sum_sq, std::size_t n, double floor) {
    const double r = rms(sum_sq, n);
    return std::isfinite(r) ? 1.0 / std::max(r, floor) : 1.0;
  };
  Weights w;
  w.linear = inv(c.lin, c.n_eq, 1e-4);     // m/s^2
  w.angular = inv(c.ang, c.n_eq, 1e-4);    // rad/s^2
  w.position = inv(c.pos, c.n_out, 1e-6);  // m
  w.velocity = inv(c.vel, c.n_out, 1e-5);  // m/s
  w.attitude = inv(c.att, c.n_out, 1e-6);  // rad
  w.rate = inv(c.rate, c.n_out, 1e-5);     // rad/s
  w.motor = inv(c.mot, c.n_mot, 1e-3);     // rad/s
  return w;
}

void add_costs(ceres::Problem& problem, double* block, const Setup& s, const std::vector<int>& fit,
               const std::vector<int>& windows, const Weights& w, bool eq, bool out, bool motor) {
  const int nf = static_cast<int>(s.map.free.size());
  for (std::size_t i = 0; i < fit.size(); i += kChunk) {
    const std::vector<int> chunk(fit.begin() + static_cast<long>(i),
                                 fit.begin() + static_cast<long>(std::min(fit.size(), i + kChunk)));
    if (eq) {
      problem.AddResidualBlock(make_cost(new EquationError{s.physics, s.d, &s.map, chunk, w}, nf,
                                         6 * static_cast<int>(chunk.size())),
                               nullptr, block);
    }
    if (motor) {
      problem.AddResidualBlock(
          make_cost(new MotorLag{s.d, &s.map, s.model, s.tau_rise_unit, s.tau_fall_unit, chunk, w},
                    nf, s.d->num_rotors * static_cast<int>(chunk.size())),
          nullptr, block);
    }
  }
  if (out) {
    for (int k0 : windows) {
      problem.AddResidualBlock(
          make_cost(new OutputError{s.physics, s.d, &s.map, k0, s.window_len, w}, nf,
                    12 * s.window_len),
          nullptr, block);
    }
  }
}

struct SolveOutcome {
  int iterations = 0;
  std::string termination;
  bool usable = false;
  Eigen::MatrixXd covariance;   // of the free block, scaled by sigma^2; empty on failure
  Eigen::MatrixXd information;  // J^T J of the weighted problem (for excitation diagnostics)
};

SolveOutcome solve(const Setup& s, std::vector<double>& block, const std::vector<int>& fit,
                   const std::vector<int>& windows, const Weights& w, bool eq, bool out, bool motor,
                   const FitOptions& o, bool with_covariance) {
  ceres::Problem::Options po;
  ceres::Problem problem(po);
  add_costs(problem, block.data(), s, fit, windows, w, eq, out, motor);
  ceres::Solver::Options so;
  // Normal equations: the Jacobian is tall (10^5 rows) and thin (<= 17 columns), so forming J^T J
  // blockwise is far cheaper than a dense QR of J, and Jacobi scaling keeps it well conditioned.
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  so.max_num_iterations = o.max_iterations;
  so.num_threads = o.num_threads;
  so.function_tolerance = 1e-10;
  so.gradient_tolerance = 1e-12;
  so.parameter_tolerance = 1e-10;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  SolveOutcome outcome;
  outcome.iterations = static_cast<int>(summary.iterations.size()) - 1;
  outcome.termination = ceres::TerminationTypeToString(summary.termination_type);
  outcome.usable = summary.IsSolutionUsable();
  if (!with_covariance || !outcome.usable) return outcome;

  const int nf = static_cast<int>(block.size());
  const int dof = summary.num_residuals - nf;
  const double sigma2 = dof > 0 ? 2.0 * summary.final_cost / dof : kNaN;

  // J^T J from the Jacobian, for the excitation analysis.
  ceres::CRSMatrix jac;
  double cost = 0.0;
  problem.Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, &jac);
  outcome.information = Eigen::MatrixXd::Zero(nf, nf);
  for (int row = 0; row < jac.num_rows; ++row) {
    for (int a = jac.rows[static_cast<std::size_t>(row)];
         a < jac.rows[static_cast<std::size_t>(row) + 1]; ++a) {
      for (int b = jac.rows[static_cast<std::size_t>(row)];
           b < jac.rows[static_cast<std::size_t>(row) + 1]; ++b) {
        outcome.information(jac.cols[static_cast<std::size_t>(a)],
                            jac.cols[static_cast<std::size_t>(b)]) +=
            jac.values[static_cast<std::size_t>(a)] * jac.values[static_cast<std::size_t>(b)];
      }
    }
  }

  // Ceres refuses (and logs an error to stderr) when the reciprocal condition number of J^T J is
  // below its threshold; test that first on our J^T J, so a rank-deficient fit is reported in
  // the result only.
  ceres::Covariance::Options co;
  const Eigen::VectorXd eig =
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(outcome.information, Eigen::EigenvaluesOnly)
          .eigenvalues();
  if (!(eig.minCoeff() > 10.0 * co.min_reciprocal_condition_number * eig.maxCoeff())) {
    return outcome;
  }
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = 0;  // rank-deficient: fail (reported), rather than a pseudo-inverse
  co.num_threads = o.num_threads;
  ceres::Covariance covariance(co);
  std::vector<std::pair<const double*, const double*>> blocks{{block.data(), block.data()}};
  if (covariance.Compute(blocks, &problem)) {
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> c(nf, nf);
    if (covariance.GetCovarianceBlock(block.data(), block.data(), c.data())) {
      outcome.covariance = sigma2 * c;
    }
  }
  return outcome;
}

std::string fmt(double v, int digits = 6) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

}  // namespace

FlightData flight_data_from_log(const LogTable& log, int num_rotors, bool prefer_measured) {
  static const char* kStateNames[kStateSize] = {"x",  "y",  "z",  "vx", "vy", "vz", "qw",
                                                "qx", "qy", "qz", "wx", "wy", "wz"};
  require(num_rotors >= 1 && num_rotors <= kMaxRotors, log.source, ": num_rotors must be in [1, ",
          kMaxRotors, "], got ", num_rotors);
  FlightData d;
  d.source = log.source;
  d.num_rotors = num_rotors;
  const auto has = [&](const std::string& name) {
    return std::find(log.columns.begin(), log.columns.end(), name) != log.columns.end();
  };
  d.used_measured = prefer_measured && has("meas_x");
  const std::string prefix = d.used_measured ? "meas_" : "";
  d.has_body_rates = has(prefix + "wx");
  const int state_columns = d.has_body_rates ? kStateSize : 10;
  std::array<std::size_t, kStateSize> cs{};
  for (int i = 0; i < state_columns; ++i)
    cs[static_cast<std::size_t>(i)] = log.column(prefix + kStateNames[i]);
  const bool has_acc = has("acc_x");
  std::array<std::size_t, 3> ca{};
  if (has_acc) ca = {log.column("acc_x"), log.column("acc_y"), log.column("acc_z")};
  const std::size_t ct = log.column("t");
  std::vector<std::size_t> cw, cr;
  for (int i = 0; i < num_rotors; ++i) cw.push_back(log.column("omega_" + std::to_string(i)));
  const bool has_ref = has("omega_ref_0");
  if (has_ref) {
    for (int i = 0; i < num_rotors; ++i) cr.push_back(log.column("omega_ref_" + std::to_string(i)));
  }
  const bool has_contact = has("in_contact");
  const std::size_t cc = has_contact ? log.column("in_contact") : 0;
  const std::size_t n = log.rows();
  for (std::size_t row = 0; row < n; ++row) {
    const double t = log.at(row, ct);
    require(std::isfinite(t), log.source, ": row ", row + 1, ": t is not finite");
    require(d.t_s.empty() || t > d.t_s.back(), log.source, ": row ", row + 1, ": t = ", t,
            " does not increase (previous ", d.t_s.empty() ? 0.0 : d.t_s.back(), ")");
    StateVector x = StateVector::Zero();
    for (int i = 0; i < state_columns; ++i) {
      x[i] = log.at(row, cs[static_cast<std::size_t>(i)]);
      require(std::isfinite(x[i]), log.source, ": row ", row + 1, ": column ",
              log.columns[cs[static_cast<std::size_t>(i)]], " is not finite");
    }
    const double qn = x.segment<4>(6).norm();
    require(qn > 0.5 && qn < 1.5, log.source, ": row ", row + 1, ": quaternion norm ", qn,
            " is not near 1");
    x.segment<4>(6) /= qn;
    RotorVector w(num_rotors), ref(num_rotors);
    for (int i = 0; i < num_rotors; ++i) {
      w[i] = log.at(row, cw[static_cast<std::size_t>(i)]);
      require(std::isfinite(w[i]), log.source, ": row ", row + 1, ": omega_", i, " is not finite");
      if (has_ref) ref[i] = log.at(row, cr[static_cast<std::size_t>(i)]);
    }
    d.t_s.push_back(t);
    d.state.push_back(x);
    d.rotor_speed_rad_s.push_back(w);
    if (has_ref) d.rotor_reference_rad_s.push_back(ref);
    d.in_contact.push_back(has_contact && log.at(row, cc) != 0.0 ? 1 : 0);
    if (has_acc) {
      const Vec3 a(log.at(row, ca[0]), log.at(row, ca[1]), log.at(row, ca[2]));
      require(a.allFinite(), log.source, ": row ", row + 1, ": acc_x/y/z is not finite");
      d.specific_force_W_m_s2.push_back(a);
    }
  }
  if (!d.has_body_rates && n >= 2) {
    // w_B from successive attitudes: q_{k+1} = q_k (x) exp(w dt / 2), so w ~ 2 vec(q_k^-1 q_{k+1})
    // / dt.
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t a = k + 1 < n ? k : k - 1;
      const Vec4 qa = d.state[a].segment<4>(6), qb = d.state[a + 1].segment<4>(6);
      Vec4 e = math::multiply<double>(Vec4(qa[0], -qa[1], -qa[2], -qa[3]), qb);
      if (e[0] < 0) e = -e;
      d.state[k].segment<3>(10) = 2.0 * e.segment<3>(1) / (d.t_s[a + 1] - d.t_s[a]);
    }
  }
  return d;
}

FitResult fit_model(const VehicleModel& model, const FlightData& data, const FitOptions& o) {
  const auto t_start = std::chrono::steady_clock::now();
  require(!o.parameters.empty(), "fit: no parameters to fit (FitOptions::parameters is empty)");
  require(o.holdout_fraction >= 0.0 && o.holdout_fraction < 0.9,
          "fit: holdout_fraction must be in [0, 0.9), got ", o.holdout_fraction);
  require(o.max_gap_factor > 1.0, "fit: max_gap_factor must be > 1, got ", o.max_gap_factor);
  require(o.window_s > 0.0, "fit: window_s must be > 0, got ", o.window_s);
  require(o.max_iterations >= 1, "fit: max_iterations must be >= 1, got ", o.max_iterations);
  require(o.num_threads >= 1, "fit: num_threads must be >= 1, got ", o.num_threads);
  require(data.num_rotors == model.num_rotors(), data.source, ": the log has ", data.num_rotors,
          " rotors, the model ", model.name(), " has ", model.num_rotors());
  require(data.state.size() == data.t_s.size() &&
              data.rotor_speed_rad_s.size() == data.t_s.size() &&
              data.in_contact.size() == data.t_s.size(),
          data.source, ": FlightData columns have different lengths");

  const ParameterMap pm(model);
  const Physics physics{&pm, o.switches, o.environment};
  // Two independent problems: the body parameters (accelerations / states) and the motor time
  // constants (rotor speeds). Nothing couples them, and solving them apart keeps each one's
  // residual weights and covariance conditioning in its own units.
  Setup body{&model, &data, &physics, {}, false, false, false, 0, 1.0, 1.0};
  body.map.fixed = pm.initial_theta();
  Setup motor = body;
  for (ModelParameter p : o.parameters) {
    (is_motor_parameter(p) ? motor : body).map.free.push_back(static_cast<int>(p));
  }
  const bool any_body = !body.map.free.empty(), any_motor = !motor.map.free.empty();
  motor.tau_rise_unit = body.tau_rise_unit = pm.value(ModelParameter::kTauRise, 1.0);
  motor.tau_fall_unit = body.tau_fall_unit = pm.value(ModelParameter::kTauFall, 1.0);
  if (any_motor) {
    require(!data.rotor_reference_rad_s.empty(), data.source,
            ": fitting tau_rise/tau_fall needs the rotor speed references (column omega_ref_0 is "
            "missing)");
    require(
        motor.tau_rise_unit > 0.0 && motor.tau_fall_unit > 0.0, model.spec().source,
        ": tau_rise/tau_fall can only be fitted for a model with motor lag (time constants > 0)");
  }
  if (!data.has_body_rates) {
    for (ModelParameter p : o.parameters) {
      const bool angular_only =
          p == ModelParameter::kInertiaXX || p == ModelParameter::kInertiaYY ||
          p == ModelParameter::kInertiaZZ || p == ModelParameter::kYawMomentPerThrust ||
          p == ModelParameter::kDragMoment || p == ModelParameter::kRollingMoment;
      require(!angular_only, data.source, ": fitting ", parameter_name(p),
              " needs the body rates (columns wx, wy, wz are missing); it acts on the angular "
              "accelerations only");
    }
  }
  motor.use_motor = any_motor;
  body.use_eq = any_body && o.method != FitMethod::kOutputError;
  body.use_out = any_body && o.method != FitMethod::kEquationError;

  const Split split = split_intervals(data, o);
  FitResult r;
  r.rows = data.t_s.size();
  r.gaps = split.gaps;
  r.contact_rows = split.contact_rows;
  r.excluded_rows = split.excluded_rows;
  r.median_dt_s = split.median_dt_s;
  r.intervals_used = split.fit.size();
  r.intervals_holdout = split.holdout.size();
  const std::size_t need = 4 * o.parameters.size() + 10;
  require(split.fit.size() >= need, data.source, ": only ", split.fit.size(),
          " usable intervals to fit (after gaps, ground contact and the hold-out); need at least ",
          need, " for ", o.parameters.size(), " parameters");
  body.window_len = std::max(2, static_cast<int>(std::lround(o.window_s / split.median_dt_s)));
  const std::vector<int> fit_windows =
      body.use_out ? pick_windows(split.fit, body.window_len, o.max_windows) : std::vector<int>{};
  const std::vector<int> holdout_windows =
      body.use_out ? pick_windows(split.holdout, body.window_len, o.max_windows)
                   : std::vector<int>{};
  require(!body.use_out || !fit_windows.empty(), data.source, ": no stretch of ", body.window_len,
          " gap-free airborne intervals for an output-error window of ", o.window_s, " s");
  r.windows = fit_windows.size();
  if (!data.has_body_rates) {
    r.warnings.push_back(
        "the log has no body rates: they were derived from successive attitudes and the "
        "angular accelerations were not fitted");
  }

  struct SubFit {
    std::vector<double> initial, block;
    SolveOutcome outcome;
  };
  Channels before_fit, before_holdout, after_fit, after_holdout;
  const auto merge = [](Channels& into, const Channels& c) {
    into.lin += c.lin;
    into.ang += c.ang;
    into.pos += c.pos;
    into.vel += c.vel;
    into.att += c.att;
    into.rate += c.rate;
    into.mot += c.mot;
    into.n_eq += c.n_eq;
    into.n_out += c.n_out;
    into.n_mot += c.n_mot;
  };
  const auto run = [&](const Setup& s) {
    SubFit f;
    for (int j : s.map.free) f.block.push_back(s.map.fixed[static_cast<std::size_t>(j)]);
    f.initial = f.block;
    const bool eq_stats = s.use_eq || s.use_out;  // accelerations are reported either way
    merge(before_fit,
          evaluate(s, f.block, split.fit, fit_windows, eq_stats, s.use_out, s.use_motor));
    merge(before_holdout,
          evaluate(s, f.block, split.holdout, holdout_windows, eq_stats, s.use_out, s.use_motor));
    // Stage 1: the cheaper problem (equation error when asked for) with unit weights.
    const bool eq1 = s.use_eq, out1 = s.use_out && !s.use_eq;
    const SolveOutcome o1 =
        solve(s, f.block, split.fit, fit_windows, Weights{}, eq1, out1, s.use_motor, o, false);
    // Stage 2: everything asked for, each channel weighted by 1/RMS at the stage-1 solution.
    const Weights w = weights_from(
        evaluate(s, f.block, split.fit, fit_windows, s.use_eq, s.use_out, s.use_motor));
    f.outcome =
        solve(s, f.block, split.fit, fit_windows, w, s.use_eq, s.use_out, s.use_motor, o, true);
    f.outcome.iterations += o1.iterations;
    merge(after_fit,
          evaluate(s, f.block, split.fit, fit_windows, eq_stats, s.use_out, s.use_motor));
    merge(after_holdout,
          evaluate(s, f.block, split.holdout, holdout_windows, eq_stats, s.use_out, s.use_motor));
    return f;
  };
  std::vector<std::pair<const Setup*, SubFit>> fits;
  if (any_body) fits.emplace_back(&body, run(body));
  if (any_motor) fits.emplace_back(&motor, run(motor));
  r.fit_before = stats_of(before_fit, split.fit.size());
  r.holdout_before = stats_of(before_holdout, split.holdout.size());
  r.fit_after = stats_of(after_fit, split.fit.size());
  r.holdout_after = stats_of(after_holdout, split.holdout.size());

  // Gather: free-parameter order body then motor = canonical order (motor parameters are last).
  std::vector<double> initial, block;
  std::vector<int> free;
  const int nf = static_cast<int>(o.parameters.size());
  Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(nf, nf);
  Eigen::MatrixXd information = Eigen::MatrixXd::Zero(nf, nf);
  bool covariance_ok = true, usable = true;
  std::vector<std::string> terminations;
  for (const auto& [setup, f] : fits) {
    const int off = static_cast<int>(block.size()), n = static_cast<int>(f.block.size());
    initial.insert(initial.end(), f.initial.begin(), f.initial.end());
    block.insert(block.end(), f.block.begin(), f.block.end());
    free.insert(free.end(), setup->map.free.begin(), setup->map.free.end());
    if (f.outcome.covariance.size())
      covariance.block(off, off, n, n) = f.outcome.covariance;
    else
      covariance_ok = false;
    if (f.outcome.information.size()) information.block(off, off, n, n) = f.outcome.information;
    usable = usable && f.outcome.usable;
    r.iterations += f.outcome.iterations;
    terminations.push_back(f.outcome.termination);
    if (!f.outcome.usable)
      r.warnings.push_back("Ceres did not reach a usable solution (" + f.outcome.termination + ")");
  }
  r.termination = terminations.front();
  for (std::size_t i = 1; i < terminations.size(); ++i) {
    if (terminations[i] != r.termination) r.termination += ", " + terminations[i];
  }
  SolveOutcome o2;
  o2.usable = usable;
  if (covariance_ok) o2.covariance = covariance;
  o2.information = information;

  // Estimates, standard errors, correlations.
  r.fitted_spec = model.spec();
  for (int i = 0; i < nf; ++i) {
    const auto p = static_cast<ModelParameter>(free[static_cast<std::size_t>(i)]);
    FittedParameter fp;
    fp.parameter = p;
    fp.name = std::string(parameter_name(p));
    fp.unit = std::string(parameter_unit(p));
    fp.initial = pm.value(p, initial[static_cast<std::size_t>(i)]);
    fp.estimate = pm.value(p, block[static_cast<std::size_t>(i)]);
    fp.std_error = o2.covariance.size()
                       ? std::abs(pm.value(p, std::sqrt(std::max(0.0, o2.covariance(i, i)))))
                       : kNaN;
    r.parameters.push_back(fp);
    set_parameter_value(r.fitted_spec, p, fp.estimate);
  }
  if (o2.covariance.size()) {
    const Eigen::VectorXd sd = o2.covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    r.correlation = Eigen::MatrixXd::Identity(nf, nf);
    for (int i = 0; i < nf; ++i) {
      for (int j = 0; j < nf; ++j) {
        if (i != j && sd[i] > 0 && sd[j] > 0)
          r.correlation(i, j) = o2.covariance(i, j) / (sd[i] * sd[j]);
      }
    }
    // A correlation only matters when it costs precision: warn for a parameter whose standard
    // error exceeds 5 % of its value (naming its most correlated partner), and for any pair so
    // close to collinear (|r| > 0.999) that the data cannot tell the two apart.
    for (int i = 0; i < nf; ++i) {
      const FittedParameter& fp = r.parameters[static_cast<std::size_t>(i)];
      const double rel = fp.std_error / std::abs(fp.estimate);
      if (rel <= 0.05) continue;
      int partner = -1;
      for (int j = 0; j < nf; ++j) {
        if (j != i &&
            (partner < 0 || std::abs(r.correlation(i, j)) > std::abs(r.correlation(i, partner))))
          partner = j;
      }
      std::string why = " of the estimate: the flight does not excite it enough to identify it";
      if (partner >= 0 && std::abs(r.correlation(i, partner)) > 0.9) {
        why = " of the estimate: it is correlated with " +
              r.parameters[static_cast<std::size_t>(partner)].name +
              " (r = " + fmt(r.correlation(i, partner), 4) +
              "); fix one of them or fly a richer flight";
      }
      r.warnings.push_back(fp.name + ": standard error " + fmt(fp.std_error, 3) + " " + fp.unit +
                           " is " + fmt(100.0 * rel, 3) + " %" + why);
    }
    for (int i = 0; i < nf; ++i) {
      for (int j = i + 1; j < nf; ++j) {
        if (std::abs(r.correlation(i, j)) > 0.999) {
          r.warnings.push_back(r.parameters[static_cast<std::size_t>(i)].name + " and " +
                               r.parameters[static_cast<std::size_t>(j)].name +
                               " are nearly collinear (r = " + fmt(r.correlation(i, j), 6) +
                               "): only a combination of them is identified");
        }
      }
    }
  } else if (o2.usable) {
    // Rank-deficient: name the combination the data cannot see (weakest eigenvector of the
    // column-normalised information matrix).
    std::string weakest;
    if (o2.information.size()) {
      const Eigen::VectorXd scale =
          o2.information.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
      const Eigen::MatrixXd normalised = scale.asDiagonal() * o2.information * scale.asDiagonal();
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(normalised);
      const Eigen::VectorXd v = es.eigenvectors().col(0);
      for (int i = 0; i < nf; ++i) {
        if (std::abs(v[i]) > 0.2)
          weakest += (weakest.empty() ? "" : ", ") + r.parameters[static_cast<std::size_t>(i)].name;
      }
    }
    r.warnings.push_back(
        "covariance: the Jacobian is rank deficient, so the parameters cannot all be "
        "identified from this flight (the combination of " +
        (weakest.empty() ? std::string("some of them") : weakest) +
        " is not seen by the data); standard errors are not available");
  }
  for (const FittedParameter& fp : r.parameters) {
    if (fp.initial != 0.0 && std::abs(fp.estimate / fp.initial - 1.0) > 1.0) {
      r.warnings.push_back(fp.name + " moved from " + fmt(fp.initial) + " to " + fmt(fp.estimate) +
                           " (more than 100 %): check the log's units and the fixed parameters");
    }
  }
  try {
    (void)VehicleModel(r.fitted_spec);
  } catch (const InvalidArgument& e) {
    r.warnings.push_back(std::string("the fitted model is not a valid model: ") + e.what());
  }
  r.solve_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return r;
}

std::string format_fit_report(const FitResult& r) {
  std::ostringstream out;
  out << "rows " << r.rows << ", median dt " << fmt(r.median_dt_s, 4) << " s, intervals fitted "
      << r.intervals_used << ", held out " << r.intervals_holdout << ", gaps " << r.gaps
      << ", rows in contact " << r.contact_rows << ", low or rotor-stopped rows left out "
      << r.excluded_rows << ", output-error windows " << r.windows << "\n";
  out << "Ceres: " << r.iterations << " iterations, " << r.termination << ", "
      << fmt(r.solve_time_s, 3) << " s\n\n";
  char line[256];
  std::snprintf(line, sizeof line, "%-22s %14s %14s %12s %9s  %s\n", "parameter", "initial",
                "estimate", "std error", "change", "unit");
  out << line;
  for (const FittedParameter& p : r.parameters) {
    std::snprintf(line, sizeof line, "%-22s %14.6g %14.6g %12.3g %8.2f%%  %s\n", p.name.c_str(),
                  p.initial, p.estimate, p.std_error,
                  p.initial != 0.0 ? 100.0 * (p.estimate / p.initial - 1.0) : 0.0, p.unit.c_str());
    out << line;
  }
  out << "\nresidual RMS                     fit before    fit after  holdout before holdout "
         "after\n";
  const auto stat = [&](const char* what, double a, double b, double c, double d) {
    std::snprintf(line, sizeof line, "%-30s %12.4g %12.4g %14.4g %13.4g\n", what, a, b, c, d);
    out << line;
  };
  stat("linear acceleration, m/s^2", r.fit_before.linear_acceleration_m_s2,
       r.fit_after.linear_acceleration_m_s2, r.holdout_before.linear_acceleration_m_s2,
       r.holdout_after.linear_acceleration_m_s2);
  stat("angular acceleration, rad/s^2", r.fit_before.angular_acceleration_rad_s2,
       r.fit_after.angular_acceleration_rad_s2, r.holdout_before.angular_acceleration_rad_s2,
       r.holdout_after.angular_acceleration_rad_s2);
  stat("window position, m", r.fit_before.position_m, r.fit_after.position_m,
       r.holdout_before.position_m, r.holdout_after.position_m);
  stat("window attitude, rad", r.fit_before.attitude_rad, r.fit_after.attitude_rad,
       r.holdout_before.attitude_rad, r.holdout_after.attitude_rad);
  stat("motor speed, rad/s", r.fit_before.motor_speed_rad_s, r.fit_after.motor_speed_rad_s,
       r.holdout_before.motor_speed_rad_s, r.holdout_after.motor_speed_rad_s);
  if (!r.warnings.empty()) {
    out << "\nwarnings:\n";
    for (const std::string& w : r.warnings) out << "  - " << w << "\n";
  }
  return out.str();
}

namespace {
std::string json_number(double v) { return std::isfinite(v) ? fmt(v, 17) : "null"; }
std::string json_text(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (c == '\n') {
      o += "\\n";
      continue;
    }
    o += c;
  }
  return o + "\"";
}
std::string json_stats(const ResidualStats& s) {
  return "{\"intervals\": " + std::to_string(s.intervals) +
         ", \"linear_acceleration_m_s2\": " + json_number(s.linear_acceleration_m_s2) +
         ", \"angular_acceleration_rad_s2\": " + json_number(s.angular_acceleration_rad_s2) +
         ", \"position_m\": " + json_number(s.position_m) +
         ", \"attitude_rad\": " + json_number(s.attitude_rad) +
         ", \"motor_speed_rad_s\": " + json_number(s.motor_speed_rad_s) + "}";
}
}  // namespace

std::string fit_result_to_json(const FitResult& r) {
  std::ostringstream out;
  out << "{\n  \"parameters\": [";
  for (std::size_t i = 0; i < r.parameters.size(); ++i) {
    const FittedParameter& p = r.parameters[i];
    out << (i ? ",\n    " : "\n    ") << "{\"name\": " << json_text(p.name)
        << ", \"unit\": " << json_text(p.unit) << ", \"initial\": " << json_number(p.initial)
        << ", \"estimate\": " << json_number(p.estimate)
        << ", \"std_error\": " << json_number(p.std_error) << "}";
  }
  out << "\n  ],\n  \"correlation\": [";
  for (Eigen::Index i = 0; i < r.correlation.rows(); ++i) {
    out << (i ? ", [" : "[");
    for (Eigen::Index j = 0; j < r.correlation.cols(); ++j)
      out << (j ? ", " : "") << json_number(r.correlation(i, j));
    out << "]";
  }
  out << "],\n  \"warnings\": [";
  for (std::size_t i = 0; i < r.warnings.size(); ++i)
    out << (i ? ", " : "") << json_text(r.warnings[i]);
  out << "],\n  \"fit_before\": " << json_stats(r.fit_before)
      << ",\n  \"fit_after\": " << json_stats(r.fit_after)
      << ",\n  \"holdout_before\": " << json_stats(r.holdout_before)
      << ",\n  \"holdout_after\": " << json_stats(r.holdout_after) << ",\n  \"rows\": " << r.rows
      << ",\n  \"intervals_used\": " << r.intervals_used
      << ",\n  \"intervals_holdout\": " << r.intervals_holdout << ",\n  \"gaps\": " << r.gaps
      << ",\n  \"contact_rows\": " << r.contact_rows
      << ",\n  \"excluded_rows\": " << r.excluded_rows << ",\n  \"windows\": " << r.windows
      << ",\n  \"median_dt_s\": " << json_number(r.median_dt_s)
      << ",\n  \"iterations\": " << r.iterations
      << ",\n  \"termination\": " << json_text(r.termination)
      << ",\n  \"solve_time_s\": " << json_number(r.solve_time_s) << "\n}\n";
  return out.str();
}

}  // namespace dronetwin
