// Tests of the experiment runner (include/dronetwin/app/run_experiment.hpp), in process: log layout
// and decimation, the wrench breakdown columns, generalized-force input, failed runs,
// summary.json, and closed-loop runs (controller input): their log columns, the tracking RMSE
// against an independent recomputation from the log, reproducibility and the saturation fields.
#include "dronetwin/app/run_experiment.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/control/reference.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/csv_log.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

const std::string kSourceDir = DRONETWIN_SOURCE_DIR;
const std::string kModel = kSourceDir + "/models/qdrone2.yaml";
const std::string kPid = kSourceDir + "/config/controllers/pid.yaml";

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

TEST_F(RunExperiment, EveryNStepsBeyondInt32IsHonoured) {
  // 2^32 + 5 steps between rows: an int32 would wrap it to 5 (11 rows in 50 steps). A run that
  // ends well logs on its schedule only: here the row at t = 0.
  const Experiment e =
      experiment("duration_s: 0.05\nlog: {every_n_steps: 4294967301}\ninput: {type: hover}\n");
  EXPECT_EQ(e.log.every_n_steps, 4294967301LL);
  const RunSummary s = run_experiment(e, out());
  ASSERT_TRUE(s.ok()) << s.failure_message;
  const LogTable log = read_csv_log(s.log_path);
  EXPECT_EQ(s.steps, 50);
  ASSERT_EQ(log.rows(), 1u);
  EXPECT_EQ(log.at(0, log.column("t")), 0.0);
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

// ---- closed loop ------------------------------------------------------------------------------

/// A PID hover run from 1 m toward a nearby setpoint with a yaw step, noise on.
std::string closed_loop_body(const std::string& extra = "", const std::string& input_extra = "") {
  return R"(
duration_s: 1.0
seed: 4
noise: true
initial_state: {position_m: [0, 0, 1], rotor_speeds_rad_s: hover}
)" + extra +
         R"(input:
  type: controller
  controller: )" +
         kPid + "\n" + input_extra + R"(
  reference: {type: setpoint, position_m: [0.1, -0.05, 1.2], yaw_rad: 0.1}
)";
}

/// The summary's number after "key": (the first occurrence), NaN if absent.
double json_number(const std::string& json, const std::string& key) {
  const std::string k = "\"" + key + "\": ";
  const auto pos = json.find(k);
  if (pos == std::string::npos) return std::nan("");
  return std::strtod(json.c_str() + pos + k.size(), nullptr);
}

/// RMSE [x, y, z, yaw] recomputed from a log's true state and ref_* columns over the rows with
/// t0 <= t <= t1: yaw from the quaternion columns (ZYX, atan2 form), its error wrapped with
/// atan2(sin, cos).
Vec4 rmse_from_log(const LogTable& log, double t0, double t1, int* rows_used) {
  const std::size_t t = log.column("t");
  const std::size_t x[3] = {log.column("x"), log.column("y"), log.column("z")};
  const std::size_t r[3] = {log.column("ref_x"), log.column("ref_y"), log.column("ref_z")};
  const std::size_t qw = log.column("qw"), qx = log.column("qx"), qy = log.column("qy"),
                    qz = log.column("qz"), ryaw = log.column("ref_yaw");
  Vec4 sum = Vec4::Zero();
  int n = 0;
  for (std::size_t i = 0; i < log.rows(); ++i) {
    const double ti = log.at(i, t);
    if (ti < t0 - 1e-9 || ti > t1 + 1e-9) continue;
    for (int a = 0; a < 3; ++a) {
      const double e = log.at(i, r[a]) - log.at(i, x[a]);
      sum[a] += e * e;
    }
    const double w = log.at(i, qw), qxv = log.at(i, qx), qyv = log.at(i, qy), qzv = log.at(i, qz);
    const double yaw = std::atan2(2.0 * (w * qzv + qxv * qyv), 1.0 - 2.0 * (qyv * qyv + qzv * qzv));
    const double d = log.at(i, ryaw) - yaw;
    const double e = std::atan2(std::sin(d), std::cos(d));
    sum[3] += e * e;
    ++n;
  }
  *rows_used = n;
  return (sum / n).cwiseSqrt();
}

