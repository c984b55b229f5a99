#pragma once
// What a reference asks of the vehicle beyond its position, for the controllers' feed-forward
// (SE(3): control/se3.hpp, cascaded PID: control/pid.hpp): the attitude, body rates and angular
// accelerations of its flat state (planning/flatness.hpp, from its jerk, snap and yaw motion),
// without drag or flown through the model's drag, and then the drag force it meets.
//
//   planning::FlatAttitude attitude;
//   if (reference_flat_attitude(ref, 9.81, attitude)) {          // false where singular
//     const Vec3 w_ref = attitude.angular_velocity_B_rad_s;
//   }
//   Vec3 F_drag;                                                  // N, world frame
//   if (reference_flat_attitude_with_drag(ref, 9.81, model, attitude, F_drag)) { ... }

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

/// The flat attitude of a reference point flown through `model`'s frame and rotor drag (Eq. 2.32,
/// still air; planning/flatness.hpp (5)), and that drag force, N, world frame: the thrust and
/// attitude balance it exactly. False, and the outputs untouched, where the state is singular or
/// the drag's fixed point does not converge.
bool reference_flat_attitude_with_drag(const ReferencePoint& reference, double gravity_m_s2,
                                       const VehicleModel& model, planning::FlatAttitude& out,
                                       Vec3& drag_force_W);

}  // namespace dronetwin
