// The run progress and the CLI's bar (include/dronetwin/app/progress.hpp): the line's numbers from
// the arithmetic of the share flown, when the bar shows (terminal and 2 s of wall clock, forced,
// never), how often it redraws, that it erases itself, and that a run reports its progress from
// t = 0 to its end every kProgressEverySteps steps.
#include "dronetwin/app/progress.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "dronetwin/app/run_experiment.hpp"

namespace dronetwin {
namespace {

namespace fs = std::filesystem;

TEST(ProgressBar, LineShowsTheShareFlownAndTheTimeLeft) {
  // Half of 60 s flown in 2 s of wall clock: 2 s more at the same pace.
  const std::string half = ProgressBar::line("pid", 30.0, 60.0, 2.0, 10);
  EXPECT_EQ(half, "pid [#####-----]  50%  30.0/60.0 s  2.0 s left");
  // A quarter in 1 s: three quarters left take 3 s.
  EXPECT_NE(ProgressBar::line("x", 15.0, 60.0, 1.0, 8).find("[##------]  25%"), std::string::npos);
  EXPECT_NE(ProgressBar::line("x", 15.0, 60.0, 1.0, 8).find("3.0 s left"), std::string::npos);
  // Nothing flown yet: no estimate; done: full bar.
  EXPECT_NE(ProgressBar::line("x", 0.0, 60.0, 0.5, 4).find("[----]   0%"), std::string::npos);
  EXPECT_NE(ProgressBar::line("x", 0.0, 60.0, 0.5, 4).find("-- s left"), std::string::npos);
  EXPECT_NE(ProgressBar::line("x", 60.0, 60.0, 9.0, 4).find("[####] 100%"), std::string::npos);
}

/// A bar on a clock the test moves.
struct Fixture {
  std::ostringstream out;
  double now_s = 100.0;
  ProgressBar bar;
  Fixture(ProgressBar::Mode mode, bool terminal)
      : bar(out, mode, terminal, "run", [this] { return now_s; }) {}
};

TEST(ProgressBar, OnATerminalItShowsOnlyOnceTheRunTakesTwoSeconds) {
  Fixture f(ProgressBar::Mode::kAuto, /*terminal=*/true);
  f.now_s += 1.9;
  f.bar.update(10.0, 60.0);
  EXPECT_FALSE(f.bar.shown()) << "a run under 2 s shows nothing";
  EXPECT_EQ(f.out.str(), "");
  f.now_s += 0.2;
  f.bar.update(12.0, 60.0);
  ASSERT_TRUE(f.bar.shown());
  EXPECT_EQ(f.out.str(), std::string("\r").append(ProgressBar::line("run", 12.0, 60.0, 2.1)));
  // Within 0.1 s of the last draw nothing is redrawn; after it, the line is rewritten in place.
  const std::string after_one = f.out.str();
  f.now_s += 0.05;
  f.bar.update(13.0, 60.0);
  EXPECT_EQ(f.out.str(), after_one);
  f.now_s += 0.1;
  f.bar.update(14.0, 60.0);
  EXPECT_GT(f.out.str().size(), after_one.size());
  EXPECT_EQ(f.out.str().find('\n'), std::string::npos) << "a terminal line is rewritten with \\r";
  // The end erases the line: blanks over it, the cursor back at its start.
  const std::size_t length = ProgressBar::line("run", 14.0, 60.0, 2.25).size();
  f.bar.finish();
  const std::string erase = std::string("\r").append(length, ' ').append("\r");
  EXPECT_TRUE(f.out.str().ends_with(erase));
  f.bar.finish();  // idempotent
  f.bar.update(60.0, 60.0);
  EXPECT_TRUE(f.out.str().ends_with(erase)) << "nothing after finish";
}

TEST(ProgressBar, NotOnATerminalAutoShowsNothing) {
  Fixture f(ProgressBar::Mode::kAuto, /*terminal=*/false);
  for (int i = 0; i <= 60; ++i) {
    f.now_s += 1.0;
    f.bar.update(i, 60.0);
  }
  f.bar.finish();
  EXPECT_FALSE(f.bar.shown());
  EXPECT_EQ(f.out.str(), "");
}

TEST(ProgressBar, NeverShowsNothingEvenOnATerminal) {
  Fixture f(ProgressBar::Mode::kNever, /*terminal=*/true);
  f.now_s += 10.0;
  f.bar.update(30.0, 60.0);
  f.bar.finish();
  EXPECT_EQ(f.out.str(), "");
}

TEST(ProgressBar, ForcedIntoAFileItWritesALinePerSecondAndTheEnd) {
  Fixture f(ProgressBar::Mode::kAlways, /*terminal=*/false);
  // 3 s of wall clock in 0.25 s ticks, 60 s simulated: lines at 0, 1 and 2 s, and the end at 3 s
  // (the ticks between are within a second of the last line).
  for (int tick = 0; tick <= 12; ++tick) {
    f.bar.update(5.0 * tick, 60.0);
    f.now_s += 0.25;
  }
  f.bar.finish();
  const std::string text = f.out.str();
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 4) << text;
  EXPECT_EQ(text.find('\r'), std::string::npos);
  EXPECT_TRUE(text.ends_with(ProgressBar::line("run", 60.0, 60.0, 3.0).append("\n"))) << text;
}

TEST(RunProgress, ARunReportsFromTheStartToItsEndEvery1024Steps) {
  const fs::path dir =
      fs::temp_directory_path() / ("dronetwin_progress_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string source = DRONETWIN_SOURCE_DIR;
  const Experiment e = parse_experiment("name: t\nmodel: " + source +
                                            "/models/qdrone2.yaml\nduration_s: 3.0\n"
                                            "initial_state: {position_m: [0, 0, 1], "
                                            "rotor_speeds_rad_s: hover}\ninput: {type: hover}\n",
                                        (dir / "t.yaml").string());
  std::vector<std::pair<double, double>> calls;
  const RunSummary s = run_experiment(e, (dir / "out").string(), false,
                                      [&](double t, double d) { calls.emplace_back(t, d); });
  fs::remove_all(dir);
  ASSERT_TRUE(s.ok()) << s.failure_message;
  // 3000 steps at 1 ms: reports at steps 0, 1024, 2048, and the end.
  ASSERT_EQ(calls.size(), 4u);
  EXPECT_DOUBLE_EQ(calls[0].first, 0.0);
  EXPECT_NEAR(calls[1].first, 1.024, 1e-12);
  EXPECT_NEAR(calls[2].first, 2.048, 1e-12);
  EXPECT_NEAR(calls[3].first, 3.0, 1e-12);
  for (const auto& c : calls) EXPECT_EQ(c.second, 3.0);
}

}  // namespace
}  // namespace dronetwin
