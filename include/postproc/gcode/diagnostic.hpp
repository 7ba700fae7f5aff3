#pragma once
/// @file
/// Located diagnostics: every message names file:line:column, the offending text and what to do.

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace postproc::gcode {

/// Byte range [begin, end) inside one block's raw text (EOL excluded).
struct Span {
  std::uint32_t begin = 0;
  std::uint32_t end = 0;
  [[nodiscard]] std::uint32_t size() const { return end - begin; }
  [[nodiscard]] std::string_view of(std::string_view raw) const { return raw.substr(begin, end - begin); }
};

/// Position in a source file: 1-based line and 1-based byte column.
struct SourceLocation {
  std::uint64_t line = 0;
  std::uint32_t column = 0;
};

enum class Severity : std::uint8_t {
  note,        ///< information, e.g. a suggested dialect
  warning,     ///< accepted, but later compensation refuses it without pass-through (codes PP-U…)
  error,       ///< the program is refused (codes PP-E…)
};

[[nodiscard]] std::string_view to_string(Severity s);

/// One diagnostic. `code` is stable (documented in README.md) and never reused.
struct Diagnostic {
  Severity severity = Severity::error;
  std::string code;         ///< e.g. "PP-E101"
  std::string file;         ///< as given on the command line ("-" for stdin)
  SourceLocation where;
  std::string message;      ///< what is wrong and what to do
  std::string source_line;  ///< the raw block text (no EOL) for the caret display
  std::uint32_t length = 1; ///< number of bytes to underline
  /// A long line is kept as a window around the column (set_source_line): the bytes of the line
  /// left out before `source_line`, and whether some are left out after it.
  std::uint32_t source_offset = 0;
  bool source_cut = false;
};

/// Bytes of a source line a diagnostic keeps at most (a window around its column).
inline constexpr std::size_t kMaxSourceEcho = 240;
/// Bytes of a diagnostic message kept at most (a message quoting a huge token is shortened).
inline constexpr std::size_t kMaxMessage = 2000;

/// Sets `d.source_line` to `line`, or for a line longer than kMaxSourceEcho to a window of it
/// around `d.where.column` (never splitting a UTF-8 character). Set `d.where` first.
void set_source_line(Diagnostic& d, std::string_view line);

/// Formats `file:line:col: severity: code: message`, then the source line and a caret.
[[nodiscard]] std::string format(const Diagnostic& d, bool with_source = true);

/// Collects diagnostics; counts per severity; stops storing after `max_stored` or `max_stored_bytes`
/// of text (counts go on; dropped() tells how many were not stored).
class DiagnosticSink {
 public:
  explicit DiagnosticSink(std::size_t max_stored = 1000, std::size_t max_stored_bytes = std::size_t{16} << 20)
      : max_stored_(max_stored), max_stored_bytes_(max_stored_bytes) {}
  void report(Diagnostic d);
  /// Called for every diagnostic as it arrives (e.g. to print while streaming). Optional.
  std::function<void(const Diagnostic&)> on_report;

  [[nodiscard]] std::size_t count(Severity s) const { return counts_[static_cast<int>(s)]; }
  [[nodiscard]] bool has_errors() const { return count(Severity::error) > 0; }
  [[nodiscard]] const std::vector<Diagnostic>& stored() const { return stored_; }
  [[nodiscard]] std::size_t dropped() const { return dropped_; }
  /// Number of diagnostics per code (all of them, stored or not), sorted by code.
  [[nodiscard]] const std::map<std::string, std::size_t>& per_code() const { return per_code_; }

 private:
  std::size_t max_stored_;
  std::size_t max_stored_bytes_;
  std::size_t stored_bytes_ = 0;
  std::size_t counts_[3] = {0, 0, 0};
  std::size_t dropped_ = 0;
  std::vector<Diagnostic> stored_;
  std::map<std::string, std::size_t> per_code_;
};

}  // namespace postproc::gcode
