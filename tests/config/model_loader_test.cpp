// Tests of the YAML model loader (include/dronetwin/config/model_loader.hpp): every malformed file
// of tests/data/bad is rejected with a message naming the file and the field, the shipped models
// load, and save -> load reproduces every number bit for bit.
#include "dronetwin/config/model_loader.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "dronetwin/core/error.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

const std::string kSourceDir = DRONETWIN_SOURCE_DIR;
const std::string kBadDir = kSourceDir + "/tests/data/bad";

std::string model_path(const std::string& file) { return kSourceDir + "/models/" + file; }

using test::error_of;

// ---- the malformed-file corpus ----------------------------------------------------------------

/// `expected`: substrings the error message must contain, besides the file name.
using BadCase = test::BadFileCase;

// One row per file of tests/data/bad. A new file must get a row (CorpusIsFullyCovered checks).
const std::vector<BadCase> kBadCases = {
    {"collision_box_zero_height.yaml", {"collision.half_size_m: expected three numbers > 0"}},
    {"collision_missing_size.yaml", {"collision: missing required key 'half_size_m'"}},
    {"collision_negative_radius.yaml", {"collision.radius_m: expected > 0, got -0.5"}},
    {"collision_sphere_with_half_size.yaml",
     {"collision.half_size_m: a sphere has no half_size_m; use radius_m", "line 7"}},
    {"collision_unknown_shape.yaml", {"collision.shape: unknown collision shape 'cube'", "box"}},
    {"default_not_a_number.yaml",
     {"rotor_defaults.thrust_coefficients[1]: expected a number, got 'x'", "line 8"}},
    {"document_is_list.yaml", {"expected a map", "got a sequence of 2 items"}},
    {"duplicate_key.yaml", {"duplicate key 'mass_kg'", "line 6"}},
    {"empty_document.yaml", {"empty document"}},
    {"inertia_not_positive_definite.yaml", {"inertia_kgm2: expected a positive-definite matrix"}},
    {"inertia_not_symmetric.yaml", {"inertia_kgm2: expected a symmetric matrix"}},
    {"inertia_row_two_numbers.yaml", {"inertia_kgm2[1]: expected 3 numbers, got 2"}},
    {"inertia_triangle_inequality.yaml", {"inertia_kgm2:", "triangle inequality"}},
    {"inertia_two_rows.yaml",
     {"inertia_kgm2: expected 3 numbers (the diagonal) or 3 rows of 3 numbers, got a sequence "
      "of 2"}},
    {"inf_inertia.yaml", {"inertia_kgm2: expected finite numbers", "inf"}},
    {"mass_is_string.yaml", {"mass_kg: expected a number, got 'abc'"}},
    {"max_speed_below_min.yaml", {"rotors[0].max_speed_rad_s: expected > min_speed_rad_s"}},
    {"missing_mass_kg.yaml", {"missing required key 'mass_kg'"}},
    {"missing_rotor_key.yaml", {"rotors[2]: missing required key 'yaw_moment_per_thrust_m'"}},
    {"nan_mass.yaml", {"mass_kg: expected a finite number, got nan"}},
    {"nan_rotor_drag.yaml", {"rotors[0].rotor_drag_coefficient: expected a finite number"}},
    {"negative_ground_effect_height.yaml", {"ground_effect_min_height_m: expected > 0"}},
    {"negative_mass.yaml", {"mass_kg: expected > 0, got -1.504"}},
    {"negative_quadratic_thrust.yaml", {"rotors[0].thrust_coefficients[0]: expected >= 0"}},
    {"negative_time_constant.yaml", {"rotors[2].time_constant_fall_s: expected >= 0"}},
    {"nine_rotors.yaml", {"rotors: expected between 1 and 8 rotors, got 9"}},
    {"position_m_in_rotor_defaults.yaml", {"rotor_defaults: 'position_m' cannot have a default"}},
    {"position_two_numbers.yaml", {"rotors[2].position_m: expected 3 numbers, got 2"}},
    {"quoted_number.yaml", {"mass_kg: expected a number, got the string \"1.504\""}},
    {"rank_deficient_same_point.yaml", {"rotors: the allocation matrix", "rank 1, expected 4"}},
    {"rotor_key_typo.yaml",
     {"rotors[1]: unknown key 'rotor_dreg_coefficient'", "did you mean 'rotor_drag_coefficient'?"}},
    {"rotors_not_a_sequence.yaml", {"rotors: expected a sequence of rotor maps, got a map"}},
    {"spin_not_integer.yaml", {"rotors[1].spin: expected an integer, got '1.5'"}},
    {"spin_zero.yaml", {"rotors[0].spin: expected +1 or -1, got 0"}},
    {"thrust_curve_decreasing.yaml",
     {"rotors[0].thrust_coefficients: thrust must increase with speed"}},
    {"top_level_key_typo.yaml",
     {"unknown key 'ground_effect_min_hieght_m'", "did you mean 'ground_effect_min_height_m'?"}},
    {"two_documents.yaml", {"expected one YAML document, got 2"}},
    {"two_rotors.yaml", {"rotors: the allocation matrix", "rank 2, expected 4"}},
    {"yaml_syntax_error.yaml", {"line 5", "YAML syntax error"}},
    {"body_drag_not_dissipative.yaml", {"body_drag_Ns_per_m: expected a dissipative"}},
    {"zero_axis.yaml", {"rotors[3].axis: expected a non-zero direction"}},
    {"zero_mass.yaml", {"mass_kg: expected > 0, got 0"}},
    {"zero_rotors.yaml", {"rotors: expected between 1 and 8 rotors, got 0"}},
};

