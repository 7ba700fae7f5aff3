// Resolver for LinuxCNC (rs274ngc) programs: numbered and named parameters, [ ] expressions,
// O-word subroutines and control flow (include/postproc/gcode/resolve.hpp).
//
// Each line is compiled once (expressions to a small stack program) and cached, so loop bodies
// run without lexing or parsing again.
#include <algorithm>
#include <array>
#include <set>
#include <cctype>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>

#include "linuxcnc_expr.hpp"
#include "support.hpp"

namespace postproc::gcode::resolver {
namespace {

using namespace lcnc;

constexpr int kNumbered = 5603;  // #0 … #5602

std::string lower(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return r;
}

/// Numbered parameters the controller fills at run time (or keeps in its var file).
const char* runtime_numbered(int n) {
  if (n >= 5061 && n <= 5070) return "the probe result (G38)";
  if (n >= 5161 && n <= 5169) return "the G28 home position (var file)";
  if (n >= 5181 && n <= 5189) return "the G30 position (var file)";
  if (n >= 5210 && n <= 5219) return "the G92 offset (var file)";
  if (n >= 5220 && n <= 5390) return "a coordinate-system offset (var file)";
  if (n == 5399) return "the M66 input result";
  if (n >= 5400 && n <= 5413) return "tool data";
  if (n >= 5420 && n <= 5428) return "the current position";
  if (n >= 5599) return "a controller setting";
  return nullptr;
}

// ---------------------------------------------------------------------------------------------
// Compiled lines

enum class Kw : std::uint8_t { none, sub, endsub, call, ret, if_, elseif, else_, endif, while_, endwhile, do_, repeat, endrepeat, break_, continue_ };

struct Assign {
  Span span;  // the assignment token
  bool named = false;
  int name_id = 0;
  Code index;  // numbered: the parameter number
  Code value;
};

struct WordValue {
  Span span;  // the value text
  char letter;
  Code code;
};

struct Line {
  bool compiled = false;
  bool ok = true;          // compiled without error (the error was reported)
  bool plain = true;       // nothing to evaluate: emitted as written
  // control
  Kw kw = Kw::none;
  std::string oname;       // lower case, "o100" or "o<name>"
  Span control_span;
  std::vector<Code> args;  // call arguments / condition / return value / repeat count
  // ordinary block
  std::vector<WordValue> words;
  std::vector<Assign> assigns;
  std::vector<Span> deletions;  // assignment tokens
  bool ends_program = false;    // M2 / M30
  // Probing (G38.2–G38.5, modal group 1): a line that probes leaves #5061–#5070 to the run.
  enum class Probe : std::uint8_t { none, starts, ends } probe = Probe::none;  ///< G38.x / another group-1 G
  bool axis_words = false;
  bool abort = false;           // (abort, …)
  bool cycle_profile = false;   // G70–G72: profile in a subroutine
  Span cycle_span;
  bool cycle_q_literal = false; // the Q word is a plain number (cycle_q)
  double cycle_q = 0;
  std::string abort_text;
  std::size_t match = 0;        // structure: see Structure
};

struct Sub {
  SourceFile* file = nullptr;
  std::size_t begin = 0;  // the sub line
  std::size_t end = 0;    // the endsub line
};

struct Frame {
  std::array<double, 31> saved{};  // #1–#30 of the caller
  std::unordered_map<int, double> locals;  // named locals
  std::map<std::size_t, long> repeats;     // remaining passes by repeat line
};

class Machine {
 public:
  Machine(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r)
      : files_(files), out_(out), opt_(opt), sink_(sink), r_(r), numbered_(kNumbered, 0.0) {
    const std::vector<std::pair<std::string, double>> fixed = {{"_vmajor", 2}, {"_vminor", 9}, {"_value", 0},
                                                               {"_value_returned", 0}, {"_call_level", 0}, {"_task", 1}};
    for (const auto& [n, v] : fixed) globals_[names_.id(n)] = v;
  }

  void run() {
    SourceFile& main = files_.main();
    prepare(main);
    frames_.emplace_back();
    try {
      execute(main, 0, main.lines(), false);
    } catch (const Stop&) {
      if (!sink_.has_errors() && out_.emitted() > 0) close_tape(main);
      if (out_.emitted() > 0 || sink_.has_errors()) throw;
    }
    if (out_.emitted() == 0 && !subs_.empty()) {
      // A file of subroutine definitions only (called from other programs): nothing runs.
      Diagnostic d;
      d.severity = Severity::error;
      d.code = "PP-E709";
      d.file = main.name();
      d.where = {1, 1};
      set_source_line(d, main.raw(0));
      d.message = fmt::format("the file only defines subroutines ({}…) and executes nothing; resolve the program that "
                              "calls them (this file is found next to it)",
                              subs_.begin()->first);
      sink_.report(std::move(d));
    }
  }

