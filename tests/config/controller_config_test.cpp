// Tests of controller files (include/dronetwin/config/controller_config.hpp): the shipped configs
// hold the thesis gains and exactly the documented deviations, the mass and period reach the
// controllers, and every file of tests/data/bad_controllers is rejected with a message that
// starts with the file and names the field.
#include "dronetwin/config/controller_config.hpp"
#include "dronetwin/app/controller_registry.hpp"

#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "dronetwin/control/pid.hpp"
#include "dronetwin/control/se3.hpp"
#include "dronetwin/core/error.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

const std::string kConfigDir = test::source_path("config/controllers");
const std::string kBadDir = test::source_path("tests/data/bad_controllers");

using test::error_of;

ControllerConfig shipped(const std::string& name) {
  return load_controller_config(kConfigDir + "/" + name + ".yaml");
}

// ---- the shipped configs ----------------------------------------------------------------------

TEST(ControllerConfig, PidThesisIsEquation321WithEveryModificationOff) {
  const ControllerConfig c = shipped("pid_thesis");
  ASSERT_EQ(c.type(), ControllerType::kPid);
  const PidGains t = PidGains::thesis_simulation();
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.outer_p, t.outer_p);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.outer_d, t.outer_d);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.outer_i, t.outer_i);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.inner_p, t.inner_p);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.inner_d1, t.inner_d1);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.inner_d2, t.inner_d2);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.outer_p,
            Vec4(0.471, 0.471, 31.5, 0.075));  // Eq. 3.21 spot check
  const PidOptions printed;
  EXPECT_TRUE(std::isinf(std::get<PidSettings>(c.settings).options.max_tilt_rad));
  EXPECT_TRUE(std::get<PidSettings>(c.settings).options.integral_limit.array().isInf().all());
  EXPECT_EQ(std::get<PidSettings>(c.settings).options.conditional_integration,
            printed.conditional_integration);
  EXPECT_FALSE(std::get<PidSettings>(c.settings).options.yaw_error_wrap);
  EXPECT_FALSE(std::get<PidSettings>(c.settings).options.velocity_feedforward);
  EXPECT_FALSE(std::get<PidSettings>(c.settings).options.yaw_frame_mapping);
  EXPECT_EQ(std::get<PidSettings>(c.settings).options.yaw_loop, PidYawLoop::kThesis);
  EXPECT_EQ(c.allocation, AllocationMethod::kThesis);
  EXPECT_FALSE(c.mass_kg.has_value());
  EXPECT_EQ(c.gravity_m_s2, 9.81);
}

TEST(ControllerConfig, PidHardwareIsEquation322AsPrinted) {
  const ControllerConfig c = shipped("pid_hardware");
  ASSERT_EQ(c.type(), ControllerType::kPid);
  const PidGains t = PidGains::thesis_hardware();
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.outer_p, t.outer_p);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.outer_d, t.outer_d);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.outer_i, t.outer_i);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.inner_p, t.inner_p);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.inner_d1, t.inner_d1);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.inner_d2, t.inner_d2);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.inner_p,
            Vec3(12, 12, 2.0));  // Eq. 3.22 spot check
  EXPECT_TRUE(std::isinf(std::get<PidSettings>(c.settings).options.max_tilt_rad));
  EXPECT_FALSE(std::get<PidSettings>(c.settings).options.conditional_integration ||
               std::get<PidSettings>(c.settings).options.yaw_error_wrap ||
               std::get<PidSettings>(c.settings).options.velocity_feedforward ||
               std::get<PidSettings>(c.settings).options.yaw_frame_mapping);
}

