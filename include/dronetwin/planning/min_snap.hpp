#pragma once
// Minimum-snap trajectories through waypoints (Mellinger & Kumar, ICRA 2011): for each axis,
// the piecewise polynomial p(t) through the waypoints at the given segment times that minimises
//   J = integral over [0, T] of (d^4 p / dt^4)^2 dt                                        (1)
// Snap is the fourth derivative of position; by differential flatness it maps to the second
// derivative of thrust and the body angular accelerations, so (1) asks for gentle motor commands.
// Yaw uses the same snap cost (1), planned as a fourth, independent axis; its units are rad^2/s^7.
//
//   std::vector<Waypoint> w = {{Vec3(0, 0, 1)}, {Vec3(2, 1, 1)}, {Vec3(4, 0, 1.5), 1.57}};
//   const std::vector<double> times_s = allocate_segment_times(w, 10.0, {});
//   const Trajectory traj = plan_min_snap(w, times_s, {});
//   const FlatOutput f = traj.at(1.0);
//
// Method (closed form in the free end derivatives, Richter, Bry & Roy, ISRR 2013, Sec. 3): a
// degree-7 segment is fixed by position, velocity, acceleration and jerk at its two ends
// (Hermite interpolation), and its cost (1) is a quadratic form d^T M(T) d in those eight
// numbers, M(T) = T^-7 S(T) M_1 S(T) with S(T) = diag(1, T, T^2, T^3, 1, T, T^2, T^3) and M_1 the
// unit-duration matrix. Sharing the end derivatives between neighbouring segments makes the path
// C3 by construction; the derivatives 1..3 at interior waypoints that are not given are the
// unknowns, and J is a quadratic in them with a block-tridiagonal Hessian, solved by a sparse LDLT
// (x, y and z share one factorisation). At the optimum the path is C6 at every interior waypoint
// whose velocity and acceleration are free: the stationarity conditions in the free velocity,
// acceleration and jerk are the continuity of derivatives 6, 5 and 4 (integrate (1) by parts).
// A given velocity or acceleration at a waypoint removes the matching condition there.
//
// Boundary conditions: velocity and acceleration at the first and last waypoint are those given,
// zero if not given; jerk there is zero. Interior waypoints fix position and yaw, and velocity and
// acceleration where given. Yaw rate and yaw acceleration are zero at both ends and free inside.
// The trap: yaw is planned through the numbers given, so 3.1 -> -3.1 rad turns 6.2 rad the long
// way; set MinSnapOptions::unwrap_yaw to turn the short way instead.

#include <optional>
#include <vector>

#include "dronetwin/core/types.hpp"
#include "dronetwin/planning/polynomial.hpp"

namespace dronetwin::planning {

struct Waypoint {
  Vec3 position_m = Vec3::Zero();
  double yaw_rad = 0.0;
  /// Velocity and acceleration to pass the waypoint with; free (interior) or zero (ends) if unset.
  std::optional<Vec3> velocity_m_s;
  std::optional<Vec3> acceleration_m_s2;
};

struct MinSnapOptions {
  /// Add multiples of 2 pi to each waypoint's yaw so that every step between consecutive
  /// waypoints is in [-pi, pi] (the short way round). The planned yaw then equals yaw_rad at each
  /// waypoint only modulo 2 pi.
  bool unwrap_yaw = false;
};

/// The minimum-snap trajectory through `waypoints`, segment i lasting segment_times_s[i].
/// Throws InvalidArgument (naming the waypoint or segment, expected versus got) on fewer than 2
/// waypoints, a segment_times_s count other than waypoints.size() - 1, a non-positive or
/// non-finite segment time, a non-finite number in a waypoint, or two consecutive waypoints at
/// the same place (closer than 1e-9 m) and yaw.
Trajectory plan_min_snap(const std::vector<Waypoint>& waypoints,
                         const std::vector<double>& segment_times_s,
                         const MinSnapOptions& options = {});

/// The optimal cost (1) summed over x, y, z plus yaw_weight times that of yaw, and its gradient
/// with respect to the segment times (envelope theorem: dJ*/dT_i = d_i^T dM/dT(T_i) d_i at the
/// optimal end derivatives d_i, since those minimise J). Validates like plan_min_snap.
struct SnapCost {
  double cost = 0.0;
  std::vector<double> gradient;  // dJ*/dT_i, per segment
};
SnapCost min_snap_cost(const std::vector<Waypoint>& waypoints,
                       const std::vector<double>& segment_times_s, double yaw_weight = 1.0,
                       const MinSnapOptions& options = {});

struct TimeAllocationOptions {
  MinSnapOptions min_snap;
  /// Initial guess: segment time = max(distance / nominal_speed, |yaw step| / nominal_yaw_rate).
  double nominal_speed_m_s = 1.0;
  double nominal_yaw_rate_rad_s = 1.0;
  /// Weight of yaw's snap cost against that of position, m^2/rad^2.
  double yaw_weight = 1.0;
  /// Converged when max_i |dF/d ln T_i| <= gradient_tolerance * F.
  double gradient_tolerance = 1e-6;
  int max_iterations = 500;
};

/// The outcome of a time allocation: the times and how the search ended.
struct TimeAllocation {
  std::vector<double> segment_times_s;
  double snap_cost = 0.0;           // J*(T) at the result
  double total_cost = 0.0;          // F = J*(T) + rho * sum(T)
  double initial_total_cost = 0.0;  // F at the initial guess
  double relative_gradient = 0.0;   // max_i |dF/d ln T_i| / F at the result
  int iterations = 0;
  bool converged = false;
};

/// Segment times minimising F(T) = J*(T) + rho * sum(T_i) (rho in cost units per second: larger
/// rho, faster trajectory). Method: BFGS with a backtracking (Armijo) line search on the log-times
/// u_i = ln T_i, which keeps every time positive and makes the problem scale-free; the gradient
/// dF/du_i = T_i (dJ*/dT_i + rho) is analytic (min_snap_cost). Starts from the nominal-speed
/// guess. For two waypoints J* = J*(1) T^-7 and the optimum is T = (7 J*(1) / rho)^(1/8).
/// Throws InvalidArgument like plan_min_snap, and on rho or an option that is not positive.
TimeAllocation optimize_segment_times(const std::vector<Waypoint>& waypoints, double rho,
                                      const TimeAllocationOptions& options = {});

/// optimize_segment_times(...).segment_times_s: the best times found (converged or not).
std::vector<double> allocate_segment_times(const std::vector<Waypoint>& waypoints, double rho,
                                           const TimeAllocationOptions& options = {});

}  // namespace dronetwin::planning
