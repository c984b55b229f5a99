#pragma once
// NmpcController: nonlinear model predictive control of the outer (translational) loop, solved
// with Ceres, over the SE(3) attitude law as inner loop (thesis Sec. 3.6.1.4, Eq. 3.23-3.25).
//
// Every `step_s` (10 ms) of calls it solves, by single shooting,
//   min over u_0..u_{N-1}   sum_{k=1..N} |x_k - x_ref,k|^2_Q  +  sum_{k=0..N-1} |u_k - u_ref,k|^2_R
//                           + sum_k w_tilt^2 (cos(max_tilt) - cos(tilt_k))_+^2
//   s.t. x_{k+1} = RK4(Eq. 3.23 [+ d], x_k, u_k, step_s),  x_0 = measured state,
//        thrust_N[0] <= |F_k| <= thrust_N[1],  tilt(F_k) <= max_tilt_rad,  |M_k| <= max_moment,
// with u = [F_W, M_B] (nmpc_model.hpp), Q and R of Eq. 3.24 (diagonal), x_ref from the reference
// (level attitude at the reference yaw, zero rates) and u_ref = [m (a_ref + g e3 - d), 0] (the
// feed-forward input: R penalises deviations from it, not the weight-carrying thrust itself).
// Inputs are move-blocked (`input_blocks`: consecutive steps sharing one value). Jacobians:
// per-step automatic differentiation of the templated RK4 step, chained exactly. The solve is
// warm-started from the previous plan shifted by one step. d is an optional disturbance
// acceleration estimated from the last plan's velocity error (offset-free MPC; off by default).
//
// Between solves, and at every call, the inner loop applies the SE(3) attitude law
// (se3_attitude_law, control/se3_law.hpp) to the plan: thrust direction b3d = the predicted body z
// axis at the end of the current interval, clipped to the tilt cone; collective thrust f = b3d . F
// (Eq. 3.23's thrust there), clipped to thrust_N[1]. With NmpcOptions::inner_feed_forward (our
// addition; off as in the thesis) the attitude law is Lee et al.'s full one (control/se3_law.hpp)
// with the plan's body rates at the end of the interval as w_d and the angular acceleration its
// moment gives, J^-1 (M_plan - w x J w), as w_d': the inner loop no longer damps the rates the plan
// turns at. The controller must therefore be called at the
// inner-loop rate (e.g. 1 kHz); `call_rate_hz` must be a whole multiple of 1 / step_s, and
// solves happen on calls 0, s, 2s, ... (s = call_rate_hz * step_s) by count, never by wall clock.
//
//   NmpcOptions o;                                   // Eq. 3.24 weights, N = 100, 10 ms
//   o.input_blocks = {1, 2, 4, 8, 16, 32, 37};
//   NmpcController nmpc(model, o, /*call_rate_hz=*/1000.0);
//   ClosedLoop loop(sim, nmpc, FigureEightReference{}, 1000.0);
//   loop.run(60.0);
//   nmpc.last_solve().iterations;  nmpc.predicted_states();   // (N + 1) x 13
//
// Failures: a solve that ends in failure, returns a non-finite plan, or is rejected by the
// failure-injection hook does not fly. The controller then follows the last good plan, shifted
// by the solves since it was made, while it lasts (N - 1 intervals), then SE(3) position control
// with the position gains of `se3`; diagnostics() and last_solve() report it. A solve that stops at
// the iteration cap or the time budget keeps its best iterate (Ceres never returns a worse one).
//
// Trap: with a finite max_solve_time_s a run is reproducible only as long as the budget never
// triggers; the default (no budget, max_iterations capped) keeps runs bitwise reproducible.
// The solve-time diagnostic is wall clock and differs between runs.

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "dronetwin/control/controller_base.hpp"
#include "dronetwin/control/se3.hpp"
#include "dronetwin/nmpc/nmpc_model.hpp"

namespace dronetwin {

enum class NmpcLinearSolver { kDenseQr, kDenseNormalCholesky };

struct NmpcOptions {
  int horizon_steps = 100;  ///< N (thesis: 100)
  double step_s = 0.01;     ///< shooting interval and re-solve period, s (thesis: 10 ms)
  /// Move blocking: lengths (in steps) of consecutive input blocks, summing to horizon_steps.
  /// Empty: one block per step (no blocking).
  std::vector<int> input_blocks;
  /// diag(Q), Eq. 3.24: [p (3), v (3)] 1, q (4) 0.1, w (3) 1.
  Eigen::Matrix<double, 13, 1> state_weights =
      (Eigen::Matrix<double, 13, 1>() << 1, 1, 1, 1, 1, 1, 0.1, 0.1, 0.1, 0.1, 1, 1, 1).finished();
  /// diag(R), Eq. 3.24: F (3) 0.3, M (3) 0.03.
  Eigen::Matrix<double, 6, 1> input_weights =
      (Eigen::Matrix<double, 6, 1>() << 0.3, 0.3, 0.3, 0.03, 0.03, 0.03).finished();
  /// Multiplies Q for the last state x_N (1: no extra terminal cost).
  double terminal_weight_scale = 1.0;
  /// Weight w of the tilt penalty residual w (cos(max_tilt_rad) - cos(tilt_k))_+ on every
  /// predicted state (single shooting cannot bound states; the command has a hard cone too).
  double tilt_penalty_weight = 100.0;

