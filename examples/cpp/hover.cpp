// Fly a QDrone2 open-loop at its hover rotor speeds for 2 s and print where it is.
// Build: part of the dronetwin build (examples/cpp); run: build/release/examples/cpp/hover
#include <cstdio>
#include <memory>

#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/sim/simulator.hpp"

int main(int argc, char** argv) {
  using namespace dronetwin;
  const char* path = argc > 1 ? argv[1] : DRONETWIN_SOURCE_DIR "/models/qdrone2.yaml";
  auto model = std::make_shared<const VehicleModel>(load_vehicle_model(path));
  Simulator sim(model);  // 1 kHz RK4, every term
  sim.reset(Simulator::hover_state(Vec3(0, 0, 1)), model->hover_speeds_rad_s());
  sim.set_rotor_speed_reference(model->hover_speeds_rad_s());  // actuate
  const StepResult r = sim.step(2000);                         // 2 s
  const StateVector x = sim.measured_state();                  // sense
  std::printf("%s after %.1f s: status %s, position [%.4f %.4f %.4f] m\n", model->name().c_str(),
              sim.time_s(), std::string(status_name(r.status)).c_str(), x[0], x[1], x[2]);
  return r.ok() ? 0 : 1;
}
