// Minimum-snap planning: boundary conditions, C6 continuity at free interior waypoints,
// optimality against an independent formulation (the constrained QP in monomial coefficients,
// solved as one dense KKT system), the rest-to-rest closed form, time allocation and errors.
// Costs are recomputed here by Gauss-Legendre quadrature of the trajectory's snap, independent of
// the planner's cost matrices.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numbers>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/planning/min_snap.hpp"
#include "test_support.hpp"

namespace dronetwin::planning {
namespace {

// Uniform in [lo, hi) from a seeded 64-bit Mersenne twister (same numbers on every platform,
// unlike std::uniform_real_distribution).
class Uniform {
 public:
  explicit Uniform(std::uint64_t seed) : gen_(seed) {}
  double operator()(double lo, double hi) {
    return lo + (hi - lo) * static_cast<double>(gen_() >> 11) * 0x1.0p-53;
  }

 private:
  std::mt19937_64 gen_;
};

Waypoint at(const Vec3& position_m, double yaw_rad = 0.0) {
  Waypoint w;
  w.position_m = position_m;
  w.yaw_rad = yaw_rad;
  return w;
}

std::vector<Waypoint> random_waypoints(int count, std::uint64_t seed) {
  Uniform u(seed);
  std::vector<Waypoint> w(static_cast<std::size_t>(count));
  for (auto& p : w) {
    p.position_m = Vec3(u(-3, 3), u(-3, 3), u(0.5, 2.5));
    p.yaw_rad = u(-1.5, 1.5);
  }
  return w;
}

std::vector<double> random_times(std::size_t count, std::uint64_t seed) {
  Uniform u(seed);
  std::vector<double> t(count);
  for (double& ti : t) ti = u(0.7, 2.5);
  return t;
}

// Integral of (d^4 axis / dt^4)^2 over the trajectory: 4-point Gauss-Legendre per segment, exact
// for the degree-6 integrand.
double quadrature_snap_cost(const Trajectory& traj, int axis) {
  const double a = std::sqrt(3.0 / 7.0 - 2.0 / 7.0 * std::sqrt(6.0 / 5.0));
  const double b = std::sqrt(3.0 / 7.0 + 2.0 / 7.0 * std::sqrt(6.0 / 5.0));
  const double wa = (18.0 + std::sqrt(30.0)) / 36.0, wb = (18.0 - std::sqrt(30.0)) / 36.0;
  const double nodes[] = {-b, -a, a, b}, weights[] = {wb, wa, wa, wb};
  double cost = 0.0;
  for (const PolynomialSegment& s : traj.segments()) {
    const double h = 0.5 * s.duration_s;
    for (int q = 0; q < 4; ++q) {
      const double snap = evaluate_segment(s, h * (1.0 + nodes[q]), 4)[axis];
      cost += weights[q] * h * snap * snap;
    }
  }
  return cost;
}

double quadrature_total_cost(const Trajectory& traj) {
  double c = 0.0;
  for (int axis = 0; axis < kAxisCount; ++axis) c += quadrature_snap_cost(traj, axis);
  return c;
}

using test::error_of;

// ---------------------------------------------------------------------------------------------
// 1. Boundary conditions.

TEST(MinSnap, PassesThroughWaypointsAndMeetsEndAndGivenDerivatives) {
  auto w = random_waypoints(6, 1);
  w[2].velocity_m_s = Vec3(0.5, -0.3, 0.2);
  w[3].acceleration_m_s2 = Vec3(-1.0, 0.4, 0.0);
  w[4].velocity_m_s = Vec3(0.0, 0.0, 0.0);
  w[4].acceleration_m_s2 = Vec3(0.2, 0.2, -0.1);
  const auto times = random_times(5, 2);
  const Trajectory traj = plan_min_snap(w, times);
  ASSERT_EQ(traj.segments().size(), 5u);
  const auto& knots = traj.knot_times_s();
  for (std::size_t j = 0; j < w.size(); ++j) {
    // At the knot from both sides: the end of segment j-1 and the start of segment j.
    const std::size_t left = j == 0 ? 0 : j - 1, right = std::min(j, w.size() - 2);
    for (std::size_t seg : {left, right}) {
      const double tau = knots[j] - knots[seg];
      const Vec4 p = evaluate_segment(traj.segments()[seg], tau, 0);
      EXPECT_LT((p.head<3>() - w[j].position_m).norm(), 1e-9) << "waypoint " << j;
      EXPECT_NEAR(p[3], w[j].yaw_rad, 1e-9) << "waypoint " << j;
      if (w[j].velocity_m_s) {
        EXPECT_LT(
            (evaluate_segment(traj.segments()[seg], tau, 1).head<3>() - *w[j].velocity_m_s).norm(),
            1e-9)
            << "waypoint " << j;
      }
      if (w[j].acceleration_m_s2) {
        EXPECT_LT(
            (evaluate_segment(traj.segments()[seg], tau, 2).head<3>() - *w[j].acceleration_m_s2)
                .norm(),
            1e-9)
            << "waypoint " << j;
      }
    }
  }
  for (double t : {0.0, traj.duration_s()})
    for (int r = 1; r <= 3; ++r)
      EXPECT_LT(traj.evaluate(t, r).norm(), 1e-9) << "t = " << t << ", derivative " << r;
  EXPECT_NEAR(traj.duration_s(), times[0] + times[1] + times[2] + times[3] + times[4], 1e-12);
}

TEST(MinSnap, GivenEndVelocityAndAccelerationAreMet) {
  auto w = random_waypoints(3, 3);
  w.front().velocity_m_s = Vec3(1.0, 0.0, 0.5);
  w.back().acceleration_m_s2 = Vec3(0.0, -2.0, 0.0);
  const Trajectory traj = plan_min_snap(w, {1.0, 1.5});
  EXPECT_LT((traj.at(0.0).velocity_m_s - *w.front().velocity_m_s).norm(), 1e-9);
  EXPECT_LT(traj.at(0.0).acceleration_m_s2.norm(), 1e-9);  // not given: zero
  EXPECT_LT(traj.at(2.5).velocity_m_s.norm(), 1e-9);
  EXPECT_LT((traj.at(2.5).acceleration_m_s2 - *w.back().acceleration_m_s2).norm(), 1e-9);
  EXPECT_LT(traj.at(0.0).jerk_m_s3.norm() + traj.at(2.5).jerk_m_s3.norm(), 1e-9);
}

TEST(Trajectory, ClampsOutsideTheDurationAndDerivativesMatchFiniteDifferences) {
  auto w = random_waypoints(5, 4);
  w.front().velocity_m_s = Vec3(1.0, 2.0, 0.0);  // non-zero derivative at t = 0: clamping shows
  const Trajectory traj = plan_min_snap(w, random_times(4, 5));
  for (int r = 0; r <= 7; ++r) {
    EXPECT_EQ(traj.evaluate(-3.0, r), traj.evaluate(0.0, r)) << r;
    EXPECT_EQ(traj.evaluate(traj.duration_s() + 1.0, r), traj.evaluate(traj.duration_s(), r));
  }
  EXPECT_GT(traj.at(-1.0).velocity_m_s.norm(), 1.0);  // the polynomial's value, not zero
  // Central differences of order r-1 against order r, across the whole duration (segment
  // lookup included).
  const double h = 1e-5;
  for (double t = 0.01; t < traj.duration_s() - 0.01; t += traj.duration_s() / 53) {
    for (int r = 1; r <= 5; ++r) {
      const Vec4 fd = (traj.evaluate(t + h, r - 1) - traj.evaluate(t - h, r - 1)) / (2 * h);
      const Vec4 exact = traj.evaluate(t, r);
      EXPECT_LT((fd - exact).norm(), 1e-6 * (1.0 + exact.norm())) << "t = " << t << ", r = " << r;
    }
  }
  // Lookup: a knot belongs to the segment it starts; the end to the last segment.
  const auto& knots = traj.knot_times_s();
  for (std::size_t i = 0; i + 1 < knots.size(); ++i) {
    EXPECT_EQ(traj.segment_index(knots[i]), i);
    EXPECT_EQ(traj.segment_index(0.5 * (knots[i] + knots[i + 1])), i);
  }
  EXPECT_EQ(traj.segment_index(traj.duration_s()), traj.segments().size() - 1);
}

// ---------------------------------------------------------------------------------------------
// 2. Continuity: C3 by construction; C6 at interior waypoints with free velocity and
// acceleration (stationarity in the free jerk, acceleration and velocity is the continuity of
// derivatives 4, 5 and 6). Derivative 7 jumps: the continuity check can tell.

// Jump of derivative r at interior knot j, relative to the largest |derivative r| at any knot.
struct Jumps {
  std::vector<std::array<double, 8>> relative;  // [knot][order]
};

Jumps knot_jumps(const Trajectory& traj) {
  const auto& segs = traj.segments();
  std::array<double, 8> scale{};
  for (std::size_t i = 0; i < segs.size(); ++i)
    for (int r = 0; r < 8; ++r)
      scale[r] = std::max({scale[r], evaluate_segment(segs[i], 0.0, r).norm(),
                           evaluate_segment(segs[i], segs[i].duration_s, r).norm()});
  Jumps out;
  for (std::size_t j = 1; j < segs.size(); ++j) {
    std::array<double, 8> rel{};
    for (int r = 0; r < 8; ++r)
      rel[r] = (evaluate_segment(segs[j - 1], segs[j - 1].duration_s, r) -
                evaluate_segment(segs[j], 0.0, r))
                   .norm() /
               scale[r];
    out.relative.push_back(rel);
  }
  return out;
}

TEST(MinSnap, OptimumIsC6AtFreeInteriorWaypoints) {
  for (std::uint64_t seed : {10u, 11u, 12u}) {
    const auto w = random_waypoints(7, seed);
    const Trajectory traj = plan_min_snap(w, random_times(6, seed + 100));
    const Jumps jumps = knot_jumps(traj);
    double largest_seventh = 0.0;
    for (std::size_t j = 0; j < jumps.relative.size(); ++j) {
      for (int r = 0; r <= 6; ++r)
        EXPECT_LT(jumps.relative[j][r], 1e-8) << "seed " << seed << " knot " << j + 1 << " r " << r;
      largest_seventh = std::max(largest_seventh, jumps.relative[j][7]);
    }
    EXPECT_GT(largest_seventh, 1e-2) << "derivative 7 should jump (seed " << seed << ")";
  }
}

TEST(MinSnap, GivenVelocityBreaksOnlyTheSixthDerivative) {
  auto w = random_waypoints(5, 20);
  w[2].velocity_m_s = Vec3(2.0, -1.0, 0.5);  // far from what the free optimum would choose
  const Trajectory traj = plan_min_snap(w, random_times(4, 21));
  const Jumps jumps = knot_jumps(traj);
  for (int r = 0; r <= 5; ++r) EXPECT_LT(jumps.relative[1][r], 1e-8) << r;
  EXPECT_GT(jumps.relative[1][6], 1e-3);
  for (std::size_t j : {0u, 2u})  // the other interior knots stay C6
    for (int r = 0; r <= 6; ++r) EXPECT_LT(jumps.relative[j][r], 1e-8) << j << " " << r;
}

// ---------------------------------------------------------------------------------------------
// 3. Optimality against an independent formulation: the coefficients of every segment as the
// unknowns, the cost integral as a Gram matrix of monomial derivatives, and every condition
// (positions, end derivatives, C3 joins, given derivatives) as a linear equality.

struct CoefficientQp {
  Eigen::MatrixXd cost;         // J = c^T cost c
  Eigen::MatrixXd constraints;  // constraints c = targets
  Eigen::VectorXd targets;
};

double falling(int k, int r) {
  double f = 1.0;
  for (int j = 0; j < r; ++j) f *= k - j;
  return f;
}

// Row of derivative r of sum_k c_k tau^k at tau, placed at segment i's coefficient block.
Eigen::RowVectorXd derivative_row(std::size_t n_segments, std::size_t i, double tau, int r) {
  Eigen::RowVectorXd row = Eigen::RowVectorXd::Zero(static_cast<Eigen::Index>(8 * n_segments));
  for (int k = r; k < 8; ++k)
    row[static_cast<Eigen::Index>(8 * i) + k] = falling(k, r) * std::pow(tau, k - r);
  return row;
}

CoefficientQp coefficient_qp(const std::vector<Waypoint>& w, const std::vector<double>& times,
                             int axis) {
  const std::size_t n = times.size();
  const auto value = [&](const Waypoint& p) { return axis < 3 ? p.position_m[axis] : p.yaw_rad; };
  CoefficientQp qp;
  qp.cost =
      Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(8 * n), static_cast<Eigen::Index>(8 * n));
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 4; k < 8; ++k)
      for (int l = 4; l < 8; ++l)
        qp.cost(static_cast<Eigen::Index>(8 * i) + k, static_cast<Eigen::Index>(8 * i) + l) =
            falling(k, 4) * falling(l, 4) * std::pow(times[i], k + l - 7) / (k + l - 7);
  std::vector<Eigen::RowVectorXd> rows;
  std::vector<double> targets;
  const auto add = [&](const Eigen::RowVectorXd& row, double target) {
    rows.push_back(row);
    targets.push_back(target);
  };
  for (std::size_t i = 0; i < n; ++i) {
    add(derivative_row(n, i, 0.0, 0), value(w[i]));
    add(derivative_row(n, i, times[i], 0), value(w[i + 1]));
  }
  const auto given = [&](const Waypoint& p, int r) {
    if (axis == 3) return std::optional<double>();
    if (r == 1 && p.velocity_m_s) return std::optional<double>((*p.velocity_m_s)[axis]);
    if (r == 2 && p.acceleration_m_s2) return std::optional<double>((*p.acceleration_m_s2)[axis]);
    return std::optional<double>();
  };
  for (int r = 1; r <= 3; ++r) {
    add(derivative_row(n, 0, 0.0, r), given(w.front(), r).value_or(0.0));
    add(derivative_row(n, n - 1, times[n - 1], r), given(w.back(), r).value_or(0.0));
    for (std::size_t j = 1; j < n; ++j) {
      add(derivative_row(n, j - 1, times[j - 1], r) - derivative_row(n, j, 0.0, r), 0.0);
      if (const auto g = given(w[j], r)) add(derivative_row(n, j, 0.0, r), *g);
    }
  }
  qp.constraints.resize(static_cast<Eigen::Index>(rows.size()), static_cast<Eigen::Index>(8 * n));
  qp.targets.resize(static_cast<Eigen::Index>(rows.size()));
  for (std::size_t k = 0; k < rows.size(); ++k) {
    qp.constraints.row(static_cast<Eigen::Index>(k)) = rows[k];
    qp.targets[static_cast<Eigen::Index>(k)] = targets[k];
  }
  return qp;
}

