// Flying on the estimate (experiment `estimation:`): the SE(3) circle of thesis Eq. 3.28 flown on
// the error-state EKF (IMU at 1 kHz + motion capture at 100 Hz, config/experiments/
// se3_circle_ekf.yaml) keeps its tracking RMSE within 1.5x of the same flight on the true state
// (se3_circle_noise_off.yaml), as issue 15 asks; the estimate itself stays within the motion-
// capture noise of the truth; the log carries est_* and every sensor column; the controller
// really reads the estimate (a filter fed a biased mocap flies a shifted circle).

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dronetwin/app/run_experiment.hpp"
#include "dronetwin/config/experiment.hpp"
#include "dronetwin/config/log_metadata_reader.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

Experiment shortened(const std::string& name, double seconds) {
  Experiment e = load_experiment(test::source_path("config/experiments/" + name + ".yaml"));
  e.duration_s = seconds;
  return e;
}

TEST(FlyingOnTheEstimate, Se3CircleRmseWithinOneAndAHalfOfTheTrueStateRun) {
  // Two laps (14 s) in sanitized builds, the full five (35 s) otherwise.
  const double seconds = test::kSanitized ? 14.0 : 35.0;
  test::TempDir dir;
  const RunSummary truth =
      run_experiment(shortened("se3_circle_noise_off", seconds), (dir.path() / "truth").string());
  const RunSummary ekf =
      run_experiment(shortened("se3_circle_ekf", seconds), (dir.path() / "ekf").string());
  ASSERT_TRUE(truth.ok() && ekf.ok()) << ekf.failure_message;
  ASSERT_TRUE(ekf.estimation.has_value());
  EXPECT_TRUE(ekf.estimation->controller_on_estimate);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE(ekf.closed_loop->rmse[i], 1.5 * truth.closed_loop->rmse[i]) << "axis " << i;
    RecordProperty("rmse_ratio_" + std::to_string(i),
                   std::to_string(ekf.closed_loop->rmse[i] / truth.closed_loop->rmse[i]));
  }
  // The mocap gives 0.5 mm and 0.1 deg per fix at 100 Hz; between fixes the IMU carries it.
  EXPECT_LT(ekf.estimation->position_rmse_m, 0.5e-3);
  EXPECT_LT(ekf.estimation->attitude_rmse_rad, 1.75e-3);
  EXPECT_EQ(ekf.estimation->updates, static_cast<std::int64_t>(std::round(seconds * 100.0)));
  const RunLog log = read_run_log(ekf.log_path);
  for (const char* column : {"est_x", "est_qw", "est_wz", "imu_fz", "mocap_qw", "mocap_t"})
    EXPECT_NO_THROW((void)log.table.column(column)) << column;
}

TEST(FlyingOnTheEstimate, TheControllerReadsTheEstimateOnlyWhenAsked) {
  // With controller_input: measured_state the sensors and the filter only watch: the flight is
  // bitwise the flight without them. With a poor motion capture (2 cm) and controller_input:
  // estimate, the filter's errors (millimetres) enter the controller and the flight changes by
  // as much. (It does not track measurably worse: the SE(3) loop filters them.)
  test::TempDir dir;
  const RunSummary plain =
      run_experiment(shortened("se3_circle_noise_off", 7.0), (dir.path() / "plain").string());
  Experiment e = shortened("se3_circle_ekf", 7.0);
  std::get<MotionCaptureParameters>(e.sensors[1].parameters).position_noise_m = 0.02;
  e.estimation->control_on_estimate = false;
  const RunSummary watching = run_experiment(e, (dir.path() / "watching").string());
  e.estimation->control_on_estimate = true;
  const RunSummary flying = run_experiment(e, (dir.path() / "flying").string());
  ASSERT_TRUE(plain.ok() && watching.ok() && flying.ok());
  EXPECT_EQ(watching.final_state, plain.final_state);
  EXPECT_FALSE(watching.estimation->controller_on_estimate);
  const double apart = (flying.final_state.head<3>() - watching.final_state.head<3>()).norm();
  EXPECT_GT(apart, 1e-4);
  EXPECT_LT(apart, 0.05);
  EXPECT_GT(flying.estimation->position_rmse_m, 1e-4);
}

}  // namespace
}  // namespace dronetwin