TEST(ControllerConfig, FlyingPidDiffersFromTheThesisOnlyWhereDocumented) {
  // docs/controllers.md lists these deviations; this keeps the list and the file in step.
  const ControllerConfig c = shipped("pid");
  ASSERT_EQ(c.type(), ControllerType::kPid);
  const PidGains t = PidGains::thesis_simulation();
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.outer_p, t.outer_p);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.outer_d, t.outer_d);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.outer_i, t.outer_i);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.inner_p, t.inner_p);
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.inner_d1,
            Vec3(0.5, 0.5, 0.0));  // raised roll/pitch D (notes #34)
  EXPECT_EQ(std::get<PidSettings>(c.settings).gains.inner_d2, t.inner_d2);
  EXPECT_EQ(std::get<PidSettings>(c.settings).options.max_tilt_rad, 0.2);
  EXPECT_EQ(std::get<PidSettings>(c.settings).options.integral_limit, Vec4(0.5, 0.5, 0.5, 1.0));
  EXPECT_TRUE(std::get<PidSettings>(c.settings).options.conditional_integration);
  EXPECT_TRUE(std::get<PidSettings>(c.settings).options.yaw_error_wrap);
  EXPECT_TRUE(std::get<PidSettings>(c.settings).options.velocity_feedforward);
  EXPECT_TRUE(std::get<PidSettings>(c.settings).options.yaw_frame_mapping);
  EXPECT_EQ(std::get<PidSettings>(c.settings).options.yaw_loop, PidYawLoop::kThesis);
  EXPECT_EQ(c.allocation, AllocationMethod::kExact);
}

TEST(ControllerConfig, Se3ThesisIsEquation329WithEveryModificationOff) {
  const ControllerConfig c = shipped("se3_thesis");
  ASSERT_EQ(c.type(), ControllerType::kSe3);
  const Se3Gains t = Se3Gains::thesis();
  EXPECT_EQ(std::get<Se3Settings>(c.settings).gains.position_p, t.position_p);
  EXPECT_EQ(std::get<Se3Settings>(c.settings).gains.position_d, t.position_d);
  EXPECT_EQ(std::get<Se3Settings>(c.settings).gains.attitude_p, t.attitude_p);
  EXPECT_EQ(std::get<Se3Settings>(c.settings).gains.attitude_d, t.attitude_d);
  EXPECT_EQ(std::get<Se3Settings>(c.settings).gains.position_d,
            Vec3(5.7746, 6.0022, 14.5));  // Eq. 3.29 spot check
  EXPECT_FALSE(std::get<Se3Settings>(c.settings).options.gravity_compensation);
  EXPECT_TRUE(std::isinf(std::get<Se3Settings>(c.settings).options.max_tilt_rad));
  EXPECT_FALSE(std::get<Se3Settings>(c.settings).options.nonnegative_thrust);
  EXPECT_EQ(c.allocation, AllocationMethod::kThesis);
}

TEST(ControllerConfig, FlyingSe3DiffersFromTheThesisOnlyWhereDocumented) {
  const ControllerConfig c = shipped("se3");
  ASSERT_EQ(c.type(), ControllerType::kSe3);
  const Se3Gains t = Se3Gains::thesis();
  EXPECT_EQ(std::get<Se3Settings>(c.settings).gains.position_p, t.position_p);
  EXPECT_EQ(std::get<Se3Settings>(c.settings).gains.position_d, t.position_d);
  EXPECT_EQ(std::get<Se3Settings>(c.settings).gains.attitude_p, t.attitude_p);
  EXPECT_EQ(std::get<Se3Settings>(c.settings).gains.attitude_d,
            Vec3(0.8, 0.8, 0.05));  // faster attitude loop (notes #36)
  EXPECT_TRUE(std::get<Se3Settings>(c.settings).options.gravity_compensation);  // notes #35
  EXPECT_EQ(std::get<Se3Settings>(c.settings).options.max_tilt_rad, 0.5);
  EXPECT_TRUE(std::get<Se3Settings>(c.settings).options.nonnegative_thrust);
  EXPECT_EQ(c.allocation, AllocationMethod::kExact);
}