class BadModelFile : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadModelFile, IsRejectedNamingFileAndField) {
  const BadCase& c = GetParam();
  const std::string path = kBadDir + "/" + c.file;
  ASSERT_TRUE(fs::exists(path)) << path;
  const std::string message = error_of([&] { (void)load_vehicle_model(path); });
  EXPECT_NE(message.find(path), std::string::npos) << "message does not name the file: " << message;
  for (const std::string& part : c.expected)
    EXPECT_NE(message.find(part), std::string::npos)
        << "message lacks \"" << part << "\": " << message;
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadModelFile, ::testing::ValuesIn(kBadCases),
                         test::bad_file_case_name);

TEST(BadModelCorpus, IsFullyCovered) {
  std::set<std::string> on_disk;
  for (const auto& entry : fs::directory_iterator(kBadDir))
    if (entry.path().extension() == ".yaml") on_disk.insert(entry.path().filename().string());
  std::set<std::string> in_table;
  for (const BadCase& c : kBadCases) in_table.insert(c.file);
  EXPECT_EQ(in_table.size(), kBadCases.size()) << "a file appears twice in kBadCases";
  EXPECT_EQ(on_disk.size(), 43u) << "tests/data/bad changed: update kBadCases and this count";
  EXPECT_EQ(on_disk, in_table);
}

TEST(ModelLoader, UnreadableFileIsNamed) {
  const std::string missing = kBadDir + "/no_such_model.yaml";
  const std::string message = error_of([&] { (void)load_vehicle_spec(missing); });
  EXPECT_NE(message.find(missing), std::string::npos) << message;
  EXPECT_NE(message.find("cannot open"), std::string::npos) << message;
  const std::string dir_message = error_of([&] { (void)load_vehicle_spec(kBadDir); });
  EXPECT_NE(dir_message.find("directory"), std::string::npos) << dir_message;
}

// ---- the shipped models -----------------------------------------------------------------------

