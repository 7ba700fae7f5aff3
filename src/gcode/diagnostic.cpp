#include "postproc/gcode/diagnostic.hpp"

#include <fmt/format.h>

namespace postproc::gcode {

std::string_view to_string(Severity s) {
  switch (s) {
    case Severity::note: return "note";
    case Severity::warning: return "warning";
    case Severity::error: return "error";
  }
  return "?";
}

std::string format(const Diagnostic& d, bool with_source) {
  // A diagnostic about a file as a whole (no line) names the file alone.
  std::string out = d.where.line > 0 ? fmt::format("{}:{}:{}: {}: {}: {}\n", d.file, d.where.line, d.where.column,
                                                   to_string(d.severity), d.code, d.message)
                                     : fmt::format("{}: {}: {}: {}\n", d.file, to_string(d.severity), d.code, d.message);
  if (with_source && d.where.line > 0) {
    // Tabs are kept so the caret lines up under the same bytes in a terminal.
    std::string caret;
    const std::size_t col = d.where.column > 0 ? d.where.column - 1 : 0;
    for (std::size_t i = 0; i < col && i < d.source_line.size(); ++i) caret += d.source_line[i] == '\t' ? '\t' : ' ';
    caret += '^';
    const std::uint32_t len = std::min<std::uint32_t>(d.length, 200);
    for (std::uint32_t i = 1; i < len; ++i) caret += '~';
    out += fmt::format("  {}\n  {}\n", d.source_line, caret);
  }
  return out;
}

void DiagnosticSink::report(Diagnostic d) {
  ++counts_[static_cast<int>(d.severity)];
  ++per_code_[d.code];
  if (on_report) on_report(d);
  if (stored_.size() < max_stored_) {
    stored_.push_back(std::move(d));
  } else {
    ++dropped_;
  }
}

}  // namespace postproc::gcode