// se3_feed_forward.yaml is se3.yaml with the two feed-forward options on (the comparison of
// docs/controllers.md, section 3.4, rests on that); se3.yaml has them off.
TEST(ControllerConfig, FeedForwardSe3IsTheFlyingSe3WithBothFeedForwards) {
  const auto se3 = std::get<Se3Settings>(shipped("se3").settings);
  const auto ff = std::get<Se3Settings>(shipped("se3_feed_forward").settings);
  EXPECT_EQ(ff.gains.position_p, se3.gains.position_p);
  EXPECT_EQ(ff.gains.position_d, se3.gains.position_d);
  EXPECT_EQ(ff.gains.attitude_p, se3.gains.attitude_p);
  EXPECT_EQ(ff.gains.attitude_d, se3.gains.attitude_d);
  EXPECT_EQ(ff.options.gravity_compensation, se3.options.gravity_compensation);
  EXPECT_EQ(ff.options.max_tilt_rad, se3.options.max_tilt_rad);
  EXPECT_EQ(ff.options.nonnegative_thrust, se3.options.nonnegative_thrust);
  EXPECT_FALSE(se3.options.angular_feed_forward || se3.options.drag_feed_forward);
  EXPECT_TRUE(ff.options.angular_feed_forward && ff.options.drag_feed_forward);
}

TEST(ControllerConfig, MassDefaultsToTheModelAndPeriodToTheRate) {
  const auto model = test::load_model("qdrone2");
  const auto pid = load_controller(kConfigDir + "/pid.yaml", model, 250.0);
  const auto* p = dynamic_cast<const CascadedPid*>(pid.get());
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(p->gains().mass_kg, model->mass_kg());
  EXPECT_EQ(p->gains().mass_kg, 1.504);  // the thesis's m (Eq. 3.18)
  EXPECT_EQ(p->control_period_s(), 1.0 / 250.0);
  EXPECT_EQ(p->allocation(), AllocationMethod::kExact);

  const auto hexa = test::load_model("hexarotor");
  const auto se3 = load_controller(kConfigDir + "/se3.yaml", hexa, 1000.0);
  const auto* s = dynamic_cast<const Se3Controller*>(se3.get());
  ASSERT_NE(s, nullptr);
  EXPECT_EQ(s->gains().mass_kg, hexa->mass_kg());
}

TEST(ControllerConfig, FileMassAndGravityOverrideTheModel) {
  const std::string text = R"(
type: se3
mass_kg: 2.5
gravity_m_s2: 9.80665
gains:
  position_p: [1, 2, 3]
  position_d: [4, 5, 6]
  attitude_p: [7, 8, 9]
  attitude_d: [0.1, 0.2, 0.3]
)";
  const auto c = make_controller_from_yaml(text, "mem.yaml", test::load_model("qdrone2"), 100.0);
  const auto& s = dynamic_cast<const Se3Controller&>(*c);
  EXPECT_EQ(s.gains().mass_kg, 2.5);
  EXPECT_EQ(s.gains().gravity_m_s2, 9.80665);
  EXPECT_EQ(s.gains().attitude_d, Vec3(0.1, 0.2, 0.3));
  EXPECT_FALSE(s.options().gravity_compensation);  // omitted options = as printed
}

TEST(ControllerConfig, EveryPidOptionParses) {
  const std::string text = R"(
type: pid
description: all options
allocation: thesis
gains:
  outer_p: [1, 1, 1, 1]
  outer_d: [1, 1, 1, 1]
  outer_i: [0, 0, 0, 0]
  inner_p: [1, 1, 1]
  inner_d1: [0, 0, 0]
  inner_d2: [0, 0, 0]
limits:
  max_tilt_rad: 0.3
  integral_limit: [1, 2, 3, 4]
options:
  conditional_integration: true
  yaw_error_wrap: true
  velocity_feedforward: true
  yaw_frame_mapping: true
  yaw_loop: rate
  acceleration_feed_forward: true
  angular_feed_forward: true
  drag_feed_forward: true
)";
  const ControllerConfig c = parse_controller_config(text, "mem.yaml");
  EXPECT_EQ(c.description, "all options");
  EXPECT_EQ(c.allocation, AllocationMethod::kThesis);
  EXPECT_EQ(std::get<PidSettings>(c.settings).options.max_tilt_rad, 0.3);
  EXPECT_EQ(std::get<PidSettings>(c.settings).options.integral_limit, Vec4(1, 2, 3, 4));
  EXPECT_TRUE(std::get<PidSettings>(c.settings).options.conditional_integration &&
              std::get<PidSettings>(c.settings).options.yaw_error_wrap &&
              std::get<PidSettings>(c.settings).options.velocity_feedforward &&
              std::get<PidSettings>(c.settings).options.yaw_frame_mapping);
  EXPECT_EQ(std::get<PidSettings>(c.settings).options.yaw_loop, PidYawLoop::kRate);
  EXPECT_TRUE(std::get<PidSettings>(c.settings).options.acceleration_feed_forward &&
              std::get<PidSettings>(c.settings).options.angular_feed_forward &&
              std::get<PidSettings>(c.settings).options.drag_feed_forward);
}

