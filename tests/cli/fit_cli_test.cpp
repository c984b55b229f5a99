// End-to-end tests of `dronetwin fit` (src/cli/fit_command.hpp): a flight of a changed QDrone2
// written by `dronetwin run`, fitted back from the unchanged model file; the real CrazyPAD flight;
// and the errors a user can make, each named.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <system_error>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/model/model_parameters.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

const std::string kCli = DRONETWIN_CLI_PATH;
const std::string kSource = DRONETWIN_SOURCE_DIR;

// 's' (built with += to dodge GCC 12's -Wrestrict false positive on "lit" + string).
std::string q(const std::string& s) {
  std::string r = "'";
  r += s;
  r += '\'';
  return r;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class FitCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (kCli.empty()) GTEST_SKIP() << "the dronetwin CLI was not built (CLI11 not found)";
  }
  int run(const std::string& args, std::string* out = nullptr, std::string* err = nullptr) {
    const fs::path o = dir_ / "stdout.txt", e = dir_ / "stderr.txt";
    const int status = std::system(
        (q(kCli) + " " + args + " > " + q(o.string()) + " 2> " + q(e.string())).c_str());
    if (out) *out = slurp(o);
    if (err) *err = slurp(e);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  // The identification flight flown by `spec` (the experiment file, pointed at a model file of
  // our own), `duration_s` long; returns the log path.
  std::string fly(const VehicleSpec& spec, double duration_s) {
    const fs::path model = dir_ / "truth.yaml", exp = dir_ / "flight.yaml";
    save_vehicle_spec(spec, model.string());
    std::string text = slurp(kSource + "/config/experiments/identification_flight.yaml");
    const auto replace = [&](const std::string& from, const std::string& to) {
      const std::size_t at = text.find(from);
      ASSERT_NE(at, std::string::npos) << from;
      text.replace(at, from.size(), to);
    };
    replace("model: ../../models/qdrone2.yaml", "model: " + model.string());
    replace("controller: ../controllers/se3.yaml",
            "controller: " + kSource + "/config/controllers/se3.yaml");
    std::ofstream(exp) << text;
    std::string err;
    EXPECT_EQ(run("run " + q(exp.string()) + " --out " + q((dir_ / "run").string()) +
                      " --quiet --duration " + std::to_string(duration_s),
                  nullptr, &err),
              0)
        << err;
    return (dir_ / "run" / "log.csv").string();
  }
  test::TempDir tmp_;
  const fs::path dir_ = tmp_.path();
};

TEST_F(FitCli, RecoversAChangedVehicleFromItsLogAndWritesTheFittedModel) {
  const VehicleSpec nominal = load_vehicle_spec(kSource + "/models/qdrone2.yaml");
  VehicleSpec truth = nominal;
  set_parameter_value(truth, ModelParameter::kThrustK1,
                      1.2 * parameter_value(nominal, ModelParameter::kThrustK1));
  set_parameter_value(truth, ModelParameter::kInertiaZZ,
                      0.8 * parameter_value(nominal, ModelParameter::kInertiaZZ));
  set_parameter_value(truth, ModelParameter::kTauRise,
                      1.2 * parameter_value(nominal, ModelParameter::kTauRise));
  const std::string log = fly(truth, 10.0);
  const fs::path fitted = dir_ / "fitted.yaml", report = dir_ / "fit.json";
  std::string out, err;
  ASSERT_EQ(run("fit --model " + q(kSource + "/models/qdrone2.yaml") + " --log " + q(log) +
                    " --params thrust_k1,inertia_zz,tau_rise --out " + q(fitted.string()) +
                    " --report " + q(report.string()),
                &out, &err),
            0)
      << out << err;
  EXPECT_NE(out.find("thrust_k1"), std::string::npos) << out;
  EXPECT_NE(out.find("holdout"), std::string::npos) << out;
  // The flight's switches, wind and gravity come from the run's sidecar.
  EXPECT_NE(out.find("flight settings from " + (dir_ / "run" / "log.json").string()),
            std::string::npos)
      << out;
  const VehicleSpec f = load_vehicle_spec(fitted.string());
  for (const ModelParameter p :
       {ModelParameter::kThrustK1, ModelParameter::kInertiaZZ, ModelParameter::kTauRise}) {
    EXPECT_NEAR(parameter_value(f, p) / parameter_value(truth, p), 1.0, 0.01) << parameter_name(p);
  }
  // Untouched parameters stay as they were in the starting model.
  EXPECT_EQ(parameter_value(f, ModelParameter::kMass), nominal.mass_kg);
  const std::string json = slurp(report);
  EXPECT_NE(json.find("\"std_error\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"holdout_after\""), std::string::npos) << json;
}

