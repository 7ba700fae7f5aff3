#include "postproc/gcode/detect.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

#include "postproc/gcode/lexer.hpp"
#include "postproc/gcode/motion.hpp"
#include "src/gcode/codes.hpp"

#include "src/gcode/text.hpp"

namespace postproc::gcode {
namespace {
using text::upper;

struct Marker {
  std::string_view text;  // matched case-insensitively
  DialectId id;
  bool at_line_start;
};

// Constructs that only one dialect writes. Order matters: the first match wins.
constexpr std::array<Marker, 22> kMarkers = {{
    {"TRAORI", DialectId::siemens, false},     {"TRAFOOF", DialectId::siemens, false},
    {"CYCLE8", DialectId::siemens, false},     {"%_N_", DialectId::siemens, true},
    {"DEF REAL", DialectId::siemens, true},    {"MSG(", DialectId::siemens, false},
    {";$PATH", DialectId::siemens, true},      {"G642", DialectId::siemens, false},
    {"#<", DialectId::linuxcnc, false},        {" SUB", DialectId::linuxcnc, false},
    {"ENDSUB", DialectId::linuxcnc, false},    {"M428", DialectId::linuxcnc, false},
    {"G64 P", DialectId::linuxcnc, false},     {"ENDWHILE", DialectId::linuxcnc, false},
    {"G43.4", DialectId::fanuc, false},        {"G05.1", DialectId::fanuc, false},
    {"G54.1", DialectId::fanuc, false},        {"WHILE [", DialectId::fanuc, false},
    {"GOTO", DialectId::fanuc, false},         {"M128", DialectId::heidenhain_iso, false},
    {"BEGIN PGM", DialectId::heidenhain, true}, {"G65 P", DialectId::fanuc, false},
}};


bool match_at(std::string_view line, std::size_t pos, std::string_view pat) {
  if (pos + pat.size() > line.size() || upper(line[pos]) != pat[0]) return false;
  for (std::size_t i = 1; i < pat.size(); ++i)
    if (upper(line[pos + i]) != pat[i]) return false;
  return true;
}

/// Heidenhain Klartext: a numbered (or unnumbered) block whose verb only Klartext has.
std::optional<std::string_view> klartext_verb(std::string_view line) {
  std::size_t p = line.find_first_not_of(" \t");
  if (p == std::string_view::npos) return std::nullopt;
  while (p < line.size() && line[p] >= '0' && line[p] <= '9') ++p;
  p = line.find_first_not_of(" \t", p);
  if (p == std::string_view::npos) return std::nullopt;
  for (const std::string_view v : {"BEGIN PGM", "TOOL CALL", "CYCL DEF", "CALL LBL", "BLK FORM"})
    if (match_at(line, p, v)) return v;
  return std::nullopt;
}

/// LinuxCNC writes its loops as o-words ("o101 while [...]"): a Fanuc marker that follows one is
/// LinuxCNC's.
bool after_o_word(std::string_view before, const Marker& m) {
  if (m.id != DialectId::fanuc) return false;
  std::size_t i = before.find_first_not_of(" \t");
  if (i == std::string_view::npos || (before[i] != 'o' && before[i] != 'O')) return false;
  return i + 1 < before.size() && (before[i + 1] == '<' || (before[i + 1] >= '0' && before[i + 1] <= '9'));
}

}  // namespace

std::optional<DialectGuess> guess_dialect(std::string_view text, std::size_t max_lines) {
  std::size_t start = 0;
  for (std::size_t ln = 1; ln <= max_lines && start < text.size(); ++ln) {
    // Lines end in LF, CR LF or a lone CR (old Mac and some DNC tools): as LineReader reads them.
    std::size_t end = text.find_first_of("\r\n", start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(start, end - start);
    if (end + 1 < text.size() && text[end] == '\r' && text[end + 1] == '\n') ++end;
    if (const auto v = klartext_verb(line))
      return DialectGuess{DialectId::heidenhain, std::string(*v), ln,
                          static_cast<std::uint32_t>(line.find(v->substr(0, 1)) + 1)};
    // The (upper-case) characters of the line: a marker whose first character is not among them
    // cannot match anywhere in it (most lines of a CAM program hold no G, #, % or ;).
    std::array<bool, 256> present{};
    for (const char c : line) present[static_cast<unsigned char>(upper(c))] = true;
    for (const Marker& m : kMarkers) {
      if (!present[static_cast<unsigned char>(m.text[0])]) continue;
      // Markers inside ( ) comments say nothing about the dialect: "(ROUGH SUB-PROGRAM)".
      const std::size_t last = m.at_line_start ? 0 : line.size();
      int depth = 0;
      for (std::size_t p = 0; p <= last && p < line.size(); ++p) {
        if (line[p] == '(' && !m.at_line_start) ++depth;
        if (depth == 0 && match_at(line, p, m.text) && !after_o_word(line.substr(0, p), m))
          return DialectGuess{m.id, std::string(m.text), ln, static_cast<std::uint32_t>(p + 1)};
        if (line[p] == ')' && depth > 0) --depth;
      }
    }
    start = end + 1;
  }
  return std::nullopt;
}

bool warn_other_dialect(std::string_view text, std::string_view file, const Dialect& used, std::string_view source,
                        DiagnosticSink& sink) {
  const std::optional<DialectGuess> g = guess_dialect(text);
  if (!g || g->id == used.id) return false;
  const Dialect other = make_dialect(g->id);
  Diagnostic w;
  w.severity = Severity::warning;
  w.code = "PP-W005";
  w.file = std::string(file);
  w.where = {g->line, g->column};
  w.message = fmt::format("'{}' is written by {} programs, but this one is read as {} ({}); if the program is for a "
                          "{} control, pass --dialect {}",
                          g->evidence, other.name, used.name, source, other.name, other.name);
  // The evidence's line, for the caret display.
  std::size_t start = 0;
  for (std::uint64_t ln = 1; ln < g->line && start < text.size(); ++ln) {
    const std::size_t end = text.find_first_of("\r\n", start);
    if (end == std::string_view::npos) {
      start = text.size();
      break;
    }
    start = end + (end + 1 < text.size() && text[end] == '\r' && text[end + 1] == '\n' ? 2 : 1);
  }
  std::size_t stop = text.find_first_of("\r\n", start);
  if (stop == std::string_view::npos) stop = text.size();
  set_source_line(w, text.substr(start, stop - start));
  w.length = static_cast<std::uint32_t>(std::max<std::size_t>(1, g->evidence.size()));
  sink.report(std::move(w));
  return true;
}

}  // namespace postproc::gcode

// ---- Fanuc lathe G-code system ----------------------------------------------------------------

namespace postproc::gcode {
namespace {

bool is_motion(int code10) { return code10 == 0 || code10 == 10 || code10 == 20 || code10 == 30; }

/// Evidence in one lexed block, or nullopt.
std::optional<GCodeSystemEvidence> evidence_of(const Block& b, const Word* g9x, int motion, bool axis, bool f, bool s);

std::optional<GCodeSystemEvidence> evidence_in(const Block& b) {
  int motion = -1;
  bool axis = false, f = false, s = false;
  for (const Word& w : b.words) {
    if (w.letter == 'F' && w.name_len == 1) f = true;
    if (w.letter == 'S' && w.name_len == 1) s = true;
    if (w.name_len == 1 && axis_index(w.letter) >= 0) axis = true;
    if (w.letter != 'G' || w.name_len != 1 || w.kind != ValueKind::number) continue;
    const long c = std::lround(w.number * 10);
    if (is_motion(static_cast<int>(c))) motion = static_cast<int>(c);
  }
  // A block may hold both (G00 G90 G99: G99 is a return level beside absolute mode in system B): B first.
  std::optional<GCodeSystemEvidence> found;
  for (const Word& w : b.words) {
    if (w.letter != 'G' || w.name_len != 1 || w.kind != ValueKind::number) continue;
    const long c = std::lround(w.number * 10);
    if (c != 900 && c != 910 && c != 940 && c != 950 && c != 920 && c != 980 && c != 990) continue;
    auto e = evidence_of(b, &w, motion, axis, f, s);
    if (e && e->system == 'B') return e;
    if (e && !found) found = std::move(e);
  }
  return found;
}

std::optional<GCodeSystemEvidence> evidence_of(const Block& b, const Word* g9x, int motion, bool axis, bool f, bool s) {
  const long c = std::lround(g9x->number * 10);
  GCodeSystemEvidence e;
  e.line = b.line;
  e.column = g9x->span.begin + 1;
  e.text = std::string(b.text(g9x->span));
  e.source = std::string(b.raw);
  if ((c == 900 || c == 910) && motion >= 0) {
    e.system = 'B';
    e.why = fmt::format("'{}' beside G0{}: {} mode of systems B/C (in system A both are group-01 motion codes)", e.text,
                        motion / 10, c == 900 ? "absolute" : "incremental");
  } else if ((c == 900 || c == 940) && !axis) {
    e.system = 'B';
    e.why = fmt::format("'{}' without axis words: {} of systems B/C (in system A, {} is a turning cycle that needs "
                        "X/U and Z/W)",
                        e.text, c == 900 ? "absolute mode" : "feed per minute", e.text);
  } else if ((c == 910 || c == 950) && !axis) {
    e.system = 'B';
    e.why = fmt::format("'{}': {} of systems B/C (system A has no {})", e.text,
                        c == 910 ? "incremental mode" : "feed per revolution", e.text);
  } else if (c == 920 && s && !axis) {
    e.system = 'B';
    e.why = fmt::format("'{}' with S: spindle speed clamp of systems B/C (system A: G50 S; G92 is its threading "
                        "cycle)",
                        e.text);
  } else if ((c == 980 || c == 990) && (motion >= 0 || f)) {
    e.system = 'A';
    e.why = fmt::format("'{}' beside a {}: feed per {} of system A (in systems B/C G98/G99 only choose a canned "
                        "cycle's return level)",
                        e.text, motion >= 0 ? "motion" : "feed", c == 980 ? "minute" : "revolution");
  } else {
    return std::nullopt;
  }
  return e;
}

}  // namespace

GCodeSystemScan scan_lathe_gcode_system(LineReader& in, const Dialect& d) {
  GCodeSystemScan scan;
  Block b;
  std::string_view line, eol;
  while ((!scan.a || !scan.b) && in.next(line, eol)) {
    if (line.find('G') == std::string_view::npos && line.find('g') == std::string_view::npos) continue;
    b.clear();
    b.raw = line;
    b.line = in.line_number();
    (void)lex_block(d, b, LexContext{});
    if (auto e = evidence_in(b)) {
      auto& slot = e->system == 'A' ? scan.a : scan.b;
      if (!slot) slot = std::move(e);
    }
  }
  return scan;
}

Dialect settle_gcode_system(const Dialect& d, LineReader& in, std::string_view file, DiagnosticSink& sink) {
  if (d.id != DialectId::fanuc || !d.lathe || d.gcode_system != '?') return d;
  Dialect settled = d;
  const auto report = [&](Severity sev, std::string_view code, std::uint64_t line, std::uint32_t column,
                          std::string msg, const std::string& source = {}, std::uint32_t length = 1) {
    Block at;  // the evidence's block as written, for the located message and its caret
    at.raw = source;
    at.line = line;
    report_at(LexContext{file, &sink}, at, Span{column - 1, column - 1 + length}, sev, code, std::move(msg));
  };
  const std::uint64_t start = in.line_number();
  GCodeSystemScan scan = scan_lathe_gcode_system(in, d);
  if (start != 0 || !in.rewind()) {
    report(Severity::error, codes::kGCodeSystemAmbiguous, 1, 1,
           "the Fanuc lathe G-code system (A or B/C) is not stated and a program read from a stream cannot be "
           "scanned for it; pass --gcode-system A or B (machine file: gcode_system)");
    set_gcode_system(settled, 'A');
    return settled;
  }
  if (scan.a && scan.b) {
    const auto& later = scan.a->line > scan.b->line ? *scan.a : *scan.b;
    const auto& earlier = scan.a->line > scan.b->line ? *scan.b : *scan.a;
    report(Severity::error, codes::kGCodeSystemAmbiguous, later.line, later.column,
           fmt::format("the program is written for two Fanuc lathe G-code systems: {}, but line {}: {}; pass "
                       "--gcode-system A or B as the control is set (parameters GSB/GSC, No. 3401)",
                       later.why, earlier.line, earlier.why),
           later.source, static_cast<std::uint32_t>(later.text.size()));
    set_gcode_system(settled, 'A');
    return settled;
  }
  const char sys = scan.b ? 'B' : 'A';
  if (scan.a || scan.b) {
    const auto& e = scan.b ? *scan.b : *scan.a;
    report(Severity::note, codes::kGCodeSystemFound, e.line, e.column,
           fmt::format("read as Fanuc lathe G-code system {}: {}; pass --gcode-system to state it", sys == 'A' ? "A" : "B",
                       e.why),
           e.source, static_cast<std::uint32_t>(e.text.size()));
  }
  set_gcode_system(settled, sys);
  return settled;
}

}  // namespace postproc::gcode
