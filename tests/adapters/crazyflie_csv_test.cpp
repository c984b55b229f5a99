// Tests of the Crazyflie CSV readers and the CrazyPAD importer (io/crazyflie_csv.hpp,
// io/crazypad_import.hpp) on the real files in tests/data/real, plus malformed copies and a
// synthetic flight whose attitude is known.
#include "dronetwin/adapters/crazyflie_csv.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include "dronetwin/adapters/crazypad_import.hpp"
#include "dronetwin/adapters/thrust_stand_fit.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/csv_log.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;
using test::error_of;

const std::string kFlight = test::source_path(
    "tests/data/real/CrazyPAD/data/motor_data/normal_flight/E8_log00.fixedFrequency.csv");
const std::string kStand =
    test::source_path("tests/data/real/crazyflie-system-id/data/bitcraze2021/cf2.1-stock-prop.csv");

class CrazyflieCsv : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("dronetwin_cf_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  /// The first `rows` data lines of `path`, with `edit` applied to the text.
  std::string copy_head(const std::string& path, int rows, const std::string& name) const {
    std::ifstream in(path);
    std::ostringstream out;
    std::string line;
    for (int i = 0; i <= rows && std::getline(in, line); ++i) out << line << "\n";
    const std::string p = (dir_ / name).string();
    std::ofstream(p) << out.str();
    return p;
  }
  fs::path dir_;
};

TEST_F(CrazyflieCsv, ReadsTheRealFlight) {
  const CrazyPadFlight f = read_crazypad_csv(kFlight);
  ASSERT_EQ(f.rows(), 2604u);
  // 101 Hz for 25.7 s (README).
  const double duration = f.t_s.back() - f.t_s.front();
  EXPECT_NEAR(duration, 25.7, 0.1);
  EXPECT_NEAR(static_cast<double>(f.rows() - 1) / duration, 101.0, 1.0);
  // Motors off at the start; one 1S LiPo.
  for (const auto& p : f.pwm) EXPECT_EQ(p.front(), 0.0);
  for (double v : f.vbat_V) {
    EXPECT_GT(v, 3.0);
    EXPECT_LT(v, 4.25);
  }
  // Take-off to about 0.55 m (README).
  double zmax = 0;
  for (double z : f.pos_m[2]) zmax = std::max(zmax, z);
  EXPECT_NEAR(zmax, 0.55, 0.05);
}

TEST_F(CrazyflieCsv, ErrorsNameFileLineAndColumn) {
  // Missing column: a stand file cut to the first 4 columns.
  {
    const std::string p = (dir_ / "cut.csv").string();
    std::ofstream(p) << "weight[g],pwm,vbat[V],rpm1\n1,2,3.5,4\n1,2,3.5,4\n";
    const std::string e = error_of([&] { read_thrust_stand_csv(p); });
    EXPECT_NE(e.find("rpm2"), std::string::npos) << e;
  }
  // Out-of-range PWM on data line 2 (file line 3), column pwm (2).
  {
    const std::string p = (dir_ / "pwm.csv").string();
    std::ofstream(p) << "weight[g],pwm,vbat[V],rpm1,rpm2,rpm3,rpm4,v[V],i[A],p[W]\n"
                     << "0,0,3.9,0,0,0,0,3.8,0.2,0.8\n0,70000,3.9,0,0,0,0,3.8,0.2,0.8\n";
    const std::string e = error_of([&] { read_thrust_stand_csv(p); });
    EXPECT_NE(e.find(p + ": line 3, column 2 (pwm): expected a value in [0, 65535], got 70000"),
              std::string::npos)
        << e;
  }
  // Time going backwards in a flight.
  {
    const std::string p = copy_head(kFlight, 5, "time.csv");
    std::string text;
    {
      std::ifstream in(p);
      std::stringstream ss;
      ss << in.rdbuf();
      text = ss.str();
    }
    const std::size_t line3 = text.find('\n', text.find('\n', text.find('\n') + 1) + 1) + 1;
    text.replace(line3, text.find(',', line3) - line3, "1.0");  // row 3 at t = 1 ms
    std::ofstream(p) << text;
    const std::string e = error_of([&] { read_crazypad_csv(p); });
    EXPECT_NE(e.find(p + ": line 4, column 1 (timestamp_ms): time must increase"),
              std::string::npos)
        << e;
  }
  // Malformed number: reported by the CSV reader with line and column.
  {
    const std::string p = (dir_ / "num.csv").string();
    std::ofstream(p) << "weight[g],pwm\n1,abc\n";
    const std::string e = error_of([&] { read_thrust_stand_csv(p); });
    EXPECT_NE(e.find("line 2, column 2 (pwm): expected a number, got 'abc'"), std::string::npos)
        << e;
  }
}

