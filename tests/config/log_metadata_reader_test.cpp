// Tests of the run-log sidecar (include/dronetwin/logging/log_metadata.hpp): FNV-1a against the
// test vectors of the FNV specification and an independent implementation, the log.json written by
// run_experiment (settings, log rate, a unit and meaning for every column, the model hash),
// byte-identical sidecars for identical runs, JSON text round trips, malformed sidecars rejected
// naming file and field, read_run_log with and without a sidecar, and the importers' sidecars.
#include "dronetwin/config/log_metadata_reader.hpp"
#include "dronetwin/logging/log_metadata.hpp"

#include <gtest/gtest.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "dronetwin/adapters/ulog.hpp"
#include "dronetwin/adapters/ulog_import.hpp"
#include "dronetwin/app/run_experiment.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/logging/csv_log.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;
using test::error_of;

const std::string kModel = test::source_path("models/qdrone2.yaml");
const std::string kPid = test::source_path("config/controllers/pid.yaml");

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_all(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << text;
}

/// Replaces the first occurrence of `from` (which must be there).
std::string replace(std::string s, const std::string& from, const std::string& to) {
  const auto pos = s.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  if (pos != std::string::npos) s.replace(pos, from.size(), to);
  return s;
}

/// FNV-1a written out from the specification (draft-eastlake-fnv): for each octet, XOR it into
/// the low byte, then multiply by the 64-bit FNV prime 2^40 + 2^8 + 0xb3, modulo 2^64.
std::uint64_t reference_fnv1a64(const std::string& bytes) {
  std::uint64_t h = 14695981039346656037ULL;  // the offset basis, in decimal
  for (const unsigned char c : bytes) h = (h ^ c) * ((1ULL << 40) + (1ULL << 8) + 0xb3);
  return h;
}

TEST(Fnv1a64, MatchesTheSpecificationTestVectors) {
  EXPECT_EQ(fnv1a64(""), 0xcbf29ce484222325ULL);
  EXPECT_EQ(fnv1a64("a"), 0xaf63dc4c8601ec8cULL);
  EXPECT_EQ(fnv1a64("foobar"), 0x85944171f73967e8ULL);
  EXPECT_EQ(content_hash(""), "fnv1a64:cbf29ce484222325");
  EXPECT_EQ(content_hash("a"), "fnv1a64:af63dc4c8601ec8c");
  // Every byte value, including NUL and bytes >= 0x80 (no sign extension).
  std::string all;
  for (int i = 0; i < 256; ++i) all.push_back(static_cast<char>(i));
  EXPECT_EQ(fnv1a64(all), reference_fnv1a64(all));
  EXPECT_EQ(reference_fnv1a64("a"), 0xaf63dc4c8601ec8cULL);
}

class LogMetadataTest : public ::testing::Test {
 protected:
  Experiment experiment(const std::string& body) const {
    return parse_experiment("name: t\nmodel: " + kModel + "\n" + body, (dir_ / "t.yaml").string());
  }
  /// An open-loop run with every optional column group; returns its summary.
  RunSummary open_loop_run(const std::string& out, std::uint64_t seed = 9) const {
    return run_experiment(experiment(R"(
duration_s: 0.1
physics_dt_s: 0.002
integrator: euler
noise: true
wind_m_s: [1, 0, 0]
disturbances: {gyroscopic: false}
seed: )" + std::to_string(seed) + R"(
initial_state: {position_m: [0, 0, 1], rotor_speeds_rad_s: hover}
log: {every_n_steps: 5, wrench_breakdown: true, measured: true}
input: {type: hover}
)"),
                          (dir_ / out).string());
  }

  test::TempDir tmp_;
  const fs::path dir_ = tmp_.path();
};

TEST_F(LogMetadataTest, FileHashIsTheHashOfTheBytes) {
  write_all(dir_ / "a.txt", "a");
  EXPECT_EQ(file_hash((dir_ / "a.txt").string()), "fnv1a64:af63dc4c8601ec8c");
  write_all(dir_ / "empty.txt", "");
  EXPECT_EQ(file_hash((dir_ / "empty.txt").string()), "fnv1a64:cbf29ce484222325");
  const std::string missing = (dir_ / "missing.yaml").string();
  EXPECT_NE(error_of([&] { (void)file_hash(missing); }).find(missing), std::string::npos);
}

