#include "postproc/gcode/program.hpp"
#include "postproc/gcode/detect.hpp"

#include <algorithm>
#include <array>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "postproc/gcode/lexer.hpp"
#include "src/gcode/codes.hpp"
#include "src/gcode/program_end.hpp"
#include "src/gcode/klartext.hpp"

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

namespace {

/// Where the program ends, as the controls read it: M2 or M30 ends it (every ISO dialect); in
/// Fanuc and LinuxCNC files a '%' line after the program's first line closes the tape. Lines after
/// the end are never run (LinuxCNC stops reading; Fanuc rewinds to the start; Sinumerik ends the
/// program): they are said once, when they hold NC words, and copied unchanged.
struct ProgramEnd {
  bool ended = false;
  bool said = false;
  bool opened = false;     ///< a '%' line before the program's first NC line
  bool content = false;    ///< an NC line was read
  bool seen = false;       ///< a line with anything but blanks was read (comments too)
  /// LinuxCNC text from the resolver (it holds O-word lines): the resolver stopped it at the end
  /// already, and what it passes on after an M2 (a G7x profile's lines) is read for the cycle.
  bool resolved = false;
  std::uint64_t end_line = 0;
  std::string what;        ///< "M30", "the closing '%'"
  std::uint64_t last_line = 0;  ///< the last NC line (LinuxCNC's end-of-file warning points at it)
  std::string last_text;

  [[nodiscard]] static bool percent_line(const Block& b) {
    return b.words.empty() && std::any_of(b.tokens.begin(), b.tokens.end(),
                                          [](const Token& t) { return t.kind == TokenKind::percent; });
  }
  [[nodiscard]] static bool tape_dialect(const Dialect& d) {
    return d.id == DialectId::fanuc || d.id == DialectId::linuxcnc;
  }

  /// A line before the end. False when it is refused (LinuxCNC: a '%' that closes nothing).
  bool before(const Dialect& d, const Block& b, const LexContext& ctx) {
    if (d.id == DialectId::linuxcnc && std::any_of(b.tokens.begin(), b.tokens.end(), [](const Token& t) {
          return t.kind == TokenKind::control_flow;
        }))
      resolved = true;
    if (resolved) return true;
    if (tape_dialect(d) && percent_line(b)) {
      // LinuxCNC takes '%' as the opening one only on the first line that is not blank.
      if (d.id == DialectId::linuxcnc ? !seen : !content) {
        opened = seen = true;
        return true;
      }
      if (opened) {
        ended = true;
        end_line = b.line;
        what = "the closing '%'";
        return true;
      }
      if (d.id == DialectId::linuxcnc) {
        report_at(ctx, b, {0, static_cast<std::uint32_t>(std::max<std::size_t>(b.raw.size(), 1))}, Severity::error,
                  codes::kStrayPercent,
                  "'%' is read only on the file's first line that is not blank, and then as the line that closes "
                  "it: LinuxCNC stops here with 'Bad character '%' used'; put the opening '%' first (before any "
                  "comment), or end the program with M2 instead");
        ended = said = true;
        return false;
      }
      ended = true;  // Fanuc: the end of the tape
      end_line = b.line;
      what = "the end of tape '%'";
      return true;
    }
    seen = seen || !b.words.empty() || !b.tokens.empty();
    if (program_end::holds_nc_words(b)) {
      content = true;
      if (d.id == DialectId::linuxcnc) {
        last_text.assign(b.raw);
        last_line = b.line;
      }
    }
    return true;
  }

  /// After the line ran: M2 / M30 end the program.
  void check(const Dialect& d, const Block& b) {
    if (ended || resolved) return;
    for (const Word& w : b.words)
      if (program_end::ends_program(w)) {
        ended = true;
        end_line = b.line;
        what = fmt::format("M{}", w.number == 2 ? (d.id == DialectId::fanuc ? "02" : "2") : "30");
        return;
      }
  }

  /// A line after the end, not yet said (lexed without diagnostics).
  void after(const Dialect& d, const Block& b, const LexContext& ctx) {
    if (program_end::starts_program(b, d.id)) {
      said = true;
      return;
    }
    if (!program_end::holds_nc_words(b)) return;
    said = true;
    report_at(ctx, b, {0, static_cast<std::uint32_t>(std::max<std::size_t>(b.raw.size(), 1))}, Severity::warning,
              codes::kAfterProgramEnd, program_end::after_end_message(what, end_line));
  }

  /// End of file: LinuxCNC wants M2/M30 or the closing '%'.
  void finish(const Dialect& d, const LexContext& ctx) const {
    if (ended || resolved || !content || d.id != DialectId::linuxcnc) return;
    Block last;
    last.raw = last_text;
    last.line = last_line;
    report_at(ctx, last, {0, static_cast<std::uint32_t>(std::max<std::size_t>(last.raw.size(), 1))},
              Severity::warning, codes::kNoProgramEnd,
              opened ? std::string("the file opens with '%' but ends without the closing '%' (or M2/M30): LinuxCNC "
                                   "runs every line, then stops with 'File ended with no percent sign'; add '%' or M2 "
                                   "at the end")
                     : std::string("the program ends without M2 or M30: LinuxCNC runs every line, then stops with "
                                   "'File ended with no percent sign or program end'; end it with M2"));
  }
};

}  // namespace