TEST(ControllerConfig, ExactMessagesForTheCommonMistakes) {
  const std::string path = kBadDir + "/outer_p_three_numbers.yaml";
  EXPECT_EQ(error_of([&] { load_controller_config(path); }),
            path + ": gains.outer_p: expected 4 numbers [x, y, z, psi], got 3 (line 4)");
  const std::string type_path = kBadDir + "/unknown_type.yaml";
  EXPECT_EQ(error_of([&] { load_controller_config(type_path); }),
            type_path + ": type: expected one of pid, se3, nmpc, policy, got 'pdi' (line 2)");
}

TEST(ControllerConfig, MissingFileAndBadRateAreRejected) {
  const auto model = test::load_model("qdrone2");
  EXPECT_NE(error_of([&] {
              load_controller(kConfigDir + "/no_such.yaml", model, 1000.0);
            }).find("no_such.yaml: cannot open"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              load_controller(kConfigDir + "/pid.yaml", model, 0.0);
            }).find("control_rate_hz"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              load_controller(kConfigDir + "/pid.yaml", nullptr, 100.0);
            }).find("model is null"),
            std::string::npos);
}

// ---- the malformed-file corpus ----------------------------------------------------------------

struct BadCase {
  const char* file;
  /// Substring the message must contain after "<file>: " (the field and what is wrong).
  const char* expected;
};

void PrintTo(const BadCase& c, std::ostream* os) { *os << c.file; }

// One row per file of tests/data/bad_controllers (CorpusIsFullyCovered checks).
const std::vector<BadCase> kBadCases = {
    {"duplicate_key.yaml", "gains: duplicate key 'outer_p'"},
    {"gain_key_typo.yaml",
     "gains: unknown key 'inner_d3'; did you mean 'inner_d1'? (valid keys: outer_p, outer_d, "
     "outer_i, inner_p, inner_d1, inner_d2)"},
    {"gains_not_a_map.yaml", "gains: expected a map of PID gains, got a sequence of 4 items"},
    {"inf_mass.yaml", "mass_kg: expected a finite number, got .inf"},
    {"limit_at_top_level.yaml", "unknown key 'max_tilt_rad' (valid keys: type"},
    {"missing_gain.yaml", "gains: missing required key 'outer_i'"},
    {"missing_type.yaml", "missing required key 'type'"},
    {"nan_gain.yaml", "gains.outer_d[2]: expected a finite number, got .nan"},
    {"nmpc_blocks_wrong_sum.yaml",
     "horizon.input_blocks: block lengths sum to 90; expected horizon.steps = 100"},
    {"nmpc_horizon_in_se3.yaml", "horizon: only for type nmpc"},
    {"nmpc_missing_horizon.yaml", "missing required key 'horizon'"},
    {"nmpc_negative_moment_observer.yaml",
     "disturbance.moment_time_constant_s: expected a number > 0, got -0.05"},
    {"nmpc_state_weights_12.yaml",
     "weights.state: expected 13 numbers [p (3), v (3), q (4), w (3)], got 12"},
    {"nmpc_step_not_multiple.yaml",
     "nmpc: step_s: expected a whole multiple of the call period 1 / 1000 s, got 0.0015 s"},
    {"nmpc_thrust_bounds_swapped.yaml",
     "limits.thrust_N: expected max cos(max_tilt_rad) > min (room for a tilted thrust), got [20.0, "
     "15.0]"},
    {"nmpc_unknown_linear_solver.yaml",
     "solver.linear_solver: expected one of dense_normal_cholesky, dense_qr, got 'sparse_schur'"},
    {"negative_gain.yaml", "gains.inner_d1[0]: expected a gain >= 0, got -0.5"},
    {"outer_p_three_numbers.yaml", "gains.outer_p: expected 4 numbers [x, y, z, psi], got 3"},
    {"payload_in_pid.yaml", "payload: only for type se3 (its payload awareness)"},
    {"payload_shaping_without_tether.yaml",
     "payload.shape_reference: shaping needs the payload's mass_kg > 0 and tether_length_m"},
    {"pid_limit_in_se3.yaml",
     "limits: unknown key 'integral_limit' (valid keys: max_tilt_rad, min_thrust_N)"},
    {"policy_env_and_training.yaml",
     "env: expected either training (the policy's training file) or env (its environment file)"},
    {"policy_gains_given.yaml", "gains: not used by type policy"},
    {"policy_key_in_se3.yaml", "policy: only for type policy"},
    {"policy_missing_file.yaml", "policy: policy (.dtpolicy) file"},
    {"policy_wrong_action_mode.yaml", "action_mode: the policy was trained with"},
    {"position_p_four_numbers.yaml", "gains.position_p: expected 3 numbers [x, y, z], got 4"},
    {"quoted_number.yaml", "gains.outer_p[1]: expected a number, got the string \"0.471\""},
    {"tilt_in_degrees.yaml", "limits.max_tilt_rad: expected an angle in (0, pi/2) rad, got 30"},
    {"two_documents.yaml", "expected one YAML document, got 2"},
    {"unknown_allocation.yaml", "allocation: expected one of exact, thesis, got 'pseudo_inverse'"},
    {"unknown_type.yaml", "type: expected one of pid, se3, nmpc, policy, got 'pdi'"},
    {"unknown_yaw_loop.yaml", "options.yaw_loop: expected one of thesis, rate, got 'angle'"},
    {"yaml_syntax_error.yaml", "YAML syntax error"},
    {"yes_is_not_a_bool.yaml", "options.yaw_error_wrap: expected true or false, got 'yes'"},
    {"zero_integral_limit.yaml", "limits.integral_limit[2]: expected a number > 0, got 0"},
    {"zero_mass.yaml", "mass_kg: expected a number > 0, got 0"},
};

