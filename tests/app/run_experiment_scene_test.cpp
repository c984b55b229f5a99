// Experiments with a scene (`scene:`): a controller sent through a pillar ends the run with
// status collided naming it (summary, summary.json, the CLI's exit status is tested in cli/);
// a start inside an object is an error naming it; the downward range finder sees a crate under
// the vehicle (its readings drop by the crate's height against the same hover without the scene).

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <iostream>
#include <string>
#include <variant>
#include <vector>

#include "dronetwin/app/run_experiment.hpp"
#include "dronetwin/config/experiment.hpp"
#include "dronetwin/config/log_metadata_reader.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "dronetwin/world/gate.hpp"
#include "test_support.hpp"
#include "world/distance_fields.hpp"

namespace dronetwin {
namespace {

// An SE(3) flight from (0, 0, 1.2) to `target`, 6 s, in the scene of tests/data/scenes.
Experiment flight(const std::string& target, const std::string& extra) {
  const std::string text =
      "name: scene_flight\nmodel: ../../../models/qdrone2.yaml\nduration_s: 6.0\n"
      "noise: false\nscene: pillar_and_crate.yaml\n"
      "initial_state: {on_reference: true}\n"
      "input:\n  type: controller\n  controller: ../../../config/controllers/se3.yaml\n"
      "  reference: {type: waypoints, points: [{time_s: 0, position_m: [0, 0, 1.2]}, "
      "{time_s: 4, position_m: " +
      target + "}]}\n" + extra;
  return parse_experiment(text, test::source_path("tests/data/scenes/flight.yaml"));
}

TEST(ExperimentScene, FlyingIntoThePillarEndsTheRunNamingIt) {
  test::TempDir dir;
  const RunSummary s = run_experiment(flight("[4, 0, 1.2]", ""), dir.path().string());
  EXPECT_EQ(s.status, StepStatus::kCollided);
  EXPECT_EQ(s.collided_with, "obstacle 'pillar' (cylinder)");
  EXPECT_NE(s.failure_message.find("collided with obstacle 'pillar' (cylinder)"), std::string::npos)
      << s.failure_message;
  EXPECT_LT(s.steps, s.steps_requested);
  // The default sphere (rotor hub + 0.1 m) stops short of the pillar's surface at x = 1.8.
  const double radius_m = test::load_model("qdrone2")->collision_shape().radius_m;
  EXPECT_LT(s.final_state[0] + radius_m, 1.8 + 1e-9);
  EXPECT_GT(s.final_state[0] + radius_m, 1.8 - 0.01);
  const std::string summary = read_text_file(s.summary_path, "summary");
  EXPECT_NE(summary.find("\"status\": \"collided\""), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"collided_with\": \"obstacle 'pillar' (cylinder)\""), std::string::npos);
  EXPECT_NE(summary.find("pillar_and_crate.yaml"), std::string::npos);
}

TEST(ExperimentScene, FlyingBesideThePillarIsFine) {
  test::TempDir dir;
  const RunSummary s = run_experiment(flight("[4, 1.0, 1.2]", ""), dir.path().string());
  EXPECT_TRUE(s.ok()) << s.failure_message;
  EXPECT_TRUE(s.collided_with.empty());
}

TEST(ExperimentScene, AStartInsideAnObjectIsAnErrorNamingIt) {
  test::TempDir dir;
  Experiment e = flight("[0, 0, 1.2]", "");
  e.initial_state.position_m = Vec3(0.0, 0.0, 0.3);  // in the crate
  const std::string message = test::error_of([&] { (void)run_experiment(e, dir.path().string()); });
  EXPECT_NE(message.find("initial_state: the vehicle's collision shape (sphere"), std::string::npos)
      << message;
  EXPECT_NE(message.find("starts inside obstacle 'crate' (box)"), std::string::npos) << message;
}

TEST(ExperimentScene, TheRangeFinderSeesTheCrate) {
  // Hovering at 1.2 m over the crate (top at 0.5 m): the downward range reads 0.7 m, against
  // 1.2 m for the same flight in an empty world.
  const std::string sensors =
      "sensors:\n  - {type: range_finder, name: range, rate_hz: 50, dropout_probability: 0}\n";
  test::TempDir dir;
  Experiment with_scene = flight("[0, 0, 1.2]", sensors);
  Experiment without = with_scene;
  without.scene.reset();
  without.scene_path.clear();
  const RunSummary a = run_experiment(with_scene, (dir.path() / "scene").string());
  const RunSummary b = run_experiment(without, (dir.path() / "empty").string());
  ASSERT_TRUE(a.ok() && b.ok()) << a.failure_message << b.failure_message;
  const RunLog la = read_run_log(a.log_path), lb = read_run_log(b.log_path);
  const std::vector<double> ra = la.table.column_values("range_d");
  const std::vector<double> rb = lb.table.column_values("range_d");
  const std::vector<double> z = la.table.column_values("z");
  int samples = 0;
  double bias_scene = 0.0, bias_empty = 0.0;
  for (std::size_t i = 0; i < ra.size(); ++i) {
    if (std::isnan(ra[i])) continue;
    // Noise 0.01 m + 0.5 % of the distance (1.6 cm at 1.2 m): within 6 sigma, and far from the
    // 0.5 m the crate makes.
    EXPECT_NEAR(ra[i], z[i] - 0.5, 0.1) << "row " << i;
    EXPECT_NEAR(rb[i], z[i], 0.1) << "row " << i;
    bias_scene += ra[i] - (z[i] - 0.5);
    bias_empty += rb[i] - z[i];
    ++samples;
  }
  // ~300 independent readings (each held for 20 rows): their mean is within 5 mm (5 sigma).
  EXPECT_NEAR(bias_scene / samples, 0.0, 0.005);
  EXPECT_NEAR(bias_empty / samples, 0.0, 0.005);
  EXPECT_GT(samples, 5000);
}

TEST(ExperimentScene, TheObstacleCourseIsFlownClearOfEveryObject) {
  // config/experiments/obstacle_course_ekf.yaml: on the EKF, through the gate and past the
  // objects. Independently of the run's own test, every logged position keeps the collision
  // sphere clear of every object by the exact distance fields; the range finder reads the
  // crate's top under the path.
  const Experiment e =
      load_experiment(test::source_path("config/experiments/obstacle_course_ekf.yaml"));
  ASSERT_NE(e.scene, nullptr);
  test::TempDir dir;
  const RunSummary s = run_experiment(e, dir.path().string());
  ASSERT_TRUE(s.ok()) << s.failure_message;
  const RunLog log = read_run_log(s.log_path);
  const std::vector<double> x = log.table.column_values("x"), y = log.table.column_values("y"),
                            z = log.table.column_values("z"),
                            range = log.table.column_values("range_d");
  const double radius_m = test::load_model("qdrone2")->collision_shape().radius_m;
  double clearance_m = 1e300;
  int over_crate = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const Vec3 p(x[i], y[i], z[i]);
    for (const Obstacle& o : e.scene->obstacles)
      clearance_m = std::min(clearance_m, test::sdf_obstacle(o, p) - radius_m);
    for (const Gate& g : e.scene->gates)
      clearance_m = std::min(clearance_m, test::sdf_frame(g, p) - radius_m);
    // Well inside the crate's top face (x, y within 0.3 m of its centre), with a fresh reading.
    if (std::abs(x[i] - 10.0) < 0.3 && std::abs(y[i]) < 0.3 && !std::isnan(range[i])) {
      EXPECT_NEAR(range[i], z[i] - 0.5, 0.1) << "row " << i;
      ++over_crate;
    }
  }
  EXPECT_GT(clearance_m, 0.2);
  EXPECT_GT(over_crate, 10);
  RecordProperty("clearance_m", std::to_string(clearance_m));
  // The flight ends at the last waypoint.
  EXPECT_NEAR(s.final_state[0], 12.0, 0.05);
}

