// Shared machinery of the dialect resolvers, and the public entry points of resolve.hpp.
#include "support.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <unordered_set>

#include <fmt/format.h>

#include "postproc/error.hpp"
#include "postproc/io/input_file.hpp"
#include "src/gcode/siemens_keywords.hpp"

namespace postproc::gcode {
namespace resolver {

SourceFile::SourceFile(std::string name, std::string text, std::uint32_t index, const Dialect& d, DiagnosticSink& sink)
    : name_(std::move(name)), text_(std::move(text)), index_(index), d_(d) {
  ctx_.file = name_;
  ctx_.sink = &sink;
  std::string_view t = text_;
  std::size_t pos = 0;
  while (pos < t.size()) {
    std::size_t end = t.find_first_of("\r\n", pos);
    if (end == std::string_view::npos) end = t.size();
    lines_.push_back(t.substr(pos, end - pos));
    if (end < t.size() && t[end] == '\r' && end + 1 < t.size() && t[end + 1] == '\n') ++end;
    pos = end + 1;
  }
  seen_.assign(lines_.size(), 0);
  ok_.assign(lines_.size(), 1);
  cache_.resize(lines_.size());
}

const Block& SourceFile::block(std::size_t i) {
  if (cache_[i]) return *cache_[i];
  if (scratch_line_ == i) return scratch_;
  Block* b = &scratch_;
  if (seen_[i]) {
    cache_[i] = std::make_unique<Block>();
    b = cache_[i].get();
  }
  b->clear();
  b->raw = lines_[i];
  b->line = i + 1;
  // Report lexical errors only the first time the line is lexed.
  DiagnosticSink quiet(0);
  LexContext ctx = ctx_;
  if (seen_[i]) ctx.sink = &quiet;
  ok_[i] = lex_block(d_, *b, ctx) ? 1 : 0;
  seen_[i] = 1;
  if (b == &scratch_) scratch_line_ = i;
  return *b;
}

std::optional<std::size_t> SourceFile::find_n(double n, std::size_t from, bool forward) {
  if (!n_built_) {
    // N numbers: the first word of a line, "N123" after optional blanks and a block delete.
    for (std::size_t i = 0; i < lines_.size(); ++i) {
      std::string_view l = lines_[i];
      std::size_t p = l.find_first_not_of(" \t/");
      if (p == std::string_view::npos || (l[p] != 'N' && l[p] != 'n')) continue;
      const Block& b = block(i);
      if (b.has_n) n_index_.emplace_back(b.n_number, i);
    }
    n_built_ = true;
  }
  std::optional<std::size_t> best;
  for (const auto& [num, i] : n_index_) {
    if (num != n) continue;
    if (forward && i >= from && (!best || i < *best)) best = i;
    if (!forward && i <= from && (!best || i > *best)) best = i;
  }
  return best;
}

void SourceFile::report(std::size_t i, Span span, Severity sev, std::string_view code, std::string message) {
  // A position past the end (a subprogram that runs off its file) is reported at the last line.
  if (lines_.empty()) {
    Block none;
    none.line = 1;
    report_at(ctx_, none, Span{0, 0}, sev, code, std::move(message));
    return;
  }
  if (i >= lines_.size()) {
    i = lines_.size() - 1;
    span = Span{0, 0};
  }
  const Block& b = block(i);
  report_at(ctx_, b, span, sev, code, std::move(message));
}

std::uint32_t Emitter::stack_id() {
  if (current_valid_) return current_;
  std::vector<std::pair<std::string, std::uint64_t>> key;
  key.reserve(frames_.size());
  for (const CallFrame& f : frames_) key.emplace_back(f.file + '\n' + f.callee, f.line);
  auto [it, fresh] = interned_.emplace(std::move(key), static_cast<std::uint32_t>(out_.stacks.size()));
  if (fresh) out_.stacks.push_back(frames_);
  current_ = it->second;
  current_valid_ = true;
  return current_;
}

void Emitter::push_call(CallFrame frame) {
  frames_.push_back(std::move(frame));
  current_valid_ = false;
}

void Emitter::pop_call() {
  if (!frames_.empty()) frames_.pop_back();
  current_valid_ = false;
  if (frames_.empty()) {
    current_ = 0;
    current_valid_ = true;
  }
}

std::string Emitter::where() const {
  std::string s;
  for (auto it = frames_.rbegin(); it != frames_.rend(); ++it)
    s += fmt::format("{}{} at {}:{}", s.empty() ? "reached through " : " ← ", it->callee, it->file, it->line);
  return s;
}

bool Emitter::emit(SourceFile& f, std::size_t line, std::span<const Edit> edits) {
  ++out_.executed_blocks;
  std::string_view raw = f.raw(line);
  bool substituted = !edits.empty();
  std::string_view text = raw;
  if (substituted) {
    line_.clear();
    std::uint32_t pos = 0;
    for (const Edit& e : edits) {
      line_.append(raw.substr(pos, e.span.begin - pos));
      line_ += e.text;
      pos = e.span.end;
    }
    line_.append(raw.substr(pos));
    if (line_.find_first_not_of(" \t") == std::string::npos) return out_.executed_blocks <= opt_.max_blocks;
    text = line_;
  }
  if (out_.source_line.size() >= opt_.max_blocks || out_.text.size() + text.size() >= opt_.max_resolved_bytes)
    return false;
  out_.text.append(text);
  out_.text += '\n';
  out_.source_line.push_back(line + 1);
  out_.source_file.push_back(f.index());
  out_.stack.push_back(stack_id());
  out_.substituted.push_back(substituted);
  return true;
}

bool LoopGuard::back_jump(std::uint32_t file, std::size_t depth, std::size_t target) {
  const std::uint64_t key = (std::uint64_t{file} << 48) ^ (std::uint64_t{depth} << 40) ^ target;
  const std::pair<std::uint64_t, std::uint64_t> now{generation_, values_};
  const auto [it, fresh] = heads_.try_emplace(key, now);
  if (fresh) return true;
  const bool same = it->second == now;
  it->second = now;
  return !same;
}

std::string LoopGuard::silent_message() const {
  return fmt::format("more than {} lines executed in a row without writing a block (ResolveOptions::max_silent_lines, "
                     "--max-silent-lines): a loop that does not end? Check the loop's condition",
                     max_silent_);
}

std::string LoopGuard::no_progress_message() {
  return "the program comes back here with every variable, counter and call unchanged since it last came here: it "
         "would repeat the same lines forever (an endless loop); check the loop's condition and that its body changes "
         "the variable it tests";
}

std::string too_deep_message() {
  return fmt::format("the expression nests deeper than {} levels (brackets, function calls, signs, indirect "
                     "variables or a chain of operators); split it over several assignments",
                     kMaxExpressionDepth);
}

std::string runaway_limits(const ResolveOptions& opt) {
  return fmt::format("more than {} blocks or {} MiB of resolved program", opt.max_blocks, opt.max_resolved_bytes >> 20);
}

std::string format_value(double v, char letter) {
  if (v == 0) v = 0;  // no "-0"
  const bool code = std::string_view("GMTHDNOPLE").find(static_cast<char>(std::toupper(letter))) != std::string_view::npos;
  const double r = std::round(v);
  if (std::fabs(v - r) < 1e-10 * std::max(1.0, std::fabs(v))) {
    const std::string whole = fmt::format("{:.0f}", r == 0 ? 0.0 : r);
    return code ? whole : whole + ".";
  }
  std::string s = fmt::format("{:.10f}", v);
  while (!s.empty() && s.back() == '0') s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s;
}

bool block_has_statements(const Block& b) {
  for (const Token& t : b.tokens)
    if (t.kind == TokenKind::assignment || t.kind == TokenKind::control_flow || t.kind == TokenKind::declaration ||
        t.kind == TokenKind::label)
      return true;
  for (const Word& w : b.words)
    if (w.kind == ValueKind::expression || w.kind == ValueKind::parameter) return true;
  return false;
}

SourceFile& FileSet::add(std::string name, std::string text) {
  const auto index = static_cast<std::uint32_t>(files_.size());
  out_.files.push_back(name);
  files_.push_back(std::make_unique<SourceFile>(std::move(name), std::move(text), index, d_, sink_));
  return *files_.back();
}

SourceFile* FileSet::find(const std::vector<std::string>& candidates) {
  namespace fs = std::filesystem;
  for (const std::string& c : candidates) {
    if (auto it = by_name_.find(c); it != by_name_.end()) return it->second;
    for (const std::string& dir : opt_.search_dirs) {
      // Exact name first, then a case-insensitive match (controllers' names are upper case,
      // files on disk often are not).
      std::error_code ec;
      fs::path p = fs::path(dir) / c;
      std::string found;
      if (fs::is_regular_file(p, ec)) {
        found = p.string();
      } else {
        for (const auto& e : fs::directory_iterator(dir, ec)) {
          const std::string n = e.path().filename().string();
          if (n.size() == c.size() && std::equal(n.begin(), n.end(), c.begin(), [](char a, char b) {
                return std::toupper(static_cast<unsigned char>(a)) == std::toupper(static_cast<unsigned char>(b));
              })) {
            found = e.path().string();
            break;
          }
        }
      }
      if (found.empty()) continue;
      SourceFile& f = add(found, io::read_file(found, "subprogram"));
      by_name_[c] = &f;
      return &f;
    }
  }
  return nullptr;
}

}  // namespace resolver

bool siemens_builtin_name(std::string_view n) {
  static const std::unordered_set<std::string_view> kNames = {
      "MSG", "TRAORI", "TRAFOOF", "TRANSMIT", "TRACYL", "TRAANG", "SUPA", "STOPRE", "MCALL", "SETAL", "WAITM",
      "WAITE", "WAITMC", "CFC", "CFTCP", "CFIN", "FFWON", "FFWOF", "SOFT", "BRISK", "DRIVE", "DIAMON", "DIAMOF",
      "DIAM90", "TRANS", "ATRANS", "ROT", "AROT", "SCALE", "ASCALE", "MIRROR", "AMIRROR", "CTRANS", "CROT",
      "ORIWKS", "ORIMKS", "ORIAXES", "ORIVECT", "ORICONO", "OST", "CUT2D", "CUT2DF", "CUT3DC", "CUT3DF",
      "CUT3DFF", "CUT3DFS", "COMPOF", "COMPON", "COMPCURV", "COMPCAD", "TOFRAME", "TOROT", "TOROTOF",
      "PAROT", "PAROTOF", "SPOS", "SPOSA", "FGROUP", "FGREF", "FL", "ACC", "VELOLIM", "JERKLIM", "G_GROUP",
      "NORM", "KONT", "KONTC", "KONTT", "DISC", "DISR", "DISCL", "G17", "M", "TCARR", "TCOABS", "TCOFR",
      "PTP", "CP", "STOPFIFO", "STARTFIFO", "FIFOCTRL", "ROTS", "AROTS", "CORROF", "DRFOF", "RESET", "GETT",
      "WRTPR", "MSG", "ACN", "ACP", "DC", "CIC", "CAC", "CDC", "CACN", "CACP", "CLEARM", "SETM", "G4",
      "RTLION", "RTLIOF", "FNORM", "FLIN", "FCUB", "SPATH", "UPATH", "CPRECON", "CPRECOF", "OFFN", "TRAFOOF",
      "DYNNORM", "DYNPOS", "DYNROUGH", "DYNSEMIFIN", "DYNFINISH", "SOFTA", "BRISKA", "EXTCALL", "PCALL",
      "MCALL", "CALL", "HOLES1", "HOLES2", "LONGHOLE", "SLOT1", "SLOT2", "POCKET1", "POCKET2", "SETMS",
      "LIMS", "G0", "DEFAULT", "ENDPROC"};
  if (kNames.count(n)) return true;
  for (std::string_view p : {"CYCLE", "POCKET", "SLOT", "HOLES", "LONGHOLE", "E_", "F_", "_"})
    if (n.substr(0, p.size()) == p) return true;
  return false;
}

namespace {

/// `w` (upper case) at raw[i], case-insensitively.
bool at(std::string_view raw, std::size_t i, std::string_view w) {
  if (raw.size() - i < w.size()) return false;
  for (std::size_t k = 0; k < w.size(); ++k) {
    char c = raw[i + k];
    if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 32);
    if (c != w[k]) return false;
  }
  return true;
}

/// Cheap pre-filter: can this line hold anything resolve() evaluates? One pass over the line
/// looking for the dialect's statement characters and words (the lexer then decides).
bool may_need(std::string_view raw, const Dialect& d) {
  if (d.id == DialectId::heidenhain)  // Q parameters, FN, LBL, CALL: the lexer decides
    return raw.find_first_of("QqLlFf") != std::string_view::npos;
  if (d.id == DialectId::linuxcnc) {
    // One pass: a parameter or expression, or an M word (M98 / M99, Fanuc-style numbered programs:
    // the lexer below decides; few lines of a program hold an M).
    for (const char c : raw)
      if (c == '#' || c == '[' || c == 'M' || c == 'm') return true;
    const auto p = raw.find_first_not_of(" \t/");
    if (p == std::string_view::npos) return false;
    std::size_t q = p;
    if (raw[q] == 'N' || raw[q] == 'n')
      while (++q < raw.size() && (std::isdigit(static_cast<unsigned char>(raw[q])) || raw[q] == ' ')) {}
    return q < raw.size() && (raw[q] == 'o' || raw[q] == 'O');
  }
  const bool fanuc = d.id == DialectId::fanuc;
  if (!fanuc && d.id != DialectId::siemens) return false;
  // The characters that can start a statement word, per dialect (both cases): most characters of
  // a motion block (digits, '.', '-', blanks, axis letters) are skipped with one table look-up.
  struct Table {
    std::array<bool, 256> fanuc{}, siemens{};
    Table() {
      for (unsigned char c : std::string_view("#[=MGIWEmgiwe")) fanuc[c] = siemens[c] = true;
      for (unsigned char c : std::string_view(":FLRUDCPSflrudcps")) siemens[c] = true;
    }
  };
  static const Table table;
  const std::array<bool, 256>& start = fanuc ? table.fanuc : table.siemens;
  const auto* u = reinterpret_cast<const unsigned char*>(raw.data());
  const std::size_t size = raw.size();
  for (std::size_t i = 0; i < size; ++i) {
    // Four characters at a time while none can start a statement word (most of a motion block).
    while (i + 4 <= size && !(start[u[i]] | start[u[i + 1]] | start[u[i + 2]] | start[u[i + 3]])) i += 4;
    if (i >= size) break;
    if (!start[u[i]]) continue;
    char c = raw[i];
    if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 32);
    const std::size_t n = i + 1;
    switch (c) {
      case '#': case '[': case '=': return true;
      case ':': if (!fanuc) return true; break;
      case 'M': if (fanuc ? (at(raw, n, "98") || at(raw, n, "99")) : at(raw, n, "17")) return true; break;
      case 'G': if (at(raw, n, "OTO") || (fanuc && (at(raw, n, "65") || at(raw, n, "66")))) return true; break;
      case 'I': if (at(raw, n, "F")) return true; break;
      case 'W': if (at(raw, n, "HILE")) return true; break;
      case 'E': if (at(raw, n, "ND") || (!fanuc && at(raw, n, "LSE"))) return true; break;
      default:
        if (fanuc) break;
        switch (c) {
          case 'F': if (at(raw, n, "OR")) return true; break;
          case 'L': return true;  // LOOP, L123 calls (the lexer decides)
          case 'R': if (at(raw, n, "EPEAT") || at(raw, n, "ET")) return true; break;
          case 'U': if (at(raw, n, "NTIL")) return true; break;
          case 'D': if (at(raw, n, "EF")) return true; break;
          case 'C': if (at(raw, n, "ALL")) return true; break;
          case 'P': if (at(raw, n, "ROC")) return true; break;
          case 'S': if (at(raw, n, "ETAL")) return true; break;
          default: break;
        }
    }
  }
  if (!fanuc) {
    // A bare subprogram name (PART1, PART1(2)) can start with any letter: two letters in a row
    // send the line to the lexer (keywords, comments and names; the lexer decides).
    const auto letter = [](char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); };
    for (std::size_t i = 0; i + 1 < raw.size(); ++i)
      if (letter(raw[i]) && letter(raw[i + 1])) return true;
  }
  return false;
}

