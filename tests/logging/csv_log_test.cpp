// Tests of the CSV run log (include/dronetwin/logging/csv_log.hpp): exact column names, bitwise
// write/read round trip, buffering across many rows, and errors that name file, line and column.
#include "dronetwin/logging/csv_log.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "dronetwin/dynamics/wrench.hpp"
#include "dronetwin/noise/random.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

using test::error_of;

fs::path temp_file(const std::string& name) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  return fs::temp_directory_path() /
         ("dronetwin_csv_test_" + std::to_string(::getpid()) + "_" + info->name() + "_" + name);
}

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(CsvLog, ColumnNamesOfAQuadrotorLog) {
  const std::vector<std::string> c = log_column_names({4, true, false});
  const std::vector<std::string> expected = {
      "t",           "x",       "y",       "z",       "vx",          "vy",          "vz",
      "qw",          "qx",      "qy",      "qz",      "wx",          "wy",          "wz",
      "omega_0",     "omega_1", "omega_2", "omega_3", "omega_ref_0", "omega_ref_1", "omega_ref_2",
      "omega_ref_3", "meas_x",  "meas_y",  "meas_z",  "meas_vx",     "meas_vy",     "meas_vz",
      "meas_qw",     "meas_qx", "meas_qy", "meas_qz", "meas_wx",     "meas_wy",     "meas_wz",
      "in_contact",  "crashed"};
  EXPECT_EQ(c, expected);
}

TEST(CsvLog, OptionalGroups) {
  const std::vector<std::string> bare = log_column_names({6, false, false});
  EXPECT_EQ(bare.size(), 1u + 13u + 6u + 6u + 2u);
  EXPECT_EQ(bare[19], "omega_5");
  EXPECT_EQ(bare[20], "omega_ref_0");
  EXPECT_EQ(bare[26], "in_contact");

  const std::vector<std::string> full = log_column_names({4, true, true});
  ASSERT_EQ(full.size(), 37u + 6u * kNumTerms);
  EXPECT_EQ(full[37], "F_thrust_x");
  EXPECT_EQ(full[42], "M_thrust_z");
  EXPECT_EQ(full[43], "F_yaw_reaction_x");
  EXPECT_EQ(full.back(), "M_gravity_z");
  for (int k = 0; k < kNumTerms; ++k) {
    const std::string term(term_name(static_cast<Term>(k)));
    EXPECT_EQ(full[37 + 6 * static_cast<std::size_t>(k)], "F_" + term + "_x");
    EXPECT_EQ(full[37 + 6 * static_cast<std::size_t>(k) + 5], "M_" + term + "_z");
  }
}

TEST(CsvLog, SensorAndEstimateGroupsComeBeforeTheClosedLoopOnes) {
  LogLayout layout{4,   false, false, true, {}, {SensorSpec::barometer(), SensorSpec::gps("fix")},
                   true};
  const std::vector<std::string> names = log_column_names(layout);
  // t, 13 state, 8 rotor columns, in_contact, crashed = 24; then baro_t, baro_p; fix_t + 6.
  ASSERT_GE(names.size(), 24u + 2u + 7u + 13u + 9u);
  EXPECT_EQ(names[24], "baro_t");
  EXPECT_EQ(names[25], "baro_p");
  EXPECT_EQ(names[26], "fix_t");
  EXPECT_EQ(names[32], "fix_vz");
  EXPECT_EQ(names[33], "est_x");
  EXPECT_EQ(names[45], "est_wz");
  EXPECT_EQ(names[46], "ref_x");
  EXPECT_EQ(log_columns(layout)[25].unit, "Pa");
}

TEST(CsvLog, ASensorWhoseColumnsTakeAnotherColumnsNameIsNamed) {
  // A motion capture named "ref" would write ref_x, ref_y, ref_z twice in a closed-loop log.
  const LogLayout layout{4, true, false, true, {}, {SensorSpec::motion_capture("ref")}};
  EXPECT_EQ(error_of([&] { (void)log_columns(layout); }),
            "sensor 'ref': its log column 'ref_x' is already a column of the log; give the "
            "sensor another name");
}

TEST(CsvLog, HeaderIsExact) {
  const fs::path p = temp_file("log.csv");
  {
    CsvLogWriter w(p.string(), {"t", "x", "omega_0"});
    w.write_row(std::vector<double>{0.0, 1.5, 2.0});
    w.close();
  }
  EXPECT_EQ(read_all(p), "t,x,omega_0\n0,1.5,2\n");
  fs::remove(p);
}

