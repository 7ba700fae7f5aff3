#pragma once
// A progress bar on stderr, drawn only when stderr is a terminal (POSTPROC_PROGRESS=0 turns it off,
// =1 forces it on); silent otherwise. Redraws at most ten times a second.
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>
#include <string_view>

namespace postproc::cli {

class ProgressBar {
 public:
  explicit ProgressBar(std::string label);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  [[nodiscard]] bool enabled() const { return enabled_; }
  /// `done` of `total` (0 = unknown), in `unit` ("files", "MB" …); `detail` follows the figures.
  void update(std::string_view stage, double done, double total, std::string_view detail = {});
  /// Prints a whole line above the bar (the bar is redrawn by the next update).
  void line(std::string_view text);
  /// Clears the bar.
  void finish();

 private:
  void clear();
  std::string label_;
  bool enabled_ = false;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point start_, last_;
  std::mutex mutex_;
};

/// Columns of the terminal on stderr: $COLUMNS when set (20 … 1000), else the terminal's width,
/// else 80.
[[nodiscard]] std::size_t terminal_columns();
/// `s` cut to fewer than `columns` characters (UTF-8), so that a redrawn line never wraps.
[[nodiscard]] std::string fit_to_width(std::string s, std::size_t columns);

/// Writes `text` to stderr; when a bar is on screen it is cleared first (and redrawn by its next
/// update), so diagnostics printed during a run do not run into the bar.
void print_stderr(std::string_view text);

/// "0:42", "1:02:03"
[[nodiscard]] std::string clock_text(double seconds);

}  // namespace postproc::cli