bool line_needs(std::string_view raw, std::uint64_t line, const Dialect& d, Block& b) {
  if (!may_need(raw, d)) return false;
  DiagnosticSink quiet(0);
  LexContext ctx{"", &quiet};
  b.clear();
  b.raw = raw;
  b.line = line;
  lex_block(d, b, ctx);
  if (d.id == DialectId::heidenhain) return resolver::klartext_needs(b);
  if (resolver::block_has_statements(b)) return true;
  if (d.id == DialectId::linuxcnc)
    for (const Word& w : b.words)
      if (w.letter == 'M' && w.kind == ValueKind::number && (w.number == 98 || w.number == 99)) return true;
  if (d.id == DialectId::fanuc)
    for (const Word& w : b.words)
      if ((w.letter == 'M' && (w.number == 98 || w.number == 99)) || (w.letter == 'G' && (w.number == 65 || w.number == 66)))
        return true;
  if (d.id == DialectId::siemens) {
    for (const Word& w : b.words)
      if (w.letter == 'L' && w.name_len == 1) return true;
    for (const Token& t : b.tokens)
      if (t.kind == TokenKind::call || t.kind == TokenKind::keyword) {
        const std::string_view n = b.text(t.name);
        std::string un(n);
        for (char& c : un) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
        if (un.find("CALL") != std::string::npos || un.find("RET") != std::string::npos ||
            un.find("SETAL") != std::string::npos)
          return true;
        // A name that is no keyword or predefined procedure: a call of the user's subprogram.
        if (!siemens_builtin_name(un) && !siemens_state_keyword(un)) return true;
      }
  }
  return false;
}

}  // namespace