TEST_F(LogMetadataTest, RunWritesASidecarWithTheRunSettings) {
  const RunSummary s = open_loop_run("run");
  ASSERT_TRUE(s.ok()) << s.failure_message;
  EXPECT_EQ(s.metadata_path, (dir_ / "run" / "log.json").string());
  ASSERT_TRUE(fs::exists(s.metadata_path));
  EXPECT_NE(read_all(s.summary_path).find("\"metadata_path\": \"" + s.metadata_path + "\""),
            std::string::npos);

  const LogMetadata m = read_log_metadata(s.metadata_path);
  EXPECT_EQ(m.source, s.metadata_path);
  EXPECT_EQ(m.format, "dronetwin.run_log");
  EXPECT_EQ(m.format_version, 1);
  EXPECT_EQ(m.dronetwin_version, std::string(version()));
  EXPECT_EQ(m.experiment, "t");
  EXPECT_EQ(m.experiment_path, (dir_ / "t.yaml").string());
  EXPECT_EQ(m.input_type, "hover");
  EXPECT_EQ(m.model, "qdrone2");
  EXPECT_EQ(m.model_path, kModel);
  EXPECT_EQ(m.seed, 9u);
  EXPECT_EQ(m.dt_s, 0.002);
  EXPECT_EQ(m.integrator, Integrator::kEuler);
  EXPECT_TRUE(m.motor_dynamics);
  EXPECT_EQ(m.log_every_n_steps, 5);
  EXPECT_DOUBLE_EQ(m.log_rate_hz, 100.0);
  EXPECT_FALSE(m.controller_path.has_value());
  EXPECT_FALSE(m.control_rate_hz.has_value());
  EXPECT_TRUE(m.noise);
  EXPECT_FALSE(m.disturbances.gyroscopic);
  EXPECT_TRUE(m.disturbances.rotor_drag);
  EXPECT_TRUE(m.disturbances.body_drag);
  EXPECT_TRUE(m.ground);
  EXPECT_EQ(m.wind_m_s, Vec3(1, 0, 0));
  EXPECT_EQ(m.gravity_m_s2, Vec3(0, 0, -9.81));
  EXPECT_EQ(m.num_rotors, 4);

  // The rows really come at log_rate_hz.
  const LogTable log = read_csv_log(s.log_path);
  EXPECT_NEAR(log.at(1, log.column("t")) - log.at(0, log.column("t")), 1.0 / m.log_rate_hz, 1e-15);

  // One entry per CSV column, in order, each with a unit and a meaning.
  EXPECT_EQ(m.column_names(), log.columns);
  EXPECT_EQ(m.columns, log_columns({4, true, true}));
  for (const LogColumn& c : m.columns) {
    EXPECT_FALSE(c.unit.empty()) << c.name;
    EXPECT_FALSE(c.meaning.empty()) << c.name;
  }
  const std::map<std::string, std::string> units = {{"t", "s"},
                                                    {"x", "m"},
                                                    {"z", "m"},
                                                    {"vy", "m/s"},
                                                    {"qw", "1"},
                                                    {"qz", "1"},
                                                    {"wx", "rad/s"},
                                                    {"omega_0", "rad/s"},
                                                    {"omega_ref_3", "rad/s"},
                                                    {"meas_z", "m"},
                                                    {"meas_vz", "m/s"},
                                                    {"meas_qx", "1"},
                                                    {"meas_wz", "rad/s"},
                                                    {"in_contact", "bool"},
                                                    {"crashed", "bool"},
                                                    {"F_thrust_z", "N"},
                                                    {"F_gravity_x", "N"},
                                                    {"M_rotor_drag_y", "N m"},
                                                    {"M_gyroscopic_z", "N m"}};
  for (const auto& [name, unit] : units) EXPECT_EQ(m.column(name).unit, unit) << name;
  EXPECT_NE(error_of([&] { (void)m.column("nope"); }).find(s.metadata_path), std::string::npos);
}

TEST_F(LogMetadataTest, ModelHashIsTheHashOfTheModelFile) {
  const RunSummary s = open_loop_run("run");
  const LogMetadata m = read_log_metadata(s.metadata_path);
  ASSERT_TRUE(m.model_hash.has_value());
  EXPECT_EQ(*m.model_hash, file_hash(kModel));
  // Independently: the test's own FNV-1a over the bytes read here.
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx",
                static_cast<unsigned long long>(reference_fnv1a64(read_all(kModel))));
  EXPECT_EQ(*m.model_hash, std::string("fnv1a64:") + hex);
  // Another model file hashes differently.
  EXPECT_NE(*m.model_hash, file_hash(test::source_path("models/hexarotor.yaml")));
}

