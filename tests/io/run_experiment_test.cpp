// Tests of the experiment runner (include/dronetwin/io/run_experiment.hpp), in process: log layout
// and decimation, the wrench breakdown columns, generalized-force input, failed runs and
// summary.json.
#include "dronetwin/io/run_experiment.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "dronetwin/core/error.hpp"
#include "dronetwin/io/csv_log.hpp"
#include "dronetwin/io/model_loader.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

const std::string kSourceDir = DRONETWIN_SOURCE_DIR;
const std::string kModel = kSourceDir + "/models/qdrone2.yaml";

class RunExperiment : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("dronetwin_run_test_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  Experiment experiment(const std::string& body) const {
    return parse_experiment("name: t\nmodel: " + kModel + "\n" + body, (dir_ / "t.yaml").string());
  }
  std::string out() const { return (dir_ / "out").string(); }

  fs::path dir_;
};

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST_F(RunExperiment, DecimatedLogWithWrenchBreakdown) {
  const Experiment e = experiment(R"(
duration_s: 0.1
initial_state: {position_m: [0, 0, 1], rotor_speeds_rad_s: hover}
log: {every_n_steps: 10, wrench_breakdown: true, measured: false}
input: {type: hover}
)");
  const RunSummary s = run_experiment(e, out());
  ASSERT_TRUE(s.ok()) << s.failure_message;
  EXPECT_EQ(s.steps, 100);
  EXPECT_EQ(s.log_rows, 11);
  const LogTable log = read_csv_log(s.log_path);
  EXPECT_EQ(log.columns, log_column_names({4, false, true}));
  ASSERT_EQ(log.rows(), 11u);
  EXPECT_NEAR(log.at(10, log.column("t")), 0.1, 1e-12);
  // Gravity in the body frame at level attitude is exactly [0, 0, -m g].
  EXPECT_EQ(log.at(0, log.column("F_gravity_z")), -1.504 * 9.81);
  EXPECT_EQ(log.at(0, log.column("F_gravity_x")), 0.0);
  // Thrust balances gravity at hover speeds; the ground effect at 1 m adds ~0.06 %.
  EXPECT_NEAR(log.at(0, log.column("F_thrust_z")), 1.504 * 9.81, 1e-9);
  const double ge = log.at(0, log.column("F_ground_effect_z"));
  EXPECT_NEAR(ge / (1.504 * 9.81), 0.0006 / (1.023 * 1.023), 1e-6);
}

TEST_F(RunExperiment, GeneralizedForceIsAllocatedToRotorReferences) {
  const VehicleModel model = load_vehicle_model(kModel);
  const Experiment e = experiment(R"(
duration_s: 0.01
ground: false
initial_state: {position_m: [0, 0, 5]}
input: {type: constant_generalized_force, u: [14.75424, 0, 0, 0], allocation: exact}
)");
  const RunSummary s = run_experiment(e, out());
  ASSERT_TRUE(s.ok());
  const LogTable log = read_csv_log(s.log_path);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(log.at(0, log.column("omega_ref_" + std::to_string(i))),
                model.hover_speeds_rad_s()[i], 1e-9);
  }
  EXPECT_EQ(s.input_type, "constant_generalized_force");
}

TEST_F(RunExperiment, FailedRunReportsStatusAndLogsTheLastGoodState) {
  // 499.9 m/s downwards plus gravity passes the 500 m/s divergence limit within ~11 ms.
  const Experiment e = experiment(R"(
duration_s: 1.0
disturbances: none
ground: false
initial_state: {position_m: [0, 0, 100], velocity_m_s: [0, 0, -499.9]}
log: {every_n_steps: 1000}
input: {type: constant_rotor_speeds, rotor_speeds_rad_s: stopped}
)");
  const RunSummary s = run_experiment(e, out());
  EXPECT_EQ(s.status, StepStatus::kDiverged);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.failure_message.find("diverged"), std::string::npos);
  EXPECT_GT(s.steps, 5);
  EXPECT_LT(s.steps, 20);
  EXPECT_EQ(s.steps_requested, 1000);
  const LogTable log = read_csv_log(s.log_path);
  ASSERT_EQ(log.rows(), 2u);  // t = 0 and the last good state
  EXPECT_NEAR(log.at(1, log.column("t")), 0.001 * static_cast<double>(s.steps), 1e-12);
  EXPECT_EQ(log.at(1, log.column("vz")), s.final_state[state_index::kVelocity + 2]);
  const std::string json = read_all(s.summary_path);
  EXPECT_NE(json.find("\"status\": \"diverged\""), std::string::npos);
  EXPECT_NE(json.find("\"failure_message\": \"state diverged"), std::string::npos) << json;
}