bool needs_resolution(std::string_view text, const Dialect& d) { return first_resolution_line(text, d) != 0; }

std::uint64_t first_resolution_line(std::string_view text, const Dialect& d) {
  Block b;
  std::size_t pos = 0;
  std::uint64_t line = 0;
  while (pos < text.size()) {
    std::size_t end = text.find_first_of("\r\n", pos);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view raw = text.substr(pos, end - pos);
    if (end < text.size() && text[end] == '\r' && end + 1 < text.size() && text[end + 1] == '\n') ++end;
    pos = end + 1;
    if (line_needs(raw, ++line, d, b)) return line;
  }
  return 0;
}

bool needs_resolution(LineReader& in, const Dialect& d) {
  Block b;
  std::string_view raw, eol;
  std::uint64_t line = 0;
  while (in.next(raw, eol))
    if (line_needs(raw, ++line, d, b)) return true;
  return false;
}

ResolvedProgram resolve(std::string_view text, std::string_view file, const Dialect& d, const ResolveOptions& opt,
                        DiagnosticSink& sink) {
  ResolvedProgram r;
  r.resolved = true;
  resolver::FileSet files(r, d, opt, sink);
  files.add(std::string(file), std::string(text));
  resolver::Emitter out(r, opt);
  switch (d.id) {
    case DialectId::linuxcnc: resolver::resolve_linuxcnc(files, out, opt, sink, r); break;
    case DialectId::fanuc: resolver::resolve_fanuc(files, out, opt, sink, r); break;
    case DialectId::siemens: resolver::resolve_siemens(files, out, opt, sink, r); break;
    case DialectId::heidenhain: resolver::resolve_heidenhain(files, out, opt, sink, r); break;
    default: {
      Diagnostic diag;
      diag.severity = Severity::error;
      diag.code = "PP-E700";
      diag.file = std::string(file);
      diag.where = {1, 1};
      diag.message = fmt::format("the {} dialect has no parameters or control flow to evaluate", d.name);
      sink.report(std::move(diag));
    }
  }
  return r;
}