 private:
  struct Stop {};  // program end (M2/M30) or a refusal: unwinds everything

  struct FileInfo {
    std::vector<Line> lines;
    // structure: for each control line, the line it pairs with (see prepare)
    std::map<std::size_t, std::size_t> end_of;    // sub → endsub, if → endif, while → endwhile, do → while, repeat → endrepeat
    std::map<std::size_t, std::size_t> start_of;  // the reverse, for closers
    std::map<std::size_t, std::vector<std::size_t>> branches;  // if → [elseif…, else…, endif]
  };

  // -- compile -------------------------------------------------------------------------------
  Line& line(SourceFile& f, std::size_t i) {
    Line& l = info(f).lines[i];
    if (!l.compiled) compile(f, i, l);
    return l;
  }
  FileInfo& info(SourceFile& f) {
    auto& p = info_[&f];
    if (!p) {
      p = std::make_unique<FileInfo>();
      p->lines.resize(f.lines());
    }
    return *p;
  }

  void parse_error(SourceFile& f, std::size_t i, Span within, const ParseError& e) {
    const auto at = static_cast<std::uint32_t>(within.begin + std::min<std::size_t>(e.pos, within.size()));
    if (e.code != "PP-E702") {  // a limit or range, not the syntax
      f.report(i, Span{at, std::max(at + 1, within.end)}, Severity::error, e.code, e.what + context());
      return;
    }
    f.report(i, Span{at, std::max(at + 1, within.end)}, Severity::error, "PP-E702",
             fmt::format("{}; the expression cannot be evaluated (rs274ngc syntax: [ ] around expressions, "
                         "operators ** * / MOD + - EQ NE GT GE LT LE AND OR XOR){}",
                         e.what, context()));
  }

  void compile(SourceFile& f, std::size_t i, Line& l) {
    l.compiled = true;
    const Block& b = f.block(i);
    if (!f.lexed_ok(i)) {
      l.ok = false;
      return;
    }
    for (const Token& t : b.tokens) {
      if (t.kind == TokenKind::control_flow) {
        l.plain = false;
        compile_control(f, i, b, t, l);
      } else if (t.kind == TokenKind::assignment) {
        l.plain = false;
        // One token may hold several assignments: "#1 = 2 #2 = [#1 + 1]".
        const std::string_view text = b.text(t.span);
        Parser p(text, names_);
        try {
          while (!p.at_end()) {
            Assign a;
            a.span = t.span;
            a.named = p.target(a.index, a.name_id);
            p.expect('=');
            p.real_value(a.value);
            l.assigns.push_back(std::move(a));
          }
        } catch (const ParseError& e) {
          parse_error(f, i, t.span, e);
          l.ok = false;
          continue;
        }
        l.deletions.push_back(t.span);
      } else if (t.kind == TokenKind::paren_comment) {
        std::string c = lower(b.text(t.span));
        c.erase(std::remove(c.begin(), c.end(), ' '), c.end());
        if (c.rfind("(abort,", 0) == 0) {
          l.abort = true;
          l.plain = false;
          l.abort_text = std::string(b.text(t.span));
        }
      }
    }
    for (const Word& w : b.words) {
      if (w.letter == 'M' && w.kind == ValueKind::number && (w.number == 2 || w.number == 30)) l.ends_program = true;
      if (w.letter == 'G' && w.kind == ValueKind::number) {
        const long g10 = std::lround(w.number * 10);
        if (g10 >= 382 && g10 <= 385) l.probe = Line::Probe::starts;
        else if (g10 == 0 || g10 == 10 || g10 == 20 || g10 == 30 || g10 == 330 || g10 == 730 || g10 == 760 ||
                 (g10 >= 800 && g10 <= 890 && g10 % 10 == 0))
          l.probe = Line::Probe::ends;
      }
      if (std::string_view("XYZABCUVW").find(w.letter) != std::string_view::npos && w.name_len == 1) l.axis_words = true;
      // G70–G72 take their profile from a subroutine (Q): resolving would drop the sub the
      // cycle needs.
      if (w.letter == 'G' && w.kind == ValueKind::number && w.number >= 70 && w.number < 73) {
        l.cycle_profile = true;
        l.cycle_span = w.span;
        l.plain = false;
      }
      if (w.letter == 'Q' && w.kind == ValueKind::number) {
        l.cycle_q_literal = true;
        l.cycle_q = w.number;
      }
      if (w.kind != ValueKind::expression && w.kind != ValueKind::parameter) continue;
      l.plain = false;
      WordValue v{w.value, w.letter, {}};
      Parser p(b.text(w.value), names_);
      try {
        p.real_value(v.code);
        p.end();
      } catch (const ParseError& e) {
        parse_error(f, i, w.value, e);
        l.ok = false;
        continue;
      }
      l.words.push_back(std::move(v));
    }
  }