  double min_thrust_N = 2.0;                 ///< lower bound on |F| (via F_z), keeps b3d defined
  double max_thrust_N = 30.0;                ///< upper bound on |F|
  double max_tilt_rad = 0.5;                 ///< bound on the angle between F and +z
  Vec3 max_moment_Nm = Vec3::Constant(1.0);  ///< bound on |M_i| in the prediction

  /// Offset-free MPC: each solve updates a constant disturbance acceleration d (added to v_dot
  /// in the prediction and cancelled in u_ref) by gain * (v_measured - v_predicted) / step_s,
  /// the velocity the last plan predicted for now. 0 = off (Eq. 3.23 as printed). Eq. 3.23 has
  /// no drag: at 0.1 m/s the plant's rotor and body drag alone leave ~10 cm of lag without it.
  double disturbance_gain = 0.0;
  /// Bound on |d|, m/s^2.
  double max_disturbance_m_s2 = 3.0;
  /// Moment disturbance observer of the inner loop (our addition; 0 = off). The plan's attitude
  /// command starts from the measured attitude, so against a constant moment the attitude law
  /// acts as a rate damper only and the vehicle turns at M_d / K_w (a rotor at half thrust: ~0.4
  /// rad/s until the tilt cone). With it, every call low-passes (this time constant, s)
  /// J w_dot + w x J w - M_applied, M_applied the commanded moment through the motors' rise lag,
  /// and subtracts the estimate from the commanded moment.
  double moment_observer_time_constant_s = 0.0;
  /// Bound on |M_d|, N m.
  double max_moment_disturbance_Nm = 0.5;

  int max_iterations = 10;  ///< Ceres iterations per solve (>= 0)
  /// Wall-clock budget per solve, s; infinity = none (reproducible runs).
  double max_solve_time_s = std::numeric_limits<double>::infinity();
  double function_tolerance = 1e-6;  ///< Ceres relative cost-change tolerance
  NmpcLinearSolver linear_solver = NmpcLinearSolver::kDenseNormalCholesky;

  /// Inner loop: feed the plan's body rates and angular acceleration forward (see the top of
  /// this file). Off: w_d = w_d' = 0 as Eq. 3.28.
  bool inner_feed_forward = false;
  /// Inner loop: SE(3) attitude gains (K_R, K_w) and, for the fallback, position gains (K_p,
  /// K_d); gravity term, tilt cone and non-negative thrust are always on in the fallback.
  Se3Gains se3 = Se3Gains::thesis();

  /// Checks every field; throws InvalidArgument naming it ("nmpc: input_blocks: ...").
  void validate() const;
  /// Number of optimisation blocks (input_blocks.size(), or horizon_steps when empty).
  int num_blocks() const;
};

enum class NmpcTermination {
  kNotRun,        ///< no solve yet
  kConverged,     ///< Ceres CONVERGENCE
  kIterationCap,  ///< Ceres NO_CONVERGENCE: iteration cap or time budget; best iterate kept
  kFailure,       ///< Ceres FAILURE / USER_FAILURE, a non-finite plan, or an injected failure
};
std::string_view termination_name(NmpcTermination t);

enum class NmpcMode {
  kPlan = 0,          ///< flying the plan of the latest solve
  kPreviousPlan = 1,  ///< fallback: the last good plan, shifted
  kSe3 = 2,           ///< fallback: SE(3) position control (no usable plan left)
};

/// Outcome of the most recent solve.
struct NmpcSolveStats {
  std::int64_t solve_index = -1;  ///< 0-based count of solves since reset
  double time_s = 0.0;            ///< control time of the solve
  int iterations = 0;             ///< Ceres iterations (successful + unsuccessful)
  double initial_cost = 0.0;      ///< 1/2 sum r^2 at the warm start
  double final_cost = 0.0;        ///< 1/2 sum r^2 at the returned plan
  double solve_time_s = 0.0;      ///< wall clock of Solve() (not reproducible)
  NmpcTermination termination = NmpcTermination::kNotRun;
  NmpcMode mode = NmpcMode::kPlan;  ///< what the controller flies after this solve
  std::int64_t consecutive_failures = 0;
  std::int64_t total_failures = 0;
};

class NmpcController final : public ControllerBase {
 public:
  /// `call_rate_hz`: how often calculate_u is called (the ClosedLoop's control rate); must be a
  /// whole multiple of 1 / step_s. Throws InvalidArgument naming a bad option.
  NmpcController(std::shared_ptr<const VehicleModel> model, const NmpcOptions& options,
                 double call_rate_hz, AllocationMethod allocation = AllocationMethod::kExact);
  ~NmpcController() override;
  NmpcController(const NmpcController& other);
  NmpcController& operator=(const NmpcController&) = delete;

