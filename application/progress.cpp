#include "application/progress.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <iostream>

namespace servokit {
namespace {

// Characters of the bar itself: with the counts, rate and time the line stays within 80
// columns up to 10^9 points at 10^7 points/s (a longer line wraps, and "\r" then redraws only
// its last part).
constexpr std::size_t kBarWidth = 12;
// Erases from the cursor to the end of the line (ANSI/VT100 "EL").
constexpr const char* kEraseLine = "\r\033[K";

std::string FormatDuration(double seconds) {
  const auto total = static_cast<long long>(std::ceil(seconds));
  char text[32];
  std::snprintf(text, sizeof text, "%lld:%02lld:%02lld", total / 3600, total / 60 % 60, total % 60);
  return text;
}

}  // namespace

bool IsTerminalStderr(const std::ostream& stream) {
  return &stream == &std::cerr && ::isatty(STDERR_FILENO) == 1;
}

std::string FormatProgress(std::size_t done, std::size_t total, double points_per_second) {
  const double fraction = total == 0 ? 1.0 : static_cast<double>(done) / static_cast<double>(total);
  const auto filled = static_cast<std::size_t>(fraction * static_cast<double>(kBarWidth));
  std::string line = "[" + std::string(filled, '#') + std::string(kBarWidth - filled, '.') + "]";
  char numbers[96];
  std::snprintf(numbers, sizeof numbers, " %5.1f%%  %zu/%zu  ", 100.0 * fraction, done, total);
  line += numbers;
  if (points_per_second <= 0.0) return line + "-- points/s";
  std::snprintf(numbers, sizeof numbers, "%.0f points/s  ", points_per_second);
  line += numbers;
  const double seconds_left = static_cast<double>(total - done) / points_per_second;
  return line + FormatDuration(seconds_left) + " left";
}

ProgressBar::ProgressBar(std::ostream& out, std::size_t total, std::size_t first, bool enabled)
    : out_(out),
      total_(total),
      first_(first),
      enabled_(enabled),
      start_(std::chrono::steady_clock::now()),
      last_redraw_(start_) {}

ProgressBar::~ProgressBar() { Clear(); }

void ProgressBar::Update(std::size_t done) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (drawn_ && now - last_redraw_ < kProgressRedrawInterval) return;
  const double seconds = std::chrono::duration<double>(now - start_).count();
  const double rate = seconds > 0.0 ? static_cast<double>(done - first_) / seconds : 0.0;
  out_ << kEraseLine << FormatProgress(done, total_, rate) << std::flush;
  drawn_ = true;
  last_redraw_ = now;
}

void ProgressBar::Clear() {
  if (!drawn_) return;
  out_ << kEraseLine << std::flush;
  drawn_ = false;
}

}  // namespace servokit