  void compile_control(SourceFile& f, std::size_t i, const Block& b, const Token& t, Line& l) {
    const std::string_view text = b.text(t.span);
    l.control_span = t.span;
    // oNNN or o<name>, then the keyword, then arguments.
    std::size_t p = 1;
    if (p < text.size() && text[p] == '<') {
      const auto e = text.find('>', p);
      p = e == std::string_view::npos ? text.size() : e + 1;
    } else {
      // LinuxCNC ignores blanks (spaces and tabs) inside the o-word and before its keyword.
      while (p < text.size() && (std::isdigit(static_cast<unsigned char>(text[p])) || text[p] == ' ' || text[p] == '\t'))
        ++p;
    }
    std::string on = lower(text.substr(0, p));
    on.erase(std::remove_if(on.begin(), on.end(), [](char c) { return c == ' ' || c == '\t'; }), on.end());
    l.oname = on;
    while (p < text.size() && (text[p] == ' ' || text[p] == '\t')) ++p;
    std::size_t k = p;
    while (k < text.size() && std::isalpha(static_cast<unsigned char>(text[k]))) ++k;
    const std::string kw = lower(text.substr(p, k - p));
    static const std::map<std::string, Kw> kws = {
        {"sub", Kw::sub},       {"endsub", Kw::endsub}, {"call", Kw::call},         {"return", Kw::ret},
        {"if", Kw::if_},        {"elseif", Kw::elseif}, {"else", Kw::else_},        {"endif", Kw::endif},
        {"while", Kw::while_},  {"endwhile", Kw::endwhile}, {"do", Kw::do_},        {"repeat", Kw::repeat},
        {"endrepeat", Kw::endrepeat}, {"break", Kw::break_}, {"continue", Kw::continue_}};
    const auto it = kws.find(kw);
    if (it == kws.end()) {
      f.report(i, t.span, Severity::error, "PP-E702",
               fmt::format("'{}' is not an O-word keyword (sub, endsub, call, return, if, elseif, else, endif, while, "
                           "endwhile, do, repeat, endrepeat, break, continue){}",
                           kw, context()));
      l.ok = false;
      return;
    }
    l.kw = it->second;
    // Arguments: [expr] [expr] … (call: any number; if/while/repeat/elseif/return/endsub: one).
    const Span rest{static_cast<std::uint32_t>(t.span.begin + k), t.span.end};
    Parser ps(text.substr(k), names_);
    try {
      while (!ps.at_end()) {
        Code c;
        ps.skip();
        ps.real_value(c);
        l.args.push_back(std::move(c));
      }
    } catch (const ParseError& e) {
      parse_error(f, i, rest, e);
      l.ok = false;
      return;
    }
    const bool needs_one = l.kw == Kw::if_ || l.kw == Kw::elseif || l.kw == Kw::while_ || l.kw == Kw::repeat;
    if ((needs_one && l.args.size() != 1) || ((l.kw == Kw::ret || l.kw == Kw::endsub) && l.args.size() > 1)) {
      f.report(i, t.span, Severity::error, "PP-E702",
               fmt::format("'{} {}' takes {} [expression]{}", l.oname, kw, needs_one ? "one" : "at most one", context()));
      l.ok = false;
    }
  }