TEST_F(LogMetadataTest, ModelGivenInMemoryIsHashedOnlyWhenItIsTheFilesModel) {
  const Experiment e = experiment("duration_s: 0.01\ninput: {type: hover}\n");
  auto same = std::make_shared<const VehicleModel>(load_vehicle_model(kModel));
  const RunSummary a = run_experiment(e, same, (dir_ / "same").string());
  EXPECT_EQ(read_log_metadata(a.metadata_path).model_hash.value_or(""), file_hash(kModel));

  VehicleSpec spec = load_vehicle_spec(kModel);
  spec.mass_kg *= 1.1;  // same file name, different vehicle
  auto heavier = std::make_shared<const VehicleModel>(spec);
  const RunSummary b = run_experiment(e, heavier, (dir_ / "heavier").string());
  const LogMetadata m = read_log_metadata(b.metadata_path);
  EXPECT_FALSE(m.model_hash.has_value());
  EXPECT_EQ(m.model_path, kModel);
  EXPECT_NE(read_all(b.metadata_path).find("\"model_hash\": null,"), std::string::npos);
}

TEST_F(LogMetadataTest, ClosedLoopSidecarHasTheControlRateAndColumns) {
  const RunSummary s = run_experiment(experiment(R"(
duration_s: 0.05
initial_state: {position_m: [0, 0, 1], rotor_speeds_rad_s: hover}
log: {every_n_steps: 2, measured: false}
input:
  type: controller
  controller: )" + kPid + R"(
  control_rate_hz: 500
  reference: {type: setpoint, position_m: [0, 0, 1.1], yaw_rad: 0}
)"),
                                      (dir_ / "cl").string());
  ASSERT_TRUE(s.ok()) << s.failure_message;
  const RunLog log = read_run_log(s.log_path);
  ASSERT_TRUE(log.metadata.has_value());
  const LogMetadata& m = *log.metadata;
  EXPECT_EQ(m.input_type, "controller");
  EXPECT_EQ(m.controller_path.value_or(""), kPid);
  EXPECT_EQ(m.control_rate_hz.value_or(0.0), 500.0);
  EXPECT_DOUBLE_EQ(m.log_rate_hz, 500.0);
  EXPECT_FALSE(m.noise);
  EXPECT_EQ(m.column_names(), log.table.columns);
  const std::map<std::string, std::string> units = {
      {"ref_x", "m"},     {"ref_z", "m"},     {"ref_yaw", "rad"},   {"u_T", "N"},
      {"u_tau_x", "N m"}, {"u_tau_z", "N m"}, {"saturated", "bool"}};
  for (const auto& [name, unit] : units) EXPECT_EQ(m.column(name).unit, unit) << name;
}

TEST(LogColumns, ControllerDiagnosticUnitsComeFromTheNameSuffix) {
  LogLayout layout{4, false, false, true, {"solve_time_ms", "iterations", "delay_s", "yaw_rad"}};
  const std::vector<LogColumn> c = log_columns(layout);
  ASSERT_EQ(c.size(), log_column_names(layout).size());
  for (std::size_t i = 0; i < c.size(); ++i) EXPECT_EQ(c[i].name, log_column_names(layout)[i]);
  const auto unit = [&](const std::string& name) {
    for (const LogColumn& col : c)
      if (col.name == name) return col.unit;
    return std::string("missing");
  };
  EXPECT_EQ(unit("ctrl_solve_time_ms"), "ms");
  EXPECT_EQ(unit("ctrl_iterations"), "1");
  EXPECT_EQ(unit("ctrl_delay_s"), "s");
  EXPECT_EQ(unit("ctrl_yaw_rad"), "rad");
}

TEST_F(LogMetadataTest, IdenticalRunsGiveByteIdenticalSidecars) {
  const RunSummary a = open_loop_run("a");
  const RunSummary b = open_loop_run("b");
  const std::string ja = read_all(a.metadata_path), jb = read_all(b.metadata_path);
  EXPECT_FALSE(ja.empty());
  EXPECT_EQ(ja, jb);
  EXPECT_EQ(read_all(a.log_path), read_all(b.log_path));
  // Only the seed line differs for another seed.
  const RunSummary c = open_loop_run("c", 10);
  EXPECT_EQ(replace(read_all(c.metadata_path), "\"seed\": 10,", "\"seed\": 9,"), ja);
}

