#include "dronetwin/planning/flatness.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/model/allocation.hpp"

namespace dronetwin::planning {
namespace {

// "[x, y, z]" (full precision) for messages.
std::string text(const Vec3& v) {
  return detail::concat("[", v.x(), ", ", v.y(), ", ", v.z(), "]");
}

bool finite(const FlatOutput& f) {
  return all_finite(f.position_m) && all_finite(f.velocity_m_s) &&
         all_finite(f.acceleration_m_s2) && all_finite(f.jerk_m_s3) && all_finite(f.snap_m_s4) &&
         std::isfinite(f.yaw_rad) && std::isfinite(f.yaw_rate_rad_s) &&
         std::isfinite(f.yaw_acceleration_rad_s2);
}

// Why the flat state is singular, as a violation with its value and threshold.
struct Singularity {
  FeasibilityViolation kind = FeasibilityViolation::kNone;
  double value = 0.0, limit = 0.0;
  std::string message;
};

// The flat state of the header's equations (1)-(4) and their derivatives; `singular.kind` set
// (and `out` incomplete) where they are undefined.
void compute(const FlatOutput& f, const VehicleModel& model, double g, FlatState& out,
             Singularity& singular) {
  FlatAttitude att;
  switch (flat_attitude(f, g, att)) {
    case FlatSingularity::kNone:
      break;
    case FlatSingularity::kFreeFall: {
      const double c = (f.acceleration_m_s2 + g * Vec3::UnitZ()).norm();
      singular = {FeasibilityViolation::kSingular, c, kMinThrustPerMass_m_s2,
                  detail::concat("zero thrust (free fall): |a + g e3| = ", c, " m/s^2 (a = ",
                                 text(f.acceleration_m_s2), " m/s^2, g = ", g, " m/s^2), below ",
                                 kMinThrustPerMass_m_s2, " m/s^2: the attitude is undefined")};
      return;
    }
    case FlatSingularity::kThrustAlongHeading: {
      const Vec3 z_B = (f.acceleration_m_s2 + g * Vec3::UnitZ()).normalized();
      const Vec3 x_C(std::cos(f.yaw_rad), std::sin(f.yaw_rad), 0.0);
      const double heading_sine = z_B.cross(x_C).norm();
      singular = {FeasibilityViolation::kSingular, heading_sine, kMinHeadingSine,
                  detail::concat("thrust direction z_B = ", text(z_B),
                                 " parallel to the heading x_C = ", text(x_C), " (yaw ", f.yaw_rad,
                                 " rad): |z_B x x_C| = ", heading_sine, ", below ", kMinHeadingSine,
                                 ": the body x axis is undefined")};
      return;
    }
  }
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
  out.torque_B_Nm = J * dw_B + w_B.cross(J * w_B);  // Euler's equation
  out.generalized_force << out.thrust_N, out.torque_B_Nm;
  out.rotor_thrusts_N = model.thrusts_for(out.generalized_force);
  const AllocationResult a = allocate_with_saturation(model, out.generalized_force);
  out.rotor_speeds_rad_s = a.speeds_rad_s;
  out.allocation_saturated = a.saturated;
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
  compute(f, model, limits.gravity_m_s2, s, singular);
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
  const Vec3 thrust_vector = f.acceleration_m_s2 + gravity_m_s2 * e3;  // c z_B, (1)
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
  const Vec3& j = f.jerk_m_s3;
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
  const Vec3& s = f.snap_m_s4;
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

FlatState flat_state(const FlatOutput& f, const VehicleModel& model, double gravity_m_s2) {
  require_gravity(gravity_m_s2, "flat_state");
  require(finite(f), "flat_state: the flat output has a non-finite number (position ",
          text(f.position_m), ", velocity ", text(f.velocity_m_s), ", acceleration ",
          text(f.acceleration_m_s2), ", jerk ", text(f.jerk_m_s3), ", snap ", text(f.snap_m_s4),
          ", yaw ", f.yaw_rad, " rad, ", f.yaw_rate_rad_s, " rad/s, ", f.yaw_acceleration_rad_s2,
          " rad/s^2)");
  FlatState out;
  Singularity singular;
  compute(f, model, gravity_m_s2, out, singular);
  require(singular.kind == FeasibilityViolation::kNone, "flat_state: ", singular.message);
  return out;
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