TEST_F(RunExperiment, ClosedLoopLogHasTheControllerColumns) {
  const RunSummary s = run_experiment(experiment(closed_loop_body()), out());
  ASSERT_TRUE(s.ok()) << s.failure_message;
  EXPECT_EQ(s.input_type, "controller");
  const LogTable log = read_csv_log(s.log_path);
  // The open-loop columns first, unchanged, then the closed-loop group at the end.
  const std::vector<std::string> open_loop = log_column_names({4, true, false});
  ASSERT_EQ(log.columns.size(), open_loop.size() + 9);
  for (std::size_t i = 0; i < open_loop.size(); ++i) EXPECT_EQ(log.columns[i], open_loop[i]);
  const std::vector<std::string> added(log.columns.end() - 9, log.columns.end());
  EXPECT_EQ(added, (std::vector<std::string>{"ref_x", "ref_y", "ref_z", "ref_yaw", "u_T", "u_tau_x",
                                             "u_tau_y", "u_tau_z", "saturated"}));
  EXPECT_EQ(log.columns, log_column_names({4, true, false, true}));
  ASSERT_EQ(log.rows(), 1001u);
  for (std::size_t i = 0; i < log.rows(); i += 100) {
    EXPECT_EQ(log.at(i, log.column("ref_x")), 0.1);
    EXPECT_EQ(log.at(i, log.column("ref_y")), -0.05);
    EXPECT_EQ(log.at(i, log.column("ref_z")), 1.2);
    EXPECT_EQ(log.at(i, log.column("ref_yaw")), 0.1);
    const double sat = log.at(i, log.column("saturated"));
    EXPECT_TRUE(sat == 0.0 || sat == 1.0);
  }
  // The z error of 0.2 m asks for more thrust than hover at t = 0 (u_T > m g).
  EXPECT_GT(log.at(0, log.column("u_T")), 1.504 * 9.81);
  // The vehicle moves toward the setpoint.
  EXPECT_GT(log.at(1000, log.column("z")), 1.05);
}

TEST_F(RunExperiment, ClosedLoopRmseMatchesARecomputationFromTheLog) {
  const RunSummary s = run_experiment(experiment(closed_loop_body()), out());
  ASSERT_TRUE(s.ok()) << s.failure_message;
  ASSERT_TRUE(s.closed_loop.has_value());
  const ClosedLoopSummary& c = *s.closed_loop;
  const LogTable log = read_csv_log(s.log_path);
  int rows = 0;
  const Vec4 expected = rmse_from_log(log, 0.0, 1.0, &rows);
  EXPECT_EQ(rows, 1001);  // every physics step, t = 0 included
  EXPECT_EQ(c.rmse_samples, 1001);
  for (int a = 0; a < 4; ++a) {
    EXPECT_GT(expected[a], 0.0);
    EXPECT_NEAR(c.rmse[a], expected[a], 1e-12 * expected[a]) << a;
  }
  EXPECT_EQ(c.rmse_window_s[0], 0.0);
  EXPECT_EQ(c.rmse_window_s[1], s.duration_s);
  // The same numbers in summary.json.
  const std::string json = read_all(s.summary_path);
  EXPECT_EQ(json_number(json, "x"), c.rmse[0]);
  EXPECT_EQ(json_number(json, "yaw"), c.rmse[3]);
  EXPECT_NE(json.find("\"rmse_window_s\": [0, 1]"), std::string::npos) << json;

  // A metrics window: only the rows inside it.
  const RunSummary w = run_experiment(
      experiment(closed_loop_body("metrics: {window_s: [0.2, 0.6]}\n")), (dir_ / "w").string());
  int window_rows = 0;
  const Vec4 in_window = rmse_from_log(read_csv_log(w.log_path), 0.2, 0.6, &window_rows);
  EXPECT_EQ(window_rows, 401);
  EXPECT_EQ(w.closed_loop->rmse_samples, 401);
  for (int a = 0; a < 4; ++a)
    EXPECT_NEAR(w.closed_loop->rmse[a], in_window[a], 1e-12 * in_window[a]) << a;
  EXPECT_EQ(w.closed_loop->rmse_window_s[0], 0.2);
  EXPECT_EQ(w.closed_loop->rmse_window_s[1], 0.6);

  // A window reaching past the end is clipped to the time reached.
  const RunSummary clipped = run_experiment(
      experiment(closed_loop_body("metrics: {window_s: [0.5, 99]}\n")), (dir_ / "c").string());
  EXPECT_EQ(clipped.closed_loop->rmse_window_s[1], 1.0);
  EXPECT_EQ(clipped.closed_loop->rmse_samples, 501);
}

TEST_F(RunExperiment, ClosedLoopRunsAreReproducible) {
  const RunSummary a = run_experiment(experiment(closed_loop_body()), (dir_ / "a").string());
  const RunSummary b = run_experiment(experiment(closed_loop_body()), (dir_ / "b").string());
  const std::string la = read_all(a.log_path), lb = read_all(b.log_path);
  EXPECT_FALSE(la.empty());
  EXPECT_TRUE(la == lb) << "same seed, different closed-loop logs";
  EXPECT_EQ(a.closed_loop->rmse, b.closed_loop->rmse);
  // Another seed: other measurement noise, which the controller feeds back into the flight.
  Experiment other = experiment(closed_loop_body());
  other.sim.seed = 5;
  const RunSummary c = run_experiment(other, (dir_ / "c").string());
  const LogTable ta = read_csv_log(a.log_path), tc = read_csv_log(c.log_path);
  EXPECT_NE(ta.column_values("x"), tc.column_values("x"));
}

