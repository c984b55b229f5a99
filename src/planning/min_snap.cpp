#include "dronetwin/planning/min_snap.hpp"

#include <Eigen/LU>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "dronetwin/core/error.hpp"
#include "dronetwin/core/vec_text.hpp"

namespace dronetwin::planning {

namespace {

using Mat8 = Eigen::Matrix<double, 8, 8>;
using Vec8 = Eigen::Matrix<double, 8, 1>;

// Derivatives 0..3 at each end of a segment: a segment's local unknown a (0..7) is derivative
// a % 4 at its start (a < 4) or end (a >= 4). Knot j's derivative r is global unknown 4 j + r, so
// segment i's local unknown a is global unknown 4 i + a.
constexpr int kEndDerivatives = 4;

// k (k-1) ... (k-r+1): the factor d^r/ds^r brings to s^k.
double falling_factorial(int k, int r) {
  double f = 1.0;
  for (int j = 0; j < r; ++j) f *= static_cast<double>(k - j);
  return f;
}

// The unit-duration segment q(s), s in [0, 1]: H maps its monomial coefficients to its end
// derivatives (Hermite interpolation), to_coefficients = H^-1, and cost = H^-T Q H^-1 with
// Q_kl = integral over [0, 1] of (d^4 s^k/ds^4)(d^4 s^l/ds^4) ds, so that the cost (1) of the unit
// segment is e^T cost e for its end derivatives e.
struct UnitSegment {
  Mat8 to_coefficients;
  Mat8 cost;
};

UnitSegment make_unit_segment() {
  Mat8 hermite = Mat8::Zero();
  for (int r = 0; r < kEndDerivatives; ++r) {
    hermite(r, r) = falling_factorial(r, r);  // at s = 0 only s^r survives
    for (int k = r; k < 8; ++k) hermite(kEndDerivatives + r, k) = falling_factorial(k, r);
  }
  Mat8 q = Mat8::Zero();
  for (int k = 4; k < 8; ++k)
    for (int l = 4; l < 8; ++l)
      q(k, l) = falling_factorial(k, 4) * falling_factorial(l, 4) / static_cast<double>(k + l - 7);
  UnitSegment u;
  u.to_coefficients = hermite.fullPivLu().inverse();
  u.cost = u.to_coefficients.transpose() * q * u.to_coefficients;
  u.cost = 0.5 * (u.cost + u.cost.transpose()).eval();  // exactly symmetric
  return u;
}

const UnitSegment& unit_segment() {
  static const UnitSegment u = make_unit_segment();
  return u;
}

// Time scaling: a segment of duration T with end derivatives d has the unit-duration shape with
// e_a = T^(a % 4) d_a (q(s) = p(T s)), and cost T^-7 e^T M_1 e. So M(T)_ab = M_1,ab T^(r_a+r_b-7).
Mat8 segment_cost_matrix(double duration_s) {
  std::array<double, 8> inverse_power{};  // T^-k
  inverse_power[0] = 1.0;
  for (int k = 1; k < 8; ++k) inverse_power[k] = inverse_power[k - 1] / duration_s;
  const Mat8& m1 = unit_segment().cost;
  Mat8 m;
  for (int a = 0; a < 8; ++a)
    for (int b = 0; b < 8; ++b) m(a, b) = m1(a, b) * inverse_power[7 - a % 4 - b % 4];
  return m;
}

Vec8 scaled_end_derivatives(const Eigen::MatrixXd& knots, std::size_t segment, Eigen::Index axis,
                            double duration_s) {
  const double power[kEndDerivatives] = {1.0, duration_s, duration_s * duration_s,
                                         duration_s * duration_s * duration_s};
  Vec8 e;
  const auto base = static_cast<Eigen::Index>(kEndDerivatives * segment);
  for (int a = 0; a < 8; ++a) e[a] = knots(base + a, axis) * power[a % 4];
  return e;
}

void validate(const std::vector<Waypoint>& waypoints, const char* who) {
  require(waypoints.size() >= 2, who, ": expected at least 2 waypoints, got ", waypoints.size());
  for (std::size_t j = 0; j < waypoints.size(); ++j) {
    const Waypoint& w = waypoints[j];
    require(all_finite(w.position_m), who, ": waypoints[", j,
            "].position_m: expected finite numbers, got ", VecText{w.position_m});
    require(std::isfinite(w.yaw_rad), who, ": waypoints[", j,
            "].yaw_rad: expected a finite number, got ", w.yaw_rad);
    if (w.velocity_m_s)
      require(all_finite(*w.velocity_m_s), who, ": waypoints[", j,
              "].velocity_m_s: expected finite numbers, got ", VecText{*w.velocity_m_s});
    if (w.acceleration_m_s2)
      require(all_finite(*w.acceleration_m_s2), who, ": waypoints[", j,
              "].acceleration_m_s2: expected finite numbers, got ", VecText{*w.acceleration_m_s2});
  }
}

void validate_times(const std::vector<Waypoint>& waypoints, const std::vector<double>& times_s,
                    const char* who) {
  require(times_s.size() + 1 == waypoints.size(), who, ": segment_times_s: expected ",
          waypoints.size() - 1, " values (one per segment between ", waypoints.size(),
          " waypoints), got ", times_s.size());
  for (std::size_t i = 0; i < times_s.size(); ++i)
    require(std::isfinite(times_s[i]) && times_s[i] > 0.0, who, ": segment_times_s[", i,
            "]: expected a positive finite duration, got ", times_s[i]);
}

// The yaw angles to plan through: as given, or unwrapped so each step is in [-pi, pi].
std::vector<double> planned_yaws(const std::vector<Waypoint>& waypoints,
                                 const MinSnapOptions& options) {
  std::vector<double> yaw(waypoints.size());
  yaw[0] = waypoints[0].yaw_rad;
  for (std::size_t j = 1; j < waypoints.size(); ++j)
    yaw[j] = options.unwrap_yaw ? yaw[j - 1] + std::remainder(waypoints[j].yaw_rad - yaw[j - 1],
                                                              2.0 * std::numbers::pi)
                                : waypoints[j].yaw_rad;
  return yaw;
}

void reject_duplicates(const std::vector<Waypoint>& waypoints, const std::vector<double>& yaw,
                       const char* who) {
  constexpr double kSamePlace_m = 1e-9, kSameYaw_rad = 1e-9;
  for (std::size_t j = 0; j + 1 < waypoints.size(); ++j) {
    const double distance_m = (waypoints[j + 1].position_m - waypoints[j].position_m).norm();
    require(distance_m >= kSamePlace_m || std::abs(yaw[j + 1] - yaw[j]) >= kSameYaw_rad, who,
            ": waypoints[", j, "] and waypoints[", j + 1,
            "] are the same point: expected consecutive waypoints at least 1e-9 m apart or with "
            "different yaw, got distance ",
            distance_m, " m and yaw ", yaw[j], " rad: remove one");
  }
}

// Minimises sum_i d_i^T M(T_i) d_i over the rows of `knots` that are not `fixed` (the rows that
// are fixed hold their values on entry), each column (axis) independently with one factorisation.
// The stationarity condition H_ff x_f = -H_fc x_c, with H block-tridiagonal in the knots.
Eigen::MatrixXd solve_free_derivatives(const std::vector<double>& times_s,
                                       const std::vector<char>& fixed, Eigen::MatrixXd knots) {
  const Eigen::Index n = knots.rows(), axes = knots.cols();
  std::vector<int> free_index(static_cast<std::size_t>(n), -1);
  int n_free = 0;
  for (std::size_t r = 0; r < free_index.size(); ++r)
    if (!fixed[r]) free_index[r] = n_free++;
  if (n_free == 0) return knots;

  // Lower triangle only (the LDLT reads no more), filled in place: a free unknown couples with
  // the free unknowns of its own and its neighbouring knots, at most 3 kEndDerivatives - 1 rows
  // below the diagonal.
  Eigen::SparseMatrix<double> h(n_free, n_free);
  h.reserve(Eigen::VectorXi::Constant(n_free, 3 * kEndDerivatives));
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(n_free, axes);
  for (std::size_t i = 0; i < times_s.size(); ++i) {
    const Mat8 m = segment_cost_matrix(times_s[i]);
    const std::size_t base = kEndDerivatives * i;
    for (int a = 0; a < 8; ++a) {
      const int fa = free_index[base + a];
      if (fa < 0) continue;
      for (int b = 0; b < 8; ++b) {
        const int fb = free_index[base + b];
        if (fb < 0)
          rhs.row(fa) -= m(a, b) * knots.row(static_cast<Eigen::Index>(base + b));
        else if (fa >= fb)
          h.coeffRef(fa, fb) += m(a, b);  // the knot blocks of neighbouring segments add up
      }
    }
  }
  h.makeCompressed();

  // Symmetric diagonal scaling: the entries scale as T^(r_a + r_b - 7), many decades apart for
  // the derivatives 1..3; equilibrating keeps the LDLT's pivots comparable.
  const Eigen::VectorXd scale = h.diagonal().cwiseSqrt().cwiseInverse();
  for (int k = 0; k < h.outerSize(); ++k)
    for (Eigen::SparseMatrix<double>::InnerIterator it(h, k); it; ++it)
      it.valueRef() *= scale[it.row()] * scale[it.col()];

  // Natural ordering: the unknowns are already in band order (knot by knot), so no fill-in
  // beyond the band.
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::NaturalOrdering<int>>
      ldlt(h);
  if (ldlt.info() != Eigen::Success)
    throw std::runtime_error(
        "plan_min_snap: the snap cost is not positive definite in the free "
        "derivatives (internal error)");
  const Eigen::MatrixXd x = scale.asDiagonal() * ldlt.solve(scale.asDiagonal() * rhs);
  for (std::size_t r = 0; r < free_index.size(); ++r)
    if (free_index[r] >= 0) knots.row(static_cast<Eigen::Index>(r)) = x.row(free_index[r]);
  return knots;
}

// All four axes' knot derivatives (rows 4 j + r, columns x, y, z, yaw) at the optimum.
Eigen::MatrixXd optimal_knots(const std::vector<Waypoint>& waypoints,
                              const std::vector<double>& times_s, const MinSnapOptions& options,
                              const char* who) {
  validate(waypoints, who);
  validate_times(waypoints, times_s, who);
  const std::vector<double> yaw = planned_yaws(waypoints, options);
  reject_duplicates(waypoints, yaw, who);

  const std::size_t n_knots = waypoints.size(), n = kEndDerivatives * n_knots;
  Eigen::MatrixXd position = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n), 3);
  Eigen::MatrixXd yaw_knots = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n), 1);
  std::vector<char> position_fixed(n, 0), yaw_fixed(n, 0);
  for (std::size_t j = 0; j < n_knots; ++j) {
    const Waypoint& w = waypoints[j];
    const bool end = j == 0 || j + 1 == n_knots;
    const auto row = [&](int r) { return static_cast<Eigen::Index>(kEndDerivatives * j + r); };
    position.row(row(0)) = w.position_m.transpose();
    yaw_knots(row(0), 0) = yaw[j];
    position_fixed[kEndDerivatives * j] = yaw_fixed[kEndDerivatives * j] = 1;
    if (w.velocity_m_s) position.row(row(1)) = w.velocity_m_s->transpose();
    if (w.acceleration_m_s2) position.row(row(2)) = w.acceleration_m_s2->transpose();
    position_fixed[kEndDerivatives * j + 1] = end || w.velocity_m_s.has_value();
    position_fixed[kEndDerivatives * j + 2] = end || w.acceleration_m_s2.has_value();
    position_fixed[kEndDerivatives * j + 3] = end;  // zero jerk at the ends
    for (int r = 1; r < kEndDerivatives; ++r) yaw_fixed[kEndDerivatives * j + r] = end;
  }
  Eigen::MatrixXd knots(static_cast<Eigen::Index>(n), kAxisCount);
  knots.leftCols<3>() = solve_free_derivatives(times_s, position_fixed, std::move(position));
  knots.col(3) = solve_free_derivatives(times_s, yaw_fixed, std::move(yaw_knots));
  return knots;
}