  /// Finds the block structure of a file: subs, if/elseif/else/endif, while, do/while, repeat.
  void prepare(SourceFile& f) {
    FileInfo& fi = info(f);
    struct Open { std::string oname; Kw kw; std::size_t line; };
    std::vector<Open> open;
    for (std::size_t i = 0; i < f.lines(); ++i) {
      const std::string_view raw = f.raw(i);
      const std::size_t p = raw.find_first_not_of(" \t/");
      if (p == std::string_view::npos) continue;
      // An O-word starts the line, possibly after an N number.
      std::size_t q = p;
      if (raw[q] == 'N' || raw[q] == 'n') {
        ++q;
        while (q < raw.size() && (std::isdigit(static_cast<unsigned char>(raw[q])) || raw[q] == ' ')) ++q;
      }
      if (q >= raw.size() || (raw[q] != 'o' && raw[q] != 'O')) {
        // An O-word statement after other words ("Z2 o1 endwhile"): rs274 reads O-words only at the
        // start of a line; refused rather than run as a statement the structure does not know.
        if (raw.find_first_of("oO") != std::string_view::npos) {
          const Line& l = line(f, i);
          if (l.ok && l.kw != Kw::none) {
            f.report(i, l.control_span, Severity::error, "PP-E708",
                     fmt::format("'{}' does not begin its line: an O-word statement must come first (after an optional "
                                 "N number); put it on its own line",
                                 f.raw(i).substr(l.control_span.begin, l.control_span.size())));
            throw Stop{};
          }
        }
        continue;
      }
      Line& l = line(f, i);
      if (l.kw == Kw::none || !l.ok) continue;
      switch (l.kw) {
        case Kw::sub:
          if (!open.empty() && open.back().kw == Kw::sub) {
            f.report(i, l.control_span, Severity::error, "PP-E708",
                     fmt::format("'{} sub' inside '{} sub' (line {}): subroutines cannot nest", l.oname,
                                 open.back().oname, open.back().line + 1));
            throw Stop{};
          }
          open.push_back({l.oname, l.kw, i});
          break;
        case Kw::if_: case Kw::while_: case Kw::do_: case Kw::repeat:
          // "oN while" closes an open "oN do".
          if (l.kw == Kw::while_) {
            auto d = std::find_if(open.rbegin(), open.rend(), [&](const Open& o) { return o.oname == l.oname && o.kw == Kw::do_; });
            if (d != open.rend()) {
              close(f, fi, open, l, i, Kw::do_);
              break;
            }
          }
          open.push_back({l.oname, l.kw, i});
          break;
        case Kw::endsub: close(f, fi, open, l, i, Kw::sub); break;
        case Kw::endif: close(f, fi, open, l, i, Kw::if_); break;
        case Kw::endwhile: close(f, fi, open, l, i, Kw::while_); break;
        case Kw::endrepeat: close(f, fi, open, l, i, Kw::repeat); break;
        case Kw::elseif: case Kw::else_: {
          auto o = std::find_if(open.rbegin(), open.rend(), [&](const Open& x) { return x.oname == l.oname && x.kw == Kw::if_; });
          if (o == open.rend()) mismatch(f, i, l, "if");
          fi.branches[o->line].push_back(i);
          fi.start_of[i] = o->line;
          break;
        }
        default: break;
      }
      if (l.kw == Kw::sub) {
        const std::string& name = l.oname;
        if (!subs_.count(name)) subs_[name] = Sub{&f, i, 0};
      }
    }
    if (!open.empty()) {
      Line& l = line(f, open.back().line);
      f.report(open.back().line, l.control_span, Severity::error, "PP-E708",
               fmt::format("'{}' is never closed (its end line is missing)", f.raw(open.back().line).substr(l.control_span.begin, l.control_span.size())));
      throw Stop{};
    }
    for (auto& [name, s] : subs_)
      if (s.file == &f) s.end = fi.end_of.at(s.begin);
  }
  template <class OpenVec>
  void close(SourceFile& f, FileInfo& fi, OpenVec& open, Line& l, std::size_t i, Kw opener) {
    if (open.empty() || open.back().oname != l.oname || open.back().kw != opener)
      mismatch(f, i, l, opener == Kw::sub ? "sub" : opener == Kw::if_ ? "if" : opener == Kw::while_ ? "while"
                                                  : opener == Kw::do_ ? "do" : "repeat");
    fi.end_of[open.back().line] = i;
    fi.start_of[i] = open.back().line;
    if (opener == Kw::if_) fi.branches[open.back().line].push_back(i);
    open.pop_back();
  }
  [[noreturn]] void mismatch(SourceFile& f, std::size_t i, const Line& l, const char* opener) {
    f.report(i, l.control_span, Severity::error, "PP-E708",
             fmt::format("'{}' has no open '{} {}' to close (O-word blocks must nest and use the same number)",
                         f.raw(i).substr(l.control_span.begin, l.control_span.size()), l.oname, opener));
    throw Stop{};
  }

  // -- evaluate ------------------------------------------------------------------------------
  std::string context() const {
    const std::string w = out_.where();
    return w.empty() ? std::string() : "; " + w;
  }

  double numbered(double index) {
    const double r = std::round(index);
    if (std::fabs(index - r) > 1e-4 || r < 0 || r >= kNumbered)
      throw EvalError{"PP-E703", fmt::format("parameter #{} does not exist (LinuxCNC has #1 … #{})", index, kNumbered - 1)};
    const int n = static_cast<int>(r);
    if (const char* what = runtime_numbered(n)) {
      const std::string key = fmt::format("#{}", n);
      if (const auto it = opt_.set.find(key); it != opt_.set.end()) {
        r_.used_settings[key] = it->second;
        return set_numbered_.count(n) ? numbered_[static_cast<std::size_t>(n)] : it->second;
      }
      if (!set_numbered_.count(n))
        throw EvalError{"PP-E701", fmt::format("#{} is {}, known only when the program runs; give its value with "
                                               "--set '#{}=…'", n, what, n)};
    }
    return numbered_[static_cast<std::size_t>(n)];
  }

