// NmpcController: single-shooting NMPC of Eq. 3.23 on Ceres (see nmpc.hpp for the formulation).
//
// One Ceres residual block holds the whole horizon: its parameter blocks are the move blocks
// (6 parameters each), its residuals sqrt(Q)(x_k - x_ref,k) for k = 1..N and sqrt(R)(u_k -
// u_ref,k) for k = 0..N-1. Its Jacobian is built by forward sensitivities: per step, the RK4 step
// of nmpc_model.hpp runs on ceres::Jet<double, 19> (13 states + 6 inputs), which gives
// A_k = dx_{k+1}/dx_k and B_k = dx_{k+1}/du_k exactly; then S_{k+1} = A_k S_k + B_k G_k E_b(k),
// with G_k = du_k/dz (the bound-friendly parametrisation) and E_b the selector of step k's block.
// This is the chain rule of single shooting; it costs N Jet steps plus N small products instead
// of one Jet pass with as many derivatives as parameters.
#include "dronetwin/nmpc/nmpc.hpp"

#include <ceres/ceres.h>
#include <ceres/jet.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <numbers>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

namespace {

constexpr int kNx = kNmpcStateSize;
constexpr int kNu = kNmpcInputSize;
using Jet19 = ceres::Jet<double, kNx + kNu>;
using StateVec = Eigen::Matrix<double, kNx, 1>;
using InputVec = Eigen::Matrix<double, kNu, 1>;
using Vec2 = Eigen::Vector2d;
/// The tilt penalty is evaluated on every kTiltEvery-th predicted state (k = kTiltEvery, 2
/// kTiltEvery, ..., and the last): the attitude moves slowly over 10 steps, and 100 mostly-zero
/// rows would cost as much in J^T J as 8 % more states.
constexpr int kTiltEvery = 5;

const NmpcOptions& validated(const NmpcOptions& o) {
  o.validate();
  return o;
}

/// Unit quaternion of a heading: level attitude at `yaw_rad`.
Vec4 yaw_quaternion(double yaw_rad) {
  return Vec4(std::cos(0.5 * yaw_rad), 0.0, 0.0, std::sin(0.5 * yaw_rad));
}

}  // namespace

// ---- options ----------------------------------------------------------------------------------

int NmpcOptions::num_blocks() const {
  return input_blocks.empty() ? horizon_steps : static_cast<int>(input_blocks.size());
}

void NmpcOptions::validate() const {
  require(horizon_steps >= 1 && horizon_steps <= 10000,
          "nmpc: horizon_steps: expected an integer in [1, 10000], got ", horizon_steps);
  require(std::isfinite(step_s) && step_s > 0.0, "nmpc: step_s: expected > 0, got ", step_s);
  if (!input_blocks.empty()) {
    long sum = 0;
    for (std::size_t i = 0; i < input_blocks.size(); ++i) {
      require(input_blocks[i] >= 1, "nmpc: input_blocks[", i, "]: expected a length >= 1, got ",
              input_blocks[i]);
      sum += input_blocks[i];
    }
    require(sum == horizon_steps, "nmpc: input_blocks: lengths sum to ", sum,
            "; expected horizon_steps = ", horizon_steps);
  }
  for (int i = 0; i < kNx; ++i)
    require(std::isfinite(state_weights[i]) && state_weights[i] >= 0.0, "nmpc: state_weights[", i,
            "]: expected a finite weight >= 0, got ", state_weights[i]);
  for (int i = 0; i < kNu; ++i)
    require(std::isfinite(input_weights[i]) && input_weights[i] >= 0.0, "nmpc: input_weights[", i,
            "]: expected a finite weight >= 0, got ", input_weights[i]);
  require(std::isfinite(tilt_penalty_weight) && tilt_penalty_weight >= 0.0,
          "nmpc: tilt_penalty_weight: expected a finite number >= 0, got ", tilt_penalty_weight);
  require(std::isfinite(terminal_weight_scale) && terminal_weight_scale >= 0.0,
          "nmpc: terminal_weight_scale: expected a finite number >= 0, got ",
          terminal_weight_scale);
  require(std::isfinite(min_thrust_N) && min_thrust_N > 0.0,
          "nmpc: min_thrust_N: expected > 0, got ", min_thrust_N);
  require(std::isfinite(max_tilt_rad) && max_tilt_rad > 0.0 && max_tilt_rad < std::numbers::pi / 2,
          "nmpc: max_tilt_rad: expected an angle in (0, pi/2) rad, got ", max_tilt_rad);
  require(std::isfinite(max_thrust_N) && max_thrust_N * std::cos(max_tilt_rad) > min_thrust_N,
          "nmpc: max_thrust_N: expected a finite number with max_thrust_N cos(max_tilt_rad) > "
          "min_thrust_N = ",
          min_thrust_N, ", got ", max_thrust_N);
  for (int i = 0; i < 3; ++i)
    require(std::isfinite(max_moment_Nm[i]) && max_moment_Nm[i] > 0.0, "nmpc: max_moment_Nm[", i,
            "]: expected a finite number > 0, got ", max_moment_Nm[i]);
  require(std::isfinite(disturbance_gain) && disturbance_gain >= 0.0 && disturbance_gain <= 1.0,
          "nmpc: disturbance_gain: expected a number in [0, 1], got ", disturbance_gain);
  require(std::isfinite(max_disturbance_m_s2) && max_disturbance_m_s2 >= 0.0,
          "nmpc: max_disturbance_m_s2: expected a finite number >= 0, got ", max_disturbance_m_s2);
  require(std::isfinite(moment_observer_time_constant_s) && moment_observer_time_constant_s >= 0.0,
          "nmpc: moment_observer_time_constant_s: expected a finite number >= 0 (0 = off), got ",
          moment_observer_time_constant_s);
  require(std::isfinite(max_moment_disturbance_Nm) && max_moment_disturbance_Nm >= 0.0,
          "nmpc: max_moment_disturbance_Nm: expected a finite number >= 0, got ",
          max_moment_disturbance_Nm);
  require(max_iterations >= 0 && max_iterations <= 1000,
          "nmpc: max_iterations: expected an integer in [0, 1000], got ", max_iterations);
  require(max_solve_time_s > 0.0,
          "nmpc: max_solve_time_s: expected > 0 (infinity: no budget), got ", max_solve_time_s);
  require(std::isfinite(function_tolerance) && function_tolerance > 0.0,
          "nmpc: function_tolerance: expected a finite number > 0, got ", function_tolerance);
}