void require_positive(double value, const char* who, const char* name) {
  require(std::isfinite(value) && value > 0.0, who, ": ", name,
          ": expected a positive finite number, got ", value);
}

}  // namespace

Trajectory plan_min_snap(const std::vector<Waypoint>& waypoints,
                         const std::vector<double>& segment_times_s,
                         const MinSnapOptions& options) {
  const Eigen::MatrixXd knots = optimal_knots(waypoints, segment_times_s, options, "plan_min_snap");
  const Mat8& to_coefficients = unit_segment().to_coefficients;
  std::vector<PolynomialSegment> segments(segment_times_s.size());
  for (std::size_t i = 0; i < segments.size(); ++i) {
    const double t = segment_times_s[i];
    segments[i].duration_s = t;
    for (Eigen::Index axis = 0; axis < kAxisCount; ++axis) {
      // Coefficients of q(s) = p(T s), then c_k = q_k / T^k for p in tau = T s.
      const Vec8 q = to_coefficients * scaled_end_derivatives(knots, i, axis, t);
      double inverse_power = 1.0;
      for (int k = 0; k < kCoefficientCount; ++k, inverse_power /= t)
        segments[i].coefficients(k, axis) = q[k] * inverse_power;
    }
  }
  return Trajectory(std::move(segments));
}

