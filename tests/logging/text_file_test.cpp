// Whole text files (logging/text_file.hpp): a failure names the file and gives the system's
// reason (the errno text of the failing call, which the C library defines, not us).
#include "dronetwin/logging/text_file.hpp"

#include <gtest/gtest.h>

#include <cerrno>
#include <filesystem>
#include <functional>
#include <string>
#include <system_error>

#include "dronetwin/core/error.hpp"

namespace dronetwin {
namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InvalidArgument& e) {
    return e.what();
  }
  return "";
}

TEST(TextFile, AWriteIntoAMissingFolderSaysWhy) {
  const std::string path = "/nonexistent_dronetwin_dir/out.txt";
  const std::string expected =
      path + ": cannot open for writing (" + std::generic_category().message(ENOENT) + ")";
  EXPECT_EQ(error_of([&] { write_text_file(path, "x"); }), expected);
}

TEST(TextFile, AMissingFileSaysWhyAndADirectoryIsNamed) {
  EXPECT_EQ(
      error_of([] { (void)read_text_file("/nonexistent_dronetwin_file.yaml", "model file"); }),
      "/nonexistent_dronetwin_file.yaml: cannot open model file (" +
          std::generic_category().message(ENOENT) + ")");
  const std::string dir = std::filesystem::temp_directory_path().string();
  EXPECT_EQ(error_of([&] { (void)read_text_file(dir, "model file"); }),
            dir + ": cannot read model file: it is a directory");
  // A device that never ends (a hostile file name in a config, found by thinking about the
  // fuzzers' reach) is refused before a byte is read.
  EXPECT_EQ(error_of([] { (void)read_text_file("/dev/zero", "environment file"); }),
            "/dev/zero: cannot read environment file: not a regular file");
}

TEST(ErrnoText, NoSystemErrorIsSaidAsUnknown) {
  EXPECT_EQ(errno_text(0), "unknown error");
  EXPECT_EQ(errno_text(ENOENT), std::generic_category().message(ENOENT));
}

}  // namespace
}  // namespace dronetwin