std::string_view termination_name(NmpcTermination t) {
  switch (t) {
    case NmpcTermination::kNotRun:
      return "not_run";
    case NmpcTermination::kConverged:
      return "converged";
    case NmpcTermination::kIterationCap:
      return "iteration_cap";
    case NmpcTermination::kFailure:
      return "failure";
  }
  return "unknown";
}

// ---- the Ceres problem ------------------------------------------------------------------------

struct NmpcController::Solver {
  Solver(const NmpcOptions& o, const NmpcModel& m);
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  /// Parameters z of block b.
  double* block(int b) { return params.data() + kNu * b; }
  /// Physical inputs of every block from the parameters z (u_blocks), and G_b = du/dz.
  void inputs_from_parameters(double const* const* z);
  /// Rolls the model out from x0 with u_blocks into x_steps (rows 0..N). False if non-finite.
  bool rollout();
  /// Residual rows: 13 N state rows (x_1..x_N), one tilt row per kTiltEvery steps, 6 nb input
  /// rows.
  int num_tilt_rows() const { return (N + kTiltEvery - 1) / kTiltEvery; }
  int num_residuals() const { return kNx * N + num_tilt_rows() + kNu * nb; }

  NmpcOptions opt;
  NmpcModel model;
  int N = 0, nb = 0;
  std::vector<int> block_of_step;  // N
  std::vector<int> block_start;    // nb
  std::vector<int> block_length;   // nb
  StateVec sqrt_q = StateVec::Zero();
  InputVec sqrt_r = InputVec::Zero();
  double sqrt_terminal = 1.0;
  double cos_tilt = 1.0;
  Eigen::Matrix<double, 6, 1> lower = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 1> upper = Eigen::Matrix<double, 6, 1>::Zero();

  // Data of the current solve (written by the controller before Solve()).
  StateVec x0 = StateVec::Zero();
  Eigen::Matrix<double, Eigen::Dynamic, kNx, Eigen::RowMajor> x_ref;    // N + 1
  Eigen::Matrix<double, Eigen::Dynamic, kNu, Eigen::RowMajor> u_ref;    // N
  Eigen::Matrix<double, Eigen::Dynamic, kNu, Eigen::RowMajor> u_ref_b;  // nb: block means
  std::vector<double> params;                                           // nb * 6

  // Scratch (preallocated: Evaluate allocates nothing).
  Eigen::Matrix<double, Eigen::Dynamic, kNu, Eigen::RowMajor> u_blocks;  // nb
  Eigen::Matrix<double, Eigen::Dynamic, kNx, Eigen::RowMajor> x_steps;   // N + 1
  std::vector<Eigen::Matrix<double, kNu, kNu>> g_blocks;                 // nb
  Eigen::Matrix<double, kNx, Eigen::Dynamic> sens, sens_next;            // 13 x 6 nb

  ceres::Problem problem;
  ceres::Solver::Options solver_options;
};