TEST_F(FitCli, FitsTheMassOfTheRealCrazyPadFlight) {
  const std::string data = kSource + "/tests/data/real/";
  std::string err;
  ASSERT_EQ(
      run("import crazypad " +
              q(data + "CrazyPAD/data/motor_data/normal_flight/E8_log00.fixedFrequency.csv") +
              " --stand " + q(data + "crazyflie-system-id/data/bitcraze2021/cf2.1-stock-prop.csv") +
              " --out " + q(dir_.string()),
          nullptr, &err),
      0)
      << err;
  const fs::path fitted = dir_ / "cf.yaml", report = dir_ / "fit.json";
  std::string out;
  ASSERT_EQ(run("fit --model " + q(kSource + "/models/crazyflie21.yaml") + " --log " +
                    q((dir_ / "E8_log00.csv").string()) +
                    " --params mass --method equation --holdout 0.3" + " --min-height 0.05 --out " +
                    q(fitted.string()) + " --report " + q(report.string()),
                &out, &err),
            0)
      << out << err;
  const double mass = load_vehicle_spec(fitted.string()).mass_kg;
  EXPECT_GT(mass, 0.027) << out;  // tests/data/real/README.md: 27-35 g with battery
  EXPECT_LT(mass, 0.035) << out;
  EXPECT_NE(out.find("no body rates"), std::string::npos) << out;  // CrazyPAD logs none
}

TEST_F(FitCli, BadInputIsNamed) {
  const std::string model = q(kSource + "/models/qdrone2.yaml");
  std::ofstream(dir_ / "short.csv") << "t,x,y,z\n0,0,0,0\n0.001,0,0,0\n";
  std::string out, err;
  EXPECT_EQ(run("fit --model " + model + " --log " + q((dir_ / "short.csv").string()) +
                    " --params mass --out " + q((dir_ / "f.yaml").string()),
                &out, &err),
            2);
  EXPECT_NE(err.find("vx"), std::string::npos) << err;  // the first missing column is named
  EXPECT_EQ(run("fit --model " + model + " --log " + q((dir_ / "short.csv").string()) +
                    " --params mas --out " + q((dir_ / "f.yaml").string()),
                &out, &err),
            2);
  EXPECT_NE(err.find("unknown parameter 'mas'"), std::string::npos) << err;
  EXPECT_EQ(run("fit --model " + model + " --log " + q((dir_ / "short.csv").string()) +
                    " --params mass --method fast --out " + q((dir_ / "f.yaml").string()),
                &out, &err),
            2);
  EXPECT_NE(err.find("--method"), std::string::npos) << err;
  EXPECT_EQ(run("fit --model " + model + " --log " + q((dir_ / "short.csv").string()) +
                    " --params mass --disturbances rotor_drag,wind --out " +
                    q((dir_ / "f.yaml").string()),
                &out, &err),
            2);
  EXPECT_NE(err.find("--disturbances: unknown term 'wind' (valid: all, none, or a comma-separated "
                     "list of rotor_drag, rolling_moment"),
            std::string::npos)
      << err;
  EXPECT_FALSE(fs::exists(dir_ / "f.yaml"));
}

TEST_F(FitCli, ASidecarForAnotherVehicleIsNamed) {
  const std::string log = fly(load_vehicle_spec(kSource + "/models/qdrone2.yaml"), 0.5);
  std::string out, err;
  EXPECT_EQ(run("fit --model " + q(kSource + "/models/hexarotor.yaml") + " --log " + q(log) +
                    " --params mass --out " + q((dir_ / "f.yaml").string()),
                &out, &err),
            2);
  EXPECT_NE(err.find("log.json: the log has 4 rotors, the model"), std::string::npos) << err;
}

