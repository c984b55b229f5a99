// End-to-end tests of the real-data commands (`dronetwin import ...`, `dronetwin identify ...`,
// src/cli/real_data_commands.hpp) on the files in tests/data/real: exit codes, the files they
// write, and physical checks on the imported PX4 flight.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include "adapters/ulog_bytes.hpp"
#include "dronetwin/logging/csv_log.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

const std::string kCli = DRONETWIN_CLI_PATH;
const std::string kSource = DRONETWIN_SOURCE_DIR;
const std::string kData = kSource + "/tests/data/real/";
const std::string kModel = kSource + "/models/crazyflie21.yaml";
const std::string kStand = kData + "crazyflie-system-id/data/bitcraze2021/cf2.1-stock-prop.csv";
const std::string kFlight =
    kData + "CrazyPAD/data/motor_data/normal_flight/E8_log00.fixedFrequency.csv";
const std::string kULog = kData + "px4-ulog-rs/esc_status_log.ulg";

class RealDataCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (kCli.empty()) GTEST_SKIP() << "the dronetwin CLI was not built (CLI11 not found)";
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("dronetwin_realdata_cli_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    if (!dir_.empty()) fs::remove_all(dir_, ec);
  }
  int run(const std::string& args, std::string* out = nullptr, std::string* err = nullptr) {
    const fs::path o = dir_ / "stdout.txt", e = dir_ / "stderr.txt";
    const std::string command =
        q(kCli) + " " + args + " > " + q(o.string()) + " 2> " + q(e.string());
    const int status = std::system(command.c_str());
    const auto slurp = [](const fs::path& p) {
      std::ifstream in(p);
      std::stringstream s;
      s << in.rdbuf();
      return s.str();
    };
    if (out) *out = slurp(o);
    if (err) *err = slurp(e);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  std::string d() const { return q(dir_.string()); }
  /// `"s"` (built with += to dodge a GCC 12 -Wrestrict false positive on "lit" + string).
  static std::string q(const std::string& s) {
    std::string r = "\"";
    r += s;
    r += '"';
    return r;
  }
  fs::path dir_;
};

TEST_F(RealDataCli, StandImportAndVerticalFit) {
  std::string out;
  ASSERT_EQ(run("identify stand " + q(kStand) + " --out " + d(), &out), 0) << out;
  EXPECT_NE(out.find("K1 = "), std::string::npos) << out;
  EXPECT_TRUE(fs::exists(dir_ / "stand_fit.json"));
  const LogTable pts = read_csv_log((dir_ / "stand_points.csv").string());
  EXPECT_EQ(pts.rows(), 2573u);

  ASSERT_EQ(run("import crazypad " + q(kFlight) + " --stand " + q(kStand) + " --out " + d(), &out),
            0)
      << out;
  const LogTable log = read_csv_log((dir_ / "E8_log00.csv").string());
  EXPECT_EQ(log.rows(), 2604u);
  EXPECT_TRUE(fs::exists(dir_ / "E8_log00.json"));

  ASSERT_EQ(run("identify vertical " + q((dir_ / "E8_log00.csv").string()) + " --model " +
                    q(kModel) + " --no-drag --out " + d(),
                &out),
            0)
      << out;
  EXPECT_NE(out.find("mass = 1/c = "), std::string::npos) << out;
  EXPECT_TRUE(fs::exists(dir_ / "vertical_fit.json"));
}

// Issue "Reliability" item 3: a prior mass that is no mass (negative, zero, NaN, inf) used to
// be taken as "the model's mass" or to poison the prediction; it is now refused by name.
TEST_F(RealDataCli, VerticalFitRefusesAPriorMassThatIsNoMass) {
  std::string out, err;
  ASSERT_EQ(run("import crazypad " + q(kFlight) + " --stand " + q(kStand) + " --out " + d(), &out),
            0)
      << out;
  const std::string log = q((dir_ / "E8_log00.csv").string());
  for (const char* mass : {"-1", "0", "nan", "inf"}) {
    EXPECT_EQ(run("identify vertical " + log + " --model " + q(kModel) + " --prior-mass " + mass +
                      " --out " + d(),
                  &out, &err),
              2)
        << mass << out;
    EXPECT_NE(err.find("--prior-mass: expected a mass in kg > 0, got"), std::string::npos)
        << mass << err;
  }
  EXPECT_FALSE(fs::exists(dir_ / "vertical_fit.json"));
  EXPECT_EQ(run("identify vertical " + log + " --model " + q(kModel) +
                    " --prior-mass 0.031 --no-drag --out " + d(),
                &out, &err),
            0)
      << out << err;
}

