#include "dronetwin/sensors/sensor_truth.hpp"

namespace dronetwin {

SensorTruth make_sensor_truth(const Simulator& sim, const StateVector& previous_state,
                              const Track* scene) {
  using namespace state_index;
  SensorTruth t;
  t.time_s = sim.time_s();
  t.state = sim.state();
  t.gravity_W_m_s2 = sim.config().environment.gravity_W_m_s2;
  t.rotor_speed_rad_s = sim.rotor_speeds_rad_s();
  t.scene = scene != nullptr ? scene : sim.scene();
  if (sim.contact().in_contact && sim.step_count() > 0) {
    const double dt = sim.config().dt_s;
    t.acceleration_W_m_s2 =
        (t.state.segment<3>(kVelocity) - previous_state.segment<3>(kVelocity)) / dt;
    t.angular_acceleration_B_rad_s2 =
        (t.state.segment<3>(kAngularVelocity) - previous_state.segment<3>(kAngularVelocity)) / dt;
  } else if (sim.contact().in_contact) {
    // At step 0 on the ground nothing has moved yet: resting.
    t.acceleration_W_m_s2.setZero();
    t.angular_acceleration_B_rad_s2.setZero();
  } else {
    const StateVector d = sim.state_derivative();
    t.acceleration_W_m_s2 = d.segment<3>(kVelocity);
    t.angular_acceleration_B_rad_s2 = d.segment<3>(kAngularVelocity);
  }
  return t;
}

}  // namespace dronetwin