TEST_F(FitCli, EstimatesThatMakeNoValidModelAreReportedButNotWritten) {
  // The hovering CrazyPAD flight cannot see vertical drag; its estimate comes out below 0, which
  // no model file may hold (body drag must be dissipative).
  const std::string data = kSource + "/tests/data/real/";
  ASSERT_EQ(
      run("import crazypad " +
          q(data + "CrazyPAD/data/motor_data/normal_flight/E8_log00.fixedFrequency.csv") +
          " --stand " + q(data + "crazyflie-system-id/data/bitcraze2021/cf2.1-stock-prop.csv") +
          " --out " + q(dir_.string())),
      0);
  const fs::path fitted = dir_ / "cf.yaml", report = dir_ / "fit.json";
  std::string out, err;
  EXPECT_EQ(run("fit --model " + q(kSource + "/models/crazyflie21.yaml") + " --log " +
                    q((dir_ / "E8_log00.csv").string()) +
                    " --params mass,body_drag_z --method equation --holdout 0.3 --min-height 0.05" +
                    " --out " + q(fitted.string()) + " --report " + q(report.string()),
                &out, &err),
            1);
  EXPECT_NE(err.find("the estimates do not make a valid model, so " + fitted.string() +
                     " was not written"),
            std::string::npos)
      << err;
  EXPECT_NE(err.find("body_drag_Ns_per_m"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(fitted));
  EXPECT_TRUE(fs::exists(report));  // the report is still there to read
}

// Issue "Reliability" item 3: numeric options out of range or not numbers are refused by name
// before anything is read or fitted (--window used to wrap silently to a 2-sample window).
TEST_F(FitCli, OptionsOutOfRangeAreNamed) {
  const std::string log = fly(load_vehicle_spec(kSource + "/models/qdrone2.yaml"), 2.0);
  const std::string base = "fit --model " + q(kSource + "/models/qdrone2.yaml") + " --log " +
                           q(log) + " --params thrust_k1 --out " + q((dir_ / "f.yaml").string());
  const std::pair<const char*, const char*> cases[] = {
      {"--window 0", "--window: expected a length in s > 0, got 0"},
      {"--window nan", "--window: expected a length in s > 0, got nan"},
      {"--window -inf", "--window: expected a length in s > 0, got -inf"},
      // 2 001 rows at 1 kHz: 0.1 ms is a twentieth of an interval, 1e12 s far beyond the flight.
      {"--window 0.0001", "window_s = 0.0001 s is shorter than two log intervals"},
      {"--window 1e12", "log intervals, longer than the 1600 intervals fitted"},
      {"--max-windows 0", "--max-windows: expected a count >= 1, got 0"},
      {"--max-windows -3", "--max-windows: expected a count >= 1, got -3"},
      {"--coarse-intervals -1", "--coarse-intervals: expected a count >= 0, got -1"},
      {"--min-height nan", "--min-height: expected a height in m, got nan"},
      {"--min-height inf", "--min-height: expected a height in m, got inf"},
      {"--holdout nan", "--holdout: expected a share in [0, 0.9), got nan"},
      {"--holdout 2", "--holdout: expected a share in [0, 0.9), got 2"},
      {"--threads 0", "--threads: expected a count in [1, 1024], got 0"},
      {"--loss l2", "--loss: expected none, huber or cauchy, got 'l2'"},
      {"--loss-scale 0", "--loss-scale: expected a number of noise levels > 0, got 0"},
      {"--loss-scale nan", "--loss-scale: expected a number of noise levels > 0, got nan"},
      {"--channels rotational", "--channels: expected auto, linear, angular or linear,angular"},
      {"--speed-gains yes", "--speed-gains: expected auto, fit or off, got 'yes'"},
  };
  for (const auto& [option, message] : cases) {
    std::string out, err;
    EXPECT_EQ(run(base + " " + option, &out, &err), 2) << option << "\n" << out << err;
    EXPECT_NE(err.find(message), std::string::npos) << option << "\n" << err;
  }
  EXPECT_FALSE(fs::exists(dir_ / "f.yaml"));
}

// Issue "Reliability" item 1: `fit -o RUN/log.csv` (or --report RUN/log.json) used to replace the
// flight log or its sidecar. Every spelling of an input (a link to it too) is refused, and the
// input is left byte for byte as it was.
TEST_F(FitCli, AnOutputThatIsAnInputIsRefused) {
  const std::string log = fly(load_vehicle_spec(kSource + "/models/qdrone2.yaml"), 0.5);
  const fs::path run_dir = dir_ / "run";
  const std::string log_text = slurp(log), sidecar_text = slurp(run_dir / "log.json");
  fs::copy_file(kSource + "/models/qdrone2.yaml", dir_ / "model.yaml");
  fs::create_symlink(run_dir / "log.csv", dir_ / "link.csv");
  const std::string base = "fit --model " + q((dir_ / "model.yaml").string()) + " --log " + q(log) +
                           " --params thrust_k1 ";
  const std::pair<std::string, std::string> cases[] = {
      {"--out " + q(log), "--out " + log + ": is also the --log"},
      {"--out " + q((run_dir / ".." / "run" / "log.csv").string()), ": is also the --log"},
      {"--out " + q((dir_ / "link.csv").string()), ": is also the --log"},
      {"--out " + q((dir_ / "model.yaml").string()), ": is also the --model file"},
      {"--out " + q((dir_ / "f.yaml").string()) + " --report " + q((run_dir / "log.json").string()),
       ": is also the log's sidecar"},
      {"--out " + q((dir_ / "f.yaml").string()) + " --report " + q((dir_ / "f.yaml").string()),
       ": is also --out"},
  };
  for (const auto& [outputs, message] : cases) {
    std::string out, err;
    EXPECT_EQ(run(base + outputs, &out, &err), 2) << outputs << "\n" << out << err;
    EXPECT_NE(err.find(message), std::string::npos) << outputs << "\n" << err;
    EXPECT_EQ(out.find("fit "), std::string::npos) << "refused before the fit\n" << out;
  }
  EXPECT_EQ(slurp(log), log_text);
  EXPECT_EQ(slurp(run_dir / "log.json"), sidecar_text);
  EXPECT_EQ(slurp(dir_ / "model.yaml"), slurp(kSource + "/models/qdrone2.yaml"));
  EXPECT_FALSE(fs::exists(dir_ / "f.yaml"));
}

// Issue "Reliability" item 3: an output folder that does not exist fails at once (not after the
// fit), and a write the system refuses says why (the errno text).
TEST_F(FitCli, OutputsThatCannotBeWrittenFailBeforeTheFitAndSayWhy) {
  const std::string log = fly(load_vehicle_spec(kSource + "/models/qdrone2.yaml"), 0.5);
  const std::string base = "fit --model " + q(kSource + "/models/qdrone2.yaml") + " --log " +
                           q(log) + " --params thrust_k1 ";
  std::string out, err;
  const fs::path missing = dir_ / "no_such_folder" / "f.yaml";
  EXPECT_EQ(run(base + "--out " + q(missing.string()), &out, &err), 2) << out << err;
  EXPECT_NE(err.find(missing.string() + ": cannot write: the folder " +
                     (dir_ / "no_such_folder").string() + " does not exist"),
            std::string::npos)
      << err;
  EXPECT_EQ(out.find("fit "), std::string::npos) << out;
  EXPECT_EQ(
      run(base + "--out " + q((dir_ / "f.yaml").string()) + " --report " + q(missing.string()),
          &out, &err),
      2);
  EXPECT_NE(err.find("does not exist"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir_ / "f.yaml"));

  // A folder nobody may create files in, not even root (sysfs): the reason the system gives.
  const fs::path refused = "/sys/kernel/dronetwin_fit_test.yaml";
  const int fd = ::open("/sys/kernel/.dronetwin_probe", O_WRONLY | O_CREAT | O_EXCL, 0666);
  if (fd >= 0 || !fs::is_directory("/sys/kernel")) {
    if (fd >= 0) ::close(fd);
    GTEST_SKIP() << "/sys/kernel is writable or missing here";
  }
  const std::string reason = std::generic_category().message(errno);
  EXPECT_EQ(run(base + "--out " + q(refused.string()), &out, &err), 2) << out << err;
  EXPECT_NE(err.find(refused.string() +
                     ": cannot write (cannot create a file in /sys/kernel: " + reason + ")"),
            std::string::npos)
      << err;
}

// Issue "Reliability" item 3: a malformed sidecar next to the log used to be skipped silently
// (the fit then assumed all terms and no wind). It is an error naming the sidecar, unless the
// user says --ignore-sidecar.
TEST_F(FitCli, AMalformedSidecarIsAnErrorNotDefaults) {
  const std::string log = fly(load_vehicle_spec(kSource + "/models/qdrone2.yaml"), 2.0);
  const fs::path sidecar = dir_ / "run" / "log.json";
  const std::string cmd = "fit --model " + q(kSource + "/models/qdrone2.yaml") + " --log " +
                          q(log) + " --params thrust_k1 --method equation --out " +
                          q((dir_ / "f.yaml").string());
  std::string out, err;
  std::ofstream(sidecar) << "{\"format\": \"dronetwin.run_log\", \"num_rotors\": ";  // cut off
  EXPECT_EQ(run(cmd, &out, &err), 2) << out << err;
  EXPECT_NE(err.find(sidecar.string()), std::string::npos) << err;
  EXPECT_NE(err.find("--ignore-sidecar"), std::string::npos) << err;
  std::ofstream(sidecar) << "{\"format\": \"someone-elses-log\"}\n";
  EXPECT_EQ(run(cmd, &out, &err), 2) << out << err;
  EXPECT_NE(err.find(sidecar.string() + ": format: expected \"dronetwin.run_log\""),
            std::string::npos)
      << err;
  EXPECT_NE(err.find("got \"someone-elses-log\""), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir_ / "f.yaml"));
  ASSERT_EQ(run(cmd + " --ignore-sidecar", &out, &err), 0) << out << err;
  EXPECT_NE(out.find("flight settings from defaults (all terms, no wind; --ignore-sidecar)"),
            std::string::npos)
      << out;
}

}  // namespace
}  // namespace dronetwin