TEST(ModelLoader, QDrone2Loads) {
  const std::string path = model_path("qdrone2.yaml");
  const VehicleModel m = load_vehicle_model(path);
  EXPECT_EQ(m.name(), "qdrone2");
  EXPECT_EQ(m.spec().source, path);
  EXPECT_EQ(m.num_rotors(), 4);
  EXPECT_EQ(m.mass_kg(), 1.504);  // thesis Table 2.1
  const Vec3 j(0.0147209, 0.0169101, 0.029448);
  EXPECT_EQ(m.inertia_kgm2(), Mat3(j.asDiagonal()));
  EXPECT_EQ(m.body_drag_Ns_per_m(), Mat3(Vec3(0.3, 0.3, 0.25).asDiagonal()));
  EXPECT_EQ(m.ground_effect_min_height_m(), 0.023);
  const int spins[4] = {1, -1, -1, 1};  // thesis text under Eq. 2.24
  for (int i = 0; i < 4; ++i) {
    const RotorParams& r = m.rotor(i);
    EXPECT_EQ(r.spin, spins[i]) << i;
    EXPECT_EQ(r.axis, Vec3::UnitZ()) << i;
    EXPECT_EQ(r.thrust_coefficients[0], 1.9533e-6);
    EXPECT_EQ(r.thrust_coefficients[1], 8.594e-4);
    EXPECT_EQ(r.thrust_coefficients[2], -0.0121);
    EXPECT_EQ(r.yaw_moment_per_thrust_m, 1.0 / 68.9055);
    EXPECT_EQ(r.rotor_drag_coefficient, 0.00020673);
    EXPECT_EQ(r.rolling_moment_coefficient, 1e-8);
    EXPECT_EQ(r.drag_moment_coefficient, 1e-7);
    EXPECT_EQ(r.ground_effect_coefficient, 0.0006);
    EXPECT_EQ(r.inertia_kgm2, 4.92e-6);
    EXPECT_EQ(r.time_constant_rise_s, 5e-4);
    EXPECT_EQ(r.time_constant_fall_s, 5e-4);
    EXPECT_EQ(r.min_speed_rad_s, 0.0);
    EXPECT_EQ(r.max_speed_rad_s, 3400.0);
    EXPECT_EQ(r.position_m.z(), 0.023);
  }
  EXPECT_EQ(m.rotor(0).position_m, Vec3(-0.1016, -0.127, 0.023));  // Eq. 2.25 r_1, SDF rotor_0
}

TEST(ModelLoader, HexarotorsLoad) {
  const VehicleModel flat = load_vehicle_model(model_path("hexarotor.yaml"));
  EXPECT_EQ(flat.name(), "hexarotor");
  EXPECT_EQ(flat.num_rotors(), 6);
  EXPECT_EQ(flat.wrench_rank(), 4);
  const VehicleModel tilted = load_vehicle_model(model_path("tilted_hexarotor.yaml"));
  EXPECT_EQ(tilted.name(), "tilted_hexarotor");
  EXPECT_EQ(tilted.num_rotors(), 6);
  EXPECT_EQ(tilted.wrench_rank(), 6);
}

// ---- save -> load round trip ------------------------------------------------------------------

bool same_bits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

void expect_same_bits(const double* a, const double* b, int n, const std::string& what) {
  for (int i = 0; i < n; ++i)
    EXPECT_TRUE(same_bits(a[i], b[i])) << what << "[" << i << "]: " << a[i] << " vs " << b[i];
}

void expect_bitwise_equal(const VehicleSpec& a, const VehicleSpec& b) {
  EXPECT_EQ(a.name, b.name);
  expect_same_bits(&a.mass_kg, &b.mass_kg, 1, "mass_kg");
  expect_same_bits(a.inertia_kgm2.data(), b.inertia_kgm2.data(), 9, "inertia_kgm2");
  expect_same_bits(a.body_drag_Ns_per_m.data(), b.body_drag_Ns_per_m.data(), 9, "body_drag");
  expect_same_bits(&a.ground_effect_min_height_m, &b.ground_effect_min_height_m, 1, "h_min");
  ASSERT_EQ(a.collision.has_value(), b.collision.has_value());
  if (a.collision) {
    EXPECT_EQ(a.collision->kind, b.collision->kind);
    expect_same_bits(&a.collision->radius_m, &b.collision->radius_m, 1, "collision.radius_m");
    expect_same_bits(a.collision->half_size_m.data(), b.collision->half_size_m.data(), 3,
                     "collision.half_size_m");
    expect_same_bits(a.collision->center_B_m.data(), b.collision->center_B_m.data(), 3,
                     "collision.center_m");
  }
  ASSERT_EQ(a.rotors.size(), b.rotors.size());
  for (std::size_t i = 0; i < a.rotors.size(); ++i) {
    const RotorParams& x = a.rotors[i];
    const RotorParams& y = b.rotors[i];
    const std::string r = "rotors[" + std::to_string(i) + "].";
    expect_same_bits(x.position_m.data(), y.position_m.data(), 3, r + "position_m");
    expect_same_bits(x.axis.data(), y.axis.data(), 3, r + "axis");
    EXPECT_EQ(x.spin, y.spin) << r;
    expect_same_bits(x.thrust_coefficients.data(), y.thrust_coefficients.data(), 3, r + "thrust");
    const double xs[] = {
        x.yaw_moment_per_thrust_m, x.rotor_drag_coefficient,    x.rolling_moment_coefficient,
        x.drag_moment_coefficient, x.ground_effect_coefficient, x.inertia_kgm2,
        x.time_constant_rise_s,    x.time_constant_fall_s,      x.min_speed_rad_s,
        x.max_speed_rad_s};
    const double ys[] = {
        y.yaw_moment_per_thrust_m, y.rotor_drag_coefficient,    y.rolling_moment_coefficient,
        y.drag_moment_coefficient, y.ground_effect_coefficient, y.inertia_kgm2,
        y.time_constant_rise_s,    y.time_constant_fall_s,      y.min_speed_rad_s,
        y.max_speed_rad_s};
    expect_same_bits(xs, ys, 10, r + "scalars");
  }
}

