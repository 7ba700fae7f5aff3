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

void set_source_line(Diagnostic& d, std::string_view line) {
  d.source_offset = 0;
  d.source_cut = false;
  if (line.size() <= kMaxSourceEcho) {
    d.source_line.assign(line);
    return;
  }
  // A window: a third before the column, the rest from it on.
  const std::size_t col = d.where.column > 0 ? std::min<std::size_t>(d.where.column - 1, line.size()) : 0;
  std::size_t begin = col > kMaxSourceEcho / 3 ? col - kMaxSourceEcho / 3 : 0;
  std::size_t end = std::min(line.size(), begin + kMaxSourceEcho);
  const auto continuation = [&](std::size_t i) { return i < line.size() && (static_cast<unsigned char>(line[i]) & 0xC0) == 0x80; };
  while (begin < col && continuation(begin)) ++begin;
  while (end > begin && continuation(end)) --end;
  d.source_line.assign(line.substr(begin, end - begin));
  d.source_offset = static_cast<std::uint32_t>(begin);
  d.source_cut = end < line.size();
}

std::string format(const Diagnostic& d, bool with_source) {
  // A diagnostic about a file as a whole (no line) names the file alone.
  std::string out = d.where.line > 0 ? fmt::format("{}:{}:{}: {}: {}: {}\n", d.file, d.where.line, d.where.column,
                                                   to_string(d.severity), d.code, d.message)
                                     : fmt::format("{}: {}: {}: {}\n", d.file, to_string(d.severity), d.code, d.message);
  if (with_source && d.where.line > 0) {
    // Tabs are kept so the caret lines up under the same bytes in a terminal.
    // A window of a long line is marked with '…' on the side(s) left out.
    const std::string_view lead = d.source_offset > 0 ? "…" : "";
    std::string caret(d.source_offset > 0 ? 1 : 0, ' ');
    const std::size_t col = d.where.column > d.source_offset ? d.where.column - 1 - d.source_offset : 0;
    for (std::size_t i = 0; i < col && i < d.source_line.size(); ++i) caret += d.source_line[i] == '\t' ? '\t' : ' ';
    caret += '^';
    // The underline stays within the line shown.
    const std::size_t room = d.source_line.size() > col ? d.source_line.size() - col : 1;
    const auto len = static_cast<std::uint32_t>(std::min<std::size_t>({d.length, 200, room}));
    for (std::uint32_t i = 1; i < len; ++i) caret += '~';
    out += fmt::format("  {}{}{}\n  {}\n", lead, d.source_line, d.source_cut ? "…" : "", caret);
  }
  return out;
}

void DiagnosticSink::report(Diagnostic d) {
  ++counts_[static_cast<int>(d.severity)];
  ++per_code_[d.code];
  // Bounded whatever the reporter passed: a window of a long line, a shortened message.
  if (d.source_line.size() > kMaxSourceEcho) {
    const std::string line = std::move(d.source_line);
    set_source_line(d, line);
  }
  if (d.message.size() > kMaxMessage) {
    std::size_t cut = kMaxMessage;
    while (cut > 0 && (static_cast<unsigned char>(d.message[cut]) & 0xC0) == 0x80) --cut;
    d.message.resize(cut);
    d.message += "…";
  }
  if (on_report) on_report(d);
  const std::size_t bytes = sizeof(Diagnostic) + d.message.size() + d.source_line.size() + d.file.size() + d.code.size();
  if (stored_.size() < max_stored_ && stored_bytes_ + bytes <= max_stored_bytes_) {
    stored_bytes_ += bytes;
    stored_.push_back(std::move(d));
  } else {
    ++dropped_;
  }
}

}  // namespace postproc::gcode
