#include "dronetwin/control/feed_forward.hpp"

namespace dronetwin {

planning::FlatOutput flat_output(const ReferencePoint& reference) {
  planning::FlatOutput f;
  f.position_m = reference.position_m;
  f.velocity_m_s = reference.velocity_m_s;
  f.acceleration_m_s2 = reference.acceleration_m_s2;
  f.jerk_m_s3 = reference.jerk_m_s3;
  f.snap_m_s4 = reference.snap_m_s4;
  f.yaw_rad = reference.yaw_rad;
  f.yaw_rate_rad_s = reference.yaw_rate_rad_s;
  f.yaw_acceleration_rad_s2 = reference.yaw_acceleration_rad_s2;
  return f;
}

bool reference_flat_attitude(const ReferencePoint& reference, double gravity_m_s2,
                             planning::FlatAttitude& out) {
  planning::FlatAttitude attitude;
  if (planning::flat_attitude(flat_output(reference), gravity_m_s2, attitude) !=
      planning::FlatSingularity::kNone)
    return false;
  out = attitude;
  return true;
}

bool reference_flat_attitude_with_drag(const ReferencePoint& reference, double gravity_m_s2,
                                       const VehicleModel& model, planning::FlatAttitude& out,
                                       Vec3& drag_force_W) {
  planning::FlatState s;
  if (!planning::try_flat_state(flat_output(reference), model, gravity_m_s2, {true, true}, s))
    return false;
  out.R_WB = s.R_WB;
  out.angular_velocity_B_rad_s = s.angular_velocity_B_rad_s;
  out.angular_acceleration_B_rad_s2 = s.angular_acceleration_B_rad_s2;
  out.thrust_per_mass_m_s2 = s.thrust_per_mass_m_s2;
  out.thrust_per_mass_rate_m_s3 = s.thrust_rate_N_s / model.mass_kg();
  // m a = T z_B + m g_W + F_drag.
  drag_force_W = model.mass_kg() * (reference.acceleration_m_s2 + gravity_m_s2 * Vec3::UnitZ()) -
                 s.thrust_N * s.R_WB.col(2);
  return true;
}

}  // namespace dronetwin