/// A file path in the temp directory, unique per test and run, removed on destruction.
class TempFile {
 public:
  TempFile() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ =
        (fs::temp_directory_path() /
         ("dronetwin_" + std::string(info->name()) + "_" +
          std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()) + ".yaml"))
            .string();
  }
  ~TempFile() {
    std::error_code ec;
    fs::remove(path_, ec);
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

TEST(ModelLoader, SaveLoadRoundTripIsBitwiseForShippedModels) {
  for (const char* file : {"qdrone2.yaml", "hexarotor.yaml", "tilted_hexarotor.yaml"}) {
    SCOPED_TRACE(file);
    const VehicleSpec original = load_vehicle_spec(model_path(file));
    const TempFile tmp;
    save_vehicle_spec(original, tmp.path());
    const VehicleSpec reloaded = load_vehicle_spec(tmp.path());
    expect_bitwise_equal(original, reloaded);
    EXPECT_EQ(reloaded.source, tmp.path());
    // The saved file is itself a valid model.
    EXPECT_NO_THROW((void)load_vehicle_model(tmp.path()));
  }
}

TEST(ModelLoader, CollisionShapesRoundTripAndReachTheModel) {
  VehicleSpec spec = load_vehicle_spec(model_path("qdrone2.yaml"));
  for (const CollisionShape& shape :
       {CollisionShape::box(Vec3(0.31, 0.27, 0.1 / 3), Vec3(0.0, 0.0, 0.021)),
        CollisionShape::sphere(0.33)}) {
    spec.collision = shape;
    const TempFile tmp;
    save_vehicle_spec(spec, tmp.path());
    const VehicleSpec reloaded = load_vehicle_spec(tmp.path());
    expect_bitwise_equal(spec, reloaded);
    const VehicleModel model(reloaded);
    EXPECT_EQ(model.collision_shape().kind, shape.kind);
    EXPECT_EQ(model.collision_shape().half_size_m, shape.half_size_m);
  }
  // Without `collision:` the file writes none and the model has its rotor sphere.
  spec.collision.reset();
  EXPECT_EQ(vehicle_spec_to_yaml(spec).find("collision"), std::string::npos);
}

TEST(ModelLoader, RoundTripKeepsAwkwardNumbersBitForBit) {
  // Plain data: nothing here needs to be physical, only representable.
  VehicleSpec spec;
  spec.name = "odd \"name\": with # and 'quotes'";
  spec.mass_kg = 0.1 + 0.2;  // 0.30000000000000004
  spec.inertia_kgm2 << 1.0 / 3.0, 1e-300, -0.0, 1e-300, 2.0 / 3.0, 5e-324, -0.0, 5e-324, 1e300;
  spec.body_drag_Ns_per_m << std::acos(-1.0), std::exp(1.0), std::sqrt(2.0), 0.1, 0.7, 1.1,
      std::numeric_limits<double>::max(), std::numeric_limits<double>::min(),
      std::numeric_limits<double>::denorm_min();
  spec.ground_effect_min_height_m = std::nextafter(0.023, 1.0);
  RotorParams r;
  r.position_m = Vec3(-0.1, 1.0 / 7.0, std::nextafter(0.0, -1.0));
  r.axis = Vec3(std::sqrt(0.5), 0.0, std::sqrt(0.5));
  r.spin = -1;
  r.thrust_coefficients = {1.0 / 68.9055, 0.117 / 136.1356, -0.0121};
  r.yaw_moment_per_thrust_m = 123456789.123456789;
  r.rotor_drag_coefficient = 9007199254740993.0;  // 2^53 + 1 rounds to 2^53
  r.rolling_moment_coefficient = std::numeric_limits<double>::infinity();
  r.drag_moment_coefficient = -std::numeric_limits<double>::infinity();
  r.ground_effect_coefficient = 1e-7;
  r.inertia_kgm2 = 4.92e-6;
  r.time_constant_rise_s = 5e-4;
  r.time_constant_fall_s = 0.0;
  r.min_speed_rad_s = 1e22;
  r.max_speed_rad_s = 3400.0;
  spec.rotors = {r, r};
  spec.rotors[1].spin = 1;
  spec.rotors[1].position_m *= -1.0;

  const std::string text = vehicle_spec_to_yaml(spec);
  const VehicleSpec back = parse_vehicle_spec(text, "round-trip");
  expect_bitwise_equal(spec, back);

  // NaN survives as NaN (the payload is not part of the format).
  spec.rotors[0].inertia_kgm2 = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(
      std::isnan(parse_vehicle_spec(vehicle_spec_to_yaml(spec), "nan").rotors[0].inertia_kgm2));

  // An empty rotor list is written as [] and reads back empty.
  const VehicleSpec bare;
  const std::string bare_text = vehicle_spec_to_yaml(bare);
  EXPECT_NE(bare_text.find("rotors: []"), std::string::npos) << bare_text;
  EXPECT_TRUE(parse_vehicle_spec(bare_text, "bare").rotors.empty());
}

TEST(ModelLoader, WriterEmitsFullMatricesAndOneMapPerRotor) {
  const VehicleSpec spec = load_vehicle_spec(model_path("qdrone2.yaml"));
  const std::string text = vehicle_spec_to_yaml(spec);
  EXPECT_EQ(text.find("rotor_defaults"), std::string::npos) << text;
  EXPECT_NE(text.find("- [0.0147209, 0, 0]"), std::string::npos) << text;
  EXPECT_NE(text.find("0.014512629615923256"), std::string::npos) << text;
  std::size_t rotor_maps = 0;
  for (std::size_t at = text.find("position_m:"); at != std::string::npos;
       at = text.find("position_m:", at + 1))
    ++rotor_maps;
  EXPECT_EQ(rotor_maps, 4u);
}

// ---- binding rules ----------------------------------------------------------------------------

const char* kHead = R"(name: t
mass_kg: 1.5
inertia_kgm2: [0.015, 0.017, 0.03]
body_drag_Ns_per_m: [0.3, 0.3, 0.25]
)";