TEST_F(LogMetadataTest, JsonTextRoundTrips) {
  const RunSummary s = open_loop_run("run");
  const std::string text = read_all(s.metadata_path);
  const LogMetadata m = parse_log_metadata(text, "x.json");
  EXPECT_EQ(log_metadata_to_json(m), text);
  // A seed above 2^63 and a null controller path survive as well.
  LogMetadata big = m;
  big.seed = 18446744073709551615ULL;
  big.controller_path = "c.yaml";
  big.control_rate_hz = 250.0;
  const LogMetadata back = parse_log_metadata(log_metadata_to_json(big), "big.json");
  EXPECT_EQ(back.seed, big.seed);
  EXPECT_EQ(back.controller_path.value_or(""), "c.yaml");
  EXPECT_EQ(back.control_rate_hz.value_or(0.0), 250.0);
  EXPECT_EQ(log_metadata_to_json(back), log_metadata_to_json(big));
}

TEST_F(LogMetadataTest, MalformedSidecarsNameFileAndField) {
  const RunSummary s = open_loop_run("run");
  const std::string good = read_all(s.metadata_path);
  const fs::path bad = dir_ / "bad.json";
  struct Case {
    std::string from, to;
    std::vector<std::string> expected;
  };
  const std::vector<Case> cases = {
      {"\"dt_s\": 0.002", "\"dt_s\": \"fast\"", {"dt_s", "expected a number"}},
      {"\"dt_s\": 0.002", "\"dt_s\": -1", {"dt_s", "expected a number > 0"}},
      {"\"seed\": 9,\n", "", {"missing required key 'seed'"}},
      {"\"seed\": 9,", "\"seed\": 9, \"sede\": 1,", {"unknown key 'sede'"}},
      {"\"seed\": 9,", "\"seed\": -9,", {"seed", "expected an integer"}},
      {"\"format_version\": 1", "\"format_version\": 2", {"format_version", "got 2"}},
      {"\"format\": \"dronetwin.run_log\"",
       "\"format\": \"dronetwin.imported_log\"",
       {"format", "importer"}},
      {"\"model_hash\": \"fnv1a64:", "\"model_hash\": \"md5:", {"model_hash", "fnv1a64"}},
      {"\"integrator\": \"euler\"", "\"integrator\": \"rk5\"", {"integrator", "rk5"}},
      {"\"noise\": true", "\"noise\": \"true\"", {"noise", "expected true or false"}},
      {"\"gyroscopic\": false", "\"gyroscopic\": 0", {"disturbances.gyroscopic"}},
      {"\"wind_m_s\": [1, 0, 0]", "\"wind_m_s\": [1, 0]", {"wind_m_s", "expected 3 numbers"}},
      {"\"num_rotors\": 4", "\"num_rotors\": 9", {"num_rotors", "[1, 8]"}},
      {"\"model\": \"qdrone2\"", "\"model\": 5", {"model", "expected a non-empty string"}},
      {"{\"name\": \"x\", \"unit\": \"m\", ",
       "{\"name\": \"x\", ",
       {"columns[1]", "missing required key 'unit'"}},
      {"{\"name\": \"y\"", "{\"name\": \"x\"", {"columns[2].name", "duplicate column 'x'"}},
      {"\"columns\": [", "\"columns\": 3, \"c\": [", {"unknown key 'c'"}},
      {"\"experiment\": \"t\",", "\"experiment\": \"t\"", {"JSON syntax error", "line"}},
  };
  for (const Case& c : cases) {
    write_all(bad, replace(good, c.from, c.to));
    const std::string e = error_of([&] { (void)read_log_metadata(bad.string()); });
    EXPECT_EQ(e.rfind(bad.string() + ": ", 0), 0u) << e;  // starts with the file
    for (const std::string& x : c.expected) EXPECT_NE(e.find(x), std::string::npos) << e;
  }
  write_all(bad, "");
  EXPECT_NE(error_of([&] { (void)read_log_metadata(bad.string()); }).find("empty"),
            std::string::npos);
  write_all(bad, "[1, 2]");
  EXPECT_NE(error_of([&] { (void)read_log_metadata(bad.string()); }).find("JSON object"),
            std::string::npos);
  const std::string missing = (dir_ / "missing.json").string();
  EXPECT_NE(error_of([&] { (void)read_log_metadata(missing); }).find(missing), std::string::npos);
}