TEST_F(CrazyflieCsv, ImportReconstructsAKnownAttitude) {
  // A synthetic flight: the world acceleration is what thrust along the body z axis of
  // from_euler(roll, pitch, yaw) gives, so the importer must return exactly that attitude.
  CrazyPadFlight f;
  f.source = "synthetic";
  const double g = 9.81;
  for (int i = 0; i < 50; ++i) {
    const double roll = 0.1 * std::sin(0.3 * i), pitch = -0.15 * std::cos(0.2 * i),
                 yaw = -3.0 + 0.12 * i, thrust_per_mass = 9.0 + 0.05 * i;
    const Vec4 q = math::from_euler(roll, pitch, yaw);
    const Vec3 a = math::rotation_matrix<double>(q) * Vec3(0, 0, thrust_per_mass) - Vec3(0, 0, g);
    f.t_s.push_back(0.01 * i + 5.0);
    for (auto& p : f.pwm) p.push_back(i == 0 ? 0.0 : 30000.0);
    f.vbat_V.push_back(3.7);
    for (int k = 0; k < 3; ++k) {
      f.pos_m[static_cast<std::size_t>(k)].push_back(0.1 * k);
      f.vel_m_s[static_cast<std::size_t>(k)].push_back(0.2 * k);
      // The source logs the kinematic acceleration in g (hover: az = 0).
      f.acc_g[static_cast<std::size_t>(k)].push_back(a[k] / g);
    }
    f.roll_deg.push_back(roll * 180 / std::numbers::pi);
    f.yaw_deg.push_back(yaw * 180 / std::numbers::pi);
  }
  const SpeedMap map{700.0, 300.0};
  const CrazyPadImport imp = import_crazypad(f, map, g);
  ASSERT_EQ(imp.columns, crazypad_import_columns());
  ASSERT_EQ(imp.rows(), 50u);
  const std::size_t nc = imp.columns.size();
  for (std::size_t r = 0; r < imp.rows(); ++r) {
    const double* row = imp.values.data() + r * nc;
    const double roll = 0.1 * std::sin(0.3 * static_cast<double>(r)),
                 yaw = -3.0 + 0.12 * static_cast<double>(r);
    // Row 0 has the motors off: pitch is not reconstructed there (set to 0).
    const double pitch = r == 0 ? 0.0 : -0.15 * std::cos(0.2 * static_cast<double>(r));
    const Vec4 q = math::from_euler(roll, pitch, yaw);
    const double s = q.dot(Vec4(row[7], row[8], row[9], row[10])) < 0 ? -1.0 : 1.0;
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(s * row[7 + k], q[k], 1e-12) << "row " << r;
    EXPECT_NEAR(row[0], 0.01 * static_cast<double>(r), 1e-12);
    const double w = r == 0 ? 0.0 : 700.0 * 30000.0 / 65535.0 * 3.7 + 300.0;
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(row[11 + k], w, 1e-9);
    // acc_z is the world-frame specific force: kinematic acceleration plus g (thrust / m).
    EXPECT_NEAR(row[17], f.acc_g[2][r] * g + g, 1e-12);
  }
}

TEST_F(CrazyflieCsv, ImportTheRealFlightWritesLogAndSidecar) {
  const ThrustStandFit stand = fit_thrust_stand(read_thrust_stand_csv(kStand));
  const CrazyPadFlight f = read_crazypad_csv(kFlight);
  const CrazyPadImport imp = import_crazypad(f, stand.speed_map);
  const std::string stem = (dir_ / "E8_log00").string();
  write_crazypad_import(imp, stem, kStand);
  const LogTable t = read_csv_log(stem + ".csv");
  ASSERT_EQ(t.columns, crazypad_import_columns());
  ASSERT_EQ(t.rows(), f.rows());
  double max_w = 0.0;
  for (std::size_t r = 0; r < t.rows(); ++r) {
    double n2 = 0;
    for (const char* c : {"qw", "qx", "qy", "qz"}) n2 += std::pow(t.at(r, t.column(c)), 2);
    EXPECT_NEAR(n2, 1.0, 1e-12);
    // Stationary on the ground before take-off: acc_z = (az + 1) g = g within the estimator's
    // noise (the source logs az without gravity).
    if (r < 50) {
      EXPECT_NEAR(t.at(r, t.column("acc_z")), 9.81, 0.05);
    }
    for (int i = 0; i < 4; ++i)
      max_w = std::max(max_w, t.at(r, t.column("omega_" + std::to_string(i))));
  }
  // Rotor speeds stay inside what the stand map can produce on a 1S battery.
  EXPECT_GT(max_w, stand.min_speed_rad_s);
  EXPECT_LT(max_w, stand.speed_map.speed_rad_s(65535, 4.2));
  // Pitch is reconstructed, small for a gentle flight.
  EXPECT_LT(imp.max_abs_pitch_rad, 0.3);
  std::ifstream js(stem + ".json");
  std::stringstream ss;
  ss << js.rdbuf();
  EXPECT_NE(ss.str().find("\"source\": \"" + kFlight + "\""), std::string::npos);
  EXPECT_NE(ss.str().find("MIT"), std::string::npos);
}

}  // namespace
}  // namespace dronetwin