namespace {

/// The whole horizon as one residual block (see the file comment).
class HorizonCost final : public ceres::CostFunction {
 public:
  explicit HorizonCost(NmpcController::Solver* s) : s_(s) {
    set_num_residuals(s->num_residuals());
    for (int b = 0; b < s->nb; ++b) mutable_parameter_block_sizes()->push_back(kNu);
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  NmpcController::Solver* s_;
};

}  // namespace

NmpcController::Solver::Solver(const NmpcOptions& o, const NmpcModel& m) : opt(o), model(m) {
  N = o.horizon_steps;
  nb = o.num_blocks();
  block_of_step.resize(static_cast<std::size_t>(N));
  block_start.resize(static_cast<std::size_t>(nb));
  block_length.resize(static_cast<std::size_t>(nb));
  int k = 0;
  for (int b = 0; b < nb; ++b) {
    const int len = o.input_blocks.empty() ? 1 : o.input_blocks[static_cast<std::size_t>(b)];
    block_start[static_cast<std::size_t>(b)] = k;
    block_length[static_cast<std::size_t>(b)] = len;
    for (int i = 0; i < len; ++i) block_of_step[static_cast<std::size_t>(k++)] = b;
  }
  sqrt_q = o.state_weights.cwiseSqrt();
  sqrt_r = o.input_weights.cwiseSqrt();
  sqrt_terminal = std::sqrt(o.terminal_weight_scale);
  cos_tilt = std::cos(o.max_tilt_rad);
  // F = f_z [t_x, t_y, 1]: f_z <= max cos(tilt) and |t_x|, |t_y| <= tan(tilt) / sqrt(2) keep
  // |F| <= max_thrust_N and the tilt of F <= max_tilt_rad (the square inscribed in the cone).
  const double t = std::tan(o.max_tilt_rad) / std::numbers::sqrt2;
  lower << o.min_thrust_N, -t, -t, -o.max_moment_Nm;
  upper << o.max_thrust_N * std::cos(o.max_tilt_rad), t, t, o.max_moment_Nm;

  x_ref.resize(N + 1, kNx);
  u_ref.resize(N, kNu);
  u_ref_b.resize(nb, kNu);
  params.assign(static_cast<std::size_t>(kNu * nb), 0.0);
  u_blocks.resize(nb, kNu);
  x_steps.resize(N + 1, kNx);
  g_blocks.resize(static_cast<std::size_t>(nb));
  sens.resize(kNx, kNu * nb);
  sens_next.resize(kNx, kNu * nb);

  auto* cost = new HorizonCost(this);
  std::vector<double*> blocks;
  for (int b = 0; b < nb; ++b) blocks.push_back(block(b));
  problem.AddResidualBlock(cost, nullptr, blocks);
  for (int b = 0; b < nb; ++b)
    for (int i = 0; i < kNu; ++i) {
      problem.SetParameterLowerBound(block(b), i, lower[i]);
      problem.SetParameterUpperBound(block(b), i, upper[i]);
    }

  ceres::Solver::Options& so = solver_options;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = o.linear_solver == NmpcLinearSolver::kDenseQr
                              ? ceres::DENSE_QR
                              : ceres::DENSE_NORMAL_CHOLESKY;
  so.max_num_iterations = o.max_iterations;
  so.max_solver_time_in_seconds = std::isinf(o.max_solve_time_s) ? 1e9 : o.max_solve_time_s;
  so.function_tolerance = o.function_tolerance;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
}

void NmpcController::Solver::inputs_from_parameters(double const* const* z) {
  for (int b = 0; b < nb; ++b) {
    const double* p = z[b];
    nmpc_input_from_parameters<double>(p, u_blocks.row(b).data());
    // G = du/dz for F = f_z [t_x, t_y, 1], M = z[3..5].
    Eigen::Matrix<double, kNu, kNu>& g = g_blocks[static_cast<std::size_t>(b)];
    g.setZero();
    g(0, 0) = p[1];
    g(1, 0) = p[2];
    g(2, 0) = 1.0;
    g(0, 1) = p[0];
    g(1, 2) = p[0];
    g(3, 3) = g(4, 4) = g(5, 5) = 1.0;
  }
}

bool NmpcController::Solver::rollout() {
  x_steps.row(0) = x0.transpose();
  for (int k = 0; k < N; ++k)
    nmpc_rk4_step<double>(model, x_steps.row(k).data(),
                          u_blocks.row(block_of_step[static_cast<std::size_t>(k)]).data(),
                          opt.step_s, x_steps.row(k + 1).data());
  return x_steps.allFinite();
}

namespace {

/// Directions of the per-step Jets: v, q, w (10 states) and u (6). Eq. 3.23 does not depend on
/// the position, so dx_{k+1}/dp_k is exactly [I; 0] and needs no Jet direction.
constexpr int kJetDirs = kNx - 3 + kNu;
using StepJet = ceres::Jet<double, kJetDirs>;

bool HorizonCost::Evaluate(double const* const* parameters, double* residuals,
                           double** jacobians) const {
  NmpcController::Solver& s = *s_;
  const int N = s.N;
  s.inputs_from_parameters(parameters);
  const int tilt_row0 = kNx * N;
  const int input_row0 = kNx * N + s.num_tilt_rows();
  // Tilt row of x_k (k = 1..N), or -1: k = kTiltEvery j, and the last state.
  const auto tilt_row = [&](int k) {
    if (k == N) return tilt_row0 + s.num_tilt_rows() - 1;
    return k % kTiltEvery == 0 ? tilt_row0 + k / kTiltEvery - 1 : -1;
  };

  // Tilt penalty: w (cos(max_tilt) - b3_z)_+ with b3_z = 1 - 2 (q_x^2 + q_y^2), the cosine of
  // the body tilt. Zero (and flat) inside the bound; its square is C1.
  const double w_tilt = s.opt.tilt_penalty_weight;
  const auto residuals_of_states = [&] {
    for (int k = 1; k <= N; ++k) {
      const double scale = k == N ? s.sqrt_terminal : 1.0;
      double* r = residuals + kNx * (k - 1);
      for (int i = 0; i < kNx; ++i) r[i] = scale * s.sqrt_q[i] * (s.x_steps(k, i) - s.x_ref(k, i));
      const int tr = tilt_row(k);
      if (tr < 0) continue;
      const double qx = s.x_steps(k, 7), qy = s.x_steps(k, 8);
      const double b3z = 1.0 - 2.0 * (qx * qx + qy * qy);
      residuals[tr] = w_tilt * std::max(s.cos_tilt - b3z, 0.0);
    }
  };
  // Input rows per block: sum over its L steps of |u_b - u_ref,k|^2_R = L |u_b - mean u_ref|^2_R
  // + a constant, so one row set per block with weight sqrt(L) has the same minimiser.
  for (int b = 0; b < s.nb; ++b) {
    const double w = std::sqrt(static_cast<double>(s.block_length[static_cast<std::size_t>(b)]));
    double* r = residuals + input_row0 + kNu * b;
    for (int i = 0; i < kNu; ++i) r[i] = w * s.sqrt_r[i] * (s.u_blocks(b, i) - s.u_ref_b(b, i));
  }

  if (jacobians == nullptr) {
    if (!s.rollout()) return false;
    residuals_of_states();
    return true;
  }

  const int rows = s.num_residuals();
  for (int b = 0; b < s.nb; ++b)
    if (jacobians[b] != nullptr)
      std::memset(jacobians[b], 0, sizeof(double) * static_cast<std::size_t>(rows * kNu));

  s.x_steps.row(0) = s.x0.transpose();
  s.sens.setZero();
  s.sens_next.setZero();
  StepJet xj[kNx], uj[kNu], xn[kNx];
  Eigen::Matrix<double, kNx, kNx - 3> A;  // dx_{k+1} / d(v, q, w)_k
  Eigen::Matrix<double, kNx, kNu> B, BG;
  for (int k = 0; k < N; ++k) {
    const int b = s.block_of_step[static_cast<std::size_t>(k)];
    for (int i = 0; i < 3; ++i) xj[i] = StepJet(s.x_steps(k, i));
    for (int i = 3; i < kNx; ++i) xj[i] = StepJet(s.x_steps(k, i), i - 3);
    for (int i = 0; i < kNu; ++i) uj[i] = StepJet(s.u_blocks(b, i), kNx - 3 + i);
    nmpc_rk4_step<StepJet>(s.model, xj, uj, s.opt.step_s, xn);
    for (int i = 0; i < kNx; ++i) {
      s.x_steps(k + 1, i) = xn[i].a;
      A.row(i) = xn[i].v.head<kNx - 3>().transpose();
      B.row(i) = xn[i].v.tail<kNu>().transpose();
    }
    const int cols = kNu * (b + 1);  // blocks after b do not influence x_{k+1}
    BG.noalias() = B * s.g_blocks[static_cast<std::size_t>(b)];
    s.sens_next.leftCols(cols).noalias() = A * s.sens.bottomRows<kNx - 3>().leftCols(cols);
    s.sens_next.topRows<3>().leftCols(cols) += s.sens.topRows<3>().leftCols(cols);
    s.sens_next.middleCols<kNu>(kNu * b) += BG;
    s.sens.swap(s.sens_next);  // O(1); columns >= cols stay zero in both

    // State rows and tilt row of x_{k+1}.
    const double scale = k + 1 == N ? s.sqrt_terminal : 1.0;
    const double qx = s.x_steps(k + 1, 7), qy = s.x_steps(k + 1, 8);
    const int tr = tilt_row(k + 1);
    const bool tilt_active = tr >= 0 && s.cos_tilt - (1.0 - 2.0 * (qx * qx + qy * qy)) > 0.0;
    for (int bb = 0; bb <= b; ++bb) {
      double* jac = jacobians[bb];
      if (jac == nullptr) continue;
      for (int i = 0; i < kNx; ++i) {
        const double w = scale * s.sqrt_q[i];
        double* row = jac + static_cast<std::ptrdiff_t>(kNx * k + i) * kNu;
        for (int j = 0; j < kNu; ++j) row[j] = w * s.sens(i, kNu * bb + j);
      }
      if (tilt_active) {  // d/dq of w (cos a - 1 + 2 (qx^2 + qy^2))
        double* row = jac + static_cast<std::ptrdiff_t>(tr) * kNu;
        for (int j = 0; j < kNu; ++j)
          row[j] = w_tilt * 4.0 * (qx * s.sens(7, kNu * bb + j) + qy * s.sens(8, kNu * bb + j));
      }
    }
  }
  // Input rows.
  for (int b = 0; b < s.nb; ++b) {
    double* jac = jacobians[b];
    if (jac == nullptr) continue;
    const double w = std::sqrt(static_cast<double>(s.block_length[static_cast<std::size_t>(b)]));
    const Eigen::Matrix<double, kNu, kNu>& g = s.g_blocks[static_cast<std::size_t>(b)];
    for (int i = 0; i < kNu; ++i) {
      double* row = jac + static_cast<std::ptrdiff_t>(input_row0 + kNu * b + i) * kNu;
      for (int j = 0; j < kNu; ++j) row[j] = w * s.sqrt_r[i] * g(i, j);
    }
  }
  if (!s.x_steps.allFinite()) return false;
  residuals_of_states();
  return true;
}

}  // namespace

// ---- controller -------------------------------------------------------------------------------

NmpcController::NmpcController(std::shared_ptr<const VehicleModel> model,
                               const NmpcOptions& options, double call_rate_hz,
                               AllocationMethod allocation)
    : ControllerBase(std::move(model), allocation),
      options_(validated(options)),
      fallback_(model_ptr(), options.se3,
                Se3Options{.gravity_compensation = true,
                           .max_tilt_rad = options.max_tilt_rad,
                           .nonnegative_thrust = true},
                allocation) {
  require(std::isfinite(call_rate_hz) && call_rate_hz > 0.0,
          "nmpc: call_rate_hz: expected > 0, got ", call_rate_hz);
  const double ratio = call_rate_hz * options_.step_s;
  const double whole = std::round(ratio);
  require(whole >= 1.0 && std::abs(ratio - whole) <= 1e-9 * whole,
          "nmpc: step_s: expected a whole multiple of the call period 1 / ", call_rate_hz,
          " s, got ", options_.step_s, " s (", ratio, " calls per solve)");
  calls_per_solve_ = static_cast<int>(whole);
  model_eq323_.mass_kg = options_.se3.mass_kg;
  model_eq323_.gravity_m_s2 = options_.se3.gravity_m_s2;
  model_eq323_.inertia_kgm2 = this->model().inertia_kgm2();
  model_eq323_.inertia_inverse = this->model().inertia_inverse();
  solver_ = std::make_unique<Solver>(options_, model_eq323_);
  for (int i = 0; i < this->model().num_rotors(); ++i)
    motor_rise_s_ += this->model().rotor(i).time_constant_rise_s / this->model().num_rotors();
  reset();
}

NmpcController::~NmpcController() = default;

NmpcController::NmpcController(const NmpcController& other)
    : ControllerBase(other),
      options_(other.options_),
      model_eq323_(other.model_eq323_),
      calls_per_solve_(other.calls_per_solve_),
      solver_(std::make_unique<Solver>(other.options_, other.model_eq323_)),
      fallback_(other.fallback_),
      calls_(other.calls_),
      stats_(other.stats_),
      solved_this_call_(other.solved_this_call_),
      plan_x_(other.plan_x_),
      plan_u_(other.plan_u_),
      plan_t0_s_(other.plan_t0_s_),
      plan_solve_index_(other.plan_solve_index_),
      force_cmd_(other.force_cmd_),
      d_hat_(other.d_hat_),
      moment_d_hat_(other.moment_d_hat_),
      moment_cmd_(other.moment_cmd_),
      moment_applied_(other.moment_applied_),
      w_prev_(other.w_prev_),
      t_prev_s_(other.t_prev_s_),
      observer_primed_(other.observer_primed_),
      motor_rise_s_(other.motor_rise_s_),
      preview_(other.preview_ ? other.preview_->clone() : nullptr),
      inject_first_(other.inject_first_),
      inject_count_(other.inject_count_) {
  solver_->params = other.solver_->params;
}

std::unique_ptr<ControllerBase> NmpcController::clone() const {
  return std::make_unique<NmpcController>(*this);
}

void NmpcController::reset() {
  calls_ = 0;
  stats_ = NmpcSolveStats{};
  solved_this_call_ = false;
  plan_x_.resize(0, 0);
  plan_u_.resize(0, 0);
  plan_t0_s_ = 0.0;
  plan_solve_index_ = -1;
  force_cmd_.setZero();
  d_hat_.setZero();
  moment_d_hat_.setZero();
  moment_cmd_.setZero();
  moment_applied_.setZero();
  w_prev_.setZero();
  t_prev_s_ = 0.0;
  observer_primed_ = false;
  fallback_.reset();
}

void NmpcController::observe_moment(const ControlInput& in) {
  if (options_.moment_observer_time_constant_s <= 0.0) return;
  const Vec3 w_B = in.state.segment<3>(state_index::kAngularVelocity);
  const double dt_s = in.time_s - t_prev_s_;
  if (observer_primed_ && dt_s > 0.0) {
    // The moment the rotors applied over the last call: the command through their rise lag
    // (Eq. 2.43, first order), exact for a command held over dt_s.
    const double lag = motor_rise_s_ > 0.0 ? std::exp(-dt_s / motor_rise_s_) : 0.0;
    moment_applied_ = lag * moment_applied_ + (1.0 - lag) * moment_cmd_;
    // Euler's equation, J w_dot = M - w x J w + M_d, over the last call.
    const Mat3& J = model_eq323_.inertia_kgm2;
    const Vec3 w_mid = 0.5 * (w_B + w_prev_);
    const Vec3 sample = J * (w_B - w_prev_) / dt_s + w_mid.cross(J * w_mid) - moment_applied_;
    const double a = 1.0 - std::exp(-dt_s / options_.moment_observer_time_constant_s);
    moment_d_hat_ += a * (sample - moment_d_hat_);
    const double n = moment_d_hat_.norm();
    if (n > options_.max_moment_disturbance_Nm)
      moment_d_hat_ *= options_.max_moment_disturbance_Nm / n;
  }
  w_prev_ = w_B;
  t_prev_s_ = in.time_s;
  observer_primed_ = true;
}

GeneralizedForce NmpcController::compensate_moment(GeneralizedForce u) {
  if (options_.moment_observer_time_constant_s <= 0.0) return u;
  u.tail<3>() -= moment_d_hat_;
  moment_cmd_ = u.tail<3>();
  return u;
}

void NmpcController::set_reference_preview(const Reference& reference) {
  preview_ = reference.clone();
}

void NmpcController::inject_solve_failures(std::int64_t first, std::int64_t count) {
  inject_first_ = first;
  inject_count_ = count;
}

std::vector<std::string> NmpcController::diagnostic_names() const {
  return {"solved",      "iterations", "initial_cost", "final_cost",          "solve_time_ms",
          "termination", "failed",     "mode",         "consecutive_failures"};
}

void NmpcController::diagnostics(double* out) const {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const bool s = solved_this_call_;
  out[0] = s ? 1.0 : 0.0;
  out[1] = s ? stats_.iterations : nan;
  out[2] = s ? stats_.initial_cost : nan;
  out[3] = s ? stats_.final_cost : nan;
  out[4] = s ? 1e3 * stats_.solve_time_s : nan;
  out[5] = s ? static_cast<double>(static_cast<int>(stats_.termination) - 1) : nan;
  out[6] = s ? (stats_.termination == NmpcTermination::kFailure ? 1.0 : 0.0) : nan;
  out[7] = static_cast<double>(static_cast<int>(stats_.mode));
  out[8] = static_cast<double>(stats_.consecutive_failures);
}

int NmpcController::num_parameters() const { return kNu * solver_->nb; }
int NmpcController::num_residuals() const { return solver_->num_residuals(); }
std::vector<double> NmpcController::last_parameters() const { return solver_->params; }

bool NmpcController::evaluate_horizon(const std::vector<double>& z, Eigen::VectorXd* residuals,
                                      Eigen::MatrixXd* jacobian) const {
  require(static_cast<int>(z.size()) == num_parameters(), "nmpc: evaluate_horizon: expected ",
          num_parameters(), " parameters, got ", z.size());
  require(residuals != nullptr, "nmpc: evaluate_horizon: residuals is null");
  Solver& s = *solver_;
  HorizonCost cost(&s);
  std::vector<const double*> blocks;
  for (int b = 0; b < s.nb; ++b) blocks.push_back(z.data() + kNu * b);
  residuals->resize(num_residuals());
  std::vector<std::vector<double>> jac_blocks;
  std::vector<double*> jac_ptrs;
  if (jacobian != nullptr) {
    jac_blocks.assign(static_cast<std::size_t>(s.nb),
                      std::vector<double>(static_cast<std::size_t>(num_residuals() * kNu)));
    for (auto& j : jac_blocks) jac_ptrs.push_back(j.data());
  }
  const bool ok = cost.Evaluate(blocks.data(), residuals->data(),
                                jacobian != nullptr ? jac_ptrs.data() : nullptr);
  if (jacobian != nullptr) {
    jacobian->resize(num_residuals(), num_parameters());
    for (int b = 0; b < s.nb; ++b)
      for (int r = 0; r < num_residuals(); ++r)
        for (int j = 0; j < kNu; ++j)
          (*jacobian)(r, kNu * b + j) =
              jac_blocks[static_cast<std::size_t>(b)][static_cast<std::size_t>(r * kNu + j)];
  }
  return ok;
}

void NmpcController::solve(const ControlInput& in) {
  Solver& s = *solver_;
  const int N = s.N;
  const double m = model_eq323_.mass_kg, g = model_eq323_.gravity_m_s2;
  const std::int64_t index = stats_.solve_index + 1;

  // Disturbance estimate (offset-free MPC): the velocity error of the last good plan's
  // prediction for now, integrated. Only against a plan, so failures do not feed it.
  if (options_.disturbance_gain > 0.0 && plan_solve_index_ >= 0 && index - plan_solve_index_ <= N) {
    const Vec3 v_pred = plan_x_.row(index - plan_solve_index_).segment<3>(3).transpose();
    const Vec3 v_meas = in.state.segment<3>(state_index::kVelocity);
    d_hat_ += options_.disturbance_gain * (v_meas - v_pred) / options_.step_s;
    const double n = d_hat_.norm();
    if (n > options_.max_disturbance_m_s2) d_hat_ *= options_.max_disturbance_m_s2 / n;
  }
  s.model.disturbance_m_s2 = d_hat_;

  // References over the horizon: the preview when the loop gave one, else the current reference
  // point extrapolated at constant acceleration.
  for (int k = 0; k <= N; ++k) {
    const double tau = k * options_.step_s;
    ReferencePoint r;
    if (preview_) {
      r = preview_->at(in.time_s + tau);
    } else {
      r = in.reference;
      r.position_m +=
          in.reference.velocity_m_s * tau + 0.5 * in.reference.acceleration_m_s2 * tau * tau;
      r.velocity_m_s += in.reference.acceleration_m_s2 * tau;
      r.yaw_rad += in.reference.yaw_rate_rad_s * tau;
    }
    auto xr = s.x_ref.row(k);
    xr.segment<3>(0) = r.position_m.transpose();
    xr.segment<3>(3) = r.velocity_m_s.transpose();
    xr.segment<4>(6) = yaw_quaternion(r.yaw_rad).transpose();
    xr.segment<3>(10).setZero();
    if (k < N) {
      s.u_ref.row(k).head<3>() =
          (m * (r.acceleration_m_s2 + g * Vec3::UnitZ() - d_hat_)).transpose();
      s.u_ref.row(k).tail<3>().setZero();
    }
  }
  for (int b = 0; b < s.nb; ++b)
    s.u_ref_b.row(b) = s.u_ref
                           .middleRows(s.block_start[static_cast<std::size_t>(b)],
                                       s.block_length[static_cast<std::size_t>(b)])
                           .colwise()
                           .mean();

  // Initial state: measured, quaternion normalised (notes #30), in the reference's hemisphere.
  using namespace state_index;
  s.x0 = in.state;
  Vec4 q = in.state.segment<4>(kQuaternion);
  const double qn = q.norm();
  q = qn > 1e-12 ? Vec4(q / qn) : Vec4(1, 0, 0, 0);
  if (q.dot(s.x_ref.row(0).segment<4>(6).transpose()) < 0.0) q = -q;
  s.x0.segment<4>(kQuaternion) = q;

  // Warm start: the last good plan shifted by the solves since it was made; the feed-forward
  // input where it has no value. Clamped into the bounds (Ceres requires a feasible start).
  const std::int64_t shift = plan_solve_index_ >= 0 ? index - plan_solve_index_ : N;
  for (int b = 0; b < s.nb; ++b) {
    const std::int64_t src = s.block_start[static_cast<std::size_t>(b)] + shift;
    InputVec u =
        src < N ? InputVec(plan_u_.row(src).transpose())
                : InputVec(s.u_ref.row(std::min(s.block_start[static_cast<std::size_t>(b)], N - 1))
                               .transpose());
    double* z = s.block(b);
    z[0] = std::clamp(u[2], s.lower[0], s.upper[0]);
    z[1] = std::clamp(u[0] / z[0], s.lower[1], s.upper[1]);
    z[2] = std::clamp(u[1] / z[0], s.lower[2], s.upper[2]);
    for (int i = 3; i < kNu; ++i) z[i] = std::clamp(u[i], s.lower[i], s.upper[i]);
  }

  ceres::Solver::Summary summary;
  const auto t0 = std::chrono::steady_clock::now();
  ceres::Solve(s.solver_options, &s.problem, &summary);
  const auto t1 = std::chrono::steady_clock::now();

  stats_.solve_index = index;
  stats_.time_s = in.time_s;
  // summary.iterations holds iteration 0 (the warm start) too.
  stats_.iterations = std::max(static_cast<int>(summary.iterations.size()) - 1, 0);
  stats_.initial_cost = summary.initial_cost;
  stats_.final_cost = summary.final_cost;
  stats_.solve_time_s = std::chrono::duration<double>(t1 - t0).count();

  bool ok = summary.IsSolutionUsable() && std::isfinite(summary.final_cost);
  stats_.termination = summary.termination_type == ceres::CONVERGENCE ||
                               summary.termination_type == ceres::USER_SUCCESS
                           ? NmpcTermination::kConverged
                           : NmpcTermination::kIterationCap;
  if (ok) {
    std::vector<const double*> z(static_cast<std::size_t>(s.nb));
    for (int b = 0; b < s.nb; ++b) z[static_cast<std::size_t>(b)] = s.block(b);
    s.inputs_from_parameters(z.data());
    ok = s.u_blocks.allFinite() && s.rollout();
  }
  if (ok && index >= inject_first_ && index < inject_first_ + inject_count_) ok = false;

  if (ok) {
    plan_x_ = s.x_steps;
    plan_u_.resize(N, kNu);
    for (int k = 0; k < N; ++k)
      plan_u_.row(k) = s.u_blocks.row(s.block_of_step[static_cast<std::size_t>(k)]);
    plan_t0_s_ = in.time_s;
    plan_solve_index_ = index;
    stats_.mode = NmpcMode::kPlan;
    stats_.consecutive_failures = 0;
  } else {
    stats_.termination = NmpcTermination::kFailure;
    ++stats_.consecutive_failures;
    ++stats_.total_failures;
    const bool plan_left = plan_solve_index_ >= 0 && index - plan_solve_index_ < N;
    stats_.mode = plan_left ? NmpcMode::kPreviousPlan : NmpcMode::kSe3;
  }
}

GeneralizedForce NmpcController::do_calculate_u(const ControlInput& in) {
  observe_moment(in);
  solved_this_call_ = calls_ % calls_per_solve_ == 0;
  if (solved_this_call_) solve(in);
  ++calls_;

  if (stats_.mode == NmpcMode::kSe3) {
    const GeneralizedForce u = fallback_.calculate_u(in);
    Vec4 q = in.state.segment<4>(state_index::kQuaternion);
    q = q.norm() > 1e-12 ? Vec4(q.normalized()) : Vec4(1, 0, 0, 0);
    force_cmd_ = u[0] * math::rotation_matrix<double>(q).col(2);  // what the fallback flies
    return compensate_moment(u);
  }
  // The plan's interval in use (0 for a fresh plan; later ones when falling back on it).
  const std::int64_t row = stats_.solve_index - plan_solve_index_;
  const Vec3 F = plan_u_.row(row).head<3>().transpose();
  // The inner loop flies the planned attitude: thrust direction b3d = the predicted body z axis
  // at the end of the interval (the SE(3) attitude loop lags the command by ~1/40 s), collective
  // thrust = the planned thrust (R e3 . F) of Eq. 3.23 there. F's direction itself does not
  // matter in Eq. 3.23 (only its projection does), so flying F / |F| would not be the plan.
  const Vec4 q_plan = plan_x_.row(row + 1).segment<4>(6).transpose();
  Vec3 b3d = math::rotation_matrix<double>(Vec4(q_plan.normalized())).col(2);
  double f = std::max(b3d.dot(F), 0.0);
  // Hard tilt cone on the command (the prediction only penalises the tilt).
  const double cos_a = std::cos(options_.max_tilt_rad);
  if (b3d.z() < cos_a) {
    Vec2 h(b3d.x(), b3d.y());
    const double hn = h.norm();
    h = hn > 1e-12 ? Vec2(h / hn) : Vec2(1, 0);
    const double sin_a = std::sin(options_.max_tilt_rad);
    b3d = Vec3(sin_a * h.x(), sin_a * h.y(), cos_a);
  }
  f = std::min(f, options_.max_thrust_N);
  force_cmd_ = f * b3d;

  using namespace state_index;
  Vec4 q = in.state.segment<4>(kQuaternion);
  const double qn = q.norm();
  q = qn > 1e-12 ? Vec4(q / qn) : Vec4(1, 0, 0, 0);
  const Mat3 R = math::rotation_matrix<double>(q);
  const Vec3 w_B = in.state.segment<3>(kAngularVelocity);
  const Mat3& J = model().inertia_kgm2();
  Se3FeedForward<double> ff{Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  if (options_.inner_feed_forward) {
    // The plan's rates at the end of the interval (where b3d is taken) and the angular
    // acceleration its moment over the interval gives (Euler's equation, Eq. 3.23).
    ff.angular_velocity_B = plan_x_.row(row + 1).segment<3>(kAngularVelocity).transpose();
    const Vec3& w = ff.angular_velocity_B;
    const Vec3 M_plan = plan_u_.row(row).tail<3>().transpose();
    ff.angular_acceleration_B = model().inertia_inverse() * (M_plan - w.cross(J * w));
  }
  const Vec3 M = se3_attitude_law<double>(R, w_B, b3d, std::cos(in.reference.yaw_rad),
                                          std::sin(in.reference.yaw_rad), options_.se3.attitude_p,
                                          options_.se3.attitude_d, J,
                                          options_.inner_feed_forward ? &ff : nullptr);
  GeneralizedForce u;
  u << f, M;
  return compensate_moment(u);
}

}  // namespace dronetwin
