#pragma once
// What a reference asks of the vehicle beyond its position, for the controllers' feed-forward
// (SE(3): control/se3.hpp, cascaded PID: control/pid.hpp): the attitude, body rates and angular
// accelerations of its flat state (planning/flatness.hpp, from its jerk, snap and yaw motion),
// and the drag force the vehicle meets flying it.
//
//   planning::FlatAttitude attitude;
//   if (reference_flat_attitude(ref, 9.81, attitude)) {          // false where singular
//     const Vec3 w_ref = attitude.angular_velocity_B_rad_s;
//     const Vec3 F_drag = flat_drag_force_W(ref, attitude, model);  // N, world frame
//   }

#include "dronetwin/control/reference.hpp"
#include "dronetwin/model/vehicle_model.hpp"
#include "dronetwin/planning/flatness.hpp"

namespace dronetwin {

/// The reference point as the flat output it is (position to snap, yaw to yaw acceleration).
planning::FlatOutput flat_output(const ReferencePoint& reference);

/// The flat attitude of a reference point with its body rates and angular accelerations. False,
/// and `out` untouched, where it is singular (free fall, thrust along the heading).
bool reference_flat_attitude(const ReferencePoint& reference, double gravity_m_s2,
                             planning::FlatAttitude& out);

/// The frame and rotor drag (Eq. 2.32) of `model` flying the reference in still air on its flat
/// attitude, at the rotor speeds the thrust-first allocation gives for the flat thrust and
/// torques; N, world frame. The rotor drag's moment is not part of it.
Vec3 flat_drag_force_W(const ReferencePoint& reference, const planning::FlatAttitude& attitude,
                       const VehicleModel& model);

}  // namespace dronetwin