TEST(ExperimentScene, TheCircuitLapOnAMinimumSnapPlanPassesEveryGate) {
  // config/experiments/se3_circuit_min_snap.yaml: a minimum-snap plan through the circuit's start
  // and gates, flown by SE(3) with feed-forward. Independently of the run: the logged path passes
  // the eight gates in order, each through its opening (world/gate.hpp's crossing test), and
  // the feed-forward tracks closer than the same controller without it (se3.yaml).
  const Experiment e =
      load_experiment(test::source_path("config/experiments/se3_circuit_min_snap.yaml"));
  ASSERT_NE(e.scene, nullptr);
  test::TempDir dir;
  const RunSummary s = run_experiment(e, (dir.path() / "ff").string());
  ASSERT_TRUE(s.ok()) << s.failure_message;
  const RunLog log = read_run_log(s.log_path);
  const std::vector<double> x = log.table.column_values("x"), y = log.table.column_values("y"),
                            z = log.table.column_values("z");
  std::size_t next_gate = 0;
  for (std::size_t i = 1; i < x.size() && next_gate < e.scene->gates.size(); ++i) {
    const GateCrossing c = cross_gate(e.scene->gates[next_gate], Vec3(x[i - 1], y[i - 1], z[i - 1]),
                                      Vec3(x[i], y[i], z[i]));
    if (c == GateCrossing::kThrough) ++next_gate;
  }
  EXPECT_EQ(next_gate, e.scene->gates.size());

  Experiment plain = e;
  auto& loop = std::get<ControllerLoopInput>(plain.input);
  loop.controller_path = test::source_path("config/controllers/se3.yaml");
  const RunSummary p = run_experiment(plain, (dir.path() / "plain").string());
  ASSERT_TRUE(p.ok()) << p.failure_message;
  ASSERT_TRUE(s.closed_loop && p.closed_loop);
  const Vec4& with_ff = s.closed_loop->rmse;
  const Vec4& without = p.closed_loop->rmse;
  std::cout << "circuit lap RMSE x, y, z: feed-forward " << with_ff.head<3>().transpose()
            << " m, plain " << without.head<3>().transpose() << " m\n";
  EXPECT_LT(with_ff.head<2>().norm(), without.head<2>().norm());
}

