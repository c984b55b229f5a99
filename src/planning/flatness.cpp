#include "dronetwin/planning/flatness.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/core/vec_text.hpp"
#include "dronetwin/dynamics/body_drag.hpp"
#include "dronetwin/dynamics/rotor.hpp"
#include "dronetwin/model/allocation.hpp"

namespace dronetwin::planning {
namespace {

bool finite(const FlatOutput& f) {
  return all_finite(f.position_m) && all_finite(f.velocity_m_s) &&
         all_finite(f.acceleration_m_s2) && all_finite(f.jerk_m_s3) && all_finite(f.snap_m_s4) &&
         std::isfinite(f.yaw_rad) && std::isfinite(f.yaw_rate_rad_s) &&
         std::isfinite(f.yaw_acceleration_rad_s2);
}

// The header's (1)-(4) and their derivative for a thrust along `thrust_vector` (c z_B) with time
// derivatives `d1` and `d2`: a + g e3, j and s without drag, alpha, alpha' and alpha'' of (5)
// with it. thrust_per_mass_m_s2 = |thrust_vector|, its rate z_B . d1.
FlatSingularity attitude_along(const Vec3& thrust_vector, const Vec3& d1, const Vec3& d2,
                               const FlatOutput& f, FlatAttitude& out) {
  const double c = thrust_vector.norm();
  if (!(c >= kMinThrustPerMass_m_s2)) return FlatSingularity::kFreeFall;
  const Vec3 z_B = thrust_vector / c;
  const double cos_psi = std::cos(f.yaw_rad), sin_psi = std::sin(f.yaw_rad);
  const Vec3 x_C(cos_psi, sin_psi, 0.0), y_C(-sin_psi, cos_psi, 0.0);
  const Vec3 y_raw = z_B.cross(x_C);
  const double heading_sine = y_raw.norm();  // = x_B . x_C, the denominator of (4)
  if (!(heading_sine >= kMinHeadingSine)) return FlatSingularity::kThrustAlongHeading;
  const Vec3 y_B = y_raw / heading_sine;
  const Vec3 x_B = y_B.cross(z_B);

  // Body rates, (3) and (4).
  const Vec3& j = d1;
  const double c_dot = z_B.dot(j);
  const double p = -j.dot(y_B) / c, q_rate = j.dot(x_B) / c;
  const double psi_dot = f.yaw_rate_rad_s, psi_ddot = f.yaw_acceleration_rad_s2;
  const double r = (p * z_B.dot(x_C) + psi_dot * y_B.dot(y_C)) / heading_sine;
  Mat3 R;
  R.col(0) = x_B;
  R.col(1) = y_B;
  R.col(2) = z_B;
  const Vec3 w_W = R * Vec3(p, q_rate, r);

  // Angular accelerations: (1) twice differentiated, s = c'' z_B + 2 c' w x z_B
  // + c (w' x z_B + w x (w x z_B)), projected on x_B and y_B; y_B . x_C = 0 twice differentiated,
  // (w' x y_B + w x (w x y_B)) . x_C + 2 psi' (w x y_B) . y_C + psi'' y_B . y_C = 0, for w'_z.
  const Vec3& s = d2;
  const double a_x = r * q_rate - (s.dot(y_B) + 2.0 * c_dot * p) / c;
  const double a_y = (s.dot(x_B) - 2.0 * c_dot * q_rate) / c - r * p;
  const Vec3 w_x_y = w_W.cross(y_B);
  const double a_z = (a_x * z_B.dot(x_C) + w_W.cross(w_x_y).dot(x_C) +
                      2.0 * psi_dot * w_x_y.dot(y_C) + psi_ddot * y_B.dot(y_C)) /
                     heading_sine;
  out.R_WB = R;
  out.angular_velocity_B_rad_s = Vec3(p, q_rate, r);
  out.angular_acceleration_B_rad_s2 = Vec3(a_x, a_y, a_z);
  out.thrust_per_mass_m_s2 = c;
  out.thrust_per_mass_rate_m_s3 = c_dot;
  return FlatSingularity::kNone;
}

// (5): the attitude under the linear drag `d` and a held force per mass `held_W` (the part of
// the drag the linear form leaves out, its rates taken as zero).
FlatSingularity attitude_with_drag(const FlatOutput& f, double g, const FlatDrag& d,
                                   const Vec3& held_W, FlatAttitude& out) {
  const double k = d.horizontal_per_s;
  const Vec3& v = f.velocity_m_s;
  const Vec3& a = f.acceleration_m_s2;
  const Vec3 alpha = a + g * Vec3::UnitZ() + k * v - held_W;
  FlatAttitude att;
  const FlatSingularity singular =
      attitude_along(alpha, f.jerk_m_s3 + k * a, f.snap_m_s4 + k * f.jerk_m_s3, f, att);
  if (singular != FlatSingularity::kNone) return singular;
  // c = |alpha| + (k_z - k) z_B . v, and its rate with z_B' = w x z_B.
  const Vec3 z_B = att.R_WB.col(2);
  const Vec3 w_W = att.R_WB * att.angular_velocity_B_rad_s;
  const double anisotropy = d.vertical_per_s - k;
  att.thrust_per_mass_m_s2 += anisotropy * z_B.dot(v);
  att.thrust_per_mass_rate_m_s3 += anisotropy * (w_W.cross(z_B).dot(v) + z_B.dot(a));
  out = att;
  return FlatSingularity::kNone;
}

// Why the flat state is singular, as a violation with its value and threshold.
struct Singularity {
  FeasibilityViolation kind = FeasibilityViolation::kNone;
  double value = 0.0, limit = 0.0;
  std::string message;
};

// `kind` as a violation with its value, threshold and message; `thrust_vector` is c z_B, named
// `name` in the message.
Singularity describe(FlatSingularity kind, const Vec3& thrust_vector, const char* name,
                     const FlatOutput& f, double g) {
  if (kind == FlatSingularity::kFreeFall) {
    const double c = thrust_vector.norm();
    return {FeasibilityViolation::kSingular, c, kMinThrustPerMass_m_s2,
            detail::concat("zero thrust (free fall): |", name, "| = ", c, " m/s^2 (a = ",
                           VecText{f.acceleration_m_s2}, " m/s^2, g = ", g, " m/s^2), below ",
                           kMinThrustPerMass_m_s2, " m/s^2: the attitude is undefined")};
  }
  const Vec3 z_B = thrust_vector.normalized();
  const Vec3 x_C(std::cos(f.yaw_rad), std::sin(f.yaw_rad), 0.0);
  const double heading_sine = z_B.cross(x_C).norm();
  return {FeasibilityViolation::kSingular, heading_sine, kMinHeadingSine,
          detail::concat("thrust direction z_B = ", VecText{z_B}, " parallel to the heading x_C = ",
                         VecText{x_C}, " (yaw ", f.yaw_rad, " rad): |z_B x x_C| = ", heading_sine,
                         ", below ", kMinHeadingSine, ": the body x axis is undefined")};
}

// The flat state of `att`: Euler's torques less the drag moment `drag_moment_B`, then the
// allocation.
void fill(const FlatAttitude& att, const Vec3& drag_moment_B, const VehicleModel& model,
          FlatState& out) {
  out.R_WB = att.R_WB;
  const Eigen::Quaterniond q(out.R_WB);
  out.q_WB = Vec4(q.w(), q.x(), q.y(), q.z());
  if (out.q_WB[0] < 0.0) out.q_WB = -out.q_WB;  // one of the two, w >= 0
  const Vec3& w_B = att.angular_velocity_B_rad_s;
  const Vec3& dw_B = att.angular_acceleration_B_rad_s2;
  const double m = model.mass_kg();
  const Mat3& J = model.inertia_kgm2();
  out.angular_velocity_B_rad_s = w_B;
  out.angular_acceleration_B_rad_s2 = dw_B;
  out.thrust_per_mass_m_s2 = att.thrust_per_mass_m_s2;
  out.thrust_N = m * att.thrust_per_mass_m_s2;
  out.thrust_rate_N_s = m * att.thrust_per_mass_rate_m_s3;
  out.torque_B_Nm = J * dw_B + w_B.cross(J * w_B) - drag_moment_B;  // Euler's equation
  out.generalized_force << out.thrust_N, out.torque_B_Nm;
  out.rotor_thrusts_N = model.thrusts_for(out.generalized_force);
  const AllocationResult a = allocate_with_saturation(model, out.generalized_force);
  out.rotor_speeds_rad_s = a.speeds_rad_s;
  out.allocation_saturated = a.saturated;
}

// The flat state with the model's drag terms (the header's (5)): a fixed point over the rotor
// speeds (which set the rotor drag) and the held force (the drag the linear form leaves out).
void compute_with_drag(const FlatOutput& f, const VehicleModel& model, double g,
                       const FlatDragTerms& terms, FlatState& out, Singularity& singular) {
  const double m = model.mass_kg();
  const Mat3 A = terms.body_drag ? model.body_drag_Ns_per_m() : Mat3(Mat3::Zero());
  // The force kernel's own drag maps of [v_B; w_B] (dynamics/body_drag.hpp, dynamics/rotor.hpp).
  const Matrix6<double> frame_map = body_drag_map<double>(A);
  // Each rotor's map per unit C_D |w_i| depends on its geometry only: built once, not per
  // iteration.
  std::array<Matrix6<double>, kMaxRotors> rotor_maps;
  if (terms.rotor_drag)
    for (int i = 0; i < model.num_rotors(); ++i)
      rotor_maps[static_cast<std::size_t>(i)] =
          rotor_drag_map<double>(model.rotor(i).position_m, model.rotor(i).axis);
  GeneralizedForce hover = GeneralizedForce::Zero();
  hover[0] = m * g;
  RotorVector speeds = allocate_with_saturation(model, hover).speeds_rad_s;
  Vec3 held_W = Vec3::Zero();
  double speed_change = 0.0, held_change = 0.0;
  for (int iteration = 0; iteration < kMaxFlatDragIterations; ++iteration) {
    Matrix6<double> map = frame_map;
    double rotor_drag_per_m_s = 0.0;  // sum_i C_D |w_i|
    if (terms.rotor_drag)
      for (int i = 0; i < model.num_rotors(); ++i) {
        const double c_i = model.rotor(i).rotor_drag_coefficient * std::abs(speeds[i]);
        rotor_drag_per_m_s += c_i;
        map += c_i * rotor_maps[static_cast<std::size_t>(i)];
      }
    const FlatDrag linear{(0.5 * (A(0, 0) + A(1, 1)) + rotor_drag_per_m_s) / m, A(2, 2) / m};
    FlatAttitude att;
    const FlatSingularity kind = attitude_with_drag(f, g, linear, held_W, att);
    if (kind != FlatSingularity::kNone) {
      const Vec3 alpha = f.acceleration_m_s2 + g * Vec3::UnitZ() +
                         linear.horizontal_per_s * f.velocity_m_s - held_W;
      singular = describe(kind, alpha, "a + g e3 + k v - F_held / m", f, g);
      return;
    }
    const Mat3& R = att.R_WB;
    const Vec3 v_B = R.transpose() * f.velocity_m_s;
    Vector6<double> air_and_rate;
    air_and_rate << v_B, att.angular_velocity_B_rad_s;
    const Vector6<double> drag = map * air_and_rate;  // [F_B; M_B]
    const Vec3 linear_B =
        -m * Vec3(linear.horizontal_per_s, linear.horizontal_per_s, linear.vertical_per_s)
                 .cwiseProduct(v_B);
    const Vec3 next_held_W = R * (drag.head<3>() - linear_B) / m;
    fill(att, drag.tail<3>(), model, out);
    const int n = model.num_rotors();
    speed_change = (out.rotor_speeds_rad_s.head(n) - speeds.head(n)).cwiseAbs().maxCoeff();
    held_change = (next_held_W - held_W).cwiseAbs().maxCoeff();
    const double speed_scale = std::max(1.0, speeds.head(n).cwiseAbs().maxCoeff());
    const double force_scale = std::max(g, att.thrust_per_mass_m_s2);
    if (speed_change <= 1e-12 * speed_scale && held_change <= 1e-13 * force_scale) return;
    speeds = out.rotor_speeds_rad_s;
    held_W = next_held_W;
  }
  singular = {
      FeasibilityViolation::kSingular, speed_change, 0.0,
      detail::concat(
          "the drag fixed point did not converge in ", kMaxFlatDragIterations,
          " iterations (last change: rotor speed ", speed_change, " rad/s, held force ",
          held_change,
          " m/s^2 per mass): the drag outside the closed form (anisotropic or non-diagonal frame "
          "drag, the hubs' w x r) is too large for it")};
}

// The flat state of the header's equations (1)-(4) (with drag: (5)) and their derivatives;
// `singular.kind` set (and `out` incomplete) where they are undefined.
void compute(const FlatOutput& f, const VehicleModel& model, double g, const FlatDragTerms& drag,
             FlatState& out, Singularity& singular) {
  if (drag.body_drag || drag.rotor_drag) return compute_with_drag(f, model, g, drag, out, singular);
  FlatAttitude att;
  const FlatSingularity kind = flat_attitude(f, g, att);
  if (kind != FlatSingularity::kNone) {
    singular = describe(kind, f.acceleration_m_s2 + g * Vec3::UnitZ(), "a + g e3", f, g);
    return;
  }
  fill(att, Vec3::Zero(), model, out);
}

void require_gravity(double g, const char* who) {
  require(std::isfinite(g) && g >= 0.0, who, ": gravity_m_s2: expected a finite value >= 0, got ",
          g);
}

void require_limits(const FeasibilityLimits& limits, double sample_dt_s, const char* who) {
  require(std::isfinite(sample_dt_s) && sample_dt_s > 0.0, who,
          ": sample_dt_s: expected a positive finite time step, got ", sample_dt_s);
  require(std::isfinite(limits.max_tilt_rad) && limits.max_tilt_rad > 0.0, who,
          ": limits.max_tilt_rad: expected a positive finite angle, got ", limits.max_tilt_rad);
  require(std::isfinite(limits.max_body_rate_rad_s) && limits.max_body_rate_rad_s > 0.0, who,
          ": limits.max_body_rate_rad_s: expected a positive finite rate, got ",
          limits.max_body_rate_rad_s);
  require_gravity(limits.gravity_m_s2, who);
}

// The first violated limit at one instant, or kNone.
FeasibilityReport check_instant(const FlatOutput& f, const VehicleModel& model,
                                const FeasibilityLimits& limits) {
  FeasibilityReport r;
  FlatState s;
  Singularity singular;
  compute(f, model, limits.gravity_m_s2, limits.drag, s, singular);
  if (singular.kind != FeasibilityViolation::kNone) {
    r.violation = singular.kind;
    r.value = singular.value;
    r.limit = singular.limit;
    r.message = singular.message;
    return r;
  }
  const double inf = std::numeric_limits<double>::infinity();
  for (int i = 0; i < model.num_rotors(); ++i) {
    const RotorParams& rp = model.rotor(i);
    const double t = s.rotor_thrusts_N[i];
    const bool above = t > rp.thrust(rp.max_speed_rad_s);
    if (!above && !(t < rp.thrust(rp.min_speed_rad_s))) continue;
    // The speed the thrust polynomial needs, without the limits (the thrust curve is increasing
    // over the speed range, so a thrust beyond the range's needs a speed beyond its limit).
    r.value = inverse_thrust_polynomial(rp.thrust_coefficients, -inf, inf, t);
    r.limit = above ? rp.max_speed_rad_s : rp.min_speed_rad_s;
    r.violation = above ? FeasibilityViolation::kRotorSpeedAboveMax
                        : FeasibilityViolation::kRotorSpeedBelowMin;
    r.rotor = i;
    r.message = detail::concat("rotor ", i, " speed ", r.value, " rad/s (thrust ", t, " N) ",
                               above ? "above max " : "below min ", r.limit, " rad/s");
    return r;
  }
  const double tilt = std::acos(std::clamp(s.R_WB(2, 2), -1.0, 1.0));
  if (tilt > limits.max_tilt_rad) {
    r.violation = FeasibilityViolation::kTilt;
    r.value = tilt;
    r.limit = limits.max_tilt_rad;
    r.message = detail::concat("tilt ", tilt, " rad above ", r.limit, " rad");
    return r;
  }
  const double rate = s.angular_velocity_B_rad_s.norm();
  if (rate > limits.max_body_rate_rad_s) {
    r.violation = FeasibilityViolation::kBodyRate;
    r.value = rate;
    r.limit = limits.max_body_rate_rad_s;
    r.message = detail::concat("body rate |w_B| ", rate, " rad/s above ", r.limit, " rad/s");
  }
  return r;
}

}  // namespace

FlatSingularity flat_attitude(const FlatOutput& f, double gravity_m_s2, FlatAttitude& out) {
  const Vec3 e3 = Vec3::UnitZ();
  return attitude_along(f.acceleration_m_s2 + gravity_m_s2 * e3, f.jerk_m_s3, f.snap_m_s4, f, out);
}

FlatSingularity flat_attitude(const FlatOutput& f, double gravity_m_s2, const FlatDrag& drag,
                              FlatAttitude& out) {
  return attitude_with_drag(f, gravity_m_s2, drag, Vec3::Zero(), out);
}

FlatState flat_state(const FlatOutput& f, const VehicleModel& model, double gravity_m_s2,
                     const FlatDragTerms& drag) {
  require_gravity(gravity_m_s2, "flat_state");
  require(finite(f), "flat_state: the flat output has a non-finite number (position ",
          VecText{f.position_m}, ", velocity ", VecText{f.velocity_m_s}, ", acceleration ",
          VecText{f.acceleration_m_s2}, ", jerk ", VecText{f.jerk_m_s3}, ", snap ",
          VecText{f.snap_m_s4}, ", yaw ", f.yaw_rad, " rad, ", f.yaw_rate_rad_s, " rad/s, ",
          f.yaw_acceleration_rad_s2, " rad/s^2)");
  FlatState out;
  Singularity singular;
  compute(f, model, gravity_m_s2, drag, out, singular);
  require(singular.kind == FeasibilityViolation::kNone, "flat_state: ", singular.message);
  return out;
}

bool try_flat_state(const FlatOutput& f, const VehicleModel& model, double gravity_m_s2,
                    const FlatDragTerms& drag, FlatState& out) {
  Singularity singular;
  compute(f, model, gravity_m_s2, drag, out, singular);
  return singular.kind == FeasibilityViolation::kNone;
}

std::string_view violation_name(FeasibilityViolation v) {
  switch (v) {
    case FeasibilityViolation::kNone:
      return "none";
    case FeasibilityViolation::kRotorSpeedAboveMax:
      return "rotor_speed_above_max";
    case FeasibilityViolation::kRotorSpeedBelowMin:
      return "rotor_speed_below_min";
    case FeasibilityViolation::kTilt:
      return "tilt";
    case FeasibilityViolation::kBodyRate:
      return "body_rate";
    case FeasibilityViolation::kSingular:
      return "singular";
  }
  return "unknown";
}

FeasibilityReport check_feasibility(const Trajectory& trajectory, const VehicleModel& model,
                                    const FeasibilityLimits& limits, double sample_dt_s) {
  require_limits(limits, sample_dt_s, "check_feasibility");
  const double end_s = trajectory.duration_s();
  // Samples k dt before the end, then the end itself (not twice when dt divides the duration).
  const double samples = std::ceil(end_s / sample_dt_s) + 1.0;
  // A bound instead of an endless loop for a mistyped step (1e-9 s over a 10 s trajectory).
  require(samples <= kMaxFeasibilitySamples, "check_feasibility: sample_dt_s: ", sample_dt_s,
          " s over a ", end_s, " s trajectory gives ", samples, " samples, expected at most ",
          kMaxFeasibilitySamples);
  const auto count = static_cast<long long>(samples) - 1;
  for (long long k = 0; k <= count; ++k) {
    const double t = std::min(static_cast<double>(k) * sample_dt_s, end_s);
    FeasibilityReport r = check_instant(trajectory.at(t), model, limits);
    if (r.violation == FeasibilityViolation::kNone) continue;
    r.feasible = false;
    r.time_s = t;
    r.samples = static_cast<int>(k + 1);
    r.message = detail::concat("t = ", t, " s: ", r.message);
    return r;
  }
  FeasibilityReport ok;
  ok.samples = static_cast<int>(count + 1);
  return ok;
}

Trajectory time_scaled(const Trajectory& trajectory, double factor) {
  require(std::isfinite(factor) && factor > 0.0,
          "time_scaled: factor: expected a positive finite number, got ", factor);
  std::vector<PolynomialSegment> segments = trajectory.segments();
  for (PolynomialSegment& s : segments) {
    s.duration_s *= factor;
    double scale = 1.0;  // factor^-k
    for (int k = 0; k < kCoefficientCount; ++k) {
      s.coefficients.row(k) *= scale;
      scale /= factor;
    }
  }
  return Trajectory(std::move(segments));
}

double feasible_time_scale(const Trajectory& trajectory, const VehicleModel& model,
                           const FeasibilityLimits& limits, double sample_dt_s,
                           double relative_tolerance, double max_factor) {
  require_limits(limits, sample_dt_s, "feasible_time_scale");
  require(std::isfinite(relative_tolerance) && relative_tolerance > 0.0 && relative_tolerance < 1.0,
          "feasible_time_scale: relative_tolerance: expected a number in (0, 1), got ",
          relative_tolerance);
  require(std::isfinite(max_factor) && max_factor > 1.0,
          "feasible_time_scale: max_factor: expected a finite number > 1, got ", max_factor);
  const auto passes = [&](double factor) {
    return check_feasibility(time_scaled(trajectory, factor), model, limits, sample_dt_s);
  };
  if (passes(1.0).feasible) return 1.0;
  double lo = 1.0, hi = 1.0;
  for (;;) {
    hi = std::min(2.0 * lo, max_factor);
    const FeasibilityReport r = passes(hi);
    if (r.feasible) break;
    require(hi < max_factor, "feasible_time_scale: even ", max_factor,
            " times slower the trajectory is infeasible: ", r.message);
    lo = hi;
  }
  while (hi - lo > relative_tolerance * lo) {
    const double mid = 0.5 * (lo + hi);
    (passes(mid).feasible ? hi : lo) = mid;
  }
  return hi;
}

}  // namespace dronetwin::planning