// KKT: [2 Q  A^T; A  0] [c; lambda] = [0; b], solved in scaled unknowns c_ik = T_i^(3.5-k) x_ik
// (so each segment's Gram block is T-free) with unit-norm constraint rows: unscaled, segments of
// 0.3 s and 4 s put the system beyond double precision.
Eigen::VectorXd solve_kkt(const CoefficientQp& qp, const std::vector<double>& times) {
  const Eigen::Index n = qp.cost.rows(), m = qp.constraints.rows();
  Eigen::VectorXd d(n);
  for (Eigen::Index j = 0; j < n; ++j)
    d[j] = std::pow(times[static_cast<std::size_t>(j / 8)], 3.5 - static_cast<double>(j % 8));
  Eigen::MatrixXd a = qp.constraints * d.asDiagonal();
  Eigen::VectorXd b = qp.targets;
  for (Eigen::Index r = 0; r < m; ++r) {
    const double norm = a.row(r).norm();
    a.row(r) /= norm;
    b[r] /= norm;
  }
  Eigen::MatrixXd kkt = Eigen::MatrixXd::Zero(n + m, n + m);
  kkt.topLeftCorner(n, n) = 2.0 * d.asDiagonal() * qp.cost * d.asDiagonal();
  kkt.topRightCorner(n, m) = a.transpose();
  kkt.bottomLeftCorner(m, n) = a;
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n + m);
  rhs.tail(m) = b;
  return d.asDiagonal() * kkt.fullPivLu().solve(rhs).head(n);
}