  std::string_view name() const override { return "nmpc"; }
  std::unique_ptr<ControllerBase> clone() const override;
  void reset() override;

  std::vector<std::string> diagnostic_names() const override;
  void diagnostics(double* out) const override;
  /// The reference over the horizon (ClosedLoop calls this). Without it, the reference point of
  /// each call is extrapolated at constant acceleration over the horizon.
  void set_reference_preview(const Reference& reference) override;

  const NmpcOptions& options() const { return options_; }
  int calls_per_solve() const { return calls_per_solve_; }
  const NmpcSolveStats& last_solve() const { return stats_; }
  NmpcMode mode() const { return stats_.mode; }
  /// The plan of the most recent successful solve: states x_0..x_N ((N + 1) x 13, row k at
  /// plan_start_time_s() + k step_s) and inputs u_0..u_{N-1} (N x 6, [F_W, M_B]). Empty before
  /// the first successful solve.
  const Eigen::MatrixXd& predicted_states() const { return plan_x_; }
  const Eigen::MatrixXd& predicted_inputs() const { return plan_u_; }
  double plan_start_time_s() const { return plan_t0_s_; }
  /// The disturbance acceleration estimate d (zero when disturbance_gain = 0).
  const Vec3& disturbance_estimate() const { return d_hat_; }
  /// The moment disturbance estimate M_d, body frame, N m (zero when the observer is off).
  const Vec3& moment_disturbance_estimate() const { return moment_d_hat_; }
  /// The force F_W the inner loop is tracking at the latest call.
  const Vec3& commanded_force() const { return force_cmd_; }

  /// The horizon cost of the most recent solve's problem (its x_0 and references) at parameters
  /// z (num_parameters() values: per move block [f_z, t_x, t_y, M_x, M_y, M_z]): the residuals
  /// (num_residuals(); state rows k = 1..N first, then input rows) and, when `jacobian` is not
  /// null, their Jacobian (num_residuals() x num_parameters()), as Ceres sees them. For tests
  /// and tools; false if the rollout is not finite.
  bool evaluate_horizon(const std::vector<double>& z, Eigen::VectorXd* residuals,
                        Eigen::MatrixXd* jacobian) const;
  int num_parameters() const;
  int num_residuals() const;
  /// The optimiser parameters of the most recent solve (its result, or its warm start if failed).
  std::vector<double> last_parameters() const;

  /// Implementation detail (Ceres problem and buffers, nmpc.cpp); opaque here.
  struct Solver;

  /// Testing hook: solves number first .. first + count - 1 (0-based since reset) are treated as
  /// failed after they run. Survives reset().
  void inject_solve_failures(std::int64_t first, std::int64_t count);

 protected:
  GeneralizedForce do_calculate_u(const ControlInput& in) override;

 private:
  void solve(const ControlInput& in);
  void observe_moment(const ControlInput& in);
  GeneralizedForce compensate_moment(GeneralizedForce u);

  NmpcOptions options_;
  NmpcModel model_eq323_;
  int calls_per_solve_ = 1;
  std::unique_ptr<Solver> solver_;
  Se3Controller fallback_;

  std::int64_t calls_ = 0;
  NmpcSolveStats stats_;
  bool solved_this_call_ = false;
  Eigen::MatrixXd plan_x_, plan_u_;
  double plan_t0_s_ = 0.0;
  std::int64_t plan_solve_index_ = -1;
  Vec3 force_cmd_ = Vec3::Zero();
  Vec3 d_hat_ = Vec3::Zero();
  // Moment observer: the last call's time, body rates and commanded moment, and the commanded
  // moment through the motor lag (what the rotors apply).
  Vec3 moment_d_hat_ = Vec3::Zero();
  Vec3 moment_cmd_ = Vec3::Zero();
  Vec3 moment_applied_ = Vec3::Zero();
  Vec3 w_prev_ = Vec3::Zero();
  double t_prev_s_ = 0.0;
  bool observer_primed_ = false;
  double motor_rise_s_ = 0.0;
  std::unique_ptr<Reference> preview_;
  std::int64_t inject_first_ = -1, inject_count_ = 0;
};

}  // namespace dronetwin