  std::optional<double> named(int id) {
    const std::string& n = names_.name(id);
    if (!n.empty() && n[0] == '_') {
      if (const auto it = globals_.find(id); it != globals_.end()) return it->second;
      const std::string key = "#<" + std::string(n) + ">";
      std::string upper = key;
      for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      if (const auto it = opt_.set.find(upper); it != opt_.set.end()) {
        r_.used_settings[upper] = it->second;
        return it->second;
      }
      return std::nullopt;
    }
    auto& loc = frames_.back().locals;
    if (const auto it = loc.find(id); it != loc.end()) return it->second;
    return std::nullopt;
  }

  double eval(const Code& c) {
    double st[64];
    int sp = 0;
    for (const Instr& in : c.ops) {
      if (sp >= 62) throw EvalError{"PP-E702", "the expression nests too deeply"};
      switch (in.op) {
        case Op::num: st[sp++] = in.value; break;
        case Op::param: st[sp++] = numbered(in.value); break;
        case Op::param_ind: st[sp - 1] = numbered(st[sp - 1]); break;
        case Op::named: {
          const auto v = named(static_cast<int>(in.value));
          if (!v) {
            const std::string& n = names_.name(static_cast<int>(in.value));
            throw EvalError{n[0] == '_' ? "PP-E701" : "PP-E703",
                            n[0] == '_' ? fmt::format("#<{}> is not set by the program (a controller value, known only "
                                                      "when it runs?); set it first or give --set '#<{}>=…'", n, n)
                                        : fmt::format("#<{}> is read before it is set (LinuxCNC refuses this)", n)};
          }
          st[sp++] = *v;
          break;
        }
        case Op::exists: st[sp++] = named(static_cast<int>(in.value)) ? 1.0 : 0.0; break;
        case Op::neg: st[sp - 1] = -st[sp - 1]; break;
        default: apply_operator(in.op, st, sp); break;
      }
    }
    return st[0];
  }

  /// Evaluates, reporting an error located at `span` of line i and stopping the run.
  double value(SourceFile& f, std::size_t i, Span span, const Code& c) {
    try {
      return eval(c);
    } catch (const EvalError& e) {
      f.report(i, span, Severity::error, e.code, e.what + context());
      throw Stop{};
    }
  }

  /// Sets a named parameter; a new value (or a new name) is progress for the loop guard.
  void store(std::unordered_map<int, double>& m, int id, double v) {
    const auto [it, fresh] = m.try_emplace(id, v);
    if (!fresh && it->second == v) return;
    it->second = v;
    guard_.changed();
  }

  void assign(const Assign& a, double v, SourceFile& f, std::size_t i, Span span) {
    if (a.named) {
      const std::string& n = names_.name(a.name_id);
      store(n[0] == '_' ? globals_ : frames_.back().locals, a.name_id, v);
      return;
    }
    const double idx = value(f, i, span, a.index);
    const double r = std::round(idx);
    if (r < 1 || r >= kNumbered || std::fabs(idx - r) > 1e-4) {
      f.report(i, span, Severity::error, "PP-E703", fmt::format("parameter #{} does not exist{}", idx, context()));
      throw Stop{};
    }
    const int n = static_cast<int>(r);
    if (numbered_[static_cast<std::size_t>(n)] != v) guard_.changed();
    numbered_[static_cast<std::size_t>(n)] = v;
    if (runtime_numbered(n)) set_numbered_.insert(n);
  }

  /// A line that probes (G38.x, or axis words while G38.x is the modal motion) fills #5061–#5070
  /// when it runs (LinuxCNC G-code "G38.x Straight Probe"): values the program set before are gone,
  /// so a later read is refused (PP-E701) unless --set gives it.
  void probe_results(const Line& l) {
    const bool was = probing_;
    if (l.probe == Line::Probe::starts) probing_ = true;
    if (l.probe == Line::Probe::ends) probing_ = false;
    if (probing_ != was) guard_.changed();
    if (!probing_ || (l.probe != Line::Probe::starts && !l.axis_words)) return;
    for (int n = 5061; n <= 5070; ++n) set_numbered_.erase(n);
    guard_.changed();
  }

  // -- execute -------------------------------------------------------------------------------
  enum class Flow { next, jump, ret };