SnapCost min_snap_cost(const std::vector<Waypoint>& waypoints,
                       const std::vector<double>& segment_times_s, double yaw_weight,
                       const MinSnapOptions& options) {
  require(std::isfinite(yaw_weight) && yaw_weight >= 0.0,
          "min_snap_cost: yaw_weight: expected a finite number >= 0, got ", yaw_weight);
  const Eigen::MatrixXd knots = optimal_knots(waypoints, segment_times_s, options, "min_snap_cost");
  const Mat8& m1 = unit_segment().cost;
  // K = diag(0, 1, 2, 3, 0, 1, 2, 3): T de/dT = K e.
  Vec8 k_diag;
  k_diag << 0, 1, 2, 3, 0, 1, 2, 3;
  SnapCost out;
  out.gradient.assign(segment_times_s.size(), 0.0);
  for (std::size_t i = 0; i < segment_times_s.size(); ++i) {
    const double t = segment_times_s[i];
    for (Eigen::Index axis = 0; axis < kAxisCount; ++axis) {
      const double weight = axis == 3 ? yaw_weight : 1.0;
      const Vec8 e = scaled_end_derivatives(knots, i, axis, t);
      const Vec8 m1e = m1 * e;
      const double ee = e.dot(m1e), eke = m1e.dot(k_diag.cwiseProduct(e));
      // J_i = T^-7 e^T M_1 e;  dJ_i/dT = T^-8 (-7 e^T M_1 e + 2 e^T M_1 K e).
      out.cost += weight * ee / std::pow(t, 7);
      out.gradient[i] += weight * (-7.0 * ee + 2.0 * eke) / std::pow(t, 8);
    }
  }
  return out;
}