Eigen::VectorXd planned_coefficients(const Trajectory& traj, int axis) {
  Eigen::VectorXd c(static_cast<Eigen::Index>(8 * traj.segments().size()));
  for (std::size_t i = 0; i < traj.segments().size(); ++i)
    c.segment<8>(static_cast<Eigen::Index>(8 * i)) = traj.segments()[i].coefficients.col(axis);
  return c;
}

void expect_optimal(const std::vector<Waypoint>& w, const std::vector<double>& times,
                    std::uint64_t seed) {
  const Trajectory traj = plan_min_snap(w, times);
  double planned_total = 0.0;
  Uniform u(seed);
  for (int axis = 0; axis < kAxisCount; ++axis) {
    const CoefficientQp qp = coefficient_qp(w, times, axis);
    const Eigen::VectorXd kkt = solve_kkt(qp, times);
    const Eigen::VectorXd c = planned_coefficients(traj, axis);
    const double kkt_cost = kkt.dot(qp.cost * kkt), planned_cost = c.dot(qp.cost * c);
    EXPECT_NEAR(planned_cost, kkt_cost, 1e-8 * kkt_cost) << "axis " << axis;
    EXPECT_NEAR(quadrature_snap_cost(traj, axis), kkt_cost, 1e-8 * kkt_cost) << "axis " << axis;
    planned_total += planned_cost;
    // Feasible: the plan meets every condition of the independent formulation.
    EXPECT_LT((qp.constraints * c - qp.targets).cwiseAbs().maxCoeff(), 1e-8) << "axis " << axis;
    // Stationary on the feasible set: the cost gradient 2 Q c has no component along the null
    // space of the constraints, and no feasible perturbation lowers the cost.
    const Eigen::MatrixXd null_space = qp.constraints.fullPivLu().kernel();
    // One free velocity, acceleration and jerk per interior waypoint (none given here).
    ASSERT_EQ(null_space.cols(), 3 * static_cast<Eigen::Index>(w.size() - 2));
    const Eigen::VectorXd gradient = 2.0 * qp.cost * c;
    const Eigen::MatrixXd basis = null_space.householderQr().householderQ() *
                                  Eigen::MatrixXd::Identity(null_space.rows(), null_space.cols());
    EXPECT_LT((basis.transpose() * gradient).norm(), 1e-8 * gradient.norm()) << "axis " << axis;
    for (int trial = 0; trial < 200; ++trial) {
      Eigen::VectorXd z(basis.cols());
      for (Eigen::Index k = 0; k < z.size(); ++k) z[k] = u(-1, 1);
      const double size = std::pow(10.0, u(-6, 0)) * c.norm();
      const Eigen::VectorXd perturbed = c + size * (basis * z).normalized();
      EXPECT_GE(perturbed.dot(qp.cost * perturbed), planned_cost * (1.0 - 1e-12))
          << "axis " << axis << " trial " << trial;
    }
  }
  EXPECT_NEAR(min_snap_cost(w, times).cost, planned_total, 1e-9 * planned_total);
}