  /// Runs lines [from, to) of f; `in_sub`: an endsub/return ends it. Returns on return/endsub.
  void execute(SourceFile& f, std::size_t from, std::size_t to, bool in_sub) {
    FileInfo& fi = info(f);
    std::size_t pc = from;
    std::vector<Edit> edits;
    std::vector<double> pending;
    while (pc < to) {
      Line& l = line(f, pc);
      if (!l.ok) throw Stop{};
      if (!guard_.step(out_.emitted())) endless(f, pc, guard_.silent_message());
      if (l.plain) {
        if (!out_.emit(f, pc, {})) runaway(f, pc);
        probe_results(l);
        if (l.ends_program) throw Stop{};
        ++pc;
        continue;
      }
      if (l.kw != Kw::none) {
        const std::size_t next = control(f, fi, pc, l, in_sub);
        if (next == kReturn) return;
        // The control line's comments stay (the O-word statement is removed).
        Edit del{l.control_span, ""};
        if (f.raw(pc).find('(') != std::string_view::npos && !out_.emit(f, pc, std::span<const Edit>(&del, 1)))
          runaway(f, pc);
        if (next <= pc && !guard_.back_jump(f.index(), frames_.size(), next))
          endless(f, pc, LoopGuard::no_progress_message());
        pc = next;
        continue;
      }
      if (l.cycle_profile) cycle_profile(f, pc, l);
      if (l.abort) {
        f.report(pc, Span{0, static_cast<std::uint32_t>(f.raw(pc).size())}, Severity::error, "PP-E710",
                 fmt::format("the program aborts here: {}{}", l.abort_text, context()));
        throw Stop{};
      }
      // Values on the line use the parameters as they were before it; its assignments take
      // effect after the line (rs274ngc).
      edits.clear();
      pending.clear();
      for (const Assign& as : l.assigns) pending.push_back(value(f, pc, as.span, as.value));
      for (const WordValue& v : l.words) edits.push_back({v.span, format_value(value(f, pc, v.span, v.code), v.letter)});
      for (const Span& d : l.deletions) edits.push_back({d, ""});
      std::sort(edits.begin(), edits.end(), [](const Edit& x, const Edit& y) { return x.span.begin < y.span.begin; });
      if (!out_.emit(f, pc, edits)) runaway(f, pc);
      probe_results(l);
      for (std::size_t k = 0; k < l.assigns.size(); ++k) assign(l.assigns[k], pending[k], f, pc, l.assigns[k].span);
      if (l.ends_program) throw Stop{};
      ++pc;
    }
  }

  static constexpr std::size_t kReturn = static_cast<std::size_t>(-1);

  /// The program ended (M2/M30) before its closing '%': a file that opens with '%' must close with
  /// one, so the closing line is written too (LinuxCNC ignores what lies between).
  void close_tape(SourceFile& main) {
    const auto percent = [&](std::size_t i) {
      const std::string_view l = main.raw(i);
      const std::size_t q = l.find_first_not_of(" \t");
      return q != std::string_view::npos && l[q] == '%';
    };
    const auto blank = [&](std::size_t i) { return main.raw(i).find_first_not_of(" \t") == std::string_view::npos; };
    std::size_t first = 0, last = main.lines();
    while (first < main.lines() && blank(first)) ++first;
    while (last > first + 1 && blank(last - 1)) --last;
    if (first >= main.lines() || last <= first + 1 || !percent(first) || !percent(last - 1)) return;
    const bool written = !r_.source_line.empty() && r_.source_file.back() == main.index() && r_.source_line.back() == last;
    if (!written) (void)out_.emit(main, last - 1, {});
  }

  [[noreturn]] void endless(SourceFile& f, std::size_t i, const std::string& why) {
    f.report(i, Span{0, static_cast<std::uint32_t>(std::max<std::size_t>(1, f.raw(i).size()))}, Severity::error, "PP-E705",
             why + context());
    throw Stop{};
  }

  [[noreturn]] void runaway(SourceFile& f, std::size_t i) {
    f.report(i, Span{0, static_cast<std::uint32_t>(f.raw(i).size())}, Severity::error, "PP-E705",
             fmt::format("the program executes {}: a loop that does not end?{}", runaway_limits(opt_), context()));
    throw Stop{};
  }

  bool truth(SourceFile& f, std::size_t i, const Line& l) { return value(f, i, l.control_span, l.args[0]) != 0; }

