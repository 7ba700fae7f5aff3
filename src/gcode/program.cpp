#include "postproc/gcode/program.hpp"

#include <deque>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "postproc/gcode/lexer.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {
namespace {

class Collect final : public MotionSink {
 public:
  std::vector<Motion> motions;
  void motion(const Motion& m, const Block&) override { motions.push_back(m); }
};

bool is_percent_line(std::string_view line) {
  const auto p = line.find_first_not_of(" \t");
  return p != std::string_view::npos && line[p] == '%';
}

/// Lines read ahead to find a Fanuc tape leader (kept as owned copies).
struct Lookahead {
  std::deque<std::pair<std::string, std::string>> lines;  // raw, eol
  std::size_t leader_lines = 0;
};

/// A Fanuc tape may carry text before its first '%' (e.g. a CAM listing); the control skips it. It
/// is a leader only if program lines follow that '%' — a single '%' at the end closes the program.
Lookahead read_leader(LineReader& reader, std::size_t max_lines = 500) {
  Lookahead la;
  std::string_view line, eol;
  bool any_before = false;
  while (la.lines.size() < max_lines && reader.next(line, eol)) {
    la.lines.emplace_back(std::string(line), std::string(eol));
    if (!is_percent_line(line)) {
      if (line.find_first_not_of(" \t") != std::string_view::npos) any_before = true;
      continue;
    }
    if (!any_before) return la;  // the tape starts with '%': no leader
    const std::size_t percent_at = la.lines.size() - 1;
    while (la.lines.size() < percent_at + 50 && reader.next(line, eol)) {
      la.lines.emplace_back(std::string(line), std::string(eol));
      if (line.find_first_not_of(" \t") != std::string_view::npos) {
        la.leader_lines = percent_at;
        return la;
      }
    }
    return la;
  }
  return la;
}

}  // namespace

ProgramStats run_program(LineReader& reader, const Dialect& dialect, std::string_view file, DiagnosticSink& sink,
                         BlockVisitor& visitor, InterpreterOptions opt) {
  Interpreter interp(dialect, std::string(file), sink, opt);
  const LexContext ctx{file, &sink};
  Block b;
  Collect collect;
  ProgramStats st;
  auto process = [&](std::string_view line, std::string_view eol, std::uint64_t number, bool leader) {
    b.raw = line;
    b.eol = eol;
    b.line = number;
    bool ok = true;
    collect.motions.clear();
    if (leader) {
      b.words.clear();
      b.tokens.clear();
      b.has_n = false;
      b.block_delete = false;
    } else {
      ok = lex_block(dialect, b, ctx);
      interp.execute(b, collect);
    }
    b.leader = leader;
    visitor.block(b, collect.motions, ok);
    b.leader = false;
    ++st.blocks;
  };
  std::uint64_t number = 0;
  if (dialect.id == DialectId::fanuc) {
    Lookahead la = read_leader(reader);
    if (la.leader_lines > 0) {
      Block first;
      first.raw = la.lines.front().first;
      first.line = 1;
      report_at(ctx, first, {0, static_cast<std::uint32_t>(first.raw.size())}, Severity::note, codes::kTapeLeader,
                fmt::format("lines 1–{} come before the first '%' and are skipped as tape leader, as the control "
                            "does; they are copied unchanged",
                            la.leader_lines));
    }
    for (std::size_t i = 0; i < la.lines.size(); ++i)
      process(la.lines[i].first, la.lines[i].second, ++number, i < la.leader_lines);
  }
  std::string_view line, eol;
  while (reader.next(line, eol)) process(line, eol, reader.line_number(), false);
  st.bytes = reader.bytes_read();
  return st;
}

}  // namespace postproc::gcode
