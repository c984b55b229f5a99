#pragma once
// How far a run has come, and the terminal bar the CLI draws from it.
//
//   ProgressBar bar(std::cerr, ProgressBar::Mode::kAuto, isatty(STDERR_FILENO), "pid_pulse");
//   RunSummary s = run_experiment(e, "out/pid", false, bar.callback());
//   bar.finish();
//
// A run tells its progress as (simulated seconds, duration) from the thread that steps it: at the
// start, every kProgressEverySteps physics steps and at the end. The bar shows on a terminal only
// once the run has taken kShowAfterS of wall clock (kAuto), so short runs, pipes, log files and
// CI logs never see it; kAlways draws it from the start (a line per second when the stream is not
// a terminal), kNever not at all. On a terminal it rewrites one line at most every 0.1 s and
// erases it at the end, so the summary printed after it starts on a clean line.
//
// Trap: not for two threads; a run calls its callback from the one thread that steps it.

#include <functional>
#include <iosfwd>
#include <string>
#include <string_view>

namespace dronetwin {

/// Called with (simulated seconds so far, the run's duration in seconds).
using RunProgressFn = std::function<void(double simulated_s, double duration_s)>;

/// Physics steps between two progress reports of a run.
inline constexpr int kProgressEverySteps = 1024;

class ProgressBar {
 public:
  enum class Mode { kAuto, kAlways, kNever };
  /// Wall-clock seconds, monotonic (a steady clock by default; tests pass their own).
  using Clock = std::function<double()>;

  /// Wall-clock time a run takes before kAuto shows the bar.
  static constexpr double kShowAfterS = 2.0;

  ProgressBar(std::ostream& out, Mode mode, bool terminal, std::string label, Clock clock = {});
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  void update(double simulated_s, double duration_s);
  /// Erases the bar from a terminal (or ends the last line elsewhere). Idempotent.
  void finish();
  /// update() as a RunProgressFn; the bar must outlive the run.
  RunProgressFn callback();
  /// Whether anything has been drawn.
  bool shown() const { return draws_ > 0; }

  /// One line of the bar: "label [#####-----]  50%  30.0/60.0 s  2.0 s left", `width` cells of
  /// bar. Time left is the elapsed wall clock scaled by the share still to fly ("--" before the
  /// first simulated step).
  static std::string line(std::string_view label, double simulated_s, double duration_s,
                          double elapsed_s, int width = 30);

 private:
  void draw(const std::string& text);

  std::ostream& out_;
  Mode mode_;
  bool terminal_;
  std::string label_;
  Clock clock_;
  double start_s_ = 0.0;
  double last_draw_s_ = 0.0;
  std::size_t last_length_ = 0;
  int draws_ = 0;
  bool finished_ = false;
};

}  // namespace dronetwin