TEST_F(RunExperiment, ClosedLoopSummaryFields) {
  const RunSummary s = run_experiment(
      experiment(closed_loop_body("", "  control_rate_hz: 250\n  allocation: thesis\n")), out());
  ASSERT_TRUE(s.ok()) << s.failure_message;
  const ClosedLoopSummary& c = *s.closed_loop;
  EXPECT_EQ(c.controller_name, "cascaded_pid");
  EXPECT_EQ(fs::path(c.controller_path), fs::path(kPid).lexically_normal());
  EXPECT_EQ(c.allocation, "thesis");  // the experiment's override of the file's 'exact'
  EXPECT_EQ(c.reference_type, "setpoint");
  EXPECT_EQ(c.reference, SetpointReference(Vec3(0.1, -0.05, 1.2), 0.1).describe());
  EXPECT_EQ(c.control_rate_hz, 250.0);
  EXPECT_FALSE(c.real_time);
  // Control instants k = 0, 4, ..., 1000 (the last one sets the command of the final row).
  EXPECT_EQ(c.control_updates, 251);
  EXPECT_GE(c.saturated_updates, 0);
  EXPECT_LE(c.saturated_updates, c.control_updates);
  EXPECT_EQ(c.saturated_fraction,
            static_cast<double>(c.saturated_updates) / static_cast<double>(c.control_updates));

  const std::string json = read_all(s.summary_path);
  EXPECT_EQ(json, summary_to_json(s));
  for (const char* key : {"controller", "name", "path", "allocation", "reference_type", "reference",
                          "control_rate_hz", "real_time", "rmse", "x", "y", "z", "yaw",
                          "rmse_window_s", "rmse_samples", "control_updates", "saturated_updates",
                          "saturated_fraction", "real_time_factor"}) {
    std::string quoted = "\"";
    quoted.append(key).append("\": ");
    EXPECT_NE(json.find(quoted), std::string::npos) << key;
  }
  EXPECT_NE(json.find("\"name\": \"cascaded_pid\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"real_time\": false"), std::string::npos);
  EXPECT_EQ(json_number(json, "control_updates"), 251.0);
  EXPECT_EQ(json_number(json, "saturated_updates"), static_cast<double>(c.saturated_updates));

  // The saturation counters count: a setpoint 5 m up saturates the allocation at first.
  const RunSummary far = run_experiment(experiment(R"(
duration_s: 0.2
initial_state: {position_m: [0, 0, 1], rotor_speeds_rad_s: hover}
input:
  type: controller
  controller: )" + kPid + R"(
  reference: {type: setpoint, position_m: [0, 0, 6]}
)"),
                                        (dir_ / "far").string());
  ASSERT_TRUE(far.ok()) << far.failure_message;
  EXPECT_GT(far.closed_loop->saturated_updates, 0);
  const LogTable log = read_csv_log(far.log_path);
  EXPECT_EQ(log.at(0, log.column("saturated")), 1.0);

  // Open-loop summaries have none of these fields.
  const RunSummary open = run_experiment(experiment("duration_s: 0.01\ninput: {type: hover}\n"),
                                         (dir_ / "open").string());
  EXPECT_FALSE(open.closed_loop.has_value());
  EXPECT_EQ(read_all(open.summary_path).find("rmse"), std::string::npos);
}

TEST_F(RunExperiment, ClosedLoopStartsOnTheReference) {
  const RunSummary s = run_experiment(experiment(R"(
duration_s: 0.3
initial_state: {on_reference: true}
input:
  type: controller
  controller: )" + kSourceDir + R"(/config/controllers/se3.yaml
  reference: {type: circle}
)"),
                                      out());
  ASSERT_TRUE(s.ok()) << s.failure_message;
  const LogTable log = read_csv_log(s.log_path);
  EXPECT_EQ(log.at(0, log.column("x")), 2.0);
  EXPECT_EQ(log.at(0, log.column("z")), 1.0);
  EXPECT_EQ(log.at(0, log.column("x")), log.at(0, log.column("ref_x")));
  EXPECT_NEAR(log.at(0, log.column("vy")), 4.0 * std::numbers::pi / 7.0, 1e-12);
  EXPECT_NEAR(log.at(0, log.column("omega_0")), 1173.9151, 1e-3);  // hover speed
  EXPECT_LT(s.closed_loop->rmse.head<3>().maxCoeff(), 0.05);
}

TEST_F(RunExperiment, RealTimeClosedLoopIsPaced) {
  const RunSummary s = run_experiment(experiment(R"(
duration_s: 0.2
initial_state: {position_m: [0, 0, 1], rotor_speeds_rad_s: hover}
log: {measured: false}
input:
  type: controller
  controller: )" + kPid + R"(
  real_time: true
  reference: {type: setpoint, position_m: [0, 0, 1]}
)"),
                                      out());
  ASSERT_TRUE(s.ok());
  EXPECT_TRUE(s.closed_loop->real_time);
  EXPECT_GE(s.wall_clock_s, 0.2 - 1e-3);
  EXPECT_LE(s.real_time_factor, 1.0 + 1e-2);
  EXPECT_NE(read_all(s.summary_path).find("\"real_time\": true"), std::string::npos);
}

}  // namespace
}  // namespace dronetwin
