// `dronetwin plot`: draws PNG figures from a run's log with Debian's Python and matplotlib.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
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

TEST(PlotCommand, AHeaderOnlyLogIsBadInputNamingTheFile) {
  // A run that stopped before its first row: the header is there, no data. Nothing to draw,
  // and the error says so instead of a traceback from matplotlib.
  const fs::path dir = fs::temp_directory_path() / "dronetwin_plot_header_only_test";
  fs::remove_all(dir);
  const std::string cli = DRONETWIN_CLI_PATH;
  ASSERT_EQ(0, run(cli +
                   " run " DRONETWIN_SOURCE_DIR
                   "/config/experiments/freefall.yaml --quiet --duration 0.01 --out " +
                   dir.string()));
  std::string header;
  {
    std::ifstream in(dir / "log.csv");
    for (std::string line; std::getline(in, line);) {
      header += line + "\n";
      if (line.rfind('#', 0) != 0) break;  // the column names end the header
    }
  }
  std::ofstream(dir / "log.csv", std::ios::trunc) << header;
  const fs::path err = dir / "stderr.txt";
  const int status =
      std::system((cli + " plot " + dir.string() + " > /dev/null 2> " + err.string()).c_str());
  EXPECT_EQ(2, WEXITSTATUS(status));
  std::ifstream in(err);
  const std::string message((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(message.find((dir / "log.csv").string() + ": the log has a header but no rows"),
            std::string::npos)
      << message;
  EXPECT_EQ(message.find("Traceback"), std::string::npos) << message;
  fs::remove_all(dir);
}

TEST(PlotCommand, MissingLogIsBadInput) {
  EXPECT_EQ(2, run(std::string(DRONETWIN_CLI_PATH) + " plot /nonexistent_dronetwin_dir"));
}

}  // namespace
