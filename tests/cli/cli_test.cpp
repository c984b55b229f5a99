// End-to-end tests of the `dronetwin` command-line tool (src/cli/main.cpp): runs the built binary
// through std::system on the shipped experiments and checks exit codes, the log against analytic
// free fall, byte-for-byte reproducibility, seeds, bad input, the take-off/landing demo, and the
// closed-loop experiments (PID pulse, SE(3) circle, --real-time).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dronetwin/logging/csv_log.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

const std::string kCli = DRONETWIN_CLI_PATH;
const std::string kSourceDir = DRONETWIN_SOURCE_DIR;
const std::string kExperiments = kSourceDir + "/config/experiments/";

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

struct CliResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

/// Runs the CLI with a scratch directory per test; removed at the end.
class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (kCli.empty()) GTEST_SKIP() << "the dronetwin CLI was not built (CLI11 not found)";
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("dronetwin_cli_test_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }

  CliResult run(const std::string& args) {
    const fs::path out = dir_ / "stdout.txt", err = dir_ / "stderr.txt";
    const std::string command =
        "\"" + kCli + "\" " + args + " > \"" + out.string() + "\" 2> \"" + err.string() + "\"";
    const int status = std::system(command.c_str());
    CliResult r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = read_all(out);
    r.err = read_all(err);
    return r;
  }
  /// `dronetwin run <experiment> --out <dir_/name> <extra>`.
  CliResult run_experiment(const std::string& experiment, const std::string& name,
                           const std::string& extra = "") {
    return run("run \"" + experiment + "\" --out \"" + (dir_ / name).string() + "\" " + extra);
  }
  fs::path out(const std::string& name) const { return dir_ / name; }

  fs::path dir_;
};

/// The number after "key": in a JSON text (the summary's flat fields), NaN if absent.
double json_number(const std::string& json, const std::string& key) {
  const std::string k = "\"" + key + "\": ";
  const auto pos = json.find(k);
  if (pos == std::string::npos) return std::nan("");
  return std::strtod(json.c_str() + pos + k.size(), nullptr);
}

TEST_F(Cli, FreefallMatchesTheAnalyticSolution) {
  const CliResult r = run_experiment(kExperiments + "freefall.yaml", "ff");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("freefall: ok"), std::string::npos) << r.out;

  const std::string log_text = read_all(out("ff") / "log.csv");
  const std::string prefix =
      "t,x,y,z,vx,vy,vz,qw,qx,qy,qz,wx,wy,wz,omega_0,omega_1,omega_2,omega_3";
  EXPECT_EQ(log_text.substr(0, prefix.size()), prefix);

  // With every disturbance term off and the rotors stopped, the only forces are gravity and the
  // thrust polynomial at w = 0: T(0) = 'K3 = -0.0121 N per rotor along body z (models/qdrone2.yaml,
  // thesis Eq. 2.22). The four yaw reactions +-eps_i T / K_tau cancel (spins +1, -1, -1, +1) and so
  // do the moments r_i x T_i (symmetric layout), so the attitude stays level and body z = world z:
  //   a_z = -g + 4 'K3 / m = -9.81 - 4 * 0.0121 / 1.504 m/s^2,   z(t) = 10 + a_z t^2 / 2.
  // RK4 integrates a constant acceleration exactly, so only rounding separates log and formula.
  const double a_z = -9.81 - 4.0 * 0.0121 / 1.504;
  const LogTable log = read_csv_log((out("ff") / "log.csv").string());
  ASSERT_EQ(log.rows(), 1001u);
  const std::size_t t = log.column("t"), z = log.column("z"), vz = log.column("vz");
  for (std::size_t i = 0; i < log.rows(); ++i) {
    const double ti = log.at(i, t);
    ASSERT_NEAR(ti, 0.001 * static_cast<double>(i), 1e-12);
    ASSERT_NEAR(log.at(i, z), 10.0 + 0.5 * a_z * ti * ti, 1e-9) << "t = " << ti;
    ASSERT_NEAR(log.at(i, vz), a_z * ti, 1e-9) << "t = " << ti;
    ASSERT_EQ(log.at(i, log.column("qw")), 1.0);
    ASSERT_EQ(log.at(i, log.column("omega_2")), 0.0);
    ASSERT_EQ(log.at(i, log.column("in_contact")), 0.0);
  }

  const std::string summary = read_all(out("ff") / "summary.json");
  EXPECT_NE(summary.find("\"status\": \"ok\""), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"experiment\": \"freefall\""), std::string::npos);
  EXPECT_NE(summary.find("\"model\": \"qdrone2\""), std::string::npos);
  EXPECT_EQ(json_number(summary, "steps"), 1000.0);
  EXPECT_NEAR(json_number(summary, "min_z_m"), 10.0 + 0.5 * a_z, 1e-9);
  EXPECT_NEAR(json_number(summary, "max_speed_m_s"), -a_z, 1e-9);
}

