// run_fleet_experiment (app/run_fleet.hpp) on the shipped crossing: each vehicle gets the folder
// a single run would write, with the downwash columns; without the wake each vehicle's log is
// exactly its experiment run alone; with it, only the lower one is disturbed, for as long as it
// is under the upper one, and it dips; bad fleets write nothing.

#include "dronetwin/app/run_fleet.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "dronetwin/logging/csv_log.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

const std::string kDir = test::source_path("config/experiments");

double column_min(const LogTable& t, const std::string& name) {
  double m = INFINITY;
  const std::size_t c = t.column(name);
  for (std::size_t r = 0; r < t.rows(); ++r) m = std::min(m, t.at(r, c));
  return m;
}

TEST(RunFleet, WithoutTheWakeEachVehicleIsItsRunAlone) {
  test::TempDir dir;
  FleetExperiment f = load_fleet_experiment(kDir + "/crossing_no_downwash.yaml");
  f.duration_s = 6.0;
  for (FleetVehicleSpec& v : f.vehicles) v.experiment.duration_s = 6.0;
  const FleetRunSummary s = run_fleet_experiment(f, (dir.path() / "fleet").string());
  ASSERT_TRUE(s.ok()) << s.failure_message;
  ASSERT_EQ(s.vehicles.size(), 2u);
  EXPECT_TRUE(fs::exists(dir.path() / "fleet" / "fleet_summary.json"));
  for (const FleetVehicleSummary& v : s.vehicles) {
    for (const char* file : {"log.csv", "log.json", "summary.json"})
      EXPECT_TRUE(fs::exists(dir.path() / "fleet" / v.name / file)) << v.name << " " << file;
    EXPECT_EQ(v.max_downwash_flow_m_s, 0.0);
  }
  Experiment alone = f.vehicles[1].experiment;
  const RunSummary a = run_experiment(alone, (dir.path() / "alone").string());
  const LogTable fleet_log = read_csv_log(s.vehicles[1].run.log_path);
  const LogTable alone_log = read_csv_log(a.log_path);
  ASSERT_EQ(fleet_log.rows(), alone_log.rows());
  for (const char* c : {"x", "z", "qx", "wy", "omega_0"})
    for (std::size_t r = 0; r < alone_log.rows(); ++r)
      ASSERT_EQ(fleet_log.at(r, fleet_log.column(c)), alone_log.at(r, alone_log.column(c)))
          << c << " row " << r;
}

TEST(RunFleet, TheWakeDisturbsTheLowerOneWhileItIsBelow) {
  test::TempDir dir;
  const FleetRunSummary on = run_fleet_experiment(
      load_fleet_experiment(kDir + "/crossing_downwash.yaml"), (dir.path() / "on").string());
  const FleetRunSummary off = run_fleet_experiment(
      load_fleet_experiment(kDir + "/crossing_no_downwash.yaml"), (dir.path() / "off").string());
  ASSERT_TRUE(on.ok()) << on.failure_message;
  ASSERT_TRUE(off.ok()) << off.failure_message;
  EXPECT_EQ(on.vehicles[0].max_thrust_loss_N, 0.0);  // nothing above the upper one
  EXPECT_GT(on.vehicles[1].max_thrust_loss_N, 1.0);
  EXPECT_GT(on.vehicles[1].max_downwash_flow_m_s, 2.0);
  const LogTable lower = read_csv_log(on.vehicles[1].run.log_path);
  const LogTable lower_off = read_csv_log(off.vehicles[1].run.log_path);
  // The force acts only while the lower one is under the upper one (both cross at t = 5 s).
  const std::size_t t = lower.column("t"), fz = lower.column("downwash_force_z");
  for (std::size_t r = 0; r < lower.rows(); ++r) {
    if (std::abs(lower.at(r, t) - 5.0) > 1.0) {
      ASSERT_GT(lower.at(r, fz), -1e-3) << "t = " << lower.at(r, t);
    }
  }
  EXPECT_LT(column_min(lower, "downwash_force_z"), -1.0);
  EXPECT_LT(column_min(lower, "z"), column_min(lower_off, "z") - 0.01);
  // The upper vehicle flies exactly as without the wake.
  EXPECT_EQ(on.vehicles[0].run.final_state, off.vehicles[0].run.final_state);
}

TEST(RunFleet, BadFleetsWriteNothing) {
  test::TempDir dir;
  FleetExperiment f = load_fleet_experiment(kDir + "/crossing_downwash.yaml");
  // Both start at the same place: refused before anything is in place.
  f.vehicles[1].experiment = f.vehicles[0].experiment;
  const std::string out = (dir.path() / "out").string();
  EXPECT_NE(test::error_of([&] {
              (void)run_fleet_experiment(f, out);
            }).find("'upper' and 'lower' start in contact"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(dir.path() / "out" / "fleet_summary.json"));
  EXPECT_FALSE(fs::exists(dir.path() / "out" / "upper" / "summary.json"));
}

}  // namespace
}  // namespace dronetwin