TEST(ModelLoader, RotorDefaultsMergeAndPerRotorOverride) {
  const std::string text = std::string(kHead) + R"(rotor_defaults:
  thrust_coefficients: [2e-6, 1e-3, 0]
  yaw_moment_per_thrust_m: 0.015
  rotor_drag_coefficient: 0.0002
  rolling_moment_coefficient: 0
  drag_moment_coefficient: 0
  ground_effect_coefficient: 0
  inertia_kgm2: 5e-6
  time_constant_rise_s: 0.001
  time_constant_fall_s: 0.002
  min_speed_rad_s: 0
  max_speed_rad_s: 3000
rotors:
  - {position_m: [0.1, 0.1, 0], spin: 1}
  - position_m: [-0.1, 0.1, 0]
    spin: -1
    rotor_drag_coefficient: 0.0003
    thrust_coefficients: [3e-6, 0, 0]
    axis: [0, 0.1, 1]
  - {position_m: [-0.1, -0.1, 0], spin: 1, max_speed_rad_s: 2500}
  - {position_m: [0.1, -0.1, 0], spin: -1}
)";
  const VehicleSpec s = parse_vehicle_spec(text, "inline.yaml");
  EXPECT_EQ(s.source, "inline.yaml");
  ASSERT_EQ(s.rotors.size(), 4u);
  // Defaults reach every rotor that does not set the key.
  for (std::size_t i : {0u, 2u, 3u}) {
    EXPECT_EQ(s.rotors[i].rotor_drag_coefficient, 0.0002) << i;
    EXPECT_EQ(s.rotors[i].thrust_coefficients[0], 2e-6) << i;
    EXPECT_EQ(s.rotors[i].axis, Vec3::UnitZ()) << i;  // built-in default when nobody sets it
  }
  for (const RotorParams& r : s.rotors) {
    EXPECT_EQ(r.yaw_moment_per_thrust_m, 0.015);
    EXPECT_EQ(r.inertia_kgm2, 5e-6);
    EXPECT_EQ(r.time_constant_rise_s, 0.001);
    EXPECT_EQ(r.time_constant_fall_s, 0.002);
  }
  // A rotor's own key wins, for that rotor only.
  EXPECT_EQ(s.rotors[1].rotor_drag_coefficient, 0.0003);
  EXPECT_EQ(s.rotors[1].thrust_coefficients[0], 3e-6);
  EXPECT_EQ(s.rotors[1].thrust_coefficients[1], 0.0);
  EXPECT_EQ(s.rotors[1].axis, Vec3(0, 0.1, 1));  // the spec keeps it as written
  EXPECT_EQ(s.rotors[2].max_speed_rad_s, 2500.0);
  EXPECT_EQ(s.rotors[3].max_speed_rad_s, 3000.0);
  EXPECT_EQ(s.rotors[1].spin, -1);
  EXPECT_EQ(s.rotors[0].position_m, Vec3(0.1, 0.1, 0));
  EXPECT_EQ(s.ground_effect_min_height_m, 0.023);  // documented default

  // The model normalises the axis.
  const VehicleModel m(s);
  EXPECT_NEAR(m.rotor(1).axis.norm(), 1.0, 1e-15);
  EXPECT_NEAR(m.rotor(1).axis.y() / m.rotor(1).axis.z(), 0.1, 1e-15);
}