TEST_F(Cli, SameRunTwiceIsByteIdentical) {
  ASSERT_EQ(run_experiment(kExperiments + "freefall.yaml", "a").exit_code, 0);
  ASSERT_EQ(run_experiment(kExperiments + "freefall.yaml", "b").exit_code, 0);
  const std::string a = read_all(out("a") / "log.csv"), b = read_all(out("b") / "log.csv");
  EXPECT_FALSE(a.empty());
  EXPECT_TRUE(a == b) << "freefall logs differ between two runs";
}

TEST_F(Cli, SeedChangesOnlyTheNoisyMeasurement) {
  const std::string hover = kExperiments + "hover_open_loop.yaml";
  ASSERT_EQ(run_experiment(hover, "s1", "--duration 0.2 --seed 1 --quiet").exit_code, 0);
  ASSERT_EQ(run_experiment(hover, "s1_again", "--duration 0.2 --seed 1 --quiet").exit_code, 0);
  ASSERT_EQ(run_experiment(hover, "s2", "--duration 0.2 --seed 2 --quiet").exit_code, 0);
  const std::string s1 = read_all(out("s1") / "log.csv");
  EXPECT_TRUE(s1 == read_all(out("s1_again") / "log.csv")) << "same seed, different logs";
  EXPECT_FALSE(s1 == read_all(out("s2") / "log.csv")) << "different seeds, identical logs";

  // The noise is measurement noise: the true state is the same, the measured state is not.
  const LogTable a = read_csv_log((out("s1") / "log.csv").string());
  const LogTable b = read_csv_log((out("s2") / "log.csv").string());
  ASSERT_EQ(a.rows(), 201u);
  ASSERT_EQ(b.rows(), 201u);
  EXPECT_EQ(a.column_values("z"), b.column_values("z"));
  EXPECT_NE(a.column_values("meas_z"), b.column_values("meas_z"));
  EXPECT_NE(read_all(out("s2") / "summary.json").find("\"seed\": 2,"), std::string::npos);
}

TEST_F(Cli, BadExperimentExitsTwoNamingTheField) {
  const std::string bad = kSourceDir + "/tests/data/bad_experiments/";
  CliResult r = run_experiment(bad + "segment_wrong_rotor_count.yaml", "bad");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err.rfind("error: ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("input.segments[1].rotor_speeds_rad_s: expected 4 numbers"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(out("bad") / "log.csv"));

  r = run_experiment(bad + "nan_wind.yaml", "bad");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("wind_m_s[1]"), std::string::npos) << r.err;

  r = run_experiment(kSourceDir + "/no/such/experiment.yaml", "bad");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("cannot open experiment file"), std::string::npos) << r.err;

  r = run_experiment(kExperiments + "freefall.yaml", "bad", "--duration -1");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--duration"), std::string::npos) << r.err;

  r = run_experiment(kExperiments + "freefall.yaml", "bad", "--seed -1");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--seed"), std::string::npos) << r.err;
}

