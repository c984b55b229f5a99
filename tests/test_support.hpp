#pragma once
// Shared helpers for the test suite: model loading by name, seeded random states, the message of
// an expected InvalidArgument, and the rows of a malformed-file corpus.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cctype>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/control/reference.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/model/vehicle_model.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/sim/simulator.hpp"

namespace dronetwin::test {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define DRONETWIN_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define DRONETWIN_TEST_SANITIZED 1
#endif
#endif

/// True in a build with AddressSanitizer or ThreadSanitizer. Such builds run 5-30x slower and are
/// there to find memory and thread errors, not to repeat statistics: the longest batch tests use
/// fewer lanes or steps in them (their tolerances follow the size), and the release stage runs
/// every test at full size.
#ifdef DRONETWIN_TEST_SANITIZED
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif

/// `full` in a plain build, `sanitized` under a sanitizer.
constexpr int full_or_sanitized(int full, int sanitized) { return kSanitized ? sanitized : full; }

inline std::string source_path(const std::string& relative) {
  return std::string(DRONETWIN_SOURCE_DIR) + "/" + relative;
}

inline std::shared_ptr<const VehicleModel> load_model(const std::string& name) {
  return std::make_shared<const VehicleModel>(
      load_vehicle_model(source_path("models/" + name + ".yaml")));
}

/// A state with every component away from zero: position, velocity, attitude and body rate.
/// A simulator at rest 2 m up with its rotors at hover speed and the hover speeds as reference.
inline Simulator hovering(std::shared_ptr<const VehicleModel> model, const SimConfig& config) {
  Simulator sim(model, config);
  sim.reset(Simulator::hover_state(Vec3(0.0, 0.0, 2.0)), model->hover_speeds_rad_s());
  sim.set_rotor_speed_reference(model->hover_speeds_rad_s());
  return sim;
}

inline StateVector random_state(Random& rng, double z_min = 0.05, double z_max = 3.0) {
  StateVector x;
  x.segment<2>(0) << 4 * rng.uniform() - 2, 4 * rng.uniform() - 2;
  x[2] = z_min + (z_max - z_min) * rng.uniform();
  for (int i = 3; i < 6; ++i) x[i] = 6 * rng.uniform() - 3;
  x.segment<4>(6) = math::from_euler(rng.uniform() - 0.5, rng.uniform() - 0.5, 6 * rng.uniform());
  for (int i = 10; i < 13; ++i) x[i] = 4 * rng.uniform() - 2;
  return x;
}

/// A scratch directory for the running test, unique per process and test name, created empty
/// and removed (with everything in it) at the end of its scope.
class TempDir {
 public:
  explicit TempDir(const std::string& tag = "") {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ =
        std::filesystem::temp_directory_path() /
        ("dronetwin_" + std::to_string(::getpid()) + "_" + std::string(info->test_suite_name()) +
         "_" + info->name() + (tag.empty() ? "" : "_" + tag));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  /// Writes `text` to `name` inside the directory (subfolders created); returns the full path.
  std::string write(const std::string& name, const std::string& text) const {
    const std::filesystem::path p = path_ / name;
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p) << text;
    return p.string();
  }

 private:
  std::filesystem::path path_;
};

/// The message of the InvalidArgument thrown by `f`; a test failure (and "") if `f` throws
/// something else or nothing.
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InvalidArgument& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected InvalidArgument, got another exception: " << e.what();
    return {};
  }
  ADD_FAILURE() << "expected InvalidArgument, nothing was thrown";
  return {};
}

/// One malformed file of a test corpus (a directory of tests/data) and what its error must say.
struct BadFileCase {
  const char* file;
  /// Substrings the error message must contain.
  std::vector<std::string> expected;
};

inline void PrintTo(const BadFileCase& c, std::ostream* os) { *os << c.file; }

/// Test name of a corpus row for INSTANTIATE_TEST_SUITE_P: the file name up to the first '.',
/// with every character other than a letter or digit replaced by '_'.
inline std::string bad_file_case_name(const ::testing::TestParamInfo<BadFileCase>& info) {
  std::string name = info.param.file;
  name = name.substr(0, name.find('.'));
  for (char& ch : name)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return name;
}

/// A reference that is one point for all time (position, velocity, acceleration, yaw), for
/// closed loops compared against the batched controllers.
class FixedPoint final : public Reference {
 public:
  explicit FixedPoint(const ReferencePoint& p) : p_(p) {}
  ReferencePoint at(double) const override { return p_; }
  std::unique_ptr<Reference> clone() const override { return std::make_unique<FixedPoint>(p_); }
  std::string describe() const override { return "fixed point"; }

 private:
  ReferencePoint p_;
};

}  // namespace dronetwin::test