TEST(ModelLoader, DiagonalAndFullMatrixFormsAgree) {
  const std::string rotors = R"(rotors:
  - {position_m: [0.1, 0.1, 0], spin: 1, thrust_coefficients: [2e-6, 1e-3, 0],
     yaw_moment_per_thrust_m: 0.015, rotor_drag_coefficient: 0, rolling_moment_coefficient: 0,
     drag_moment_coefficient: 0, ground_effect_coefficient: 0, inertia_kgm2: 0,
     time_constant_rise_s: 0, time_constant_fall_s: 0, min_speed_rad_s: 0, max_speed_rad_s: 1}
)";
  const auto parse = [&rotors](const std::string& head, const std::string& name) {
    return parse_vehicle_spec("name: x\nmass_kg: 1\n" + head + rotors, name);
  };
  const VehicleSpec diagonal = parse(
      "inertia_kgm2: [0.0147209, 0.0169101, 0.029448]\n"
      "body_drag_Ns_per_m: [0.3, 0.3, 0.25]\n",
      "diagonal");
  const VehicleSpec full = parse(
      "inertia_kgm2:\n  - [0.0147209, 0, 0]\n  - [0, 0.0169101, 0]\n  - [0, 0, 0.029448]\n"
      "body_drag_Ns_per_m: [[0.3, 0, 0], [0, 0.3, 0], [0, 0, 0.25]]\n",
      "full");
  EXPECT_EQ(diagonal.inertia_kgm2, full.inertia_kgm2);
  EXPECT_EQ(diagonal.body_drag_Ns_per_m, full.body_drag_Ns_per_m);
  Mat3 expected = Mat3::Zero();
  expected.diagonal() << 0.0147209, 0.0169101, 0.029448;
  EXPECT_EQ(full.inertia_kgm2, expected);

  // Rows are rows: the full form keeps off-diagonal terms where they were written.
  const VehicleSpec off = parse(
      "inertia_kgm2: [[1, 2, 3], [4, 5, 6], [7, 8, 9]]\n"
      "body_drag_Ns_per_m: [0, 0, 0]\n",
      "off");
  EXPECT_EQ(off.inertia_kgm2(0, 1), 2.0);
  EXPECT_EQ(off.inertia_kgm2(1, 0), 4.0);
  EXPECT_EQ(off.inertia_kgm2(2, 0), 7.0);
}