TEST(MinSnap, ClosedFormEqualsTheCoefficientSpaceQp) {
  expect_optimal(random_waypoints(3, 30), random_times(2, 31), 32);
  expect_optimal(random_waypoints(4, 33), random_times(3, 34), 35);
  expect_optimal(random_waypoints(4, 36), {0.3, 4.0, 1.1}, 37);  // unequal segments
}

TEST(MinSnap, ClosedFormEqualsTheCoefficientSpaceQpWithGivenDerivatives) {
  auto w = random_waypoints(4, 40);
  w[1].velocity_m_s = Vec3(0.3, 0.1, -0.2);
  w[2].acceleration_m_s2 = Vec3(1.0, 0.0, 0.5);
  w[3].velocity_m_s = Vec3(0.5, 0.5, 0.0);
  const auto times = random_times(3, 41);
  const Trajectory traj = plan_min_snap(w, times);
  for (int axis = 0; axis < kAxisCount; ++axis) {
    const CoefficientQp qp = coefficient_qp(w, times, axis);
    const Eigen::VectorXd kkt = solve_kkt(qp, times), c = planned_coefficients(traj, axis);
    const double kkt_cost = kkt.dot(qp.cost * kkt);
    EXPECT_NEAR(c.dot(qp.cost * c), kkt_cost, 1e-8 * kkt_cost) << "axis " << axis;
    EXPECT_LT((c - kkt).norm(), 1e-7 * kkt.norm()) << "axis " << axis;
  }
}