void map_to_source(const ResolvedProgram& r, Diagnostic& d) {
  if (!r.resolved || d.where.line == 0 || d.where.line > r.source_line.size()) return;
  const std::size_t i = d.where.line - 1;
  const std::uint32_t f = r.source_file[i];
  if (f < r.files.size()) d.file = r.files[f];
  if (r.substituted[i]) d.message += fmt::format(" (in the block as resolved: {})", d.source_line);
  d.where.line = r.source_line[i];
  if (r.substituted[i]) {
    d.where.column = 1;
    d.length = 1;
  }
  const auto& frames = r.stacks[r.stack[i]];
  if (!frames.empty()) {
    std::string s;
    for (auto it = frames.rbegin(); it != frames.rend(); ++it)
      s += fmt::format("{}{} at {}:{}", s.empty() ? "; reached through " : " ← ", it->callee, it->file, it->line);
    d.message += s;
  }
}

std::pair<std::string, double> parse_setting(std::string_view text) {
  const auto eq = text.rfind('=');
  if (eq == std::string_view::npos || eq == 0 || eq + 1 >= text.size())
    throw Error(ExitCode::usage, fmt::format("--set '{}': give NAME=VALUE, e.g. --set '#5061=1.25'", text));
  std::string name(text.substr(0, eq));
  while (!name.empty() && name.back() == ' ') name.pop_back();
  const std::string value(text.substr(eq + 1));
  std::size_t used = 0;
  double v = 0;
  try {
    v = std::stod(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != value.size() || !std::isfinite(v))
    throw Error(ExitCode::usage, fmt::format("--set '{}': '{}' is not a number", text, value));
  for (char& c : name) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return {name, v};
}

}  // namespace postproc::gcode
