#include "dronetwin/control/feed_forward.hpp"

#include <cmath>

#include "dronetwin/dynamics/body_drag.hpp"
#include "dronetwin/dynamics/rotor.hpp"
#include "dronetwin/model/allocation.hpp"

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

Vec3 flat_drag_force_W(const ReferencePoint& reference, const planning::FlatAttitude& attitude,
                       const VehicleModel& model) {
  // Eq. 2.32 in still air on the flat state, through the force kernel's own linear drag maps
  // (dynamics/body_drag.hpp, dynamics/rotor.hpp) of [v_B; w_B]: the frame's, and each rotor's
  // times C_D |w_i| at the speeds the allocation gives for the flat thrust and torques.
  const Mat3& R = attitude.R_WB;
  const Vec3& w = attitude.angular_velocity_B_rad_s;
  const Mat3& J = model.inertia_kgm2();
  GeneralizedForce u;
  u << model.mass_kg() * attitude.thrust_per_mass_m_s2,
      J * attitude.angular_acceleration_B_rad_s2 + w.cross(J * w);
  const RotorVector speeds = allocate_with_saturation(model, u).speeds_rad_s;
  Matrix6<double> drag_map = body_drag_map<double>(model.body_drag_Ns_per_m());
  for (int i = 0; i < model.num_rotors(); ++i) {
    const RotorParams& r = model.rotor(i);
    drag_map += r.rotor_drag_coefficient * std::abs(speeds[i]) *
                rotor_drag_map<double>(r.position_m, r.axis);
  }
  Vector6<double> air_and_rate;
  air_and_rate << R.transpose() * reference.velocity_m_s, w;
  return R * (drag_map * air_and_rate).head<3>();
}

}  // namespace dronetwin