// A .npy written by NpyFrameWriter (its header is tested in logging/): the frames after the
// 128-byte header.
std::vector<float> npy_frames(const std::string& path) {
  const std::string bytes = read_text_file(path, "frames");
  std::vector<float> v((bytes.size() - 128) / sizeof(float));
  std::memcpy(v.data(), bytes.data() + 128, v.size() * sizeof(float));
  return v;
}

TEST(ExperimentScene, TheDepthCameraSeesThePillarAndWritesItsFrames) {
  // Hovering at (0, 0, 1.2) facing +x, the centre pixel of an odd-sized image looks along the
  // optical axis at the pillar's surface, 1.8 m ahead; in the empty world it sees nothing
  // (max_range_m). 3 s at 10 Hz: 31 frames, at t = 0, 0.1, ... 3.0 s.
  const std::string camera =
      "sensors:\n  - {type: depth_camera, name: cam, rate_hz: 10, width_px: 33, height_px: 25, "
      "max_range_m: 12}\n";
  Experiment with_scene = flight("[0, 0, 1.2]", camera);
  with_scene.duration_s = 3.0;
  Experiment without = with_scene;
  without.scene.reset();
  test::TempDir dir;
  const RunSummary a = run_experiment(with_scene, (dir.path() / "scene").string());
  const RunSummary b = run_experiment(without, (dir.path() / "empty").string());
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a.depth_frames.size(), 1u);
  const DepthFramesSummary& d = a.depth_frames[0];
  EXPECT_EQ(d.name, "cam");
  EXPECT_EQ(d.frames, 31);
  EXPECT_EQ(d.height_px, 25);
  EXPECT_EQ(d.width_px, 33);
  const std::vector<float> fa = npy_frames(d.path), fb = npy_frames(b.depth_frames[0].path);
  ASSERT_EQ(fa.size(), 31u * 25u * 33u);
  const std::size_t centre = 12 * 33 + 16;
  for (int f = 0; f < 31; ++f) {
    EXPECT_NEAR(fa[static_cast<std::size_t>(f) * 825 + centre], 1.8, 0.01) << "frame " << f;
    EXPECT_EQ(fb[static_cast<std::size_t>(f) * 825 + centre], 12.0f) << "frame " << f;
  }
  // The log says which frame is the latest at each row.
  const RunLog log = read_run_log(a.log_path);
  const std::vector<double> t = log.table.column_values("t"),
                            frame = log.table.column_values("cam_frame"),
                            stamp = log.table.column_values("cam_t");
  for (std::size_t i = 0; i < t.size(); ++i) {
    EXPECT_EQ(frame[i], std::floor(t[i] * 10.0 + 1e-9)) << "row " << i;
    EXPECT_NEAR(stamp[i], frame[i] * 0.1, 1e-12) << "row " << i;
  }
  // Same seed, same frames: the run is repeatable bit for bit.
  const RunSummary again = run_experiment(with_scene, (dir.path() / "again").string());
  EXPECT_EQ(read_text_file(again.depth_frames[0].path, "frames"), read_text_file(d.path, "frames"));
}

}  // namespace
}  // namespace dronetwin