TEST_F(LogMetadataTest, ReadRunLogWithAndWithoutSidecar) {
  const RunSummary s = open_loop_run("run");
  EXPECT_EQ(sidecar_path(s.log_path), s.metadata_path);
  EXPECT_EQ(sidecar_path("out/flight.csv"), "out/flight.json");

  RunLog with = read_run_log(s.log_path);
  ASSERT_TRUE(with.metadata.has_value());
  EXPECT_EQ(with.metadata->seed, 9u);
  EXPECT_EQ(with.table.rows(), static_cast<std::size_t>(s.log_rows));

  // A sidecar that describes other columns than the CSV holds is an error naming both files.
  const std::string text = read_all(s.metadata_path);
  write_all(s.metadata_path, replace(text, "{\"name\": \"vx\"", "{\"name\": \"vx_m_s\""));
  const std::string e = error_of([&] { (void)read_run_log(s.log_path); });
  EXPECT_NE(e.find(s.metadata_path), std::string::npos) << e;
  EXPECT_NE(e.find(s.log_path), std::string::npos) << e;
  EXPECT_NE(e.find("'vx_m_s'"), std::string::npos) << e;

  fs::remove(s.metadata_path);
  const RunLog without = read_run_log(s.log_path);
  EXPECT_FALSE(without.metadata.has_value());
  EXPECT_EQ(without.table.columns, with.table.columns);
  EXPECT_EQ(without.table.values, with.table.values);
}

TEST_F(LogMetadataTest, UlogImportSidecarCarriesTheCoreFields) {
  const std::string stem = (dir_ / "flight").string();
  write_ulog_import(
      import_ulog(read_ulog(test::source_path("tests/data/real/px4-ulog-rs/esc_status_log.ulg"))),
      stem);
  const LogTable t = read_csv_log(stem + ".csv");
  const YAML::Node j = YAML::LoadFile(stem + ".json");
  EXPECT_EQ(j["format"].as<std::string>(), "dronetwin.imported_log");
  EXPECT_EQ(j["format_version"].as<int>(), 1);
  EXPECT_EQ(j["dronetwin_version"].as<std::string>(), std::string(version()));
  EXPECT_EQ(j["source_kind"].as<std::string>(), "PX4 ULog");
  EXPECT_EQ(j["rows"].as<std::size_t>(), t.rows());
  ASSERT_EQ(j["columns"].size(), t.columns.size());
  for (std::size_t i = 0; i < t.columns.size(); ++i) {
    EXPECT_EQ(j["columns"][i]["name"].as<std::string>(), t.columns[i]);
    EXPECT_FALSE(j["columns"][i]["unit"].as<std::string>().empty()) << t.columns[i];
    EXPECT_FALSE(j["columns"][i]["meaning"].as<std::string>().empty()) << t.columns[i];
  }
  EXPECT_EQ(j["columns"][0]["unit"].as<std::string>(), "s");
  EXPECT_EQ(j["columns"][t.column("acc_z")]["unit"].as<std::string>(), "m/s^2");
  EXPECT_EQ(j["num_rotors"].as<int>() > 0,
            std::find(t.columns.begin(), t.columns.end(), "omega_0") != t.columns.end());
  // A run-log reader refuses it by its format, not by a list of unknown keys.
  const std::string e = error_of([&] { (void)read_log_metadata(stem + ".json"); });
  EXPECT_NE(e.find("format: expected \"dronetwin.run_log\""), std::string::npos) << e;
  // log_sidecar_format tells the two kinds apart before choosing a reader.
  EXPECT_EQ(log_sidecar_format(stem + ".json"), kImportedLogFormat);
}

TEST_F(LogMetadataTest, SidecarFormatOfARunLogAndOfBadFiles) {
  ASSERT_TRUE(open_loop_run("run").ok());
  EXPECT_EQ(log_sidecar_format((dir_ / "run" / "log.json").string()), kRunLogFormat);
  write_all(dir_ / "noformat.json", "{\"seed\": 1}");
  EXPECT_EQ(log_sidecar_format((dir_ / "noformat.json").string()), "");
  write_all(dir_ / "broken.json", "{\"format\": [");
  const std::string e =
      error_of([&] { (void)log_sidecar_format((dir_ / "broken.json").string()); });
  EXPECT_NE(e.find("broken.json: line 1"), std::string::npos) << e;
  EXPECT_NE(e.find("JSON syntax error"), std::string::npos) << e;
}