// ---------------------------------------------------------------------------------------------
// 4. Two waypoints, rest to rest: p = p0 + (p1 - p0) (35 s^4 - 84 s^5 + 70 s^6 - 20 s^7),
// s = t / T, the unique degree-7 polynomial with zero velocity, acceleration and jerk at both ends.
// Its cost is |p1 - p0|^2 T^-7 * 840^2 * integral (1 - 12 s + 30 s^2 - 20 s^3)^2 ds
// = 100800 |p1 - p0|^2 / T^7 (the integral is 1/7, by hand).

TEST(MinSnap, TwoWaypointsGiveTheRestToRestPolynomial) {
  const Vec3 p0(0.5, -1.0, 1.0), p1(2.5, 1.0, 0.25);
  const double yaw0 = 0.2, yaw1 = -1.1, T = 1.7;
  const Trajectory traj = plan_min_snap({at(p0, yaw0), at(p1, yaw1)}, {T});
  const Vec4 delta(p1.x() - p0.x(), p1.y() - p0.y(), p1.z() - p0.z(), yaw1 - yaw0);
  const Vec4 start(p0.x(), p0.y(), p0.z(), yaw0);
  for (int k = 0; k <= 40; ++k) {
    const double s = k / 40.0, t = s * T;
    const double shape =
        35 * std::pow(s, 4) - 84 * std::pow(s, 5) + 70 * std::pow(s, 6) - 20 * std::pow(s, 7);
    const double shape_rate = (140 * std::pow(s, 3) - 420 * std::pow(s, 4) + 420 * std::pow(s, 5) -
                               140 * std::pow(s, 6)) /
                              T;
    EXPECT_LT((traj.evaluate(t, 0) - (start + shape * delta)).norm(), 1e-12) << "s = " << s;
    EXPECT_LT((traj.evaluate(t, 1) - shape_rate * delta).norm(), 1e-11) << "s = " << s;
  }
  const SegmentCoefficients& c = traj.segments()[0].coefficients;
  const double expected[8] = {0, 0, 0, 0, 35, -84, 70, -20};
  for (int k = 0; k < 8; ++k)
    for (int a = 0; a < 4; ++a)
      EXPECT_NEAR(c(k, a) * std::pow(T, k), (k == 0 ? start[a] : 0.0) + expected[k] * delta[a],
                  1e-10)
          << "k " << k << " axis " << a;
  const double expected_cost = 100800.0 * delta.squaredNorm() / std::pow(T, 7);
  EXPECT_NEAR(quadrature_total_cost(traj), expected_cost, 1e-10 * expected_cost);
  EXPECT_NEAR(min_snap_cost({at(p0, yaw0), at(p1, yaw1)}, {T}).cost, expected_cost,
              1e-10 * expected_cost);
}

