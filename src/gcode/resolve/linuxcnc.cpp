// Resolver for LinuxCNC (rs274ngc) programs: numbered and named parameters, [ ] expressions,
// O-word subroutines and control flow (include/postproc/gcode/resolve.hpp).
//
// Each line is compiled once (expressions to a small stack program) and cached, so loop bodies
// run without lexing or parsing again. This file: compiling lines and the block structure, the
// run; linuxcnc_statements.cpp: executing them.
#include "linuxcnc_runner.hpp"
#include "src/gcode/program_end.hpp"

namespace postproc::gcode::resolver {
namespace lcnc_run {

void Machine::run() {
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
    // A file of subroutine definitions only (called from other programs): rs274 runs it without a
    // move. Said, because its moves are read (and compensated) only where a program calls them.
    Diagnostic d;
    d.severity = Severity::warning;
    d.code = "PP-U223";
    d.file = main.name();
    d.where = {1, 1};
    set_source_line(d, main.raw(0));
    d.message = fmt::format("the file only defines subroutines ({}…) and executes nothing: LinuxCNC runs it without "
                            "a move; their moves are read, and compensated, where a program calls them: give that "
                            "program (this file is found next to it)",
                            subs_.begin()->first);
    sink_.report(std::move(d));
  }
}

Line& Machine::line(SourceFile& f, std::size_t i) {
  Line& l = info(f).lines[i];
  if (!l.compiled) compile(f, i, l);
  return l;
}

Machine::FileInfo& Machine::info(SourceFile& f) {
  auto& p = info_[&f];
  if (!p) {
    p = std::make_unique<FileInfo>();
    p->lines.resize(f.lines());
  }
  return *p;
}

void Machine::parse_error(SourceFile& f, std::size_t i, Span within, const ParseError& e) {
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

void Machine::compile(SourceFile& f, std::size_t i, Line& l) {
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
      // Assignments one after another ("#1 = 2 #2 = 3") go as one piece, with the blanks between.
      const std::string_view raw = b.raw;
      if (!l.deletions.empty() && raw.substr(l.deletions.back().end, t.span.begin - l.deletions.back().end)
                                          .find_first_not_of(" \t") == std::string_view::npos)
        l.deletions.back().end = t.span.end;
      else
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
  for (const Word& w : b.words)
    if (w.letter == 'M' && w.kind == ValueKind::number && (w.number == 98 || w.number == 99)) {
      (w.number == 98 ? l.numbered_call : l.numbered_return) = true;
      l.call_span = w.span;
      l.plain = false;
    }
  if (l.numbered_call || l.numbered_return) {
    // The call's words: M98 P L (M99 alone); anything else on the line (N aside) is refused where
    // it runs: the order of a motion and the call within one block is not followed.
    for (const Word& w : b.words) {
      if (w.letter == 'N' && w.name_len == 1) continue;
      const bool call_m = w.letter == 'M' && w.kind == ValueKind::number && w.span.begin == l.call_span.begin;
      const bool pl = l.numbered_call && (w.letter == 'P' || w.letter == 'L') && w.name_len == 1;
      if (!call_m && !pl) {
        l.call_other_words = true;
        continue;
      }
      l.call_words.push_back(w.span);
      if (!pl) continue;
      Code c;
      Parser p(b.text(w.value), names_);
      try {
        p.real_value(c);
        p.end();
      } catch (const ParseError& e) {
        parse_error(f, i, w.value, e);
        l.ok = false;
        return;
      }
      (w.letter == 'P' ? l.call_p : l.call_l) = std::move(c);
    }
    for (const Token& t : b.tokens)
      if (t.kind == TokenKind::assignment || t.kind == TokenKind::control_flow) l.call_other_words = true;
    return;
  }
  for (const Word& w : b.words) {
    if (program_end::ends_program(w)) l.ends_program = true;
    if (w.letter == 'M' && w.kind == ValueKind::number && w.number >= 70 && w.number <= 73 &&
        w.number == std::floor(w.number)) {
      if (l.context == 0) l.context_span = w.span;
      l.context = static_cast<std::uint8_t>(l.context | (1u << (static_cast<int>(w.number) - 70)));
    }
    if (w.letter == 'G' && w.kind == ValueKind::number) {
      const long g10 = std::lround(w.number * 10);
      if (g10 >= 382 && g10 <= 385) l.probe = Line::Probe::starts;
      else if (g10 == 0 || g10 == 10 || g10 == 20 || g10 == 30 || g10 == 330 || g10 == 730 || g10 == 760 ||
               (g10 >= 800 && g10 <= 890 && g10 % 10 == 0))
        l.probe = Line::Probe::ends;
    }
    if (std::string_view("XYZABCUVW").find(w.letter) != std::string_view::npos && w.name_len == 1) l.axis_words = true;
    if (w.letter == 'G' && w.kind == ValueKind::number) {
      const long g10 = std::lround(w.number * 10);
      if (g10 == 900) l.modes |= 1u;
      if (g10 == 910) l.modes |= 2u;
      if (g10 == 70) l.modes |= 4u;
      if (g10 == 80) l.modes |= 8u;
    }
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

void Machine::compile_control(SourceFile& f, std::size_t i, const Block& b, const Token& t, Line& l) {
  const std::string_view text = b.text(t.span);
  l.control_span = t.span;
  // oNNN or o<name>, then the keyword, then arguments.
  std::size_t p = 1;
  if (p < text.size() && text[p] == '<') {
    const auto e = text.find('>', p);
    p = e == std::string_view::npos ? text.size() : e + 1;
  } else if (p < text.size() && text[p] == '[') {
    // o[expression]: rs274 reads the number from the expression (a whole number within 0.0001,
    // else "Non integer value for integer"); followed for call, where the number names the sub.
    int depth = 0;
    std::size_t e = p;
    for (; e < text.size(); ++e) {
      if (text[e] == '[') ++depth;
      if (text[e] == ']' && --depth == 0) break;
    }
    if (e == text.size()) {
      f.report(i, t.span, Severity::error, "PP-E702", "o[ without its closing ']'" + context());
      l.ok = false;
      return;
    }
    Code c;
    Parser pn(text.substr(p, e + 1 - p), names_);
    try {
      pn.real_value(c);
      pn.end();
    } catch (const ParseError& err) {
      parse_error(f, i, Span{static_cast<std::uint32_t>(t.span.begin + p), static_cast<std::uint32_t>(t.span.begin + e + 1)},
                  err);
      l.ok = false;
      return;
    }
    l.onumber = std::move(c);
    p = e + 1;
  } else {
    // LinuxCNC ignores blanks (spaces and tabs) inside the o-word and before its keyword.
    while (p < text.size() && (std::isdigit(static_cast<unsigned char>(text[p])) || text[p] == ' ' || text[p] == '\t'))
      ++p;
  }
  std::string on = lower(text.substr(0, p));
  on.erase(std::remove_if(on.begin(), on.end(), [](char c) { return c == ' ' || c == '\t'; }), on.end());
  l.oname = on;
  while (p < text.size() && (text[p] == ' ' || text[p] == '\t')) ++p;
  // rs274 drops blanks before it reads a line and takes the keyword as the longest one the letters
  // begin with: "else if [c]" is "elseif [c]", "end if" is "endif", and "else G0 Z5" is "else"
  // followed by text (refused below).
  static const std::map<std::string, Kw> kws = {
      {"sub", Kw::sub},       {"endsub", Kw::endsub}, {"call", Kw::call},         {"return", Kw::ret},
      {"if", Kw::if_},        {"elseif", Kw::elseif}, {"else", Kw::else_},        {"endif", Kw::endif},
      {"while", Kw::while_},  {"endwhile", Kw::endwhile}, {"do", Kw::do_},        {"repeat", Kw::repeat},
      {"endrepeat", Kw::endrepeat}, {"break", Kw::break_}, {"continue", Kw::continue_}};
  std::string letters;                 // the letters after the o-word, blanks left out
  std::vector<std::size_t> after;      // after[n]: where the text goes on after letters[0..n]
  for (std::size_t q = p; q < text.size() && letters.size() < 16; ++q) {
    if (text[q] == ' ' || text[q] == '\t') continue;
    if (!std::isalpha(static_cast<unsigned char>(text[q]))) break;
    letters += static_cast<char>(std::tolower(static_cast<unsigned char>(text[q])));
    after.push_back(q + 1);
  }
  std::string kw;
  std::size_t k = p;
  for (const auto& [name, code] : kws)
    if (name.size() > kw.size() && letters.starts_with(name)) {
      kw = name;
      k = after[name.size() - 1];
    }
  if (kw.empty()) kw = letters;
  const auto it = kws.find(kw);
  if (it == kws.end() && kw.empty() && !l.onumber && on.size() > 1 && on[1] != '<' && p == text.size()) {
    // "O100" alone: a Fanuc-style program number. rs274 runs through it (interp_o_word.cc, O_: "continue
    // executing into Fanuc-style programs"); M98 calls to it and its M99 are refused by the interpreter.
    l.kw = Kw::program_number;
    return;
  }
  if (it == kws.end()) {
    f.report(i, t.span, Severity::error, "PP-E702",
             fmt::format("'{}' is not an O-word keyword (sub, endsub, call, return, if, elseif, else, endif, while, "
                         "endwhile, do, repeat, endrepeat, break, continue){}",
                         kw, context()));
    l.ok = false;
    return;
  }
  l.kw = it->second;
  if (l.onumber && l.kw != Kw::call) {
    f.report(i, t.span, Severity::error, "PP-E702",
             fmt::format("a computed O-word number ({}) is followed for call only, not for '{}': give the {} a "
                         "number or a name{}",
                         l.oname, kw, kw, context()));
    l.ok = false;
    return;
  }
  // Arguments: [expr] [expr] … (call: any number; if/while/repeat/elseif/return/endsub: one; the
  // others none). rs274 stops at anything else after the keyword ("Unexpected character after
  // O-word"; after else and elseif only where the line is run, not where a jump lands on it: refused
  // in both cases here).
  const bool no_args = l.kw == Kw::else_ || l.kw == Kw::endif || l.kw == Kw::do_ || l.kw == Kw::endwhile ||
                       l.kw == Kw::endrepeat || l.kw == Kw::break_ || l.kw == Kw::continue_ || l.kw == Kw::sub;
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
  if ((needs_one && l.args.size() != 1) || ((l.kw == Kw::ret || l.kw == Kw::endsub) && l.args.size() > 1) ||
      (no_args && !l.args.empty())) {
    f.report(i, t.span, Severity::error, "PP-E702",
             fmt::format("'{} {}' takes {} (rs274: \"Unexpected character after O-word\"){}", l.oname, kw,
                         no_args ? "nothing after it" : needs_one ? "one [expression]" : "at most one [expression]",
                         context()));
    l.ok = false;
  }
}

namespace {

/// Line i holds M2 or M30 (looked at only where the text can: lexing every line would report
/// errors on lines rs274 skips over without reading their words).
bool ends_program(SourceFile& f, std::size_t i) {
  const std::string_view raw = f.raw(i);
  bool maybe = false;
  for (std::size_t k = raw.find_first_of("mM"); k != std::string_view::npos && !maybe; k = raw.find_first_of("mM", k + 1))
    maybe = raw.find_first_of("23", k + 1) != std::string_view::npos;
  if (!maybe || !f.lexed_ok(i)) return false;
  const Block& b = f.block(i);
  return std::any_of(b.words.begin(), b.words.end(), program_end::ends_program);
}

}  // namespace

void Machine::prepare(SourceFile& f) {
  FileInfo& fi = info(f);
  struct Open { std::string oname; Kw kw; std::size_t line; };
  std::vector<Open> open;
  // A block inside a block of the same number: rs274 stops at it whether it runs it or skips over
  // it looking for the outer block's end ("duplicate O-word label"). Blocks of the same number one
  // after the other are refused only where both run (Machine::control).
  const auto label = [&](const Line& l, std::size_t i) {
    const auto o = std::find_if(open.begin(), open.end(), [&](const Open& x) { return x.oname == l.oname && x.kw != Kw::sub; });
    if (o == open.end()) return;
    f.report(i, l.control_span, Severity::error, "PP-E708",
             fmt::format("'{}' inside the block of the same number at line {}: LinuxCNC refuses it (\"duplicate O-word "
                         "label\"); give each block its own number",
                         f.raw(i).substr(l.control_span.begin, l.control_span.size()), o->line + 1));
    throw Stop{};
  };
  // rs274 reads every line up to the M2 / M30 that ends the program, run or skipped over: the
  // length limit holds for each (the first M2 / M30 outside any block ends the reading).
  bool ended = false;
  for (std::size_t i = 0; i < f.lines(); ++i) {
    const std::string_view raw = f.raw(i);
    if (!ended) {
      if (const auto too_long = line_too_long(f.dialect(), raw.size(), f.ends_in_cr(i))) {
        const auto at = static_cast<std::uint32_t>(std::min(raw.size(), max_line_length(f.dialect())));
        f.report(i, Span{at, static_cast<std::uint32_t>(std::max<std::size_t>(raw.size(), at + 1))}, Severity::error,
                 "PP-E207", *too_long + ": split the line (a comment can go on a line of its own)");
        throw Stop{};
      }
      ended = open.empty() && ends_program(f, i);
    }
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
        label(l, i);
        open.push_back({l.oname, l.kw, i});
        break;
      case Kw::break_: case Kw::continue_: {
        // rs274 2.9 checks the loop a break / continue names as it reads the line, executed or not
        // (a branch not taken, a subroutine's definition): a repeat loop stops it with "no matching
        // while/do label".
        const auto o = std::find_if(open.rbegin(), open.rend(), [&](const Open& x) {
          return x.oname == l.oname && (x.kw == Kw::while_ || x.kw == Kw::do_ || x.kw == Kw::repeat);
        });
        if (o != open.rend() && o->kw == Kw::repeat) {
          f.report(i, l.control_span, Severity::error, "PP-E708",
                   fmt::format("'{}' in a repeat loop: LinuxCNC takes break and continue only in while and do loops "
                               "and stops here (\"no matching while/do label\"); write the loop with while",
                               f.raw(i).substr(l.control_span.begin, l.control_span.size())));
          throw Stop{};
        }
        if (o != open.rend() && l.kw == Kw::break_) fi.breaks[o->line].push_back(i);
        break;
      }
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

void Machine::mismatch(SourceFile& f, std::size_t i, const Line& l, const char* opener) {
  f.report(i, l.control_span, Severity::error, "PP-E708",
           fmt::format("'{}' has no open '{} {}' to close (O-word blocks must nest and use the same number)",
                       f.raw(i).substr(l.control_span.begin, l.control_span.size()), l.oname, opener));
  throw Stop{};
}

}  // namespace lcnc_run

void resolve_linuxcnc(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r) {
  lcnc_run::Machine m(files, out, opt, sink, r);
  try {
    m.run();
  } catch (const lcnc_run::Machine::StopT&) {
    // program end, or a refusal already reported
  }
}

}  // namespace postproc::gcode::resolver
