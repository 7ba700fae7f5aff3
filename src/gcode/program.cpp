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

/// A line that starts a Fanuc program: O1234 or :1234 (the program number).
bool is_program_number_line(std::string_view line) {
  const auto p = line.find_first_not_of(" \t");
  if (p == std::string_view::npos || p + 1 >= line.size()) return false;
  const char c = line[p];
  return (c == 'O' || c == 'o' || c == ':') && line[p + 1] >= '0' && line[p + 1] <= '9';
}

/// 0: `line` is not a block the Fanuc lexer accepts (listing text); 1: comments only; 2: NC words.
int nc_kind(const Dialect& d, std::string_view line) {
  Block b;
  b.raw = line;
  b.line = 1;
  if (!lex_block(d, b, LexContext{"", nullptr})) return 0;
  return b.words.empty() && !b.has_n ? 1 : 2;
}

/// A Fanuc tape may carry text before its first '%' (e.g. a CAM listing); the control skips it. It
/// is a leader only if program lines follow that '%' — a single '%' at the end closes the program.
/// Without any '%', listing text (lines that are not NC blocks) before the first program number
/// O#### is a leader as well: B-64484EN "Label skip" — the control ignores what precedes the
/// program; a block of NC before the O number is kept (and read) instead.
Lookahead read_leader(LineReader& reader, const Dialect& d, std::size_t max_lines = 500) {
  Lookahead la;
  std::string_view line, eol;
  bool any_before = false;
  bool text = false, blocks = false;  // before a program number: listing text, NC blocks
  while (la.lines.size() < max_lines && reader.next(line, eol)) {
    la.lines.emplace_back(std::string(line), std::string(eol));
    if (!is_percent_line(line)) {
      if (is_program_number_line(line)) {
        if (text && !blocks) la.leader_lines = la.lines.size() - 1;
        return la;
      }
      if (line.find_first_not_of(" \t") != std::string_view::npos) {
        any_before = true;
        const int k = nc_kind(d, line);
        text = text || k == 0;
        blocks = blocks || k == 2;
      }
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
    Lookahead la = read_leader(reader, dialect);
    if (la.leader_lines > 0) {
      Block first;
      first.raw = la.lines.front().first;
      first.line = 1;
      report_at(ctx, first, {0, static_cast<std::uint32_t>(first.raw.size())}, Severity::note, codes::kTapeLeader,
                fmt::format("lines 1–{} come before the first '%' (or, without '%', are listing text before the "
                            "program number) and are skipped as tape leader, as the control does; they are copied "
                            "unchanged",
                            la.leader_lines));
    }
    for (std::size_t i = 0; i < la.lines.size(); ++i)
      process(la.lines[i].first, la.lines[i].second, ++number, i < la.leader_lines);
  }
  std::string_view line, eol;
  while (reader.next(line, eol)) process(line, eol, reader.line_number(), false);
  interp.finish();
  st.bytes = reader.bytes_read();
  return st;
}

}  // namespace postproc::gcode
