#include "dronetwin/app/progress.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ostream>
#include <utility>

namespace dronetwin {

namespace {

double steady_now_s() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string format(const char* pattern, double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, pattern, value);
  return buffer;
}

}  // namespace

ProgressBar::ProgressBar(std::ostream& out, Mode mode, bool terminal, std::string label,
                         Clock clock)
    : out_(out),
      mode_(mode),
      terminal_(terminal),
      label_(std::move(label)),
      clock_(clock ? std::move(clock) : Clock(steady_now_s)) {
  start_s_ = clock_();
}

ProgressBar::~ProgressBar() {
  try {
    finish();
  } catch (...) {  // a stream that throws on write: nothing left to tell
  }
}

std::string ProgressBar::line(std::string_view label, double simulated_s, double duration_s,
                              double elapsed_s, int width) {
  const double share = duration_s > 0.0 ? std::clamp(simulated_s / duration_s, 0.0, 1.0) : 1.0;
  const int filled = static_cast<int>(std::floor(share * width));
  std::string text(label);
  text += " [";
  text.append(static_cast<std::size_t>(filled), '#');
  text.append(static_cast<std::size_t>(width - filled), '-');
  text += "] ";
  text += format("%3.0f%%", std::floor(share * 100.0));
  text += "  " + format("%.1f", simulated_s) + "/" + format("%.1f", duration_s) + " s  ";
  text += share > 0.0 ? format("%.1f", elapsed_s * (1.0 - share) / share) + " s left" : "-- s left";
  return text;
}

void ProgressBar::update(double simulated_s, double duration_s) {
  if (mode_ == Mode::kNever || finished_ || (mode_ == Mode::kAuto && !terminal_)) return;
  const double now = clock_();
  const double elapsed = now - start_s_;
  if (mode_ == Mode::kAuto && elapsed < kShowAfterS) return;
  const bool last = simulated_s >= duration_s;
  // A terminal line is cheap to rewrite; a file gets a line per second.
  const double every_s = terminal_ ? 0.1 : 1.0;
  if (draws_ > 0 && !last && now - last_draw_s_ < every_s) return;
  last_draw_s_ = now;
  draw(line(label_, simulated_s, duration_s, elapsed));
}

void ProgressBar::draw(const std::string& text) {
  if (terminal_) {
    // Pad over a longer previous line; no newline, so the next draw overwrites this one.
    std::string padded = text;
    if (padded.size() < last_length_) padded.append(last_length_ - padded.size(), ' ');
    out_ << '\r' << padded << std::flush;
  } else {
    out_ << text << '\n' << std::flush;
  }
  last_length_ = text.size();
  ++draws_;
}

void ProgressBar::finish() {
  if (finished_) return;
  finished_ = true;
  if (terminal_ && draws_ > 0) out_ << '\r' << std::string(last_length_, ' ') << '\r' << std::flush;
}

RunProgressFn ProgressBar::callback() {
  return [this](double simulated_s, double duration_s) { update(simulated_s, duration_s); };
}

}  // namespace dronetwin