TEST(CsvLog, RoundTripIsBitwise) {
  // Awkward doubles: non-representable decimals, extremes, subnormals, signed zero, and random
  // bit patterns (every finite one must come back identical).
  std::vector<double> values = {0.1,
                                -0.0,
                                1.0 / 3.0,
                                3.141592653589793,
                                1e-300,
                                -1.7976931348623157e308,
                                std::numeric_limits<double>::denorm_min(),
                                std::numeric_limits<double>::min(),
                                2.0 / 3.0 * 1e-5,
                                123456789012345678.0,
                                9.81,
                                -4.921092553191489};
  Random rng(42);
  while (values.size() < 12 * 500) {
    const double v = std::bit_cast<double>(rng.next_u64());
    if (std::isfinite(v)) values.push_back(v);
    values.push_back(rng.normal());
  }
  values.resize(12 * 500);
  std::vector<std::string> columns;
  // Not "c" + std::to_string(i): GCC 12 warns falsely (-Wrestrict) on that once inlined.
  for (int i = 0; i < 12; ++i) columns.push_back(std::string("c").append(std::to_string(i)));
  const fs::path p = temp_file("roundtrip.csv");
  {
    CsvLogWriter w(p.string(), columns);
    for (std::size_t r = 0; r < 500; ++r) w.write_row(values.data() + 12 * r, 12);
    EXPECT_EQ(w.rows_written(), 500u);
    w.close();
  }
  const LogTable t = read_csv_log(p.string());
  EXPECT_EQ(t.columns, columns);
  ASSERT_EQ(t.rows(), 500u);
  ASSERT_EQ(t.values.size(), values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    ASSERT_EQ(std::bit_cast<std::uint64_t>(t.values[i]), std::bit_cast<std::uint64_t>(values[i]))
        << "value " << i << ": wrote " << values[i] << ", read " << t.values[i];
  }
  EXPECT_EQ(t.at(0, t.column("c0")), 0.1);
  EXPECT_EQ(t.column_values("c2")[0], 1.0 / 3.0);
  EXPECT_THROW((void)t.column("nope"), InvalidArgument);

  // Writing the table again gives the same bytes.
  const fs::path q = temp_file("again.csv");
  {
    CsvLogWriter w(q.string(), t.columns);
    for (std::size_t r = 0; r < t.rows(); ++r) w.write_row(t.values.data() + 12 * r, 12);
  }  // the destructor flushes too
  EXPECT_EQ(read_all(p), read_all(q));
  fs::remove(p);
  fs::remove(q);
}

TEST(CsvLog, FormatMatchesPrintf17g) {
  const fs::path p = temp_file("printf.csv");
  const std::vector<double> v = {0.1, 1e-5, 1e21, -2.5e-310, 1234567.0, 0.001 * 3};
  {
    CsvLogWriter w(p.string(), {"a", "b", "c", "d", "e", "f"});
    w.write_row(v);
  }
  std::string expected = "a,b,c,d,e,f\n";
  for (std::size_t i = 0; i < v.size(); ++i) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v[i]);
    expected += buf;
    expected += i + 1 < v.size() ? "," : "\n";
  }
  EXPECT_EQ(read_all(p), expected);
  fs::remove(p);
}

TEST(CsvLog, WriterRejectsBadInput) {
  const fs::path p = temp_file("bad.csv");
  CsvLogWriter w(p.string(), {"a", "b"});
  const std::string m = error_of([&] { w.write_row(std::vector<double>{1.0}); });
  EXPECT_NE(m.find("row 1: expected 2 values (one per column), got 1"), std::string::npos) << m;
  w.close();
  EXPECT_THROW(w.write_row(std::vector<double>{1.0, 2.0}), InvalidArgument);
  EXPECT_THROW(CsvLogWriter(p.string(), {"a,b"}), InvalidArgument);
  EXPECT_THROW(CsvLogWriter(p.string(), {}), InvalidArgument);
  EXPECT_NE(error_of([] {
              CsvLogWriter("/nonexistent/dir/log.csv", {"t"});
            }).find("/nonexistent/dir/log.csv: cannot open for writing"),
            std::string::npos);
  fs::remove(p);
}

TEST(CsvLog, MalformedRowNamesLineAndColumn) {
  const fs::path p = temp_file("malformed.csv");
  std::ofstream(p) << "t,x,z\n0,1,2\n0.001,1,2\n0.002,abc,2\n";
  std::string m = error_of([&] { (void)read_csv_log(p.string()); });
  EXPECT_NE(m.find(p.string() + ": line 4, column 2 (x): expected a number, got 'abc'"),
            std::string::npos)
      << m;

  std::ofstream(p) << "t,x,z\n0,1,2\n0,1\n";
  m = error_of([&] { (void)read_csv_log(p.string()); });
  EXPECT_NE(m.find(p.string() + ": line 3: expected 3 fields, got 2"), std::string::npos) << m;

  std::ofstream(p) << "t,x,z\n0,1,2,3\n";
  m = error_of([&] { (void)read_csv_log(p.string()); });
  EXPECT_NE(m.find(p.string() + ": line 2: expected 3 fields, got more"), std::string::npos) << m;

  std::ofstream(p) << "t,x,z\n0,,2\n";
  m = error_of([&] { (void)read_csv_log(p.string()); });
  EXPECT_NE(m.find("line 2, column 2 (x): expected a number, got ''"), std::string::npos) << m;

  std::ofstream(p) << "t,x,z\n0,1.5e,2\n";
  m = error_of([&] { (void)read_csv_log(p.string()); });
  EXPECT_NE(m.find("line 2, column 2 (x): expected a number, got '1.5e'"), std::string::npos) << m;

  std::ofstream(p) << "";
  m = error_of([&] { (void)read_csv_log(p.string()); });
  EXPECT_NE(m.find("line 1: empty file"), std::string::npos) << m;

  std::ofstream(p) << "t,,z\n";
  m = error_of([&] { (void)read_csv_log(p.string()); });
  EXPECT_NE(m.find("line 1, column 2: expected a column name"), std::string::npos) << m;

  EXPECT_NE(error_of([] { (void)read_csv_log("/nonexistent/log.csv"); }).find("cannot open log"),
            std::string::npos);

  // CRLF line endings and a header-only file are fine.
  std::ofstream(p) << "t,x\r\n0,1\r\n";
  const LogTable t = read_csv_log(p.string());
  EXPECT_EQ(t.columns, (std::vector<std::string>{"t", "x"}));
  EXPECT_EQ(t.values, (std::vector<double>{0, 1}));
  std::ofstream(p) << "t,x\n";
  EXPECT_EQ(read_csv_log(p.string()).rows(), 0u);
  fs::remove(p);
}

}  // namespace
}  // namespace dronetwin
