// Links the installed dronetwin and flies one second of hover: exit code 0 when it stays up.
#include <cstdio>
#include <memory>

#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/sim/simulator.hpp"

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  using namespace dronetwin;
  auto model = std::make_shared<const VehicleModel>(load_vehicle_model(argv[1]));
  Simulator sim(model);
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  sim.set_rotor_speed_reference(model->hover_speeds_rad_s());
  const bool ok = sim.step(1000).ok() && sim.state()[2] > 0.9;
  std::printf("consumer: z = %.6f m after 1 s\n", sim.state()[2]);
  return ok ? 0 : 1;
}