ProgramStats run_program(LineReader& reader, const Dialect& given, std::string_view file, DiagnosticSink& sink,
                         BlockVisitor& visitor, InterpreterOptions opt) {
  // A Fanuc lathe program whose G-code system is not stated: read it off the program first.
  const Dialect settled = given.gcode_system == '?' ? settle_gcode_system(given, reader, file, sink) : Dialect{};
  const Dialect& dialect = given.gcode_system == '?' ? settled : given;
  if (dialect.id == DialectId::heidenhain) return klartext::run(reader, dialect, file, sink, visitor);
  Interpreter interp(dialect, std::string(file), sink, opt);
  const LexContext ctx{file, &sink};
  Block b;
  Collect collect;
  ProgramStats st;
  // Lines come from the Fanuc leader look-ahead first, then from the reader. A chamfer or corner
  // rounding needs the next line before its own block is passed on: that line is read ahead and
  // held (both lines are copied, since a read may reuse the reader's buffer).
  struct Source {
    std::string_view line, eol;
    std::uint64_t number = 0;
    bool leader = false;
    int buffer = -1;  ///< index into `copies` when the line lives there
  };
  struct Pending {
    std::string text;  ///< the line and its end, owned
    Block block;       ///< spans into `text`
    std::vector<Motion> motions;
    bool ok = true;
  };
  std::deque<Pending> pending;
  const auto release_pending = [&] {
    for (Pending& p : pending) visitor.block(p.block, p.motions, p.ok);
    pending.clear();
  };
  Lookahead la;
  std::size_t la_next = 0, la_count = 0;
  std::uint64_t number = 0;
  std::optional<Source> held;
  std::array<std::string, 2> copies;
  const auto fetch = [&](Source& src) {
    if (held) {
      src = *held;
      held.reset();
      return true;
    }
    if (la_next < la_count) {
      src = {la.lines[la_next].first, la.lines[la_next].second, ++number, la_next < la.leader_lines, -1};
      ++la_next;
      return true;
    }
    std::string_view l, e;
    if (!reader.next(l, e)) return false;
    src = {l, e, reader.line_number(), false, -1};
    return true;
  };
  const auto keep = [&](Source& src, int k) {
    copies[static_cast<std::size_t>(k)].assign(src.line).append(src.eol);
    const std::string_view all = copies[static_cast<std::size_t>(k)];
    src.line = all.substr(0, src.line.size());
    src.eol = all.substr(src.line.size());
    src.buffer = k;
  };
  // The program's end: M2/M30, or (Fanuc, LinuxCNC) the '%' that closes an opening one. The
  // control runs nothing after it: later lines are copied unchanged, like a tape leader.
  ProgramEnd end;
  const auto process = [&](Source& src) {
    b.raw = src.line;
    b.eol = src.eol;
    b.line = src.number;
    bool ok = true;
    collect.motions.clear();
    if (!src.leader && end.ended) {
      if (!end.said) {
        (void)lex_block(dialect, b, LexContext{file, nullptr});
        end.after(dialect, b, ctx);
      }
      src.leader = true;
    }
    if (src.leader) {
      b.words.clear();
      b.tokens.clear();
      b.has_n = false;
      b.block_delete = false;
    } else {
      ok = lex_block(dialect, b, ctx);
      if (const auto too_long = opt.source_text ? line_too_long(dialect, b.raw, b.eol) : std::nullopt) {
        const auto at = static_cast<std::uint32_t>(std::min(b.raw.size(), max_line_length(dialect)));
        report_at(ctx, b, {at, static_cast<std::uint32_t>(std::max<std::size_t>(b.raw.size(), at + 1))},
                  Severity::error, codes::kControllerRefuses,
                  *too_long + ": split the line (a comment can go on a line of its own)");
        ok = false;
        b.words.clear();
        b.tokens.clear();
      } else if (!end.before(dialect, b, ctx)) {
        ok = false;
        b.words.clear();
        b.tokens.clear();
      }
      interp.execute(b, collect);
      end.check(dialect, b);
      if (interp.corner_pending()) {
        if (src.buffer < 0) {
          keep(src, 0);
          b.raw = src.line;
          b.eol = src.eol;
        }
        Source ahead;
        Block next;
        if (fetch(ahead)) {
          keep(ahead, 1 - src.buffer);
          held = ahead;
          next.raw = ahead.line;
          next.line = ahead.number;
          (void)lex_block(dialect, next, LexContext{file, nullptr});
        }
        interp.resolve_corner(b, next, collect.motions);
      }
    }
    b.leader = src.leader;
    if (pending.empty() && !interp.offset_holding()) {
      visitor.block(b, collect.motions, ok);
    } else {
      // LinuxCNC cutter radius compensation holds a block's move until a later block fixes its end:
      // the blocks wait (in order, with their text) and each gets its own motions by line.
      Pending& p = pending.emplace_back();  // (a deque: the elements, and so their text, stay put)
      p.text.assign(b.raw).append(b.eol);
      p.block = b;
      p.block.raw = std::string_view(p.text).substr(0, b.raw.size());
      p.block.eol = std::string_view(p.text).substr(b.raw.size());
      p.ok = ok;
      for (Motion& m : collect.motions) {
        auto it = pending.rbegin();
        while (it != pending.rend() && it->block.line != m.line) ++it;
        (it != pending.rend() ? *it : pending.back()).motions.push_back(std::move(m));
      }
      if (!interp.offset_holding()) release_pending();
    }
    b.leader = false;
    ++st.blocks;
  };
  if (dialect.id == DialectId::fanuc) {
    la = read_leader(reader, dialect);
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
  }
  la_count = la.lines.size();
  Source src;
  while (fetch(src)) process(src);
  end.finish(dialect, ctx);
  interp.finish();
  release_pending();
  st.bytes = reader.bytes_read();
  return st;
}

}  // namespace postproc::gcode