TimeAllocation optimize_segment_times(const std::vector<Waypoint>& waypoints, double rho,
                                      const TimeAllocationOptions& options) {
  constexpr const char* who = "allocate_segment_times";
  require_positive(rho, who, "rho");
  require_positive(options.nominal_speed_m_s, who, "nominal_speed_m_s");
  require_positive(options.nominal_yaw_rate_rad_s, who, "nominal_yaw_rate_rad_s");
  require_positive(options.gradient_tolerance, who, "gradient_tolerance");
  require(std::isfinite(options.yaw_weight) && options.yaw_weight >= 0.0, who,
          ": yaw_weight: expected a finite number >= 0, got ", options.yaw_weight);
  require(options.max_iterations >= 0, who, ": max_iterations: expected >= 0, got ",
          options.max_iterations);
  validate(waypoints, who);
  const std::vector<double> yaw = planned_yaws(waypoints, options.min_snap);
  reject_duplicates(waypoints, yaw, who);

  const std::size_t n = waypoints.size() - 1;
  using Eigen::VectorXd;
  VectorXd u(static_cast<Eigen::Index>(n));  // ln T_i
  for (std::size_t i = 0; i < n; ++i) {
    const double distance_m = (waypoints[i + 1].position_m - waypoints[i].position_m).norm();
    const double turn_rad = std::abs(yaw[i + 1] - yaw[i]);
    u[static_cast<Eigen::Index>(i)] = std::log(std::max(distance_m / options.nominal_speed_m_s,
                                                        turn_rad / options.nominal_yaw_rate_rad_s));
  }

  // F(u) and dF/du; +inf when the times leave the range the closed form can handle.
  std::vector<double> times(n);
  const auto evaluate = [&](const VectorXd& at, VectorXd& gradient, double& snap) {
    for (std::size_t i = 0; i < n; ++i) times[i] = std::exp(at[static_cast<Eigen::Index>(i)]);
    gradient.resize(at.size());
    try {
      const SnapCost c = min_snap_cost(waypoints, times, options.yaw_weight, options.min_snap);
      double total_s = 0.0;
      for (std::size_t i = 0; i < n; ++i) {
        total_s += times[i];
        gradient[static_cast<Eigen::Index>(i)] = times[i] * (c.gradient[i] + rho);
      }
      snap = c.cost;
      const double f = c.cost + rho * total_s;
      return std::isfinite(f) && gradient.allFinite() ? f : std::numeric_limits<double>::infinity();
    } catch (const InvalidArgument&) {  // a time underflowed to 0 or overflowed
      return std::numeric_limits<double>::infinity();
    }
  };

  TimeAllocation out;
  VectorXd g, g_new;
  double snap = 0.0, snap_new = 0.0;
  double f = evaluate(u, g, snap);
  require(std::isfinite(f), who, ": the cost at the initial guess is not finite");
  out.initial_total_cost = f;
  // BFGS on the inverse Hessian (Nocedal & Wright, Numerical Optimization, Alg. 6.1).
  Eigen::MatrixXd inverse_hessian = Eigen::MatrixXd::Identity(u.size(), u.size());
  bool first_update = true;
  int iteration = 0;
  for (; iteration < options.max_iterations; ++iteration) {
    if (g.cwiseAbs().maxCoeff() <= options.gradient_tolerance * f) {
      out.converged = true;
      break;
    }
    VectorXd p = -inverse_hessian * g;
    if (g.dot(p) >= 0.0) {  // lost descent (should not happen with the curvature check)
      inverse_hessian.setIdentity();
      p = -g;
    }
    // At most a factor e on any time per iteration: keeps early steps in the closed form's range.
    const double largest = p.cwiseAbs().maxCoeff();
    if (largest > 1.0) p /= largest;
    // Backtracking (Armijo, c1 = 1e-4). Near the optimum the predicted decrease alpha |slope|
    // falls below F's rounding (a few ulps of F) and F can no longer rank two points; there a
    // step is taken when it lowers the gradient instead, which is still computed accurately.
    const double slope = g.dot(p), rounding = 8.0 * std::numeric_limits<double>::epsilon() * f;
    double alpha = 1.0, f_new = 0.0;
    VectorXd u_new;
    bool accepted = false;
    for (int halving = 0; halving < 50; ++halving, alpha *= 0.5) {
      u_new = u + alpha * p;
      f_new = evaluate(u_new, g_new, snap_new);
      accepted = f_new <= f + 1e-4 * alpha * slope ||
                 (alpha * -slope <= rounding && f_new <= f + rounding &&
                  g_new.cwiseAbs().maxCoeff() < g.cwiseAbs().maxCoeff());
      if (accepted) break;
    }
    if (!accepted) break;
    const VectorXd s = u_new - u, y = g_new - g;
    const double sy = s.dot(y);
    if (sy > 1e-12 * s.norm() * y.norm()) {  // curvature condition: keeps the update positive
      if (first_update) {
        inverse_hessian *= sy / y.squaredNorm();  // Nocedal & Wright Eq. 6.20
        first_update = false;
      }
      // H+ = (I - r s y^T) H (I - r y s^T) + r s s^T, expanded to O(n^2) (H symmetric).
      const double r = 1.0 / sy;
      const VectorXd hy = inverse_hessian * y;
      // Rank-one updates in place: n x n temporaries cost more than the arithmetic.
      inverse_hessian.noalias() += ((r * r * y.dot(hy) + r) * s) * s.transpose();
      inverse_hessian.noalias() -= (r * s) * hy.transpose();
      inverse_hessian.noalias() -= (r * hy) * s.transpose();
    }
    u = u_new;
    g = g_new;
    f = f_new;
    snap = snap_new;
  }
  if (!out.converged) out.converged = g.cwiseAbs().maxCoeff() <= options.gradient_tolerance * f;
  out.iterations = iteration;
  out.segment_times_s.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    out.segment_times_s[i] = std::exp(u[static_cast<Eigen::Index>(i)]);
  out.snap_cost = snap;
  out.total_cost = f;
  out.relative_gradient = g.cwiseAbs().maxCoeff() / f;
  return out;
}

std::vector<double> allocate_segment_times(const std::vector<Waypoint>& waypoints, double rho,
                                           const TimeAllocationOptions& options) {
  return optimize_segment_times(waypoints, rho, options).segment_times_s;
}

}  // namespace dronetwin::planning
