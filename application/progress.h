#pragma once
// A one-line progress bar for long runs (`servokit sweep`): points done of the total, the rate
// and the time left, redrawn in place on a terminal and silent anywhere else (a log file or a
// pipe gets no carriage-return noise).
#include <chrono>
#include <cstddef>
#include <iosfwd>
#include <string>

namespace servokit {

/// Redraws at most this often: a redraw per block (every few ms) flickers and costs terminal
/// time, five per second reads as live.
inline constexpr std::chrono::milliseconds kProgressRedrawInterval{200};

/// True when `stream` is std::cerr and the process's stderr is a terminal. A stream a caller
/// captures (tests, RunCommandLine into a string) never gets a bar.
bool IsTerminalStderr(const std::ostream& stream);

/// The bar's text, without carriage return, e.g.
/// "[####........]  35.0%  350000/1000000  151234 points/s  0:00:04 left".
/// `points_per_second` <= 0 means not yet known (shown as "--").
std::string FormatProgress(std::size_t done, std::size_t total, double points_per_second);

/// Draws FormatProgress on `out` when enabled, at most every kProgressRedrawInterval.
class ProgressBar {
 public:
  /// `first` points were done before this run started (a resumed sweep): the rate counts only
  /// the points of this run.
  ProgressBar(std::ostream& out, std::size_t total, std::size_t first, bool enabled);
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;
  /// Erases the bar, so that what follows starts on a clean line.
  ~ProgressBar();

  /// `done` points are done in all; redraws if the last redraw is old enough.
  void Update(std::size_t done);
  /// Erases the bar now (before a message).
  void Clear();

 private:
  std::ostream& out_;
  std::size_t total_, first_;
  bool enabled_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point start_, last_redraw_;
};

}  // namespace servokit
