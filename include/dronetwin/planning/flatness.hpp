#pragma once
// Differential flatness of a multirotor (Mellinger & Kumar, ICRA 2011): from the flat outputs
// (position up to snap, yaw up to yaw acceleration) to the attitude, body rates and their
// derivatives, the collective thrust and its rate, the body torques and the rotor speeds.
//
//   const FlatState s = flat_state(traj.at(1.0), model);       // s.q_WB, s.angular_velocity_B...
//   const FeasibilityReport r = check_feasibility(traj, model, limits, 0.01);
//   if (!r.feasible) traj = time_scaled(traj, feasible_time_scale(traj, model, limits, 0.01));
//
// Model: a rigid body with the collective thrust along body z, gravity, and the rotor thrusts'
// moments of the allocation matrix (thrust and yaw reaction, Eq. 2.30); no ground effect, drag
// or rolling moment, gyroscopic moment or motor lag. Drag (FlatDragTerms) is optional; without
// it the simulator flies the same model with DisturbanceSwitches::none() and motor_dynamics
// off. Equations (world z up, g_W = -g e3, R = R_WB = [x_B y_B z_B]):
//   c z_B = a + g e3,  c = |a + g e3|                (thrust per mass along body z)     (1)
//   x_C = [cos psi, sin psi, 0],  y_B = z_B x x_C / |z_B x x_C|,  x_B = y_B x z_B        (2)
//   c' = z_B . j;  q = (j . x_B) / c;  p = -(j . y_B) / c                                 (3)
//   r = (p z_B . x_C + psi' y_B . y_C) / (x_B . x_C),  y_C = [-sin psi, cos psi, 0]       (4)
// (2) is the heading construction of the project's SE(3) controller (control/se3_law.hpp), so
// a flat attitude is the one that controller asks for. (3) projects dz_B/dt = w x z_B; (4)
// differentiates y_B . x_C = 0 once. The angular accelerations differentiate (1) and (2) once
// more (flatness.cpp). Torques by Euler's equation tau = J w' + w x J w (docs/model.md), then
// [c m, tau] goes through the thrust-first allocation (model/allocation.hpp).
//
// Drag (Faessler, Franchi & Scaramuzza, RA-L 2018): a linear drag F_D = -m R diag(k, k, k_z) R^T v
// (per mass, 1/s) keeps the vehicle flat. x_B and y_B are then normal to
//   alpha = a + g e3 + k v,  so z_B = alpha / |alpha|,  c = |alpha| + (k_z - k) z_B . v,      (5)
// and (3), (4) and their derivative hold with alpha, alpha' = j + k a and alpha'' = s + k j in
// place of a + g e3, j and s. The model's frame drag (Eq. 2.32, F_A = -A v) is of that form when A
// is diagonal with A_xx = A_yy; its rotor drag (-C_D |w_i| times the hub's in-plane air velocity)
// adds sum_i C_D |w_i| / m to k for rotors along body z. flat_state() solves (5) with k at the
// state's own rotor speeds, and puts what the linear form leaves out (an anisotropic or
// non-diagonal A, the hubs' w x r_i, tilted rotor planes) into alpha as a force held fixed,
// iterating to a fixed point; so the thrust and attitude balance the simulator's force to
// round-off. Exact throughout for frame drag alone. With rotor drag, k and the held force change
// along the path and their rates are not in (3)-(4): they need the rotor speeds' rates, i.e. the
// torques' rates and the angular jerk, which is why the model with rotor drag is not flat
// (docs/planning.md measures what that leaves). The drag moments (the hub forces' r_i x F) join
// Euler's torques.
//
// Trap: yaw here is the heading of (2), not the ZYX yaw of math::to_euler; the two agree when
// the vehicle is level. Singular: zero thrust (free fall, c = 0) and a thrust direction parallel
// to the heading x_C; flat_state() throws there, check_feasibility() reports it as a violation.
// The collective thrust is the allocation matrix's first row (the rotor axes' body z parts), so
// the model is exact for rotors parallel to body z (the QDrone2, the flat hexarotor); the
// in-plane thrust of tilted rotors is not accounted for.

#include <string>
#include <string_view>

#include "dronetwin/core/types.hpp"
#include "dronetwin/model/vehicle_model.hpp"
#include "dronetwin/planning/polynomial.hpp"

