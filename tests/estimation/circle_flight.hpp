#pragma once
// The flight the estimation tests watch: the QDrone2 flying the SE(3) controller
// (config/controllers/se3.yaml) on its true state around a circle at 1 kHz, started on the
// circle at hover speeds, with a SensorSuite sampling it at every physics step.
//
//   CircleFlight f(CircleReference(Vec3(0, 0, 1), 1.0, 6.0), {SensorSpec::imu()}, /*seed=*/1);
//   for (int k = 0; k < 1000; ++k) f.advance();   // the first call samples t = 0 only

#include <memory>
#include <stdexcept>
#include <vector>

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/control/reference.hpp"
#include "dronetwin/sensors/sensor_suite.hpp"
#include "test_support.hpp"

namespace dronetwin::test {

class CircleFlight {
 public:
  CircleFlight(const CircleReference& circle, std::vector<SensorSpec> sensors, std::uint64_t seed)
      : circle_(circle),
        model_(load_model("qdrone2")),
        sim_(model_),
        controller_(load_controller(source_path("config/controllers/se3.yaml"), model_, 1000.0)),
        loop_(sim_, *controller_, circle_, 1000.0),
        suite_(std::move(sensors), 1e-3, model_->num_rotors(), seed) {
    const ReferencePoint r0 = circle_.at(0.0);
    initial_ = Simulator::hover_state(r0.position_m);
    initial_.segment<3>(state_index::kVelocity) = r0.velocity_m_s;
    sim_.reset(initial_, model_->hover_speeds_rad_s());
  }
  CircleFlight(const CircleFlight&) = delete;
  CircleFlight& operator=(const CircleFlight&) = delete;

  /// The first call samples the sensors at t = 0; each later one steps first.
  void advance() {
    const StateVector previous = sim_.state();
    if (started_ && !loop_.step().ok())
      throw std::runtime_error("CircleFlight: the flight failed: " + sim_.failure_message());
    started_ = true;
    suite_.update(sim_.step_count(), make_sensor_truth(sim_, previous));
  }

  const StateVector& initial_state() const { return initial_; }
  const Simulator& sim() const { return sim_; }
  const SensorSuite& sensors() const { return suite_; }

 private:
  const CircleReference circle_;
  std::shared_ptr<const VehicleModel> model_;
  Simulator sim_;
  std::unique_ptr<ControllerBase> controller_;
  ClosedLoop loop_;
  SensorSuite suite_;
  StateVector initial_ = StateVector::Zero();
  bool started_ = false;
};

}  // namespace dronetwin::test