  /// Carries out an O-word line; returns the next line, or kReturn.
  std::size_t control(SourceFile& f, FileInfo& fi, std::size_t i, Line& l, bool in_sub) {
    switch (l.kw) {
      case Kw::sub: return fi.end_of.at(i) + 1;  // a definition: skipped
      case Kw::endsub:
      case Kw::ret:
        if (!in_sub) {
          f.report(i, l.control_span, Severity::error, "PP-E708",
                   fmt::format("'{}' outside a subroutine", f.raw(i).substr(l.control_span.begin, l.control_span.size())));
          throw Stop{};
        }
        if (!l.args.empty()) {
          globals_[names_.id("_value")] = value(f, i, l.control_span, l.args[0]);
          globals_[names_.id("_value_returned")] = 1;
          guard_.changed();
        }
        return kReturn;
      case Kw::call: call(f, i, l); return i + 1;
      case Kw::if_: {
        if (truth(f, i, l)) return i + 1;
        for (std::size_t b : fi.branches.at(i)) {
          Line& bl = line(f, b);
          if (bl.kw == Kw::elseif && truth(f, b, bl)) return b + 1;
          if (bl.kw == Kw::else_) return b + 1;
          if (bl.kw == Kw::endif) return b + 1;
        }
        return fi.end_of.at(i) + 1;
      }
      case Kw::elseif:
      case Kw::else_:  // reached from the end of a taken branch: leave the if
        return fi.end_of.at(fi.start_of.at(i)) + 1;
      case Kw::endif: return i + 1;
      case Kw::while_:
        if (auto s = fi.start_of.find(i); s != fi.start_of.end()) {  // the end of a do … while
          return truth(f, i, l) ? s->second + 1 : i + 1;
        }
        return truth(f, i, l) ? i + 1 : fi.end_of.at(i) + 1;
      case Kw::endwhile: return fi.start_of.at(i);
      case Kw::do_: return i + 1;
      case Kw::repeat: {
        const double n = std::floor(value(f, i, l.control_span, l.args[0]));
        if (n < 1) return fi.end_of.at(i) + 1;
        frames_.back().repeats[i] = saturate<long>(n) - 1;
        guard_.changed();
        return i + 1;
      }
      case Kw::endrepeat: {
        const std::size_t s = fi.start_of.at(i);
        long& left = frames_.back().repeats[s];
        if (left > 0) {
          --left;
          guard_.changed();  // the pass count is state: a repeat with an empty body still ends
          return s + 1;
        }
        return i + 1;
      }
      case Kw::break_:
      case Kw::continue_: {
        const std::size_t loop = enclosing_loop(f, fi, i, l);
        const Line& ll = line(f, loop);
        const std::size_t end = fi.end_of.at(loop);
        if (l.kw == Kw::break_) {
          if (ll.kw == Kw::repeat) frames_.back().repeats.erase(loop);
          return end + 1;
        }
        if (ll.kw == Kw::while_) return loop;  // evaluate the condition again
        return end;                            // do: its while line; repeat: its endrepeat
      }
      default: return i + 1;
    }
  }

  /// G70–G72 read their profile from the subroutine numbered Q (LinuxCNC docs, G70 and G71-G72):
  /// its lines are passed on, values substituted, as "oN sub" … "oN endsub" right before the
  /// cycle's line, where the interpreter reads them as the profile. rs274 reads those lines
  /// without executing them, so statements inside the profile are refused.
  void cycle_profile(SourceFile& f, std::size_t pc, const Line& l) {
    double q = l.cycle_q;
    bool have_q = l.cycle_q_literal;
    for (const WordValue& v : l.words)
      if (v.letter == 'Q') {
        q = value(f, pc, v.span, v.code);
        have_q = true;
      }
    if (!have_q) return;  // the interpreter refuses the cycle without Q
    const auto it = subs_.find(fmt::format("o{}", std::lround(q)));
    if (it == subs_.end()) return;  // … and without its subroutine
    const Sub s = it->second;
    SourceFile& sf = *s.file;
    out_.push_call(CallFrame{f.name(), pc + 1, fmt::format("o{} profile", std::lround(q))});
    if (!out_.emit(sf, s.begin, {})) runaway(sf, s.begin);
    std::vector<Edit> edits;
    for (std::size_t i = s.begin + 1; i < s.end; ++i) {
      Line& bl = line(sf, i);
      if (!bl.ok) throw Stop{};
      if (bl.kw != Kw::none || !bl.assigns.empty() || bl.abort || bl.cycle_profile || bl.ends_program) {
        const Span at = bl.kw != Kw::none ? bl.control_span
                        : !bl.assigns.empty() ? bl.assigns.front().span
                        : bl.cycle_profile ? bl.cycle_span
                                           : Span{0, static_cast<std::uint32_t>(sf.raw(i).size())};
        sf.report(i, at, Severity::error, "PP-E251",
                  fmt::format("the profile of a lathe cycle (o{} sub, used by the G7x at line {}) holds a statement "
                              "or cycle; rs274 reads the profile's moves without executing statements, so this "
                              "cannot be followed: keep only G0/G1/G2/G3 moves in the profile{}",
                              std::lround(q), pc + 1, context()));
        throw Stop{};
      }
      edits.clear();
      for (const WordValue& v : bl.words) edits.push_back({v.span, format_value(value(sf, i, v.span, v.code), v.letter)});
      if (!out_.emit(sf, i, edits)) runaway(sf, i);
    }
    if (!out_.emit(sf, s.end, {})) runaway(sf, s.end);
    out_.pop_call();
  }