// ---------------------------------------------------------------------------------------------
// 5. Time allocation.

TEST(MinSnapCost, GradientMatchesCentralDifferences) {
  auto w = random_waypoints(6, 50);
  w[3].velocity_m_s = Vec3(0.2, 0.0, 0.1);
  const auto times = random_times(5, 51);
  const SnapCost c = min_snap_cost(w, times, 0.5);
  for (std::size_t i = 0; i < times.size(); ++i) {
    auto plus = times, minus = times;
    const double h = 1e-5 * times[i];
    plus[i] += h;
    minus[i] -= h;
    const double fd =
        (min_snap_cost(w, plus, 0.5).cost - min_snap_cost(w, minus, 0.5).cost) / (2 * h);
    EXPECT_NEAR(c.gradient[i], fd, 1e-6 * std::abs(fd) + 1e-9 * c.cost) << "segment " << i;
  }
}

TEST(TimeAllocation, TwoWaypointsReachTheAnalyticOptimum) {
  // F = 100800 L^2 T^-7 + rho T  =>  T* = (7 * 100800 L^2 / rho)^(1/8).
  const Vec3 p0(0, 0, 1), p1(3, 4, 1);  // L = 5 m
  for (double rho : {1.0, 100.0, 1e4}) {
    const TimeAllocation a = optimize_segment_times({at(p0), at(p1)}, rho);
    ASSERT_TRUE(a.converged) << "rho " << rho;
    const double expected = std::pow(7.0 * 100800.0 * 25.0 / rho, 1.0 / 8.0);
    EXPECT_NEAR(a.segment_times_s[0], expected, 1e-6 * expected) << "rho " << rho;
  }
}