TEST_F(Cli, StepOpenLoopTakesOffAndLandsWithoutCrashing) {
  const CliResult r = run_experiment(kExperiments + "step_open_loop.yaml", "step");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string summary = read_all(out("step") / "summary.json");
  EXPECT_NE(summary.find("\"status\": \"ok\""), std::string::npos);
  EXPECT_NE(summary.find("\"crashed\": false"), std::string::npos) << summary;
  EXPECT_GT(json_number(summary, "max_z_m"), 0.5);
  EXPECT_EQ(json_number(summary, "touchdowns"), 1.0);
  const double touchdown = json_number(summary, "max_touchdown_speed_m_s");
  EXPECT_GT(touchdown, 0.1);
  EXPECT_LT(touchdown, 1.5);  // the default crash speed

  const LogTable log = read_csv_log((out("step") / "log.csv").string());
  ASSERT_EQ(log.rows(), 6001u);
  const std::size_t z = log.column("z"), contact = log.column("in_contact");
  EXPECT_EQ(log.at(0, z), 0.0);
  EXPECT_EQ(log.at(499, z), 0.0);  // still on the ground with the rotors stopped
  EXPECT_EQ(log.at(log.rows() - 1, z), 0.0);
  EXPECT_EQ(log.at(log.rows() - 1, contact), 1.0);
  EXPECT_EQ(log.at(log.rows() - 1, log.column("crashed")), 0.0);
  // The references follow the schedule: 1.05 w_h from 0.5 s, 0.97 w_h from 1.0 s, 0 from 5.26 s.
  const std::size_t ref = log.column("omega_ref_0");
  // Row k (t = k dt) holds the reference in effect from t on; the rotors lag behind it.
  EXPECT_EQ(log.at(499, ref), 0.0);
  EXPECT_EQ(log.at(500, ref), 1232.611);
  EXPECT_EQ(log.at(500, log.column("omega_0")), 0.0);
  EXPECT_GT(log.at(501, log.column("omega_0")), 1000.0);  // tau = 0.5 ms: 1 - e^-2 of the way
  EXPECT_EQ(log.at(999, ref), 1232.611);
  EXPECT_EQ(log.at(1000, ref), 1138.698);
  EXPECT_EQ(log.at(5259, ref), 1138.698);
  EXPECT_EQ(log.at(5260, ref), 0.0);
}

TEST_F(Cli, DivergedRunExitsThreeAndStillWritesItsFiles) {
  // Free fall with no ground reaches the 500 m/s divergence limit at about 50.8 s.
  const CliResult r = run_experiment(kExperiments + "freefall.yaml", "div", "--duration 60");
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("diverged"), std::string::npos) << r.err;
  const std::string summary = read_all(out("div") / "summary.json");
  EXPECT_NE(summary.find("\"status\": \"diverged\""), std::string::npos) << summary;
  const double steps = json_number(summary, "steps");
  EXPECT_GT(steps, 50000.0);
  EXPECT_LT(steps, 60000.0);
  const LogTable log = read_csv_log((out("div") / "log.csv").string());
  EXPECT_EQ(static_cast<double>(log.rows()), steps + 1.0);
}

TEST_F(Cli, ProgressBarOnlyWhereAsked) {
  // stderr is a file here, as in a CI log: no bar by default.
  CliResult r = run_experiment(kExperiments + "freefall.yaml", "auto", "--duration 0.5");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find('%'), std::string::npos) << r.err;
  // Forced: a line per second of wall clock and the last one at 100 %, 0.5 of 0.5 s simulated.
  r = run_experiment(kExperiments + "freefall.yaml", "forced", "--duration 0.5 --progress");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("freefall ["), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("100%  0.5/0.5 s"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("freefall: ok"), std::string::npos) << "the summary still goes to stdout";
  // --quiet wins; --progress with --no-progress is a usage error naming both.
  r = run_experiment(kExperiments + "freefall.yaml", "quiet", "--duration 0.5 --progress -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  r = run_experiment(kExperiments + "freefall.yaml", "both", "--progress --no-progress");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--no-progress"), std::string::npos) << r.err;
}

TEST_F(Cli, OverridesAndUsage) {
  CliResult r = run_experiment(kExperiments + "freefall.yaml", "o", "--duration 0.1 --seed 5 -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  const std::string summary = read_all(out("o") / "summary.json");
  EXPECT_EQ(json_number(summary, "steps"), 100.0);
  EXPECT_EQ(json_number(summary, "seed"), 5.0);

  r = run("--version");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_FALSE(r.out.empty());
  EXPECT_NE(r.out.find('.'), std::string::npos) << r.out;  // "major.minor.patch"
  EXPECT_NE(summary.find("\"dronetwin_version\": \"" + r.out.substr(0, r.out.find('\n')) + "\""),
            std::string::npos);

  EXPECT_EQ(run("--help").exit_code, 0);
  EXPECT_EQ(run("").exit_code, 2);
  r = run("frobnicate");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("frobnicate"), std::string::npos);
  EXPECT_EQ(run("run \"" + kExperiments + "freefall.yaml\" --out x --bogus").exit_code, 2);
  EXPECT_EQ(run("run \"" + kExperiments + "freefall.yaml\"").exit_code, 2);  // --out missing

  r = run("info \"" + kSourceDir + "/models/qdrone2.yaml\"");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("1.504 kg"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("pseudo-inverse"), std::string::npos);
  EXPECT_NE(r.out.find("1173.915"), std::string::npos);   // hover speed, rad/s
  r = run("info \"" + kExperiments + "freefall.yaml\"");  // not a model
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown key"), std::string::npos) << r.err;
}