TEST(ModelLoader, NumberGrammar) {
  const auto mass = [](const std::string& value) {
    return parse_vehicle_spec(std::string("name: n\nmass_kg: ") + value +
                                  "\ninertia_kgm2: [1, 1, 1]\nbody_drag_Ns_per_m: [0, 0, 0]\n"
                                  "rotors: []\n",
                              "numbers")
        .mass_kg;
  };
  EXPECT_EQ(mass("1.5"), 1.5);
  EXPECT_EQ(mass("+1.5"), 1.5);
  EXPECT_EQ(mass("-2"), -2.0);
  EXPECT_EQ(mass(".5"), 0.5);
  EXPECT_EQ(mass("3."), 3.0);
  EXPECT_EQ(mass("1e3"), 1000.0);
  EXPECT_EQ(mass("1.5E-3"), 1.5e-3);
  EXPECT_EQ(mass("!!float 2"), 2.0);
  EXPECT_EQ(mass(".inf"), std::numeric_limits<double>::infinity());
  EXPECT_EQ(mass("-.Inf"), -std::numeric_limits<double>::infinity());
  EXPECT_TRUE(std::isnan(mass(".NaN")));
  for (const char* bad : {"abc", "inf", "nan", "1,5", "1e", "e3", "0x10", "1_000", "--1", "1.2.3",
                          "\"2\"", "'2'", "!!str 2", "[1]", "{a: 1}", "~", "1e999"}) {
    const std::string message = error_of([&] { (void)mass(bad); });
    EXPECT_NE(message.find("numbers: mass_kg: expected a number, got"), std::string::npos)
        << bad << " -> " << message;
  }
  // An empty value is null, not zero.
  EXPECT_NE(error_of([&] { (void)mass(""); }).find("got nothing (null)"), std::string::npos);
}

TEST(ModelLoader, ReportsEveryMissingKeyAtOnce) {
  const std::string message =
      error_of([] { (void)parse_vehicle_spec("name: x\nmass_kg: 1\n", "partial.yaml"); });
  EXPECT_NE(message.find("partial.yaml: missing required keys 'inertia_kgm2', "
                         "'body_drag_Ns_per_m', 'rotors'"),
            std::string::npos)
      << message;
}