TEST(TimeAllocation, LowersTheCostToAStationaryPointAndShortensWithRho) {
  auto w = random_waypoints(8, 60);
  w[4].velocity_m_s = Vec3(0.5, 0.0, 0.0);
  TimeAllocationOptions options;
  options.nominal_speed_m_s = 2.0;
  options.gradient_tolerance = 1e-7;  // the independent check below allows 1e-6
  double previous_total_s = std::numeric_limits<double>::infinity();
  for (double rho : {1.0, 10.0, 100.0, 1000.0}) {
    const TimeAllocation a = optimize_segment_times(w, rho, options);
    ASSERT_TRUE(a.converged) << "rho " << rho << ", relative gradient " << a.relative_gradient;
    // F recomputed independently: plan, quadrature of the snap, plus rho * total time.
    const auto total_cost = [&](const std::vector<double>& times) {
      double sum_s = 0.0;
      for (double t : times) sum_s += t;
      return quadrature_total_cost(plan_min_snap(w, times)) + rho * sum_s;
    };
    std::vector<double> initial(w.size() - 1);
    for (std::size_t i = 0; i + 1 < w.size(); ++i)
      initial[i] = std::max((w[i + 1].position_m - w[i].position_m).norm() / 2.0,
                            std::abs(w[i + 1].yaw_rad - w[i].yaw_rad) / 1.0);
    const double f = total_cost(a.segment_times_s), f0 = total_cost(initial);
    EXPECT_NEAR(f, a.total_cost, 1e-9 * f);
    EXPECT_NEAR(f0, a.initial_total_cost, 1e-9 * f0);
    EXPECT_LT(f, f0) << "rho " << rho;
    // Stationary: central differences in ln T_i of the independent F (step 1e-4: truncation
    // error ~1e-8 F, rounding ~1e-12 F).
    for (std::size_t i = 0; i < initial.size(); ++i) {
      auto plus = a.segment_times_s, minus = a.segment_times_s;
      const double h = 1e-4;
      plus[i] *= std::exp(h);
      minus[i] *= std::exp(-h);
      const double dfdu = (total_cost(plus) - total_cost(minus)) / (2 * h);
      EXPECT_LT(std::abs(dfdu), 1e-6 * f) << "rho " << rho << " segment " << i;
      // and a real minimum along that axis, not a maximum
      EXPECT_GE(total_cost(plus), f * (1 - 1e-12));
      EXPECT_GE(total_cost(minus), f * (1 - 1e-12));
    }
    double total_s = 0.0;
    for (double t : a.segment_times_s) total_s += t;
    EXPECT_LT(total_s, previous_total_s) << "rho " << rho;
    previous_total_s = total_s;
  }
}

// ---------------------------------------------------------------------------------------------
// 6. Errors name what is wrong.

