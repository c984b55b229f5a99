#pragma once
// The aggressive minimum-snap lap the feed-forward tests fly (SE(3) and cascaded PID), and the
// position error of a controller flying it in a closed loop at the physics rate.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/control/trajectory_reference.hpp"
#include "dronetwin/planning/min_snap.hpp"
#include "test_support.hpp"

namespace dronetwin::test {

inline std::shared_ptr<const VehicleModel> qdrone2() {
  static const auto model = load_model("qdrone2");
  return model;
}

// A 6.4 s lap through five waypoints at up to 3.1 m/s, 0.48 rad of tilt and 1.6 rad/s of body
// rate, with the yaw turning 2 rad and back; feasible for the QDrone2's rotors (checked in
// se3_feed_forward_test.cpp), and inside the 0.5 rad tilt cone of config/controllers/se3.yaml.
inline planning::Trajectory aggressive_lap() {
  std::vector<planning::Waypoint> w(5);
  w[0].position_m = Vec3(0, 0, 1);
  w[1].position_m = Vec3(2, 1.5, 1.5);
  w[1].yaw_rad = 1.0;
  w[2].position_m = Vec3(4, 0, 1);
  w[2].yaw_rad = 2.0;
  w[3].position_m = Vec3(2, -1.5, 0.6);
  w[3].yaw_rad = 1.0;
  w[4].position_m = Vec3(0, 0, 1);
  return planning::plan_min_snap(w, {1.6, 1.6, 1.6, 1.6}, {});
}

struct Tracking {
  double rms_m = 0.0, max_m = 0.0;
};

// Position error against the reference at every step of the lap (and 0.5 s after it).
struct ErrorLog final : LoopObserver {
  double sum_sq = 0.0, max_m = 0.0;
  long count = 0;
  void observe(const ClosedLoop& loop) override {
    const Simulator& sim = loop.simulator();
    const Vec3 e = sim.state().segment<3>(state_index::kPosition) -
                   loop.reference().at(sim.time_s()).position_m;
    sum_sq += e.squaredNorm();
    max_m = std::max(max_m, e.norm());
    ++count;
  }
};

// Flies `controller` along `lap` from hover at its start, the controller at every physics step.
inline Tracking fly_lap(const planning::Trajectory& lap, ControllerBase& controller,
                        const SimConfig& cfg) {
  Simulator sim(qdrone2(), cfg);
  const planning::FlatOutput start = lap.at(0.0);
  sim.reset(Simulator::hover_state(start.position_m, start.yaw_rad),
            qdrone2()->hover_speeds_rad_s());
  const TrajectoryReference reference(lap);
  ClosedLoop loop(sim, controller, reference, 1.0 / cfg.dt_s);
  ErrorLog log;
  const StepResult r = loop.run(lap.duration_s() + 0.5, &log);
  EXPECT_TRUE(r.ok());
  return {std::sqrt(log.sum_sq / static_cast<double>(log.count)), log.max_m};
}

}  // namespace dronetwin::test
