// Parameter identification (fit.hpp): equation error and motor lag streamed through the log into
// normal equations, multiple-shooting output error as Ceres blocks, per-channel noise levels, a
// robust loss, speed-sensor gains and the held-out check.
#include "dronetwin/identification/fit.hpp"

#include <ceres/ceres.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>

#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/force_kernel.hpp"
#include "dronetwin/dynamics/motor.hpp"
#include "dronetwin/identification/parameter_map.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "streamed_normal_equations.hpp"

namespace dronetwin {
namespace {

using Theta = ParameterMap::Theta;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---- residual channels -----------------------------------------------------------------------

enum Channel : int {
  kLinear,    // equation error, m/s^2
  kAngular,   // equation error, rad/s^2
  kPosition,  // output-error windows, m
  kVelocity,  // m/s
  kAttitude,  // rad
  kRate,      // rad/s
  kMotor,     // motor lag, rad/s
  kNumChannels
};
template <class T>
using PerChannel = std::array<T, kNumChannels>;
constexpr PerChannel<const char*> kChannelNames{
    "linear acceleration", "angular acceleration", "window position", "window velocity",
    "window attitude",     "window rate",          "motor speed"};
// A noise level is never taken below this resolution (far below any real sensor's noise): a
// noise-free synthetic log, whose residuals at the optimum are round-off, must not get weights
// of 1e15 that swamp the other channels and the covariance conditioning.
constexpr PerChannel<double> kResolution{1e-4, 1e-4, 1e-6, 1e-5, 1e-6, 1e-5, 1e-3};
// The median of |r| of Gaussian noise is 0.6745 sigma.
constexpr double kMadToSigma = 1.4826;

// ---- data ------------------------------------------------------------------------------------

struct Split {
  std::vector<int> fit, holdout;  // interval start rows k (interval k -> k+1)
  std::size_t gaps = 0, contact_rows = 0, excluded_rows = 0;
  double median_dt_s = 0.0;
};

Split split_intervals(const FlightData& d, const FitOptions& o) {
  Split s;
  const std::size_t n = d.rows();
  require(n >= 2, d.source(), ": a fit needs at least two rows, the log has ", n);
  {
    std::vector<double> dts(n - 1);
    for (std::size_t k = 0; k + 1 < n; ++k) dts[k] = d.t_s(k + 1) - d.t_s(k);
    std::nth_element(dts.begin(), dts.begin() + static_cast<long>(dts.size() / 2), dts.end());
    s.median_dt_s = dts[dts.size() / 2];
  }
  const int nr = d.num_rotors();
  const auto excluded = [&](std::size_t k) {
    const double* w = d.rotor_speeds_rad_s(k);
    return d.state(k)[2] < o.min_height_m || *std::min_element(w, w + nr) < o.min_rotor_speed_rad_s;
  };
  for (std::size_t k = 0; k < n; ++k) {
    s.contact_rows += d.in_contact(k) ? 1 : 0;
    s.excluded_rows += excluded(k) ? 1 : 0;
  }
  const double t_split = d.t_s(0) + (1.0 - o.holdout_fraction) * (d.t_s(n - 1) - d.t_s(0));
  bool previous_excluded = excluded(0);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const bool next_excluded = excluded(k + 1);
    const bool skip = previous_excluded || next_excluded;
    previous_excluded = next_excluded;
    if (d.t_s(k + 1) - d.t_s(k) > o.max_gap_factor * s.median_dt_s) {
      ++s.gaps;
      continue;
    }
    if (d.in_contact(k) || d.in_contact(k + 1) || skip) continue;
    (d.t_s(k + 1) <= t_split ? s.fit : s.holdout).push_back(static_cast<int>(k));
  }
  return s;
}

// Windows of `len` consecutive usable intervals starting at interval indices from `intervals`
// (which must be contiguous row-wise), at most `max_count`, spread evenly.
std::vector<int> pick_windows(const std::vector<int>& intervals, int len, int max_count) {
  std::vector<int> starts;
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

// ---- unknowns --------------------------------------------------------------------------------

// The free block: the free model parameters (multipliers theta_j, parameter_map.hpp), then the
// speed-sensor gains of rotors 0..N-2. The last rotor's gain is N minus the others: the gains'
// mean is 1, because a scale common to every sensor multiplies all speeds alike, which the thrust
// coefficients absorb exactly ('K1 g^2 w^2 + 'K2 g w + 'K3).
struct Unknowns {
  std::vector<int> free;  // indices into theta of the free parameters, in block order
  Theta fixed{};
  int num_rotors = 0;
  bool gains = false;

  int num_gains() const { return gains ? num_rotors - 1 : 0; }
  int size() const { return static_cast<int>(free.size()) + num_gains(); }
  template <class T>
  std::array<T, kNumModelParameters> theta(const T* block) const {
    std::array<T, kNumModelParameters> th;
    for (int j = 0; j < kNumModelParameters; ++j)
      th[static_cast<std::size_t>(j)] = T(fixed[static_cast<std::size_t>(j)]);
    for (std::size_t i = 0; i < free.size(); ++i) th[static_cast<std::size_t>(free[i])] = block[i];
    return th;
  }
  /// True speed = gain x logged speed, per rotor.
  template <class T>
  std::array<T, kMaxRotors> gain(const T* block) const {
    std::array<T, kMaxRotors> g;
    g.fill(T(1.0));
    if (!gains) return g;
    const T* free_gains = block + free.size();
    T last(static_cast<double>(num_rotors));
    for (int i = 0; i + 1 < num_rotors; ++i) {
      g[static_cast<std::size_t>(i)] = free_gains[i];
      last -= free_gains[i];
    }
    g[static_cast<std::size_t>(num_rotors - 1)] = last;
    return g;
  }
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

// kernel.prepare with the logged speeds, corrected by the gains when they are fitted.
template <class T>
void prepare_held(const ForceKernel<T>& kernel, const Unknowns& u,
                  const std::array<T, kMaxRotors>& gain, const double* logged,
                  HeldRotorTerms<T>& held) {
  if (!u.gains) {
    kernel.prepare(logged, held);
    return;
  }
  std::array<T, kMaxRotors> speeds;
  for (int i = 0; i < u.num_rotors; ++i)
    speeds[static_cast<std::size_t>(i)] = gain[static_cast<std::size_t>(i)] * logged[i];
  kernel.prepare(speeds, held);
}

// ---- per-interval residual families (streamed) -----------------------------------------------

// The residual functors are flattened (DRONETWIN_FLATTEN, core/types.hpp: optimised GCC builds
// only): with T = ceres::Jet, GCC otherwise leaves the Eigen expression evaluators of Jet
// arithmetic out of line, and profiles of long fits spent about two thirds of their time in those
// calls. Inlining changes no arithmetic, only call overhead. (An ASan build of the flattened
// functors took GCC 12 over 17 minutes and 3.8 GB.)

// Equation error: 3 linear and 3 angular acceleration residuals per interval.
struct EquationErrorRows {
  const Physics* physics;
  const FlightData* d;
  const Unknowns* u;

  int per_interval() const { return 6; }
  Channel channel(int i) const { return i < 3 ? kLinear : kAngular; }
  template <class T, class Sink>
  DRONETWIN_FLATTEN void operator()(const T* block, const int* intervals, std::size_t count,
                                    Sink&& sink) const {
    const ForceKernel<T> kernel = physics->kernel_at(u->theta<T>(block));
    const std::array<T, kMaxRotors> gain = u->gain<T>(block);
    const Environment& env = physics->environment;
    const bool accelerometer = d->has_specific_force();
    HeldRotorTerms<T> held;
    std::array<T, 6> res;
    for (std::size_t i = 0; i < count; ++i) {
      const auto k = static_cast<std::size_t>(intervals[i]);
      const double dt = d->t_s(k + 1) - d->t_s(k);
      prepare_held(kernel, *u, gain, d->rotor_speeds_rad_s(k), held);  // held over the interval
      const StateVector x0 = d->state(k), x1 = d->state(k + 1);
      const StateVectorT<T> f0 = kernel.derivative(held, x0, env);
      const StateVectorT<T> f1 = kernel.derivative(held, x1, env);
      for (int a = 0; a < 3; ++a) {
        const double dv =
            accelerometer
                ? 0.5 * (d->specific_force_W_m_s2(k)[a] + d->specific_force_W_m_s2(k + 1)[a]) +
                      env.gravity_W_m_s2[a]
                : (x1[3 + a] - x0[3 + a]) / dt;
        res[static_cast<std::size_t>(a)] = dv - T(0.5) * (f0[3 + a] + f1[3 + a]);
        if (d->has_body_rates()) {
          const double dw = (x1[10 + a] - x0[10 + a]) / dt;
          res[static_cast<std::size_t>(3 + a)] = dw - T(0.5) * (f0[10 + a] + f1[10 + a]);
        } else {
          res[static_cast<std::size_t>(3 + a)] = T(0.0);  // no rates logged: channel unused
        }
      }
      sink(res.data());
    }
  }
};

// Motor lag: one residual per rotor and interval (Eq. 2.45 with the rise/fall switch), from the
// logged speeds as they are (the gains belong to the body problem).
struct MotorLagRows {
  const FlightData* d;
  const Unknowns* u;
  const VehicleModel* model;
  double tau_rise_unit = 1.0, tau_fall_unit = 1.0;

  int per_interval() const { return d->num_rotors(); }
  Channel channel(int) const { return kMotor; }
  template <class T, class Sink>
  DRONETWIN_FLATTEN void operator()(const T* block, const int* intervals, std::size_t count,
                                    Sink&& sink) const {
    const auto th = u->theta<T>(block);
    const T tau_rise = th[static_cast<std::size_t>(ModelParameter::kTauRise)] * tau_rise_unit;
    const T tau_fall = th[static_cast<std::size_t>(ModelParameter::kTauFall)] * tau_fall_unit;
    const int nr = d->num_rotors();
    std::array<T, kMaxRotors> res;
    for (std::size_t i = 0; i < count; ++i) {
      const auto k = static_cast<std::size_t>(intervals[i]);
      const double dt = d->t_s(k + 1) - d->t_s(k);
      const T decay_rise = motor_decay(tau_rise, dt), decay_fall = motor_decay(tau_fall, dt);
      for (int r = 0; r < nr; ++r) {
        const double w0 = d->rotor_speeds_rad_s(k)[r];
        const double ref = clamp_speed(model->rotor(r), d->rotor_references_rad_s(k)[r]);
        res[static_cast<std::size_t>(r)] =
            d->rotor_speeds_rad_s(k + 1)[r] -
            motor_speed_after(decay_rise, decay_fall, ref, w0);  // Eq. 2.45
      }
      sink(res.data());
    }
  }
};

// ---- weighting and loss ----------------------------------------------------------------------

// How residuals enter the objective: each channel's residual is divided by its noise level, and
// the loss (nullptr: squares) applies to each scaled residual.
struct Weighting {
  PerChannel<double> weight{1, 1, 1, 1, 1, 1, 1};   // 1 / noise level
  PerChannel<bool> active{};                        // channels in the objective
  std::shared_ptr<const ceres::LossFunction> loss;  // per scalar residual

  // rho(s), rho'(s) of s = (weight r)^2.
  void evaluate(double s, double rho[3]) const {
    if (loss) {
      loss->Evaluate(s, rho);
    } else {
      rho[0] = s;
      rho[1] = 1.0;
      rho[2] = 0.0;
    }
  }
};

// Sums over a set of residuals, per channel (unweighted squares for the RMS, the loss of the
// weighted ones for the held-out check).
struct ChannelSums {
  PerChannel<double> sum_sq{}, loss{};
  PerChannel<std::size_t> count{};
  void merge(const ChannelSums& o) {
    for (int c = 0; c < kNumChannels; ++c) {
      sum_sq[static_cast<std::size_t>(c)] += o.sum_sq[static_cast<std::size_t>(c)];
      loss[static_cast<std::size_t>(c)] += o.loss[static_cast<std::size_t>(c)];
      count[static_cast<std::size_t>(c)] += o.count[static_cast<std::size_t>(c)];
    }
  }
};

// What one pass over residuals gives.
struct Pass {
  double loss = 0.0;  // sum of rho over the active channels
  bool finite = true;
  std::size_t active_residuals = 0;
  ChannelSums sums;
  PerChannel<detail::MagnitudeHistogram> magnitude;  // |r| per channel (when asked for)
  Eigen::MatrixXd information;                       // sum rho' J^T J (with jacobians)
  Eigen::VectorXd gradient;                          // sum rho' J^T r

  void merge_sums(const Pass& o) {
    loss += o.loss;
    finite = finite && o.finite;
    active_residuals += o.active_residuals;
    sums.merge(o.sums);
    for (int c = 0; c < kNumChannels; ++c)
      magnitude[static_cast<std::size_t>(c)].merge(o.magnitude[static_cast<std::size_t>(c)]);
  }
};

// ---- streaming a residual family over a set of intervals -------------------------------------

// Intervals per chunk: the unit of work of a thread and of the ordered reduction. Fixed, so the
// sums do not depend on the number of threads. The model at theta is built once per chunk.
constexpr std::size_t kChunk = 4096;

template <class Rows>
class Stream {
 public:
  Stream(const Rows* rows, const std::vector<int>* intervals, int num_free, int num_threads)
      : rows_(rows), intervals_(intervals), num_free_(num_free), num_threads_(num_threads) {}

  int num_free() const { return num_free_; }
  std::size_t num_intervals() const { return intervals_->size(); }

  /// One pass at `block`: loss and channel sums, |r| histograms when `magnitudes`, the normal
  /// equations when `jacobian`.
  Pass run(const double* block, const Weighting& w, bool jacobian, bool magnitudes) const {
    const std::size_t n = intervals_->size();
    const std::size_t chunks = (n + kChunk - 1) / kChunk;
    std::vector<Pass> per_chunk(chunks);
    std::vector<PerChannel<detail::MagnitudeHistogram>> per_worker(
        magnitudes ? static_cast<std::size_t>(std::max(1, num_threads_)) : 0);
    detail::for_each_chunk(chunks, num_threads_, [&](std::size_t c, int worker) {
      const std::size_t begin = c * kChunk, count = std::min(kChunk, n - begin);
      PerChannel<detail::MagnitudeHistogram>* hist =
          magnitudes ? &per_worker[static_cast<std::size_t>(worker)] : nullptr;
      if (jacobian) {
        run_jet(block, w, begin, count, hist, per_chunk[c]);
      } else {
        run_double(block, w, begin, count, hist, per_chunk[c]);
      }
    });
    Pass total;
    if (jacobian) {
      total.information = Eigen::MatrixXd::Zero(num_free_, num_free_);
      total.gradient = Eigen::VectorXd::Zero(num_free_);
    }
    for (const Pass& p : per_chunk) {  // in chunk order: the same sums on any number of threads
      total.merge_sums(p);
      if (jacobian) {
        total.information += p.information;
        total.gradient += p.gradient;
      }
    }
    for (const auto& h : per_worker) {  // integer counts: any order gives the same histogram
      for (int ch = 0; ch < kNumChannels; ++ch)
        total.magnitude[static_cast<std::size_t>(ch)].merge(h[static_cast<std::size_t>(ch)]);
    }
    return total;
  }

 private:
  // Books one residual (unweighted value r) into the sums; returns its weighted value and rho.
  bool book(const Weighting& w, int index, double r, PerChannel<detail::MagnitudeHistogram>* hist,
            Pass& out, double& scaled, double rho[3]) const {
    const auto c = static_cast<std::size_t>(rows_->channel(index));
    if (!std::isfinite(r)) out.finite = false;
    out.sums.sum_sq[c] += r * r;
    ++out.sums.count[c];
    if (hist) (*hist)[c].add(std::abs(r));
    if (!w.active[c]) return false;
    scaled = w.weight[c] * r;
    w.evaluate(scaled * scaled, rho);
    out.loss += rho[0];
    out.sums.loss[c] += rho[0];
    ++out.active_residuals;
    return true;
  }

  void run_double(const double* block, const Weighting& w, std::size_t begin, std::size_t count,
                  PerChannel<detail::MagnitudeHistogram>* hist, Pass& out) const {
    const int per = rows_->per_interval();
    (*rows_)(block, intervals_->data() + begin, count, [&](const double* res) {
      for (int i = 0; i < per; ++i) {
        double scaled = 0.0, rho[3];
        book(w, i, res[i], hist, out, scaled, rho);
      }
    });
  }

  template <int N>
  void run_jet_width(const double* block, const Weighting& w, std::size_t begin, std::size_t count,
                     PerChannel<detail::MagnitudeHistogram>* hist, Pass& out) const {
    using Jet = ceres::Jet<double, N>;
    std::vector<Jet> jets(static_cast<std::size_t>(num_free_));
    for (int i = 0; i < num_free_; ++i) jets[static_cast<std::size_t>(i)] = Jet(block[i], i);
    detail::NormalEquations ne(num_free_);
    const int per = rows_->per_interval();
    Eigen::Matrix<double, N, 1> row;
    (*rows_)(jets.data(), intervals_->data() + begin, count, [&](const Jet* res) {
      for (int i = 0; i < per; ++i) {
        double scaled = 0.0, rho[3];
        if (!book(w, i, res[i].a, hist, out, scaled, rho)) continue;
        // IRLS: rows scaled by sqrt(rho'), so J^T J and J^T r carry rho' (Ceres' loss convention:
        // cost 1/2 sum rho(|r|^2), gradient sum rho' J^T r).
        const double root = std::sqrt(std::max(rho[1], 0.0));
        row = (root * w.weight[static_cast<std::size_t>(rows_->channel(i))]) * res[i].v;
        ne.add(row, root * scaled);
      }
    });
    ne.finish(out.information, out.gradient);
  }

  void run_jet(const double* block, const Weighting& w, std::size_t begin, std::size_t count,
               PerChannel<detail::MagnitudeHistogram>* hist, Pass& out) const {
    // The Jet width follows the number of free parameters: multiples of 4 keep Eigen's
    // vectorised Jet arithmetic (an odd width such as 13 measured 50 % slower than 12).
    if (num_free_ <= 4) return run_jet_width<4>(block, w, begin, count, hist, out);
    if (num_free_ <= 8) return run_jet_width<8>(block, w, begin, count, hist, out);
    if (num_free_ <= 12) return run_jet_width<12>(block, w, begin, count, hist, out);
    if (num_free_ <= 16) return run_jet_width<16>(block, w, begin, count, hist, out);
    if (num_free_ <= 20) return run_jet_width<20>(block, w, begin, count, hist, out);
    return run_jet_width<24>(block, w, begin, count, hist, out);
  }

  const Rows* rows_;
  const std::vector<int>* intervals_;
  int num_free_;
  int num_threads_;
};

// A whole stream as one Ceres residual block: at each point, the square-root information form of
// its normal equations (streamed_normal_equations.hpp), so Ceres' Levenberg-Marquardt sees the
// exact cost, gradient and Gauss-Newton Hessian of millions of rows in num_free + 1 residuals.
// Every evaluation computes the Jacobian (a step Ceres accepts is evaluated again with the
// Jacobian at the same point, which then comes from the memo). A stream over every m-th interval
// of a log stands for all of them with `multiplicity` m: its sums count m times, so it keeps its
// weight against the output-error windows.
template <class Rows>
class StreamedCost final : public ceres::CostFunction {
 public:
  StreamedCost(const Stream<Rows>* stream, Weighting weighting, double multiplicity)
      : stream_(stream), weighting_(std::move(weighting)), multiplicity_(multiplicity) {
    set_num_residuals(stream->num_free() + 1);
    mutable_parameter_block_sizes()->push_back(stream->num_free());
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const int n = stream_->num_free();
    const std::lock_guard<std::mutex> lock(memo_mutex_);
    const std::vector<double> at(parameters[0], parameters[0] + n);
    if (at != memo_at_ || memo_residuals_.empty()) {
      const Pass p = stream_->run(parameters[0], weighting_, true, false);
      if (!p.finite || !std::isfinite(p.loss) || !p.information.allFinite()) return false;
      memo_at_ = at;
      memo_residuals_.assign(static_cast<std::size_t>(n + 1), 0.0);
      memo_jacobian_.assign(static_cast<std::size_t>((n + 1) * n), 0.0);
      const double m = multiplicity_;  // 1 (exact) unless a coarse stream
      detail::square_root_information(m * p.information, m * p.gradient, m * p.loss,
                                      memo_residuals_.data(), memo_jacobian_.data());
    }
    std::copy(memo_residuals_.begin(), memo_residuals_.end(), residuals);
    if (jacobians != nullptr && jacobians[0] != nullptr)
      std::copy(memo_jacobian_.begin(), memo_jacobian_.end(), jacobians[0]);
    return true;
  }

 private:
  const Stream<Rows>* stream_;
  Weighting weighting_;
  double multiplicity_;
  mutable std::mutex memo_mutex_;
  mutable std::vector<double> memo_at_, memo_residuals_, memo_jacobian_;
};

// ---- output error (Ceres blocks) -------------------------------------------------------------

// Output error over one window of `len` intervals from row k0: 12 residuals per row reached
// (position, velocity, attitude, rates; a channel not fitted has weight 0).
struct OutputError {
  const Physics* physics;
  const FlightData* d;
  const Unknowns* u;
  int k0 = 0, len = 0;
  PerChannel<double> w{};
  // Longer log intervals are integrated in substeps of at most this (the thesis physics step).
  static constexpr double kMaxSubstep_s = 1.0e-3;
  template <class T>
  DRONETWIN_FLATTEN bool operator()(T const* const* params, T* res) const {
    const ForceKernel<T> kernel = physics->kernel_at(u->theta<T>(params[0]));
    const std::array<T, kMaxRotors> gain = u->gain<T>(params[0]);
    const Environment& env = physics->environment;
    HeldRotorTerms<T> held;
    StateVectorT<T> x = d->state(static_cast<std::size_t>(k0)).template cast<T>();
    for (int j = 0; j < len; ++j) {
      const auto k = static_cast<std::size_t>(k0 + j);
      const double dt_total = d->t_s(k + 1) - d->t_s(k);
      const int sub = std::max(1, static_cast<int>(std::ceil(dt_total / kMaxSubstep_s - 1e-9)));
      const T h(dt_total / sub);
      prepare_held(kernel, *u, gain, d->rotor_speeds_rad_s(k), held);
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
      const StateVector y = d->state(k + 1);
      T* r = res + 12 * static_cast<std::size_t>(j);
      for (int a = 0; a < 3; ++a) {
        r[a] = w[kPosition] * (x[a] - y[a]);
        r[3 + a] = w[kVelocity] * (x[3 + a] - y[3 + a]);
        r[9 + a] = w[kRate] * (x[10 + a] - y[10 + a]);
      }
      // attitude: 2 vec(q_log^-1 (x) q_pred), sign chosen so the scalar part is positive
      const Vector4<T> qc(T(y[6]), T(-y[7]), T(-y[8]), T(-y[9]));
      const Vector4<T> e = math::multiply<T>(qc, Vector4<T>(x.template segment<4>(6)));
      const T sign = e[0] < T(0) ? T(-2) : T(2);
      for (int a = 0; a < 3; ++a) r[6 + a] = w[kAttitude] * sign * e[1 + a];
    }
    return true;
  }
};
constexpr std::array<Channel, 4> kWindowChannels{kPosition, kVelocity, kAttitude, kRate};

template <int kStride, class F>
ceres::CostFunction* make_cost_with_stride(F* f, int num_free, int num_residuals) {
  auto* c = new ceres::DynamicAutoDiffCostFunction<F, kStride>(f);
  c->AddParameterBlock(num_free);
  c->SetNumResiduals(num_residuals);
  return c;
}

// The Jet width follows the number of free parameters (see Stream::run_jet).
template <class F>
ceres::CostFunction* make_cost(F* f, int num_free, int num_residuals) {
  if (num_free <= 4) return make_cost_with_stride<4>(f, num_free, num_residuals);
  if (num_free <= 8) return make_cost_with_stride<8>(f, num_free, num_residuals);
  if (num_free <= 12) return make_cost_with_stride<12>(f, num_free, num_residuals);
  if (num_free <= 16) return make_cost_with_stride<16>(f, num_free, num_residuals);
  if (num_free <= 20) return make_cost_with_stride<20>(f, num_free, num_residuals);
  return make_cost_with_stride<24>(f, num_free, num_residuals);
}

std::shared_ptr<const ceres::LossFunction> make_loss(FitLoss loss, double scale) {
  switch (loss) {
    case FitLoss::kHuber:
      return std::make_shared<const ceres::HuberLoss>(scale);
    case FitLoss::kCauchy:
      return std::make_shared<const ceres::CauchyLoss>(scale);
    case FitLoss::kNone:
      break;
  }
  return nullptr;
}

// ---- the problem -----------------------------------------------------------------------------

struct Setup {
  const VehicleModel* model;
  const FlightData* d;
  const Physics* physics;
  Unknowns u;
  bool use_eq = false, use_out = false, use_motor = false;
  bool linear = false, angular = false;  // channels of the equation error and the windows
  int window_len = 0;
  double tau_rise_unit = 1.0, tau_fall_unit = 1.0;
  FitLoss loss = FitLoss::kNone;
  double loss_scale = 0.0;
  int num_threads = 1;

  // The channels this problem fits.
  PerChannel<bool> active() const {
    PerChannel<bool> a{};
    a[kLinear] = use_eq && linear;
    a[kAngular] = use_eq && angular && d->has_body_rates();
    a[kPosition] = a[kVelocity] = use_out && linear;
    a[kAttitude] = a[kRate] = use_out && angular;
    a[kMotor] = use_motor;
    return a;
  }
};

// Residuals of every channel at `block` on `intervals` and `windows` (equation error for the
// report even when it is not fitted), with the loss of `w`.
Pass evaluate(const Setup& s, const std::vector<double>& block, const std::vector<int>& intervals,
              const std::vector<int>& windows, const Weighting& w, bool magnitudes) {
  Pass e;
  const int nf = s.u.size();
  if (s.use_eq || s.use_out) {
    const EquationErrorRows rows{s.physics, s.d, &s.u};
    e.merge_sums(Stream<EquationErrorRows>(&rows, &intervals, nf, s.num_threads)
                     .run(block.data(), w, false, magnitudes));
  }
  if (s.use_motor) {
    const MotorLagRows rows{s.d, &s.u, s.model, s.tau_rise_unit, s.tau_fall_unit};
    e.merge_sums(Stream<MotorLagRows>(&rows, &intervals, nf, s.num_threads)
                     .run(block.data(), w, false, magnitudes));
  }
  if (s.use_out) {
    const double* p[1] = {block.data()};
    std::vector<double> r(12 * static_cast<std::size_t>(s.window_len));
    PerChannel<double> unit{};
    unit.fill(1.0);
    for (int k0 : windows) {
      OutputError f{s.physics, s.d, &s.u, k0, s.window_len, unit};
      f(p, r.data());
      for (std::size_t i = 0; i < r.size(); ++i) {
        const auto c = static_cast<std::size_t>(kWindowChannels[(i % 12) / 3]);
        const double v = r[i];
        Pass& out = e;
        if (!std::isfinite(v)) out.finite = false;
        out.sums.sum_sq[c] += v * v;
        ++out.sums.count[c];
        if (magnitudes) out.magnitude[c].add(std::abs(v));
        if (w.active[c]) {
          const double scaled = w.weight[c] * v;
          double rho[3];
          w.evaluate(scaled * scaled, rho);
          out.sums.loss[c] += rho[0];
        }
      }
    }
  }
  return e;
}

double rms(double sum_sq, std::size_t n) {
  return n ? std::sqrt(sum_sq / static_cast<double>(n)) : kNaN;
}

ResidualStats stats_of(const ChannelSums& c, std::size_t intervals, bool has_body_rates) {
  ResidualStats r;
  r.intervals = intervals;
  r.linear_acceleration_m_s2 = rms(c.sum_sq[kLinear], c.count[kLinear]);
  r.angular_acceleration_rad_s2 =
      has_body_rates ? rms(c.sum_sq[kAngular], c.count[kAngular]) : kNaN;
  r.position_m = rms(c.sum_sq[kPosition], c.count[kPosition]);
  r.attitude_rad = rms(c.sum_sq[kAttitude], c.count[kAttitude]);
  r.motor_speed_rad_s = rms(c.sum_sq[kMotor], c.count[kMotor]);
  return r;
}

// Each channel's noise level: the RMS for least squares, the robust 1.4826 median |r| for a
// robust loss; never below the channel's resolution.
Weighting weighting_from(const Setup& s, const Pass& e, bool robust) {
  Weighting w;
  w.active = s.active();
  for (int c = 0; c < kNumChannels; ++c) {
    const auto i = static_cast<std::size_t>(c);
    const double level =
        robust ? kMadToSigma * e.magnitude[i].median() : rms(e.sums.sum_sq[i], e.sums.count[i]);
    w.weight[i] =
        std::isfinite(level) && e.sums.count[i] > 0 ? 1.0 / std::max(level, kResolution[i]) : 1.0;
  }
  if (robust) w.loss = make_loss(s.loss, s.loss_scale);
  return w;
}

struct SolveOutcome {
  int iterations = 0;
  std::string termination;
  bool usable = false;
  std::size_t residuals = 0;    // active residuals (for sigma^2)
  double cost = 0.0;            // Ceres' final cost, 1/2 sum rho
  Eigen::MatrixXd information;  // J^T J of the weighted problem at the solution
};

// Solves on the intervals `fit` (standing for `multiplicity` times as many) and `windows`.
SolveOutcome solve(const Setup& s, std::vector<double>& block, const std::vector<int>& fit,
                   double multiplicity, const std::vector<int>& windows, const Weighting& w,
                   const FitOptions& o, bool with_information) {
  const int nf = s.u.size();
  const EquationErrorRows eq_rows{s.physics, s.d, &s.u};
  const MotorLagRows motor_rows{s.d, &s.u, s.model, s.tau_rise_unit, s.tau_fall_unit};
  const Stream<EquationErrorRows> eq_stream(&eq_rows, &fit, nf, s.num_threads);
  const Stream<MotorLagRows> motor_stream(&motor_rows, &fit, nf, s.num_threads);
  ceres::Problem::Options po;
  ceres::Problem problem(po);  // after the streams: its blocks point to them
  const PerChannel<bool> active = w.active;
  std::size_t residuals = 0;
  if (active[kLinear] || active[kAngular]) {
    problem.AddResidualBlock(new StreamedCost<EquationErrorRows>(&eq_stream, w, multiplicity),
                             nullptr, block.data());
    residuals += fit.size() *
                 static_cast<std::size_t>((active[kLinear] ? 3 : 0) + (active[kAngular] ? 3 : 0));
  }
  if (active[kMotor]) {
    problem.AddResidualBlock(new StreamedCost<MotorLagRows>(&motor_stream, w, multiplicity),
                             nullptr, block.data());
    residuals += fit.size() * static_cast<std::size_t>(s.d->num_rotors());
  }
  if (s.use_out) {
    PerChannel<double> window_weight{};
    int per_row = 0;
    for (Channel c : kWindowChannels) {
      window_weight[c] = active[c] ? w.weight[c] : 0.0;
      per_row += active[c] ? 3 : 0;
    }
    // A robust loss applies to a window as a whole (a Ceres block): a window whose residuals
    // are larger than `scale` noise levels in RMS is down-weighted.
    const double scale = s.loss_scale * std::sqrt(static_cast<double>(per_row * s.window_len));
    for (int k0 : windows) {
      ceres::LossFunction* loss = nullptr;
      if (w.loss && s.loss == FitLoss::kHuber) loss = new ceres::HuberLoss(scale);
      if (w.loss && s.loss == FitLoss::kCauchy) loss = new ceres::CauchyLoss(scale);
      problem.AddResidualBlock(
          make_cost(new OutputError{s.physics, s.d, &s.u, k0, s.window_len, window_weight}, nf,
                    12 * s.window_len),
          loss, block.data());
    }
    residuals += windows.size() * static_cast<std::size_t>(per_row * s.window_len);
  }
  ceres::Solver::Options so;
  // Normal equations: every block is thin (<= 24 columns); the streamed blocks are already
  // reduced to num_free + 1 rows, and Jacobi scaling keeps the windows well conditioned.
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  so.max_num_iterations = o.max_iterations;
  // One Ceres thread: its per-thread cost sums would depend on the thread count; the streamed
  // blocks use their own threads with a fixed reduction order.
  so.num_threads = 1;
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
  outcome.residuals = residuals;
  outcome.cost = summary.final_cost;
  if (!with_information || !outcome.usable) return outcome;
  // J^T J at the solution (the streamed blocks' rows are their square-root information).
  ceres::CRSMatrix jac;
  double cost = 0.0;
  problem.Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, &jac);
  outcome.cost = cost;
  outcome.information = Eigen::MatrixXd::Zero(nf, nf);
  for (int row = 0; row < jac.num_rows; ++row) {
    const auto begin = static_cast<std::size_t>(jac.rows[static_cast<std::size_t>(row)]);
    const auto end = static_cast<std::size_t>(jac.rows[static_cast<std::size_t>(row) + 1]);
    for (std::size_t a = begin; a < end; ++a) {
      for (std::size_t b = begin; b < end; ++b) {
        outcome.information(jac.cols[a], jac.cols[b]) += jac.values[a] * jac.values[b];
      }
    }
  }
  return outcome;
}

std::string fmt(double v, int digits = 6) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

// Validates the options; every message names the option and its value.
void check_options(const FitOptions& o) {
  require(!o.parameters.empty(), "fit: no parameters to fit (FitOptions::parameters is empty)");
  require(o.holdout_fraction >= 0.0 && o.holdout_fraction < 0.9,
          "fit: holdout_fraction must be in [0, 0.9), got ", o.holdout_fraction);
  require(std::isfinite(o.holdout_tolerance) && o.holdout_tolerance >= 0.0,
          "fit: holdout_tolerance must be a finite number >= 0, got ", o.holdout_tolerance);
  require(o.max_gap_factor > 1.0 && std::isfinite(o.max_gap_factor),
          "fit: max_gap_factor must be a finite number > 1, got ", o.max_gap_factor);
  require(!std::isnan(o.min_height_m) && o.min_height_m < std::numeric_limits<double>::infinity(),
          "fit: min_height_m must be a height in m (or -inf for no limit), got ", o.min_height_m);
  require(std::isfinite(o.min_rotor_speed_rad_s) && o.min_rotor_speed_rad_s >= 0.0,
          "fit: min_rotor_speed_rad_s must be a finite speed >= 0, got ", o.min_rotor_speed_rad_s);
  require(std::isfinite(o.window_s) && o.window_s > 0.0,
          "fit: window_s must be a finite length in s > 0, got ", o.window_s);
  require(o.max_windows >= 1, "fit: max_windows must be >= 1, got ", o.max_windows);
  require(o.max_iterations >= 1, "fit: max_iterations must be >= 1, got ", o.max_iterations);
  require(o.num_threads >= 1 && o.num_threads <= 1024,
          "fit: num_threads must be in [1, 1024], got ", o.num_threads);
  if (o.loss_scale) {
    require(std::isfinite(*o.loss_scale) && *o.loss_scale > 0.0,
            "fit: loss_scale must be a finite number of noise levels > 0, got ", *o.loss_scale);
  }
  require(o.environment.wind_W_m_s.allFinite() && o.environment.gravity_W_m_s2.allFinite(),
          "fit: the wind and gravity must be finite");
}

// Parameters that act on the angular accelerations only.
bool angular_only(ModelParameter p) {
  return p == ModelParameter::kInertiaXX || p == ModelParameter::kInertiaYY ||
         p == ModelParameter::kInertiaZZ || p == ModelParameter::kYawMomentPerThrust ||
         p == ModelParameter::kDragMoment || p == ModelParameter::kRollingMoment;
}

}  // namespace

// ---- names -----------------------------------------------------------------------------------

FitChannels parse_fit_channels(std::string_view text) {
  if (text == "auto") return FitChannels::kAuto;
  if (text == "linear") return FitChannels::kLinear;
  if (text == "angular") return FitChannels::kAngular;
  if (text == "linear,angular" || text == "angular,linear") return FitChannels::kLinearAngular;
  throw InvalidArgument("channels: expected auto, linear, angular or linear,angular, got '" +
                        std::string(text) + "'");
}

std::string_view fit_channels_name(FitChannels channels) {
  switch (channels) {
    case FitChannels::kAuto:
      return "auto";
    case FitChannels::kLinear:
      return "linear";
    case FitChannels::kAngular:
      return "angular";
    case FitChannels::kLinearAngular:
      return "linear,angular";
  }
  return "?";
}

FitLoss parse_fit_loss(std::string_view text) {
  if (text == "none") return FitLoss::kNone;
  if (text == "huber") return FitLoss::kHuber;
  if (text == "cauchy") return FitLoss::kCauchy;
  throw InvalidArgument("loss: expected none, huber or cauchy, got '" + std::string(text) + "'");
}

std::string_view fit_loss_name(FitLoss loss) {
  switch (loss) {
    case FitLoss::kNone:
      return "none";
    case FitLoss::kHuber:
      return "huber";
    case FitLoss::kCauchy:
      return "cauchy";
  }
  return "?";
}

double default_loss_scale(FitLoss loss) {
  switch (loss) {
    case FitLoss::kHuber:
      return 1.345;
    case FitLoss::kCauchy:
      return 2.385;
    case FitLoss::kNone:
      break;
  }
  return 0.0;
}

SpeedSensorGains parse_speed_sensor_gains(std::string_view text) {
  if (text == "auto") return SpeedSensorGains::kAuto;
  if (text == "fit") return SpeedSensorGains::kFit;
  if (text == "off") return SpeedSensorGains::kOff;
  throw InvalidArgument("speed sensor gains: expected auto, fit or off, got '" + std::string(text) +
                        "'");
}

std::string_view speed_sensor_gains_name(SpeedSensorGains gains) {
  switch (gains) {
    case SpeedSensorGains::kAuto:
      return "auto";
    case SpeedSensorGains::kFit:
      return "fit";
    case SpeedSensorGains::kOff:
      return "off";
  }
  return "?";
}

// ---- the fit ---------------------------------------------------------------------------------

FitResult fit_model(const VehicleModel& model, const FlightData& data, const FitOptions& o) {
  const auto t_start = std::chrono::steady_clock::now();
  check_options(o);
  require(data.num_rotors() == model.num_rotors(), data.source(), ": the log has ",
          data.num_rotors(), " rotors, the model ", model.name(), " has ", model.num_rotors());

  const ParameterMap pm(model);
  const Physics physics{&pm, o.switches, o.environment};
  // Two independent problems: the body parameters (accelerations / states) and the motor time
  // constants (rotor speeds). Nothing couples them, and solving them apart keeps each one's
  // residual weights and covariance conditioning in its own units.
  Setup body{&model, &data, &physics, {},  false,          false, false,        false,
             false,  0,     1.0,      1.0, FitLoss::kNone, 0.0,   o.num_threads};
  body.u.fixed = pm.initial_theta();
  body.u.num_rotors = model.num_rotors();
  body.loss = o.loss;
  body.loss_scale = o.loss_scale ? *o.loss_scale : default_loss_scale(o.loss);
  Setup motor = body;
  for (ModelParameter p : o.parameters) {
    (is_motor_parameter(p) ? motor : body).u.free.push_back(static_cast<int>(p));
  }
  const bool any_body = !body.u.free.empty(), any_motor = !motor.u.free.empty();
  motor.tau_rise_unit = body.tau_rise_unit = pm.value(ModelParameter::kTauRise, 1.0);
  motor.tau_fall_unit = body.tau_fall_unit = pm.value(ModelParameter::kTauFall, 1.0);
  if (any_motor) {
    require(data.has_rotor_references(), data.source(),
            ": fitting tau_rise/tau_fall needs the rotor speed references (column omega_ref_0 is "
            "missing)");
    require(
        motor.tau_rise_unit > 0.0 && motor.tau_fall_unit > 0.0, model.spec().source,
        ": tau_rise/tau_fall can only be fitted for a model with motor lag (time constants > 0)");
  }
  if (!data.has_body_rates()) {
    for (ModelParameter p : o.parameters) {
      require(!angular_only(p), data.source(), ": fitting ", parameter_name(p),
              " needs the body rates (columns wx, wy, wz are missing); it acts on the angular "
              "accelerations only");
    }
    require(o.channels != FitChannels::kAngular && o.channels != FitChannels::kLinearAngular,
            data.source(), ": channels ", fit_channels_name(o.channels),
            ": the angular channel needs the body rates (columns wx, wy, wz are missing)");
  }

  // Channels: the angular accelerations only when asked for or needed (fit.hpp says why).
  bool needs_angular = false, acts_on_linear = false;
  for (int j : body.u.free) {
    const auto p = static_cast<ModelParameter>(j);
    needs_angular = needs_angular || angular_only(p);
    acts_on_linear = acts_on_linear || !angular_only(p);
  }
  switch (o.channels) {
    case FitChannels::kAuto:
      body.linear = acts_on_linear;
      body.angular = needs_angular;
      break;
    case FitChannels::kLinear:
      body.linear = true;
      break;
    case FitChannels::kAngular:
      body.angular = true;
      break;
    case FitChannels::kLinearAngular:
      body.linear = body.angular = true;
      break;
  }
  if (any_body && !body.angular) {
    for (int j : body.u.free) {
      const auto p = static_cast<ModelParameter>(j);
      require(!angular_only(p), "fit: ", parameter_name(p),
              " acts on the angular accelerations only, but the channels are ",
              fit_channels_name(o.channels), " (add angular)");
    }
  }
  if (any_body && !body.linear) {
    for (int j : body.u.free) {
      const auto p = static_cast<ModelParameter>(j);
      require(p != ModelParameter::kMass && p != ModelParameter::kBodyDragX &&
                  p != ModelParameter::kBodyDragY && p != ModelParameter::kBodyDragZ,
              "fit: ", parameter_name(p),
              " acts on the linear accelerations only, but the "
              "channels are ",
              fit_channels_name(o.channels), " (add linear)");
    }
  }
  body.u.gains = any_body && model.num_rotors() >= 2 &&
                 (o.speed_sensor_gains == SpeedSensorGains::kFit ||
                  (o.speed_sensor_gains == SpeedSensorGains::kAuto && body.angular));
  if (o.speed_sensor_gains == SpeedSensorGains::kFit) {
    require(any_body,
            "fit: speed-sensor gains are fitted with body parameters (mass, thrust, "
            "inertia, ...), not with the motor time constants alone");
    require(body.angular, "fit: speed-sensor gains need the angular channel (channels ",
            fit_channels_name(o.channels),
            "): the linear accelerations see only the sum of the rotor thrusts");
    require(model.num_rotors() >= 2, "fit: speed-sensor gains need at least two rotors");
  }
  motor.use_motor = any_motor;
  body.use_eq = any_body && o.method != FitMethod::kOutputError;
  body.use_out = any_body && o.method != FitMethod::kEquationError;

  const Split split = split_intervals(data, o);
  FitResult r;
  r.rows = data.rows();
  r.gaps = split.gaps;
  r.contact_rows = split.contact_rows;
  r.excluded_rows = split.excluded_rows;
  r.median_dt_s = split.median_dt_s;
  r.intervals_used = split.fit.size();
  r.intervals_holdout = split.holdout.size();
  r.used_linear = any_body && body.linear;
  r.used_angular = any_body && body.angular;
  r.loss = o.loss;
  r.loss_scale = body.loss_scale;
  const std::size_t need = 4 * static_cast<std::size_t>(body.u.size() + motor.u.size()) + 10;
  require(split.fit.size() >= need, data.source(), ": only ", split.fit.size(),
          " usable intervals to fit (after gaps, ground contact and the hold-out); need at least ",
          need, " for ", body.u.size() + motor.u.size(), " unknowns");
  // The window in log intervals, checked before it is rounded (a huge window_s would overflow).
  const double window_intervals = o.window_s / split.median_dt_s;
  if (body.use_out) {
    require(window_intervals >= 1.5, data.source(), ": window_s = ", o.window_s,
            " s is shorter than two log intervals (median interval ", split.median_dt_s,
            " s): an output-error window needs at least 2 (window_s >= ", 2.0 * split.median_dt_s,
            " s)");
    require(window_intervals <= static_cast<double>(split.fit.size()), data.source(),
            ": window_s = ", o.window_s, " s is ", window_intervals,
            " log intervals, longer than the ", split.fit.size(), " intervals fitted");
    body.window_len = static_cast<int>(std::lround(window_intervals));
  }
  const std::vector<int> fit_windows =
      body.use_out ? pick_windows(split.fit, body.window_len, o.max_windows) : std::vector<int>{};
  const std::vector<int> holdout_windows =
      body.use_out ? pick_windows(split.holdout, body.window_len, o.max_windows)
                   : std::vector<int>{};
  require(!body.use_out || !fit_windows.empty(), data.source(), ": no stretch of ", body.window_len,
          " gap-free airborne intervals for an output-error window of ", o.window_s, " s");
  r.windows = fit_windows.size();
  if (!data.has_body_rates()) {
    r.warnings.push_back(
        "the log has no body rates: they were derived from successive attitudes and the "
        "angular accelerations were not fitted");
  }

  struct SubFit {
    std::vector<double> initial, block;
    SolveOutcome outcome;
  };
  ChannelSums before_fit, before_holdout, after_fit, after_holdout;
  std::vector<HoldoutCheck::Channel> checked;
  // A long log: the iterations start on every m-th fitted interval (at most coarse_intervals of
  // them), where each costs 1/m of a full pass, and only the last few, from a nearly converged
  // start, walk the whole log. The objective is the same, so is the solution (to the solver's
  // tolerances); the noise levels of stage 2 come from the whole log.
  const std::size_t stride = o.coarse_intervals > 0 && split.fit.size() > 2 * o.coarse_intervals
                                 ? (split.fit.size() + o.coarse_intervals - 1) / o.coarse_intervals
                                 : 1;
  std::vector<int> coarse;
  for (std::size_t i = 0; stride > 1 && i < split.fit.size(); i += stride)
    coarse.push_back(split.fit[i]);
  const double multiplicity =
      stride > 1 ? static_cast<double>(split.fit.size()) / static_cast<double>(coarse.size()) : 1.0;
  r.coarse_stride = stride;
  const auto run = [&](Setup& s) {
    SubFit f;
    for (int j : s.u.free) f.block.push_back(s.u.fixed[static_cast<std::size_t>(j)]);
    for (int i = 0; i < s.u.num_gains(); ++i) f.block.push_back(1.0);
    f.initial = f.block;
    const bool robust = s.loss != FitLoss::kNone;
    const Pass e0 = evaluate(s, f.block, split.fit, fit_windows, Weighting{}, robust);
    before_fit.merge(e0.sums);
    // Stage 1: least squares with unit weights (as ever), or the robust loss with each channel
    // in units of its noise level at the starting model.
    Weighting w1;
    w1.active = s.active();
    if (robust) w1 = weighting_from(s, e0, true);
    // Each stage ends on all intervals: the noise levels of stage 2 and the estimates are then
    // those of the fit without the coarse start (to the solver's tolerances).
    int coarse_iterations = 0;
    if (stride > 1) {
      coarse_iterations +=
          solve(s, f.block, coarse, multiplicity, fit_windows, w1, o, false).iterations;
    }
    const SolveOutcome o1 = solve(s, f.block, split.fit, 1.0, fit_windows, w1, o, false);
    // Stage 2: each channel in units of its noise level at the stage-1 solution.
    const Weighting w2 = weighting_from(
        s, evaluate(s, f.block, split.fit, fit_windows, Weighting{}, robust), robust);
    if (stride > 1) {
      coarse_iterations +=
          solve(s, f.block, coarse, multiplicity, fit_windows, w2, o, false).iterations;
    }
    f.outcome = solve(s, f.block, split.fit, 1.0, fit_windows, w2, o, true);
    f.outcome.iterations += o1.iterations + coarse_iterations;
    after_fit.merge(evaluate(s, f.block, split.fit, fit_windows, w2, false).sums);
    // The held-out part, before and after, in the fit's final units.
    const ChannelSums hb = evaluate(s, f.initial, split.holdout, holdout_windows, w2, false).sums;
    const ChannelSums ha = evaluate(s, f.block, split.holdout, holdout_windows, w2, false).sums;
    before_holdout.merge(hb);
    after_holdout.merge(ha);
    for (int c = 0; c < kNumChannels; ++c) {
      const auto i = static_cast<std::size_t>(c);
      if (!w2.active[i] || hb.count[i] == 0) continue;
      checked.push_back({kChannelNames[i], hb.loss[i] / static_cast<double>(hb.count[i]),
                         ha.loss[i] / static_cast<double>(ha.count[i])});
    }
    return f;
  };
  std::vector<std::pair<const Setup*, SubFit>> fits;
  if (any_body) fits.emplace_back(&body, run(body));
  if (any_motor) fits.emplace_back(&motor, run(motor));
  r.fit_before = stats_of(before_fit, split.fit.size(), data.has_body_rates());
  r.holdout_before = stats_of(before_holdout, split.holdout.size(), data.has_body_rates());
  r.fit_after = stats_of(after_fit, split.fit.size(), data.has_body_rates());
  r.holdout_after = stats_of(after_holdout, split.holdout.size(), data.has_body_rates());

  // The held-out check: every fitted channel must explain the held-out part at least as well as
  // the starting model (within the tolerance, relative and in units of the noise level^2).
  HoldoutCheck& hc = r.holdout_check;
  hc.available = !split.holdout.empty() && !checked.empty();
  hc.channels = checked;
  std::string worse_list, all_list;
  for (const HoldoutCheck::Channel& c : checked) {
    const bool worse = c.after > c.before * (1.0 + o.holdout_tolerance) + o.holdout_tolerance;
    const std::string item =
        c.name + " " + fmt(c.before, 4) + " -> " + fmt(c.after, 4) + (worse ? " (worse)" : "");
    all_list += (all_list.empty() ? "" : ", ") + item;
    if (worse) worse_list += (worse_list.empty() ? "" : ", ") + c.name;
    hc.worse = hc.worse || worse;
  }
  if (!hc.available) {
    hc.summary =
        "no held-out intervals (holdout 0): the fit could not be checked on data it "
        "was not fitted to";
    r.warnings.push_back(hc.summary);
  } else {
    hc.summary = std::string(hc.worse ? "WORSE" : "ok") +
                 ": held-out mean loss per residual (in noise levels), starting model -> fitted: " +
                 all_list;
    if (hc.worse) {
      r.warnings.push_back(
          "the fitted model explains the held-out part of the flight worse than "
          "the starting model (" +
          worse_list + "): " + hc.summary);
    }
  }

  // Gather: free-parameter order body then motor = canonical order (motor parameters are last);
  // the gains follow the body parameters.
  const int num_params = static_cast<int>(o.parameters.size());
  const int num_gains = body.u.num_gains();
  const int nf = num_params + num_gains;
  std::vector<double> initial(static_cast<std::size_t>(nf)), estimate(static_cast<std::size_t>(nf));
  std::vector<int> param_index(static_cast<std::size_t>(num_params));  // into the model's theta
  Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(nf, nf);
  Eigen::MatrixXd information = Eigen::MatrixXd::Zero(nf, nf);
  bool covariance_ok = true, usable = true;
  std::vector<std::string> terminations;
  int next_param = 0;
  for (const auto& [setup, f] : fits) {
    const int nfree = static_cast<int>(setup->u.free.size());
    std::vector<int> at(f.block.size());
    for (int i = 0; i < nfree; ++i) {
      param_index[static_cast<std::size_t>(next_param)] =
          setup->u.free[static_cast<std::size_t>(i)];
      at[static_cast<std::size_t>(i)] = next_param++;
    }
    for (int g = 0; g < setup->u.num_gains(); ++g)
      at[static_cast<std::size_t>(nfree + g)] = num_params + g;
    for (std::size_t i = 0; i < f.block.size(); ++i) {
      initial[static_cast<std::size_t>(at[i])] = f.initial[i];
      estimate[static_cast<std::size_t>(at[i])] = f.block[i];
    }
    const SolveOutcome& so = f.outcome;
    usable = usable && so.usable;
    r.iterations += so.iterations;
    terminations.push_back(so.termination);
    if (!so.usable) {
      r.warnings.push_back("Ceres did not reach a usable solution (" + so.termination + ")");
      covariance_ok = false;
      continue;
    }
    for (std::size_t a = 0; a < f.block.size(); ++a) {
      for (std::size_t b = 0; b < f.block.size(); ++b) {
        information(at[a], at[b]) =
            so.information(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
      }
    }
    // Ceres refuses a covariance when the reciprocal condition number of J^T J is below 1e-14;
    // the same test here, so a rank-deficient fit is reported in the result.
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(so.information);
    const Eigen::VectorXd& eig = es.eigenvalues();
    const auto n = static_cast<Eigen::Index>(f.block.size());
    const auto dof = static_cast<double>(so.residuals) - static_cast<double>(n);
    if (!(eig.minCoeff() > 10.0 * 1e-14 * eig.maxCoeff()) || dof <= 0.0) {
      covariance_ok = false;
      continue;
    }
    const double sigma2 = 2.0 * so.cost / dof;  // cost = 1/2 sum rho
    const Eigen::MatrixXd c = sigma2 * es.eigenvectors() * eig.cwiseInverse().asDiagonal() *
                              es.eigenvectors().transpose();
    for (Eigen::Index a = 0; a < n; ++a) {
      for (Eigen::Index b = 0; b < n; ++b)
        covariance(at[static_cast<std::size_t>(a)], at[static_cast<std::size_t>(b)]) = c(a, b);
    }
  }
  r.termination = terminations.front();
  for (std::size_t i = 1; i < terminations.size(); ++i) {
    if (terminations[i] != r.termination) r.termination += ", " + terminations[i];
  }

  // Estimates, standard errors, correlations.
  r.fitted_spec = model.spec();
  std::vector<std::string> names;
  std::vector<double> rel_error;  // std error / |estimate| per block entry
  for (int i = 0; i < num_params; ++i) {
    const auto p = static_cast<ModelParameter>(param_index[static_cast<std::size_t>(i)]);
    FittedParameter fp;
    fp.parameter = p;
    fp.name = std::string(parameter_name(p));
    fp.unit = std::string(parameter_unit(p));
    fp.initial = pm.value(p, initial[static_cast<std::size_t>(i)]);
    fp.estimate = pm.value(p, estimate[static_cast<std::size_t>(i)]);
    fp.std_error =
        covariance_ok ? std::abs(pm.value(p, std::sqrt(std::max(0.0, covariance(i, i))))) : kNaN;
    r.parameters.push_back(fp);
    names.push_back(fp.name);
    rel_error.push_back(fp.std_error / std::abs(fp.estimate));
    set_parameter_value(r.fitted_spec, p, fp.estimate);
  }
  if (num_gains > 0) {
    const Eigen::Index g0 = num_params;
    double last = static_cast<double>(model.num_rotors());
    for (int g = 0; g < num_gains; ++g) {
      const double v = estimate[static_cast<std::size_t>(num_params + g)];
      last -= v;
      const double se = covariance_ok ? std::sqrt(std::max(0.0, covariance(g0 + g, g0 + g))) : kNaN;
      r.speed_sensor_gains.push_back({g, v, se});
      names.push_back("speed_gain_" + std::to_string(g));
      rel_error.push_back(se / std::abs(v));
    }
    const double last_se =
        covariance_ok
            ? std::sqrt(std::max(0.0, covariance.block(g0, g0, num_gains, num_gains).sum()))
            : kNaN;
    r.speed_sensor_gains.push_back({model.num_rotors() - 1, last, last_se});
  }
  if (covariance_ok) {
    const Eigen::VectorXd sd = covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    r.correlation = Eigen::MatrixXd::Identity(nf, nf);
    for (int i = 0; i < nf; ++i) {
      for (int j = 0; j < nf; ++j) {
        if (i != j && sd[i] > 0 && sd[j] > 0)
          r.correlation(i, j) = covariance(i, j) / (sd[i] * sd[j]);
      }
    }
    // A correlation only matters when it costs precision: warn for a parameter whose standard
    // error exceeds 5 % of its value (naming its most correlated partner), and for any pair so
    // close to collinear (|r| > 0.999) that the data cannot tell the two apart.
    for (int i = 0; i < nf; ++i) {
      const double rel = rel_error[static_cast<std::size_t>(i)];
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
              names[static_cast<std::size_t>(partner)] +
              " (r = " + fmt(r.correlation(i, partner), 4) +
              "); fix one of them or fly a richer flight";
      }
      const bool is_param = i < num_params;
      const double se =
          is_param ? r.parameters[static_cast<std::size_t>(i)].std_error
                   : r.speed_sensor_gains[static_cast<std::size_t>(i - num_params)].std_error;
      const std::string unit =
          is_param ? r.parameters[static_cast<std::size_t>(i)].unit : std::string("(gain)");
      r.warnings.push_back(names[static_cast<std::size_t>(i)] + ": standard error " + fmt(se, 3) +
                           " " + unit + " is " + fmt(100.0 * rel, 3) + " %" + why);
    }
    for (int i = 0; i < nf; ++i) {
      for (int j = i + 1; j < nf; ++j) {
        if (std::abs(r.correlation(i, j)) > 0.999) {
          r.warnings.push_back(names[static_cast<std::size_t>(i)] + " and " +
                               names[static_cast<std::size_t>(j)] +
                               " are nearly collinear (r = " + fmt(r.correlation(i, j), 6) +
                               "): only a combination of them is identified");
        }
      }
    }
  } else if (usable) {
    // Rank-deficient: name the combination the data cannot see (weakest eigenvector of the
    // column-normalised information matrix).
    std::string weakest;
    const Eigen::VectorXd scale =
        information.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
    const Eigen::MatrixXd normalised = scale.asDiagonal() * information * scale.asDiagonal();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(normalised);
    const Eigen::VectorXd v = es.eigenvectors().col(0);
    for (int i = 0; i < nf; ++i) {
      if (std::abs(v[i]) > 0.2)
        weakest += (weakest.empty() ? "" : ", ") + names[static_cast<std::size_t>(i)];
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
  for (const FittedGain& g : r.speed_sensor_gains) {
    if (std::abs(g.estimate - 1.0) > 0.2) {
      r.warnings.push_back("speed_gain_" + std::to_string(g.rotor) + " = " + fmt(g.estimate, 4) +
                           ": rotor " + std::to_string(g.rotor) +
                           "'s logged speed is more than 20 % off the others: check its column");
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
  out << "channels "
      << (r.used_linear ? (r.used_angular ? "linear, angular" : "linear")
                        : (r.used_angular ? "angular" : "none (motor lag)"))
      << ", loss " << fit_loss_name(r.loss);
  if (r.loss != FitLoss::kNone) out << " (scale " << fmt(r.loss_scale, 4) << " noise levels)";
  out << ", speed-sensor gains " << (r.speed_sensor_gains.empty() ? "not fitted" : "fitted")
      << "\n";
  out << "Ceres: " << r.iterations << " iterations";
  if (r.coarse_stride > 1) out << " (started on one interval in " << r.coarse_stride << ")";
  out << ", " << r.termination << ", " << fmt(r.solve_time_s, 3) << " s\n\n";
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
  for (const FittedGain& g : r.speed_sensor_gains) {
    std::snprintf(line, sizeof line, "%-22s %14.6g %14.6g %12.3g %8.2f%%  %s\n",
                  ("speed_gain_" + std::to_string(g.rotor)).c_str(), 1.0, g.estimate, g.std_error,
                  100.0 * (g.estimate - 1.0), "(true speed / logged)");
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
  out << "\nheld-out check: " << r.holdout_check.summary << "\n";
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
  out << "\n  ],\n  \"speed_sensor_gains\": [";
  for (std::size_t i = 0; i < r.speed_sensor_gains.size(); ++i) {
    const FittedGain& g = r.speed_sensor_gains[i];
    out << (i ? ", " : "") << "{\"rotor\": " << g.rotor
        << ", \"estimate\": " << json_number(g.estimate)
        << ", \"std_error\": " << json_number(g.std_error) << "}";
  }
  out << "],\n  \"channels\": "
      << json_text(r.used_linear ? (r.used_angular ? "linear,angular" : "linear")
                                 : (r.used_angular ? "angular" : "none"))
      << ",\n  \"loss\": " << json_text(std::string(fit_loss_name(r.loss)))
      << ",\n  \"loss_scale\": " << json_number(r.loss_scale);
  out << ",\n  \"holdout_check\": {\"available\": "
      << (r.holdout_check.available ? "true" : "false")
      << ", \"worse\": " << (r.holdout_check.worse ? "true" : "false") << ", \"channels\": [";
  for (std::size_t i = 0; i < r.holdout_check.channels.size(); ++i) {
    const HoldoutCheck::Channel& c = r.holdout_check.channels[i];
    out << (i ? ", " : "") << "{\"name\": " << json_text(c.name)
        << ", \"before\": " << json_number(c.before) << ", \"after\": " << json_number(c.after)
        << "}";
  }
  out << "], \"summary\": " << json_text(r.holdout_check.summary) << "}";
  out << ",\n  \"correlation\": [";
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
      << ",\n  \"iterations\": " << r.iterations << ",\n  \"coarse_stride\": " << r.coarse_stride
      << ",\n  \"termination\": " << json_text(r.termination)
      << ",\n  \"solve_time_s\": " << json_number(r.solve_time_s) << "\n}\n";
  return out.str();
}

}  // namespace dronetwin
