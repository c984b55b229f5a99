#pragma once
// The time-optimal lap: the fastest flight through a track's gates that the model's own dynamics
// (the force kernel of Sec. 2.3, every term the switches leave on) allow with rotor speeds inside
// their limits. The physical-limit yardstick for the racing policies (docs/rl.md,
// docs/planning.md).
//
//   const Track track = load_track("config/tracks/circuit.yaml");
//   const TimeOptimalLap lap = solve_time_optimal_lap(track, model, {});
//   lap.lap_time_s;  lap.states[k];  lap.rotor_speeds_rad_s[k];  lap.warm_start.lap_time_s;
//
// Method: direct multiple shooting on Ceres. The lap runs from the last gate round to it again
// (a closed track's flying lap: every lap of a race after the first) and is cut at the gates
// into segments j, each with its own duration T_j and n_j intervals of dt_j = T_j / n_j. The
// unknowns are the state x_k at every node (quaternion on Ceres's quaternion manifold), the
// controls v_k held over interval k, the log-scales of the T_j, and two numbers per gate:
//  - v_k is the wrench [collective thrust, body moments], each over a scale; the rotor thrusts
//    are the allocation's pseudo-inverse of it passed through a tanh onto each rotor's thrust
//    range, and the rotor speeds their thrust polynomial's inverse. So every rotor stays inside
//    its speed limits for any v_k without box bounds (on an active bound a projected
//    Levenberg-Marquardt step stalls), and the unknowns are the quantities the motion
//    responds to (per-rotor unknowns couple through the allocation and stalled the solver).
//  - the node that ends segment j lies in gate j's plane, inside its opening shrunk by a margin
//    on every side: p_k = c_g + sin(s_1) (w/2 - m) y_g + sin(s_2) (h/2 - m) z_g.
// The dynamics x_{k+1} = Phi(x_k, u_k, dt_j) is the simulator's own physics step (kernel
// prepare() with u_k held, RK4, the quaternion projected back), in `substeps` equal steps; the
// lap closes on itself (x_N = x_0). Ceres minimises sums of squares with box bounds only, so
// the lap time is not an objective but a constraint: stage 1 finds a feasible lap (every
// constraint's least squares at zero) from the warm start, stage 2 bisects the lap time between
// the shortest feasible lap found and one found infeasible, each attempt starting from the best
// feasible lap flown faster. The result is a feasible lap and an upper bound on the minimum
// time: an attempt that fails to converge counts as infeasible, so the bisection can stop
// above the true optimum (docs/planning.md says how far the shipped circuit's lap is from the
// rotor limits).
//
// Why this method: multiple shooting keeps the full model (drag, rotor drag, gyroscopic
// moments) with no reformulation, its Jacobian is block-sparse (one interval touches two nodes),
// and a Jet pass over one physics step gives each block exactly; the warm start's gate times
// fix which node crosses which gate, and the free T_j move every crossing in time. A
// progress-based formulation (Foehn et al., Science Robotics 2021) also chooses the gate
// crossings' order of nodes, at the price of complementarity constraints that Ceres cannot
// state; for a fixed gate order it finds the same lap.
//
// Warm start: a flown lap. By default the minimum-snap plan through the gate centres
// (planning/min_snap.hpp, segment times by allocate_segment_times, slowed by
// feasible_time_scale until its flat rotor speeds are within limits: the fastest feasible
// minimum-snap lap, reported as `warm_start`) flown in the simulator by the SE(3) controller
// with feed-forward; or any recorded flight (FlownTrajectory), such as a racing policy's
// episode. The plan's own flat states do not serve: they obey the flatness model, not the
// drag terms, and their rotor speeds vary within an interval, and from them the feasibility
// least squares stalls. Each interval's warm-start controls are the rotor speeds whose thrusts
// are the flight's mean thrusts over it (the flight's impulse; the speeds at its middle miss
// every switch inside it), so a lap given back as a flight on its own grid
// (TimeOptimalOptions::intervals_per_segment) starts where it ended.
//
// Left out (docs/planning.md): the motor lag (the rotor speeds themselves are the controls, as
// in the simulator with motor_dynamics off); collisions with gate frames other than through the
// margin; wind; the first lap from a standing start.

#include <string>
#include <utility>
#include <vector>

#include "dronetwin/core/types.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/model/vehicle_model.hpp"
#include "dronetwin/planning/polynomial.hpp"
#include "dronetwin/world/track.hpp"

