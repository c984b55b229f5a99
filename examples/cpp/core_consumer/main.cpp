// Links only dronetwin::core: a quadrotor built in code, flown for one second at its hover speeds.
// Exit code 0 when it stays within 1 cm of where it started.
#include <cstdio>
#include <memory>

#include "dronetwin/model/vehicle_model.hpp"
#include "dronetwin/sim/simulator.hpp"

int main() {
  using namespace dronetwin;
  VehicleSpec spec;
  spec.name = "x-quad";
  spec.mass_kg = 1.0;
  spec.inertia_kgm2 = Vec3(0.01, 0.01, 0.018).asDiagonal();
  const double arm = 0.15;
  const double x[4] = {arm, -arm, -arm, arm}, y[4] = {arm, arm, -arm, -arm};
  const int spin[4] = {1, -1, 1, -1};
  for (int i = 0; i < 4; ++i) {
    RotorParams r;
    r.position_m = Vec3(x[i], y[i], 0.0);
    r.spin = spin[i];
    r.thrust_coefficients = {2e-6, 0.0, 0.0};
    r.yaw_moment_per_thrust_m = 0.015;
    r.time_constant_rise_s = r.time_constant_fall_s = 0.02;
    r.max_speed_rad_s = 3000.0;
    spec.rotors.push_back(r);
  }
  auto model = std::make_shared<const VehicleModel>(spec);
  Simulator sim(model);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  sim.set_rotor_speed_reference(model->hover_speeds_rad_s());
  const bool ok = sim.step(1000).ok() && (sim.state().head<3>() - Vec3(0, 0, 1)).norm() < 0.01;
  std::printf("core_consumer: position [%.6f %.6f %.6f] m after 1 s\n", sim.state()[0],
              sim.state()[1], sim.state()[2]);
  return ok ? 0 : 1;
}