class BadControllerFile : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadControllerFile, IsRejectedNamingFileAndField) {
  const BadCase& c = GetParam();
  const std::string path = kBadDir + "/" + c.file;
  ASSERT_TRUE(fs::exists(path)) << path;
  const std::string message =
      error_of([&] { load_controller(path, test::load_model("qdrone2"), 1000.0); });
  EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << "message must start with the file: " << message;
  EXPECT_NE(message.find(c.expected), std::string::npos)
      << "missing '" << c.expected << "' in: " << message;
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadControllerFile, ::testing::ValuesIn(kBadCases),
                         [](const ::testing::TestParamInfo<BadCase>& p) {
                           std::string name = p.param.file;
                           name = name.substr(0, name.find('.'));
                           for (char& ch : name)
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return name;
                         });

TEST(BadControllerCorpus, CorpusIsFullyCovered) {
  std::set<std::string> files;
  for (const auto& entry : fs::directory_iterator(kBadDir))
    files.insert(entry.path().filename().string());
  std::set<std::string> covered;
  for (const BadCase& c : kBadCases) covered.insert(c.file);
  EXPECT_EQ(files, covered);
  EXPECT_EQ(files.size(), 37u);
}

TEST(ControllerConfig, TheFuzzersHangingInputIsRefusedAsNotUtf8) {
  // An input the controller_config fuzzer found: its line 2 starts with ',' after a comment, on
  // which yaml-cpp 0.7's LoadAll looped allocating (1.2 GB at 10 s). It also holds a byte 0x9E,
  // and the encoding is checked first.
  const std::string path = test::source_path(
      "tests/fuzz/corpus/controller_config/"
      "finding_timeout_invalid_utf8_in_flow_sequence.yaml");
  const std::string message = error_of([&] { (void)load_controller_config(path); });
  EXPECT_NE(message.find(path + ": line 4, column 28: expected UTF-8 text (as YAML is), got byte "
                                "0x9E"),
            std::string::npos)
      << message;
}

}  // namespace
}  // namespace dronetwin