TEST_F(RealDataCli, ImportULogGivesAZUpFlight) {
  std::string out;
  ASSERT_EQ(run("import ulog " + q(kULog) + " --out " + d(), &out), 0) << out;
  const LogTable t = read_csv_log((dir_ / "esc_status_log.csv").string());
  ASSERT_GT(t.rows(), 1000u);  // vehicle_attitude at ~28 Hz for ~38 s
  EXPECT_EQ(t.column("omega_3"), t.column("omega_0") + 3);
  double acc_z = 0.0, z_min = 1e9;
  for (std::size_t r = 0; r < t.rows(); ++r) {
    double n2 = 0.0;
    for (const char* c : {"qw", "qx", "qy", "qz"}) n2 += std::pow(t.at(r, t.column(c)), 2);
    EXPECT_NEAR(std::sqrt(n2), 1.0, 1e-6);
    acc_z += t.at(r, t.column("acc_z")) / static_cast<double>(t.rows());
    z_min = std::min(z_min, t.at(r, t.column("z")));
    // Flying (rotors spinning, ESC rpm > 1000) the whole logged span.
    EXPECT_GT(t.at(r, t.column("omega_0")), 1000 * 2 * std::numbers::pi / 60);
  }
  // Over a whole flight the mean vertical acceleration is about zero, so the mean specific force
  // is g (z up: +9.81). A sign error in the NED conversion would give -9.81.
  EXPECT_NEAR(acc_z, 9.81, 0.3);
  // PX4's z is down; ours is up: the vehicle stays above its EKF origin height.
  EXPECT_GT(z_min, -1.0);
}

TEST_F(RealDataCli, BadInputExitsWithTwoAndNamesTheFile) {
  std::string err;
  EXPECT_EQ(run("import crazypad " + q((dir_ / "missing.csv").string()) + " --stand " + q(kStand) +
                    " --out " + d(),
                nullptr, &err),
            2);
  EXPECT_NE(err.find("missing.csv"), std::string::npos) << err;
  EXPECT_EQ(run("import ulog " + q(kStand) + " --out " + d(), nullptr, &err), 2);
  EXPECT_NE(err.find("byte 0: not a ULog file"), std::string::npos) << err;
  EXPECT_EQ(run("identify", nullptr, &err), 2);
}

TEST_F(RealDataCli, ULogWithAHugeArrayIsRefusedWithoutEatingMemory) {
  // ~100 bytes declaring 2e9 floats per message: before the caps, `import ulog` grew past 12 GB.
  test::Bytes f = test::ulog_header();
  test::format(f, "huge:uint64_t timestamp;float[2000000000] x");
  test::subscribe(f, "huge", 0);
  test::message(f, 'D', test::Bytes().put(std::uint16_t{0}).put(std::uint64_t{1}).put(1.0f));
  const fs::path file = dir_ / "huge.ulg";
  {
    std::ofstream out(file, std::ios::binary);
    out.write(reinterpret_cast<const char*>(f.bytes().data()),
              static_cast<std::streamsize>(f.size()));
  }
  std::string err;
  EXPECT_EQ(run("import ulog " + q(file.string()) + " --out " + d(), nullptr, &err), 2);
  EXPECT_NE(err.find(file.string() + ": byte 16: format 'huge', field 'float[2000000000] x': "
                                     "2000000000 elements exceed the limit of a ULog message "
                                     "(65535 bytes)"),
            std::string::npos)
      << err;
  EXPECT_FALSE(fs::exists(dir_ / "huge.csv"));
}

}  // namespace
}  // namespace dronetwin