TEST(ModelLoader, MissingRotorKeysAreListed) {
  const std::string message = error_of([] {
    (void)parse_vehicle_spec(std::string(kHead) + "rotors:\n  - {position_m: [0, 0, 0], spin: 1}\n",
                             "r.yaml");
  });
  EXPECT_NE(message.find("r.yaml: rotors[0]: missing required keys 'thrust_coefficients', "
                         "'yaw_moment_per_thrust_m'"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("'max_speed_rad_s'"), std::string::npos) << message;
  EXPECT_EQ(message.find("'axis'"), std::string::npos) << "axis is optional: " << message;
}

TEST(ModelLoader, SourceNameAndLineAppearInMessages) {
  const std::string message = error_of([] {
    (void)parse_vehicle_spec(std::string(kHead) + "rotors:\n  - {position_m: [0, 0], spin: 1}\n",
                             "somewhere/model.yaml");
  });
  EXPECT_EQ(
      message.rfind("somewhere/model.yaml: rotors[0].position_m: expected 3 numbers, got 2", 0), 0u)
      << message;
  EXPECT_NE(message.find("(line 6)"), std::string::npos) << message;
}

TEST(ModelLoader, LoadVehicleModelNamesTheFileInPhysicalErrors) {
  const TempFile tmp;
  {
    std::ofstream out(tmp.path());
    out << "name: heavy\nmass_kg: -3\ninertia_kgm2: [1, 1, 1]\nbody_drag_Ns_per_m: [0, 0, 0]\n"
           "rotors: []\n";
  }
  // The spec alone parses (physical checks belong to VehicleModel) ...
  EXPECT_EQ(load_vehicle_spec(tmp.path()).mass_kg, -3.0);
  // ... and the model names the file, not just the vehicle.
  const std::string message = error_of([&] { (void)load_vehicle_model(tmp.path()); });
  EXPECT_EQ(message.rfind(tmp.path() + ": mass_kg: expected > 0, got -3", 0), 0u) << message;
}

TEST(ModelLoader, TextThatIsNotUtf8IsRefusedWithLineAndColumn) {
  // YAML is UTF-8: a file in another encoding, or a corrupted one, is refused at its first bad
  // byte (the fuzzers' first inputs held such bytes).
  const auto message = [](const std::string& yaml) {
    return error_of([&] { (void)parse_vehicle_spec(yaml, "enc.yaml"); });
  };
  EXPECT_NE(
      message("name: x\nmass_kg: [1.0\x9e"
              "2]\n")
          .find("enc.yaml: line 2, column 14: expected UTF-8 text (as YAML is), got byte 0x9E"),
      std::string::npos);
  EXPECT_NE(message("# \xC0\xAF overlong\n")
                .find("line 1, column 3: expected UTF-8 text (as YAML is), got byte 0xC0"),
            std::string::npos);
  EXPECT_NE(message("# \xED\xA0\x80 surrogate\n")
                .find("line 1, column 3: expected UTF-8 text (as YAML is), got byte 0xA0 inside a "
                      "multi-byte character"),
            std::string::npos);
  EXPECT_NE(message("# \xF4\x90\x80\x80 past U+10FFFF\n")
                .find("got byte 0x90 inside a multi-byte character"),
            std::string::npos);
  EXPECT_NE(message("# arrow \xE2\x86")
                .find("line 1, column 9: expected UTF-8 text (as YAML is), got byte 0xE2 (a "
                      "character cut off at the end)"),
            std::string::npos);
  // yaml-cpp decodes the YAML escapes \N and \_ to single bytes that are not UTF-8: a name
  // holding them would make every log sidecar written with it unreadable (found by the fuzzers).
  {
    std::ifstream in(model_path("qdrone2.yaml"), std::ios::binary);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::size_t at = text.find("name: qdrone2");
    ASSERT_NE(at, std::string::npos);
    text.replace(at, 13, "name: \"qdrone\\N2\"");
    EXPECT_NE(
        message(text).find("enc.yaml: name: the string is not UTF-8 once its escapes are decoded"),
        std::string::npos)
        << message(text);
  }
  // Well-formed UTF-8 of every length is fine.
  std::ifstream in(model_path("qdrone2.yaml"), std::ios::binary);
  const std::string qdrone2((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const VehicleSpec spec =
      parse_vehicle_spec("# \xC3\xA9 \xE2\x86\x92 \xF0\x9F\x9A\x81 \n" + qdrone2, "utf8.yaml");
  EXPECT_EQ(spec.name, "qdrone2");
}

TEST(ModelLoader, AStrayCommaOrBracketIsASyntaxErrorNotAHang) {
  // yaml-cpp 0.7's LoadAll adds empty documents without end at a ',' or ']' outside a flow
  // collection (found by the model_loader and experiment fuzzers; 1.5 GB after 10 s).
  const auto message = [](const std::string& yaml) {
    return error_of([&] { (void)parse_vehicle_spec(yaml, "stray.yaml"); });
  };
  EXPECT_NE(message(",\n").find("stray.yaml: line 1, column 1: YAML syntax error: unexpected ','"),
            std::string::npos)
      << message(",\n");
  std::ifstream in(
      test::source_path("tests/fuzz/corpus/model_loader/finding_timeout_stray_flow_indicator.yaml"),
      std::ios::binary);
  const std::string finding =
      message(std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()));
  EXPECT_NE(finding.find("stray.yaml: line "), std::string::npos) << finding;
  EXPECT_NE(finding.find("YAML syntax error"), std::string::npos) << finding;
  // Two documents are still refused as such.
  EXPECT_NE(message("name: a\n---\nname: b\n")
                .find("expected one YAML document, got 2 or more (the second starts at line 2)"),
            std::string::npos)
      << message("name: a\n---\nname: b\n");
}

}  // namespace
}  // namespace dronetwin