TEST(MinSnap, RejectsBadInputsNamingThem) {
  const auto w = random_waypoints(3, 70);
  const std::vector<double> times{1.0, 1.0};
  const auto expect_message = [](const std::string& message, const std::string& part) {
    EXPECT_NE(message.find(part), std::string::npos) << "message: " << message;
  };
  expect_message(error_of([&] { plan_min_snap({w[0]}, {}); }),
                 "expected at least 2 waypoints, got 1");
  expect_message(error_of([&] { plan_min_snap(w, {1.0}); }),
                 "segment_times_s: expected 2 values (one per segment between 3 waypoints), got 1");
  expect_message(error_of([&] {
                   plan_min_snap(w, {1.0, -0.5});
                 }),
                 "segment_times_s[1]: expected a positive finite duration, got -0.5");
  expect_message(error_of([&] {
                   plan_min_snap(w, {0.0, 1.0});
                 }),
                 "segment_times_s[0]: expected a positive finite duration, got 0");
  expect_message(error_of([&] {
                   plan_min_snap(w, {1.0, std::nan("")});
                 }),
                 "segment_times_s[1]: expected a positive finite duration, got nan");
  expect_message(error_of([&] {
                   plan_min_snap(w, {1.0, std::numeric_limits<double>::infinity()});
                 }),
                 "segment_times_s[1]: expected a positive finite duration, got inf");
  auto bad = w;
  bad[1].position_m.y() = std::nan("");
  expect_message(error_of([&] { plan_min_snap(bad, times); }),
                 "waypoints[1].position_m: expected finite numbers, got [");
  bad = w;
  bad[2].yaw_rad = std::numeric_limits<double>::infinity();
  expect_message(error_of([&] { plan_min_snap(bad, times); }),
                 "waypoints[2].yaw_rad: expected a finite number, got inf");
  bad = w;
  bad[0].velocity_m_s = Vec3(0, std::nan(""), 0);
  expect_message(error_of([&] { plan_min_snap(bad, times); }),
                 "waypoints[0].velocity_m_s: expected finite numbers");
  bad = w;
  bad[1].acceleration_m_s2 = Vec3(0, 0, -std::numeric_limits<double>::infinity());
  expect_message(error_of([&] { plan_min_snap(bad, times); }),
                 "waypoints[1].acceleration_m_s2: expected finite numbers");
  bad = w;
  bad[2].position_m = bad[1].position_m + Vec3(1e-10, 0, 0);
  bad[2].yaw_rad = bad[1].yaw_rad;
  expect_message(error_of([&] { plan_min_snap(bad, times); }),
                 "waypoints[1] and waypoints[2] are the same point");
  bad[2].yaw_rad += 0.5;  // a turn on the spot is a real segment
  EXPECT_NO_THROW(plan_min_snap(bad, times));
  // Allocation checks its own parameters and the waypoints.
  expect_message(error_of([&] { allocate_segment_times(w, 0.0); }),
                 "allocate_segment_times: rho: expected a positive finite number, got 0");
  TimeAllocationOptions options;
  options.nominal_speed_m_s = -1.0;
  expect_message(error_of([&] { allocate_segment_times(w, 1.0, options); }),
                 "nominal_speed_m_s: expected a positive finite number, got -1");
  expect_message(error_of([&] { allocate_segment_times({w[0]}, 1.0); }),
                 "allocate_segment_times: expected at least 2 waypoints, got 1");
  // Evaluation.
  const Trajectory traj = plan_min_snap(w, times);
  expect_message(error_of([&] { traj.evaluate(std::nan(""), 0); }), "t_s is NaN");
  expect_message(error_of([&] { traj.evaluate(1.0, 8); }),
                 "derivative order: expected 0..7, got 8");
  expect_message(error_of([&] { Trajectory({}); }), "expected at least 1 segment, got 0");
}

TEST(MinSnap, UnwrapYawTurnsTheShortWay) {
  std::vector<Waypoint> w = {at(Vec3(0, 0, 1), 3.0), at(Vec3(1, 0, 1), -3.0)};
  MinSnapOptions options;
  EXPECT_NEAR(plan_min_snap(w, {1.0}, options).at(1.0).yaw_rad, -3.0, 1e-12);
  options.unwrap_yaw = true;
  const double end = plan_min_snap(w, {1.0}, options).at(1.0).yaw_rad;
  EXPECT_NEAR(end, 2.0 * std::numbers::pi - 3.0, 1e-12);  // 3.0 + 0.283..., not 3.0 - 6.0
}

}  // namespace
}  // namespace dronetwin::planning