TEST(LogMetadataReader, ASidecarThatIsNotUtf8IsRefusedWithLineAndColumn) {
  const std::string message = error_of(
      [] { (void)parse_log_metadata("{\n  \"format\": \"dronetwin \xFF\"\n}\n", "enc.json"); });
  EXPECT_NE(message.find("enc.json: line 2, column 24: expected UTF-8 text (as JSON is), got "
                         "byte 0xFF"),
            std::string::npos)
      << message;
}

// Found by the fuzzer: a raw NUL inside a string was accepted, written back as \u0000, and the
// written sidecar then did not read again. Raw control characters are refused up front; an
// accepted sidecar's JSON always reads back.
TEST(LogMetadataReader, ARawControlCharacterIsRefusedWithLineAndColumn) {
  std::string text = "{\n  \"format\": \"dronetwin.run_log\",\n  \"experiment\": \"se3_";
  text += std::string(1, '\0') + "circle\"\n}\n";
  const std::string message = error_of([&] { (void)parse_log_metadata(text, "nul.json"); });
  EXPECT_NE(message.find("nul.json: line 3, column 22: control character 0x00 inside a string"),
            std::string::npos)
      << message;
  text[56] = '\x01';
  EXPECT_NE(error_of([&] { (void)parse_log_metadata(text, "soh.json"); }).find("0x01"),
            std::string::npos);
  // JSON has no raw line breaks or tabs inside strings either (yaml-cpp would fold them).
  EXPECT_NE(error_of([] {
              (void)parse_log_metadata("{\"format\": \"dronetwin.\n run_log\"}", "nl.json");
            }).find("nl.json: line 1, column 23: control character 0x0a inside a string"),
            std::string::npos);
}

// Found by the fuzzer: yaml-cpp reads a sidecar as YAML, and YAML's escapes \N and \_ decode to
// the single bytes 0x85 and 0xA0, not UTF-8: the metadata was accepted and its JSON, written
// back, was not. Only JSON's escapes (and double-quoted strings) are read; the same characters
// written as JSON escapes read back.
TEST_F(LogMetadataTest, EscapesAndQuotesThatAreNotJsonAreRefused) {
  const auto message = [](const std::string& text) {
    return error_of([&] { (void)parse_log_metadata(text, "esc.json"); });
  };
  EXPECT_NE(
      message("{\n  \"format\": \"dronetwin\\N\"\n}")
          .find("esc.json: line 2, column 23: escape \\N is not JSON (JSON has \\\" \\\\ \\/ \\b "
                "\\f \\n \\r \\t \\uXXXX)"),
      std::string::npos)
      << message("{\n  \"format\": \"dronetwin\\N\"\n}");
  EXPECT_NE(message("{\"format\": \"a\\_b\"}").find("escape \\_ is not JSON"), std::string::npos);
  EXPECT_NE(message("{\"format\": \"a\\x41\"}").find("escape \\x is not JSON"), std::string::npos);
  EXPECT_NE(message("{\"format\": 'dronetwin.run_log'}")
                .find("line 1, column 12: a single quote (JSON strings are in double quotes)"),
            std::string::npos);
  // A quote inside a double-quoted string, escaped quotes and backslashes are JSON.
  EXPECT_NE(message("{\"format\": \"it's \\\"x\\\" \\\\\"}").find("expected \"dronetwin.run_log\""),
            std::string::npos);

  // The characters themselves, as \u escapes, go through and read back after writing.
  const LogMetadata m = parse_log_metadata(read_all(open_loop_run("run").metadata_path), "r.json");
  std::string text = log_metadata_to_json(m);
  const std::string key = "\"experiment\": \"";
  text.insert(text.find(key) + key.size(), "\\u0085\\u00a0");
  const LogMetadata escaped = parse_log_metadata(text, "u.json");
  EXPECT_EQ(escaped.experiment, "\u0085\u00a0" + m.experiment);
  EXPECT_EQ(parse_log_metadata(log_metadata_to_json(escaped), "again.json").experiment,
            escaped.experiment);
}

}  // namespace
}  // namespace dronetwin