namespace dronetwin::planning {

/// Below this thrust per mass (m/s^2) the attitude (1) is undefined: free fall.
inline constexpr double kMinThrustPerMass_m_s2 = 1e-6;
/// Below this |z_B x x_C| the body y axis (2) is undefined: thrust along the heading.
inline constexpr double kMinHeadingSine = 1e-6;

/// The linear drag of (5), per mass: F_D = -m R diag(k, k, k_z) R^T v.
struct FlatDrag {
  double horizontal_per_s = 0.0;  ///< k, along body x and y, 1/s
  double vertical_per_s = 0.0;    ///< k_z, along body z, 1/s
};

/// Which of the model's drag terms (Eq. 2.32, still air) flat_state() includes.
struct FlatDragTerms {
  bool body_drag = false;   ///< the frame's F_A = -A v (VehicleModel::body_drag_Ns_per_m)
  bool rotor_drag = false;  ///< each rotor's -C_D |w_i| v_perp at its hub, and its moment
};

/// At most this many fixed-point iterations of flat_state() with drag (it converges in a handful:
/// the held force is a small part of the drag).
inline constexpr int kMaxFlatDragIterations = 100;

/// Everything the flat outputs fix, for the rigid-body model above.
struct FlatState {
  /// Attitude q_WB (w, x, y, z), w >= 0, and its rotation matrix R_WB (v_W = R v_B).
  Vec4 q_WB = Vec4(1, 0, 0, 0);
  Mat3 R_WB = Mat3::Identity();
  Vec3 angular_velocity_B_rad_s = Vec3::Zero();
  Vec3 angular_acceleration_B_rad_s2 = Vec3::Zero();
  /// Collective thrust per mass c = |a + g e3| (with drag: (5)), m/s^2; the thrust m c (N) and
  /// its rate (N/s).
  double thrust_per_mass_m_s2 = 0.0;
  double thrust_N = 0.0;
  double thrust_rate_N_s = 0.0;
  /// Body torques tau = J w' + w x J w (with drag: minus the drag moments), N m: what the
  /// rotor thrusts must give.
  Vec3 torque_B_Nm = Vec3::Zero();
  /// [thrust_N, torque_B_Nm]: the input of the allocation.
  GeneralizedForce generalized_force = GeneralizedForce::Zero();
  /// Rotor thrusts A^+ u that give generalized_force exactly (N), not clamped to the rotors'
  /// thrust range.
  RotorVector rotor_thrusts_N;
  /// Rotor speeds of the thrust-first allocation (allocate_with_saturation), clamped to the speed
  /// limits; equal to the speeds of rotor_thrusts_N unless allocation_saturated.
  RotorVector rotor_speeds_rad_s;
  bool allocation_saturated = false;
};

/// The part of the flat state that needs no model: attitude, body rates and angular
/// accelerations (equations (1)-(4) and their derivative), the thrust per mass and its rate. What
/// a tracking controller feeds forward (control/se3.hpp).
struct FlatAttitude {
  Mat3 R_WB = Mat3::Identity();
  Vec3 angular_velocity_B_rad_s = Vec3::Zero();
  Vec3 angular_acceleration_B_rad_s2 = Vec3::Zero();
  double thrust_per_mass_m_s2 = 0.0;       ///< c = |a + g e3|
  double thrust_per_mass_rate_m_s3 = 0.0;  ///< c' = z_B . j
};

/// Why flat_attitude could not answer.
enum class FlatSingularity {
  kNone,
  kFreeFall,            ///< |a + g e3| below kMinThrustPerMass_m_s2
  kThrustAlongHeading,  ///< |z_B x x_C| below kMinHeadingSine
};

/// FlatAttitude for flat outputs `f` and gravity g (along -z), without checks and without
/// throwing: for a controller's inner loop. Returns kNone and fills `out`, or the singularity
/// (then `out` is unchanged). Non-finite inputs give non-finite outputs; use flat_state() for a
/// checked answer.
FlatSingularity flat_attitude(const FlatOutput& f, double gravity_m_s2, FlatAttitude& out);

/// The same under the linear drag `drag` ((5); zero drag gives the same bits as above).
/// kFreeFall when |alpha| is below kMinThrustPerMass_m_s2.
FlatSingularity flat_attitude(const FlatOutput& f, double gravity_m_s2, const FlatDrag& drag,
                              FlatAttitude& out);

/// The flat state for flat outputs `f` (gravity g along -z, m/s^2). Throws InvalidArgument on a
/// non-finite number in `f`, a gravity that is negative or not finite, zero thrust (|a + g e3|
/// below kMinThrustPerMass_m_s2: free fall) or a thrust direction parallel to the heading,
/// naming the value. With `drag`, the model's drag terms (see the top of this file); then also
/// when the fixed point does not converge in kMaxFlatDragIterations.
FlatState flat_state(const FlatOutput& f, const VehicleModel& model, double gravity_m_s2 = 9.81,
                     const FlatDragTerms& drag = {});

/// flat_state() without its checks and without throwing, for a controller's inner loop: false
/// (and `out` incomplete) where flat_state() would throw on finite flat outputs (a singular state,
/// a drag fixed point that does not converge). Allocates nothing when it returns true.
bool try_flat_state(const FlatOutput& f, const VehicleModel& model, double gravity_m_s2,
                    const FlatDragTerms& drag, FlatState& out);

/// What a trajectory must stay within besides the model's rotor speed limits.
struct FeasibilityLimits {
  /// Largest angle between body z and world z, rad.
  double max_tilt_rad = 1.0;
  /// Largest body rate |w_B|, rad/s.
  double max_body_rate_rad_s = 10.0;
  double gravity_m_s2 = 9.81;
  /// Not a limit: the drag terms of the flat states checked (flat_state()).
  FlatDragTerms drag{};
};

enum class FeasibilityViolation {
  kNone,
  kRotorSpeedAboveMax,  ///< a rotor needs more than its max_speed_rad_s
  kRotorSpeedBelowMin,  ///< a rotor needs less than its min_speed_rad_s
  kTilt,                ///< tilt above FeasibilityLimits::max_tilt_rad
  kBodyRate,            ///< |w_B| above FeasibilityLimits::max_body_rate_rad_s
  kSingular,            ///< free fall or thrust along the heading (flat_state throws)
};

std::string_view violation_name(FeasibilityViolation v);

/// The outcome of check_feasibility: the first infeasible sample, if any.
struct FeasibilityReport {
  bool feasible = true;
  /// Time of the first infeasible sample, s (0 when feasible).
  double time_s = 0.0;
  FeasibilityViolation violation = FeasibilityViolation::kNone;
  /// The rotor, for a rotor speed violation (-1 otherwise).
  int rotor = -1;
  /// The offending value and the limit it crosses: rad/s for rotor speeds (the speed the thrust
  /// polynomial needs for the rotor's thrust, unclamped), rad for tilt, rad/s for body rate;
  /// |a + g e3| or |z_B x x_C| and its threshold for kSingular.
  double value = 0.0;
  double limit = 0.0;
  /// Samples evaluated (up to and including the first infeasible one).
  int samples = 0;
  /// "t = 0.42 s: rotor 2 speed 3512.3 rad/s above max 3400 rad/s" (empty when feasible).
  std::string message;
};

/// At most this many samples per feasibility check (1e7: ~10 s of work).
inline constexpr double kMaxFeasibilitySamples = 1e7;

/// Samples `trajectory` at t = 0, dt, 2 dt, ... and at its end, and reports the first sample at
/// which a rotor needs a speed outside the model's limits, the tilt or the body rate is above
/// its limit, or the flat state is singular. At one sample the checks run in that order (rotors
/// by index) and the first violation is reported. Throws InvalidArgument on a sample_dt_s that is
/// not positive and finite or gives more than kMaxFeasibilitySamples samples, or limits that are
/// not positive (gravity: non-negative) and finite.
FeasibilityReport check_feasibility(const Trajectory& trajectory, const VehicleModel& model,
                                    const FeasibilityLimits& limits, double sample_dt_s);

/// The same path flown `factor` times slower (factor < 1: faster): segment durations times
/// factor, the coefficient of tau^k divided by factor^k, so that p_new(t) = p(t / factor) and
/// the k-th derivative scales by factor^-k. Throws InvalidArgument unless factor > 0 and finite.
Trajectory time_scaled(const Trajectory& trajectory, double factor);

/// The smallest factor >= 1 (within relative tolerance) for which time_scaled(trajectory, factor)
/// passes check_feasibility: 1 when the trajectory already does; otherwise the factor is doubled
/// until it passes and the bracket [infeasible, feasible] is bisected until
/// hi - lo <= relative_tolerance * lo, and hi is returned. Bisection assumes that slowing down
/// never makes a trajectory less feasible (true for tilt and rates; rotor speeds approach
/// hover): check the result's neighbourhood if that is in doubt. Throws InvalidArgument on bad
/// arguments (as check_feasibility; relative_tolerance in (0, 1), max_factor > 1) and when
/// max_factor does not pass, with that check's message.
double feasible_time_scale(const Trajectory& trajectory, const VehicleModel& model,
                           const FeasibilityLimits& limits, double sample_dt_s,
                           double relative_tolerance = 1e-3, double max_factor = 1e3);

}  // namespace dronetwin::planning