  std::size_t enclosing_loop(SourceFile& f, FileInfo& fi, std::size_t i, const Line& l) {
    for (const auto& [start, end] : fi.end_of) {
      if (start > i || end < i) continue;
      const Line& s = line(f, start);
      if (s.oname == l.oname && (s.kw == Kw::while_ || s.kw == Kw::do_ || s.kw == Kw::repeat)) return start;
    }
    f.report(i, l.control_span, Severity::error, "PP-E708",
             fmt::format("'{}' is not inside a loop named {}", f.raw(i).substr(l.control_span.begin, l.control_span.size()),
                         l.oname));
    throw Stop{};
  }

  void call(SourceFile& f, std::size_t i, Line& l) {
    std::vector<double> args;
    for (const Code& c : l.args) args.push_back(value(f, i, l.control_span, c));
    if (args.size() > 30) {
      f.report(i, l.control_span, Severity::error, "PP-E702", "a call takes at most 30 arguments" + context());
      throw Stop{};
    }
    auto it = subs_.find(l.oname);
    if (it == subs_.end() && l.oname.size() > 2 && l.oname[1] == '<') {
      const std::string name = l.oname.substr(2, l.oname.size() - 3);
      if (SourceFile* sf = files_.find({name + ".ngc", name + ".NGC", name})) {
        prepare(*sf);
        it = subs_.find(l.oname);
      }
    }
    if (it == subs_.end()) {
      f.report(i, l.control_span, Severity::error, "PP-E704",
               fmt::format("no subroutine '{} sub' in this file{}{}", l.oname,
                           l.oname[1] == '<' ? fmt::format(" and no file {}.ngc in the search folders",
                                                           l.oname.substr(2, l.oname.size() - 3))
                                             : std::string(),
                           context()));
      throw Stop{};
    }
    if (static_cast<int>(frames_.size()) > opt_.max_call_depth) {
      f.report(i, l.control_span, Severity::error, "PP-E706",
               fmt::format("calls nest deeper than {} levels (endless recursion?){}", opt_.max_call_depth, context()));
      throw Stop{};
    }
    const Sub s = it->second;
    Frame fr;
    std::copy(numbered_.begin() + 1, numbered_.begin() + 31, fr.saved.begin() + 1);
    for (int k = 1; k <= 30; ++k) numbered_[static_cast<std::size_t>(k)] = k <= static_cast<int>(args.size()) ? args[static_cast<std::size_t>(k - 1)] : 0;
    frames_.push_back(std::move(fr));
    guard_.changed();
    globals_[names_.id("_value_returned")] = 0;
    globals_[names_.id("_call_level")] = static_cast<double>(frames_.size() - 1);
    out_.push_call(CallFrame{f.name(), i + 1, l.oname + " call"});
    execute(*s.file, s.begin + 1, s.end + 1, true);
    out_.pop_call();
    std::copy(frames_.back().saved.begin() + 1, frames_.back().saved.end(), numbered_.begin() + 1);
    frames_.pop_back();
    globals_[names_.id("_call_level")] = static_cast<double>(frames_.size() - 1);
  }

  FileSet& files_;
  Emitter& out_;
  const ResolveOptions& opt_;
  DiagnosticSink& sink_;
  ResolvedProgram& r_;
  LoopGuard guard_{opt_};
  Names names_;
  std::vector<double> numbered_;
  std::set<int> set_numbered_;
  bool probing_ = false;  ///< G38.x is the modal motion
  std::unordered_map<int, double> globals_;
  std::vector<Frame> frames_;
  std::map<std::string, Sub> subs_;
  std::map<const SourceFile*, std::unique_ptr<FileInfo>> info_;

 public:
  using StopT = Stop;
};

}  // namespace

void resolve_linuxcnc(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r) {
  Machine m(files, out, opt, sink, r);
  try {
    m.run();
  } catch (const Machine::StopT&) {
    // program end, or a refusal already reported
  }
}

}  // namespace postproc::gcode::resolver