namespace dronetwin {

struct TimeOptimalOptions {
  /// The force terms of the model: every term by default; DisturbanceSwitches::none() is the
  /// flatness model of planning/flatness.hpp (thrust and yaw reaction only).
  DisturbanceSwitches switches{};
  double gravity_m_s2 = 9.81;
  /// Intervals over the whole lap, shared among the segments in proportion to the warm start's
  /// segment times (at least 4 each).
  int intervals = 150;
  /// Intervals per segment (the last gate to the first, then gate to gate), at least 4 each;
  /// replaces `intervals` when not empty. Re-solving from a lap on its own grid
  /// (TimeOptimalLap::gate_nodes' differences) starts from a lap that is feasible already.
  std::vector<int> intervals_per_segment;
  /// RK4 steps per interval.
  int substeps = 2;
  /// How far the vehicle's centre stays inside every edge of a gate's opening, m. Negative: the
  /// model's collision shape's bounding radius.
  double gate_margin_m = -1.0;
  /// The rho values (cost per second) of the warm start's segment-time allocation
  /// (planning/min_snap.hpp) to try; the fastest lap after time scaling wins.
  std::vector<double> warm_start_rhos = {1e1, 1e2, 1e3, 1e4, 1e5};
  /// The fastest feasible minimum-snap plan is flown with its segment times times each of these
  /// (below 1: faster than its flat rotor speeds allow, the controller saturating and cutting
  /// corners); every flight through all gates is a warm start, and the fastest solution wins.
  /// The solve is local, so faster warm starts reach faster laps (docs/planning.md).
  std::vector<double> warm_start_time_factors = {1.0, 0.9, 0.8, 0.7, 0.6, 0.55, 0.5, 0.45};
  /// A lap is feasible when every constraint (dynamics in m, m/s, 1 and rad/s / 10; gates in
  /// m) is within this.
  double constraint_tolerance = 1e-6;
  /// The search for the time scale stops when its bracket is narrower than this, relative.
  double scale_tolerance = 1e-3;
  /// Feasibility solves at most, and Levenberg-Marquardt iterations per solve.
  int max_outer_iterations = 40;
  int max_inner_iterations = 100;
};

/// The fastest feasible minimum-snap lap (the warm start, and the baseline a time-optimal lap
/// must beat).
struct MinSnapLap {
  planning::Trajectory trajectory;
  double lap_time_s = 0.0;
  /// feasible_time_scale's factor applied to the allocated times.
  double time_scale = 1.0;
};

struct TimeOptimalLap {
  /// A planning::Trajectory has no empty state, so neither has a lap: it starts from its
  /// minimum-snap baseline.
  explicit TimeOptimalLap(MinSnapLap min_snap) : warm_start(std::move(min_snap)) {}

  double lap_time_s = 0.0;
  /// Per segment (the last gate to the first, then gate to gate), s.
  std::vector<double> segment_times_s;
  /// Node times (intervals + 1), states at the nodes, and the rotor speeds held from node k to
  /// k + 1 (intervals).
  std::vector<double> times_s;
  std::vector<StateVector> states;
  std::vector<RotorVector> rotor_speeds_rad_s;
  /// Node index at which each gate is crossed, in track order (the last gate's is the lap's end).
  std::vector<int> gate_nodes;
  /// Largest constraint violation at the end (the scaled units of constraint_tolerance).
  double max_violation = 0.0;
  /// The flown lap the solve started from (gate to gate, s).
  double warm_start_lap_time_s = 0.0;
  int outer_iterations = 0;
  int inner_iterations = 0;
  double solve_time_s = 0.0;
  bool converged = false;
  /// The fastest feasible minimum-snap lap (the baseline; flown, it is the default warm start).
  MinSnapLap warm_start;
  /// Gate margin used, m.
  double gate_margin_m = 0.0;
};

/// The fastest minimum-snap lap through the gate centres whose flat rotor speeds stay within
/// the model's limits (tilt and rate unlimited). Throws InvalidArgument for a track without
/// gates, or an open one.
MinSnapLap min_snap_lap(const Track& track, const VehicleModel& model,
                        const TimeOptimalOptions& options);

/// A flown trajectory to start from instead of the flown minimum-snap plan: states and rotor speeds
/// at strictly increasing times, e.g. a racing policy's episode (`dronetwin evaluate --record`, 100
/// Hz). Its fastest full lap (a passage of the last gate, then one of every gate in order) is the
/// warm start: the segment times are the lap's gate-to-gate times, the nodes its states, the rotor
/// speeds its own.
struct FlownTrajectory {
  std::vector<double> times_s;
  std::vector<StateVector> states;
  std::vector<RotorVector> rotor_speeds_rad_s;
};

/// The time-optimal lap (see the top of this file). Throws InvalidArgument on options out of
/// range (naming the field) or a track min_snap_lap refuses, and a gate whose opening is not
/// wider than twice the margin.
TimeOptimalLap solve_time_optimal_lap(const Track& track, const VehicleModel& model,
                                      const TimeOptimalOptions& options = {});

/// The same, warm-started from a flown lap instead of the flown minimum-snap plan. Throws
/// InvalidArgument naming the index of a bad sample (sizes, order, non-finite values) or saying
/// that the flight holds no full lap.
TimeOptimalLap solve_time_optimal_lap(const Track& track, const VehicleModel& model,
                                      const TimeOptimalOptions& options,
                                      const FlownTrajectory& flown);

}  // namespace dronetwin