// ---- outputs are never lost (issue "Reliability") ----------------------------------------------

TEST_F(Cli, AnEarlierRunIsKeptUnlessForced) {
  const std::string freefall = kExperiments + "freefall.yaml";
  ASSERT_EQ(run_experiment(freefall, "r", "--duration 0.2 -q").exit_code, 0);
  const std::string first = read_all(out("r") / "log.csv");
  CliResult r = run_experiment(freefall, "r", "--duration 0.1 -q");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("exists (an earlier run?)"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--force"), std::string::npos) << r.err;
  EXPECT_EQ(read_all(out("r") / "log.csv"), first);  // untouched
  r = run_experiment(freefall, "r", "--duration 0.1 -q --force");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(read_all(out("r") / "log.csv"), first);
  EXPECT_EQ(json_number(read_all(out("r") / "summary.json"), "steps"), 100.0);
  for (const auto& entry : fs::directory_iterator(out("r")))  // no temporary file left behind
    EXPECT_EQ(entry.path().filename().string().find(".partial"), std::string::npos) << entry.path();
}

TEST_F(Cli, TwoRunsIntoOneFolderNeverTearTheLog) {
  // Both start at once. Whichever comes second finds the folder locked (or, if the first is
  // already done, a finished run): exactly one writes, and what it wrote is a whole run.
  const std::string pid = kExperiments + "pid_pulse_noise_off.yaml";
  ASSERT_EQ(run_experiment(pid, "reference", "-q").exit_code, 0);
  const std::string target = (dir_ / "same").string();
  std::string script;
  for (int i = 0; i < 2; ++i) {
    const std::string n = std::to_string(i);
    script += "(\"" + kCli + "\" run \"" + pid + "\" --out \"" + target + "\" -q > \"" +
              (dir_ / ("out" + n)).string() + "\" 2> \"" + (dir_ / ("err" + n)).string() +
              "\"; echo $? > \"" + (dir_ / ("code" + n)).string() + "\") & ";
  }
  script += "wait";
  ASSERT_EQ(std::system(script.c_str()), 0);
  int succeeded = 0;
  for (int i = 0; i < 2; ++i) {
    const std::string n = std::to_string(i);
    const int code = std::stoi(read_all(dir_ / ("code" + n)));
    const std::string err = read_all(dir_ / ("err" + n));
    if (code == 0) {
      ++succeeded;
    } else {
      EXPECT_EQ(code, 2) << err;
      EXPECT_TRUE(err.find("another dronetwin command is writing into this folder") !=
                      std::string::npos ||
                  err.find("exists (an earlier run?)") != std::string::npos)
          << err;
    }
  }
  EXPECT_EQ(succeeded, 1);
  EXPECT_EQ(read_all(fs::path(target) / "log.csv"), read_all(out("reference") / "log.csv"));
  EXPECT_EQ(read_all(fs::path(target) / "log.json"), read_all(out("reference") / "log.json"));
}

TEST_F(Cli, AModelThatCannotHoverIsSaidSoNotPrintedAsReachable) {
  // The QDrone2 at 10 times its mass: m g / 4 = 36.9 N per rotor, far above what a rotor gives
  // at its maximum speed.
  std::string model = read_all(kSourceDir + "/models/qdrone2.yaml");
  const auto pos = model.find("mass_kg: 1.504");
  ASSERT_NE(pos, std::string::npos);
  model.replace(pos, 14, "mass_kg: 15.04");
  std::ofstream(dir_ / "heavy.yaml") << model;
  CliResult r = run("info \"" + (dir_ / "heavy.yaml").string() + "\"");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("hover (g = 9.81 m/s^2): NOT POSSIBLE"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("more than this rotor gives at its maximum speed"), std::string::npos);
  EXPECT_EQ(r.out.find("rpm"), std::string::npos) << "a clamped hover speed printed: " << r.out;
  EXPECT_NE(r.err.find("warning: "), std::string::npos) << r.err;

  // An experiment that asks for its hover speeds runs, but says they do not hold it.
  std::string experiment = read_all(kExperiments + "hover_open_loop.yaml");
  const auto m = experiment.find("model: ../../models/qdrone2.yaml");
  ASSERT_NE(m, std::string::npos);
  experiment.replace(m, 32, "model: heavy.yaml");
  std::ofstream(dir_ / "heavy_hover.yaml") << experiment;
  r = run_experiment((dir_ / "heavy_hover.yaml").string(), "h", "--duration 0.1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string summary = read_all(out("h") / "summary.json");
  EXPECT_NE(summary.find("cannot hover at g = 9.81"), std::string::npos) << summary;
  EXPECT_NE(r.err.find("warning: qdrone2 cannot hover"), std::string::npos) << r.err;
}

// ---- closed loop ------------------------------------------------------------------------------

/// The number after "key": inside the summary's "rmse" object.
double rmse_of(const std::string& summary, const std::string& axis) {
  const auto pos = summary.find("\"rmse\": {");
  if (pos == std::string::npos) return std::nan("");
  return json_number(summary.substr(pos), axis);
}

// The 'Done when' of the control-library issue: both closed-loop experiments run to the end.
TEST_F(Cli, PidPulseNoiseOffFliesThePulse) {
  const CliResult r = run_experiment(kExperiments + "pid_pulse_noise_off.yaml", "pid");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("pid_pulse_noise_off: ok"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("  rmse            x "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("cascaded_pid"), std::string::npos) << r.out;
  const std::string summary = read_all(out("pid") / "summary.json");
  EXPECT_NE(summary.find("\"status\": \"ok\""), std::string::npos);
  EXPECT_NE(summary.find("\"crashed\": false"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"input_type\": \"controller\""), std::string::npos);
  EXPECT_EQ(json_number(summary, "steps"), 60000.0);
  EXPECT_EQ(json_number(summary, "rmse_samples"), 60001.0);
  // The pulse is flown: every axis tracked to within the size of its steps (0.75 m, 1.5 m).
  EXPECT_LT(rmse_of(summary, "x"), 0.5);
  EXPECT_LT(rmse_of(summary, "y"), 0.01);
  EXPECT_LT(rmse_of(summary, "z"), 0.2);
  EXPECT_LT(rmse_of(summary, "yaw"), 0.01);
  const LogTable log = read_csv_log((out("pid") / "log.csv").string());
  const std::size_t last = log.rows() - 1;
  EXPECT_NEAR(log.at(last, log.column("z")), 0.75, 0.02);
  EXPECT_NEAR(log.at(last, log.column("x")), 0.0, 0.02);
}

TEST_F(Cli, Se3CircleNoiseOffFliesTheCircle) {
  const CliResult r = run_experiment(kExperiments + "se3_circle_noise_off.yaml", "se3");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("se3_circle_noise_off: ok"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("  rmse            x "), std::string::npos) << r.out;
  const std::string summary = read_all(out("se3") / "summary.json");
  EXPECT_NE(summary.find("\"crashed\": false"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"reference_type\": \"circle\""), std::string::npos);
  EXPECT_EQ(json_number(summary, "steps"), 35000.0);
  for (const char* axis : {"x", "y", "z"}) EXPECT_LT(rmse_of(summary, axis), 0.1) << axis;
  EXPECT_LT(rmse_of(summary, "yaw"), 0.05);
}

TEST_F(Cli, NmpcFigureEightRunsWithSolveStatistics) {
  // The NMPC issue's "done when" command, shortened to 1 s (the full run is in validation.md):
  // exits 0, logs the solve statistics and summarises them.
  const CliResult r =
      run_experiment(kExperiments + "nmpc_figure8_noise_off.yaml", "nmpc", "--duration 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("nmpc_figure8_noise_off: ok"), std::string::npos) << r.out;
  const std::string summary = read_all(out("nmpc") / "summary.json");
  EXPECT_NE(summary.find("\"name\": \"nmpc\""), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"solve_time_ms\": {"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"failed\": {"), std::string::npos) << summary;
  const std::string log = read_all(out("nmpc") / "log.csv");
  EXPECT_NE(log.substr(0, log.find('\n')).find(",ctrl_iterations,"), std::string::npos);
}

TEST_F(Cli, RealTimeFlag) {
  CliResult r = run_experiment(kExperiments + "hover_pid.yaml", "rt", "--duration 0.1 --real-time");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("real time"), std::string::npos) << r.out;
  const std::string summary = read_all(out("rt") / "summary.json");
  EXPECT_NE(summary.find("\"real_time\": true"), std::string::npos) << summary;
  EXPECT_LE(json_number(summary, "real_time_factor"), 1.01);

  r = run_experiment(kExperiments + "freefall.yaml", "rt_open", "--real-time");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--real-time: only for closed-loop experiments"), std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace dronetwin