TEST_F(RunExperiment, SummaryJsonHasEveryField) {
  const Experiment e = experiment("duration_s: 0.05\nseed: 9\ninput: {type: hover}\n");
  const RunSummary s = run_experiment(e, out());
  const std::string json = read_all(s.summary_path);
  EXPECT_EQ(json, summary_to_json(s));
  for (const char* key : {"dronetwin_version",
                          "experiment",
                          "experiment_path",
                          "model",
                          "model_path",
                          "seed",
                          "dt_s",
                          "integrator",
                          "input_type",
                          "steps_requested",
                          "steps",
                          "duration_s",
                          "status",
                          "failure_message",
                          "final_state",
                          "t_s",
                          "position_m",
                          "velocity_m_s",
                          "quaternion_wxyz",
                          "angular_velocity_rad_s",
                          "rotor_speeds_rad_s",
                          "min_z_m",
                          "max_z_m",
                          "max_speed_m_s",
                          "max_tilt_rad",
                          "crashed",
                          "touchdowns",
                          "max_touchdown_speed_m_s",
                          "log_rows",
                          "log_path",
                          "wall_clock_s",
                          "real_time_factor"}) {
    std::string quoted = "\"";  // built stepwise: GCC 12 warns (-Wrestrict) on "x" + string
    quoted.append(key).append("\": ");
    EXPECT_NE(json.find(quoted), std::string::npos) << key;
  }
  EXPECT_NE(json.find("\"seed\": 9,"), std::string::npos);
  EXPECT_NE(json.find("\"integrator\": \"rk4\""), std::string::npos);
  EXPECT_NE(json.find("\"dronetwin_version\": \"" + std::string(version()) + "\""),
            std::string::npos);
  EXPECT_FALSE(version().empty());
  EXPECT_EQ(s.model_name, "qdrone2");
  // Starting on the ground (hover references from rest): no crash, in contact at t = 0.
  EXPECT_FALSE(s.crashed);
}

TEST_F(RunExperiment, JsonEscapesStrings) {
  RunSummary s;
  s.experiment_name = "quote\" backslash\\ newline\n tab\t";
  s.final_rotor_speeds_rad_s = RotorVector::Zero(4);
  s.real_time_factor = std::nan("");
  const std::string json = summary_to_json(s);
  EXPECT_NE(json.find(R"("experiment": "quote\" backslash\\ newline\n tab\t")"), std::string::npos)
      << json;
  EXPECT_NE(json.find("\"real_time_factor\": null"), std::string::npos);
}

TEST_F(RunExperiment, BadInputThrowsBeforeWritingAnything) {
  const Experiment e = experiment(
      "duration_s: 0.1\ninput: {type: constant_rotor_speeds, rotor_speeds_rad_s: [1, 2, 3]}\n");
  EXPECT_THROW((void)run_experiment(e, out()), InvalidArgument);
  EXPECT_FALSE(fs::exists(dir_ / "out"));

  std::ofstream(dir_ / "file") << "x";
  const Experiment ok = experiment("duration_s: 0.1\ninput: {type: hover}\n");
  EXPECT_THROW((void)run_experiment(ok, (dir_ / "file").string()), InvalidArgument);
}

}  // namespace
}  // namespace dronetwin
