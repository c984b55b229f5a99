// `dronetwin plot`: draws PNG figures from a run's log with Debian's Python and matplotlib.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include <sys/wait.h>

namespace {

namespace fs = std::filesystem;

int run(const std::string& command) {
  const int status = std::system((command + " > /dev/null 2>&1").c_str());
  return WEXITSTATUS(status);
}

TEST(PlotCommand, WritesFiguresForARun) {
  const fs::path dir = fs::temp_directory_path() / "dronetwin_plot_test";
  fs::remove_all(dir);
  const std::string cli = DRONETWIN_CLI_PATH;
  ASSERT_EQ(
      0, run(cli +
             " run " DRONETWIN_SOURCE_DIR "/config/experiments/step_open_loop.yaml --quiet --out " +
             dir.string()));
  ASSERT_EQ(0, run(cli + " plot " + dir.string()));
  for (const char* png : {"tracking.png", "rotors.png", "path3d.png"}) {
    ASSERT_TRUE(fs::exists(dir / png)) << png;
    EXPECT_GT(fs::file_size(dir / png), 10000u) << png;  // a real figure, not an empty file
  }
  fs::remove_all(dir);
}

TEST(PlotCommand, MissingLogIsBadInput) {
  EXPECT_EQ(2, run(std::string(DRONETWIN_CLI_PATH) + " plot /nonexistent_dronetwin_dir"));
}

}  // namespace
