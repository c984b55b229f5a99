// logging/output_folder.hpp: an output folder never loses a user's data. Existing outputs are
// refused without overwrite, an output that is an input (however spelled) always, a second writer
// is locked out, and files appear only when committed (a command that dies leaves what was there).

#include "dronetwin/logging/output_folder.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "dronetwin/logging/text_file.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) { return read_text_file(p.string(), "test file"); }

TEST(OutputFolder, FilesAppearOnlyWhenCommitted) {
  const test::TempDir tmp;
  const fs::path dir = tmp.path() / "run";
  {
    OutputFolder out(dir, {"log.csv", "summary.json"}, {}, false, "run");
    write_text_file(out.partial("log.csv"), "t\n0\n");
    write_text_file(out.partial("summary.json"), "{}\n");
    EXPECT_FALSE(fs::exists(dir / "log.csv"));  // a reader sees nothing half-written
    EXPECT_TRUE(fs::exists(out.partial("log.csv")));
    out.commit();
  }
  EXPECT_EQ(slurp(dir / "log.csv"), "t\n0\n");
  EXPECT_EQ(slurp(dir / "summary.json"), "{}\n");
  EXPECT_FALSE(fs::exists(dir / ".log.csv.partial"));
}

TEST(OutputFolder, AnEarlierRunIsReplacedOnlyWithOverwriteAndSurvivesAFailedOne) {
  const test::TempDir tmp;
  const fs::path dir = tmp.path();
  std::ofstream(dir / "log.csv") << "earlier\n";
  const std::string msg = test::error_of([&] {
    OutputFolder out(dir, {"log.csv", "log.json"}, {}, false, "run");
  });
  EXPECT_NE(msg.find("log.csv: exists"), std::string::npos) << msg;
  EXPECT_NE(msg.find("--force"), std::string::npos) << msg;
  {
    // With overwrite, but the command dies before commit(): the earlier file is intact and the
    // temporary is gone.
    OutputFolder out(dir, {"log.csv"}, {}, true, "run");
    write_text_file(out.partial("log.csv"), "new, unfinished\n");
  }
  EXPECT_EQ(slurp(dir / "log.csv"), "earlier\n");
  EXPECT_FALSE(fs::exists(dir / ".log.csv.partial"));
  {
    OutputFolder out(dir, {"log.csv"}, {}, true, "run");
    write_text_file(out.partial("log.csv"), "new\n");
    out.commit();
  }
  EXPECT_EQ(slurp(dir / "log.csv"), "new\n");
}

TEST(OutputFolder, AnOutputThatIsAnInputIsRefusedHoweverItIsSpelled) {
  const test::TempDir tmp;
  const fs::path dir = tmp.path() / "flight";
  fs::create_directories(dir);
  std::ofstream(dir / "log.csv") << "the user's flight\n";
  fs::create_directory_symlink(dir, tmp.path() / "link");
  for (const std::string& input :
       {(dir / "log.csv").string(), (tmp.path() / "link" / "log.csv").string(),
        (dir / ".." / "flight" / "log.csv").string()}) {
    const std::string msg = test::error_of(
        [&] { OutputFolder out(dir, {"log.csv"}, {input}, /*overwrite=*/true, "import"); });
    EXPECT_NE(msg.find("would write over its own input"), std::string::npos)
        << input << ": " << msg;
  }
  EXPECT_EQ(slurp(dir / "log.csv"), "the user's flight\n");
}

TEST(OutputFolder, ASecondWriterIsLockedOut) {
  const test::TempDir tmp;
  OutputFolder first(tmp.path(), {"log.csv"}, {}, false, "run");
  const std::string msg =
      test::error_of([&] { OutputFolder second(tmp.path(), {"other.csv"}, {}, false, "run"); });
  EXPECT_NE(msg.find("another dronetwin command is writing into this folder"), std::string::npos)
      << msg;
}

TEST(OutputFolder, AFileInTheWayOfTheFolderIsNamed) {
  const test::TempDir tmp;
  std::ofstream(tmp.path() / "out") << "a file\n";
  const std::string msg =
      test::error_of([&] { OutputFolder out(tmp.path() / "out", {"log.csv"}, {}, false, "run"); });
  EXPECT_NE(msg.find("cannot create the output folder"), std::string::npos) << msg;
}

}  // namespace
}  // namespace dronetwin
