// Progress bar on a terminal's stderr.
#include "progress_bar.hpp"

#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include <fmt/format.h>

namespace postproc::cli {

namespace {
std::mutex g_active_mutex;
ProgressBar* g_active = nullptr;  // the bar on screen, if any
}  // namespace

void print_stderr(std::string_view text) {
  std::lock_guard<std::mutex> g(g_active_mutex);
  if (g_active != nullptr) {
    g_active->line(text);
    return;
  }
  std::fwrite(text.data(), 1, text.size(), stderr);
}

std::string clock_text(double seconds) {
  const auto s = static_cast<long long>(std::max(0.0, std::round(seconds)));
  return s >= 3600 ? fmt::format("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60) : fmt::format("{}:{:02}", s / 60, s % 60);
}

std::size_t terminal_columns() {
  if (const char* env = std::getenv("COLUMNS")) {
    const long v = std::strtol(env, nullptr, 10);
    if (v >= 20 && v <= 1000) return static_cast<std::size_t>(v);
  }
  winsize ws{};
  if (::ioctl(STDERR_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col >= 20) return ws.ws_col;
  return 80;
}

std::string fit_to_width(std::string s, std::size_t columns) {
  // Counts UTF-8 characters (each one column: the bar writes no wide characters) and cuts at a
  // character boundary, leaving the last column free so that the terminal does not wrap.
  std::size_t chars = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if ((static_cast<unsigned char>(s[i]) & 0xC0) == 0x80) continue;
    if (++chars == columns) {
      s.resize(i);
      break;
    }
  }
  return s;
}

ProgressBar::ProgressBar(std::string label) : label_(std::move(label)) {
  const char* env = std::getenv("POSTPROC_PROGRESS");
  if (env != nullptr && std::strcmp(env, "0") == 0)
    enabled_ = false;
  else if (env != nullptr && std::strcmp(env, "1") == 0)
    enabled_ = true;
  else
    enabled_ = ::isatty(STDERR_FILENO) == 1;
  start_ = std::chrono::steady_clock::now();
  last_ = start_ - std::chrono::seconds(1);
  if (enabled_) {
    std::lock_guard<std::mutex> g(g_active_mutex);
    g_active = this;
  }
}

ProgressBar::~ProgressBar() {
  finish();
  std::lock_guard<std::mutex> g(g_active_mutex);
  if (g_active == this) g_active = nullptr;
}

void ProgressBar::clear() {
  if (drawn_) std::fputs("\r\033[K", stderr);
  drawn_ = false;
}

void ProgressBar::update(std::string_view stage, double done, double total, std::string_view detail) {
  if (!enabled_) return;
  std::lock_guard<std::mutex> g(mutex_);
  const auto now = std::chrono::steady_clock::now();
  const bool last = total > 0 && done >= total;
  if (!last && now - last_ < std::chrono::milliseconds(100)) return;
  last_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const std::size_t columns = terminal_columns();
  std::string s = label_;
  if (!stage.empty()) s += fmt::format(" {}", stage);
  if (total > 0) {
    const double f = std::clamp(done / total, 0.0, 1.0);
    // 28 columns for the bar on a wide terminal, fewer on a narrow one (the text around it needs
    // about 60).
    const int kWidth = static_cast<int>(std::clamp<std::size_t>(columns > 60 ? columns - 60 : 0, 8, 28));
    const int filled = static_cast<int>(f * kWidth);
    s += " [" + std::string(static_cast<std::size_t>(filled), '=') + (filled < kWidth ? ">" : "") +
         std::string(static_cast<std::size_t>(std::max(0, kWidth - filled - 1)), ' ') + "]";
    s += fmt::format(" {:3.0f} %", 100 * f);
    if (f > 0.02 && f < 1) s += fmt::format("  ETA {}", clock_text(elapsed * (1 - f) / f));
  }
  s += fmt::format("  {} elapsed", clock_text(elapsed));
  if (!detail.empty()) s += fmt::format("  {}", detail);
  s = "\r\033[K" + fit_to_width(std::move(s), columns);
  std::fputs(s.c_str(), stderr);
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressBar::line(std::string_view text) {
  std::lock_guard<std::mutex> g(mutex_);
  clear();
  std::fwrite(text.data(), 1, text.size(), stderr);
  if (text.empty() || text.back() != '\n') std::fputc('\n', stderr);
  std::fflush(stderr);
  last_ = std::chrono::steady_clock::now() - std::chrono::seconds(1);  // redraw at the next update
}

void ProgressBar::finish() {
  if (!enabled_) return;
  std::lock_guard<std::mutex> g(mutex_);
  clear();
  std::fflush(stderr);
}

}  // namespace postproc::cli
