#pragma once
// What the sensors measure: the true motion of the vehicle at one physics step, and the scene
// the rays of a range finder or an optical-flow sensor hit. Plain data; make_sensor_truth()
// fills it from a Simulator.

#include "dronetwin/core/types.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "dronetwin/world/track.hpp"

namespace dronetwin {

struct SensorTruth {
  double time_s = 0.0;
  /// [p_W, v_W, q_WB, w_B] (core/types.hpp).
  StateVector state = StateVector::Zero();
  /// Acceleration of the centre of mass, world frame, m/s^2 (gravity included: a free fall has
  /// a = g, and an accelerometer reads zero).
  Vec3 acceleration_W_m_s2 = Vec3::Zero();
  /// dw_B/dt, body frame, rad/s^2.
  Vec3 angular_acceleration_B_rad_s2 = Vec3::Zero();
  Vec3 gravity_W_m_s2{0.0, 0.0, -9.81};
  RotorVector rotor_speed_rad_s = RotorVector::Zero(4);
  /// Objects the rays hit besides the ground (z = 0); null: the ground alone.
  const Track* scene = nullptr;
};

/// The truth at the simulator's current step. In flight the accelerations are the model's state
/// derivative at this instant; in ground contact (where the contact is resolved after the step,
/// dynamics/ground.hpp) they are the step's own change of velocity and rates over dt, so that an
/// accelerometer resting on the ground reads +g and a touchdown shows as the jolt it is.
/// `previous_state` is the state one step earlier (ignored at step 0). The rays see `scene`, or
/// the simulator's own (Simulator::set_scene) when it is null.
SensorTruth make_sensor_truth(const Simulator& sim, const StateVector& previous_state,
                              const Track* scene = nullptr);

}  // namespace dronetwin
