// Klartext lexer: one line of a Heidenhain conversational program into a Block (klartext.hpp).
//
// Layout of a line (TNC 640 / iTNC 530 User's Manual "Klartext programming", "Program structure"):
//   [block number] [/] VERB items… [; comment] [~]
// Items are address words (a letter group followed by a signed number or Q parameter: X+10,
// IX-5, PR+30, F500, FQ53, M3), keywords (letters alone: FMAX, R0 is a word, RL, DR+, SEQ-),
// bare numbers (TOOL CALL 1, CYCL DEF 7.1, LBL 3) and quoted names. `*` as the verb makes the
// line a structure comment; FN, Q-parameter formulas and the continuation lines of cycle
// definitions keep the rest of the line as one statement token.
#include <cctype>
#include <charconv>

#include <fmt/format.h>

#include "src/gcode/codes.hpp"
#include "src/gcode/klartext.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode::klartext {
namespace {

bool is_alpha(char c) { return std::isalpha(static_cast<unsigned char>(c)) != 0; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }
bool is_blank(char c) { return c == ' ' || c == '\t'; }

struct Verbs {
  std::string_view first, second;
  Verb verb;
};
// Two-word verbs first: the second word decides.
constexpr Verbs kVerbs[] = {
    {"BEGIN", "PGM", Verb::begin_pgm}, {"END", "PGM", Verb::end_pgm},    {"BLK", "FORM", Verb::blk_form},
    {"TOOL", "CALL", Verb::tool_call}, {"TOOL", "DEF", Verb::tool_def},  {"CYCL", "DEF", Verb::cycl_def},
    {"CYCL", "CALL", Verb::cycl_call}, {"CALL", "LBL", Verb::call_lbl},  {"CALL", "PGM", Verb::call_pgm},
    {"TCH", "PROBE", Verb::tch_probe}, {"PATTERN", "DEF", Verb::pattern_def},
    {"L", "", Verb::l},                {"LN", "", Verb::ln},              {"LP", "", Verb::lp},
    {"C", "", Verb::c},                {"CC", "", Verb::cc},              {"CR", "", Verb::cr},
    {"CT", "", Verb::ct},              {"CP", "", Verb::cp},              {"RND", "", Verb::rnd},
    {"CHF", "", Verb::chf},            {"APPR", "", Verb::appr},          {"DEP", "", Verb::dep},
    {"LBL", "", Verb::lbl},            {"FN", "", Verb::fn},              {"PLANE", "", Verb::plane},
    {"FUNCTION", "", Verb::function},  {"STOP", "", Verb::stop},          {"SEL", "", Verb::sel},
    {"DECLARE", "", Verb::declare},    {"CALL", "", Verb::call_pgm},
};

class Lexer {
 public:
  Lexer(Block& b, const LexContext& ctx) : b_(b), ctx_(ctx), raw_(b.raw) {}

  bool run() {
    skip_blanks();
    // Block skip before the block number ("/85 M30", as hyperMILL writes it) or after it ("85 /M30").
    if (pos_ + 1 < raw_.size() && raw_[pos_] == '/' && is_digit(raw_[pos_ + 1])) {
      b_.block_delete = true;
      b_.block_delete_span = span(pos_, pos_ + 1);
      ++pos_;
    }
    // Block number.
    if (pos_ < raw_.size() && is_digit(raw_[pos_])) {
      const std::size_t s = pos_;
      while (pos_ < raw_.size() && is_digit(raw_[pos_])) ++pos_;
      if (pos_ == raw_.size() || is_blank(raw_[pos_]) || raw_[pos_] == '/') {
        b_.has_n = true;
        b_.n_span = span(s, pos_);
        double n = 0;
        (void)parse_number(raw_.substr(s, pos_ - s), n);
        b_.n_number = n;
      } else {
        pos_ = s;
      }
    }
    skip_blanks();
    if (pos_ < raw_.size() && raw_[pos_] == '/') {
      b_.block_delete = true;
      b_.block_delete_span = span(pos_, pos_ + 1);
      ++pos_;
      skip_blanks();
    }
    if (pos_ >= raw_.size()) return ok_;
    return verb() && items();
  }

 private:
  Span span(std::size_t a, std::size_t e) const {
    return {static_cast<std::uint32_t>(a), static_cast<std::uint32_t>(e)};
  }
  void skip_blanks() {
    while (pos_ < raw_.size() && is_blank(raw_[pos_])) ++pos_;
  }
  std::size_t letters_end(std::size_t p) const {
    while (p < raw_.size() && is_alpha(raw_[p])) ++p;
    return p;
  }
  void token(TokenKind k, std::size_t a, std::size_t e, Span name) { b_.tokens.push_back({span(a, e), k, name}); }
  void rest_as(TokenKind k, Span name) {
    token(k, pos_, raw_.size(), name);
    pos_ = raw_.size();
  }

  /// A line that starts with a blank and is not a Klartext block may be the rest of a block the
  /// line before continued with '~' (a long comment wraps so: "; … on the~" then " Head"). Which
  /// it is depends on that line, so it is kept as one unknown keyword from `s` to the end (verb
  /// Verb::other) without a report; the interpreter reports it unless it continues a block
  /// (klartext::unread_text). `e` is where the first word ends (== s: no word).
  bool indented_text(std::size_t s, std::size_t e) {
    if (raw_.empty() || !is_blank(raw_[0]) || (e > s && known_verb(raw_.substr(s, e - s)))) return false;
    token(TokenKind::keyword, s, raw_.size(), span(s, raw_.size()));
    pos_ = raw_.size();
    return true;
  }
  static bool known_verb(std::string_view w1) {
    for (const Verbs& v : kVerbs)
      if (text::iequals(w1, v.first)) return true;
    return false;
  }

  bool verb() {
    const char c = raw_[pos_];
    if (c == ';') {
      token(TokenKind::line_comment, pos_, raw_.size(), span(pos_, pos_ + 1));
      pos_ = raw_.size();
      return true;
    }
    if (c == '*') {  // "* - text": a structure block, shown in the outline; no effect
      token(TokenKind::line_comment, pos_, raw_.size(), span(pos_, pos_ + 1));
      pos_ = raw_.size();
      return true;
    }
    const std::size_t s = pos_;
    const std::size_t e = letters_end(pos_);
    if (e == s) {
      if (indented_text(s, e)) return true;
      report(span(s, s + 1), fmt::format("'{}' cannot start a Klartext block (expected a word such as L, CC, "
                                         "TOOL CALL or CYCL DEF)", raw_.substr(s, 1)));
      token(TokenKind::keyword, s, raw_.size(), span(s, raw_.size()));
      pos_ = raw_.size();
      return false;
    }
    const std::string_view w1 = raw_.substr(s, e - s);
    // Q-parameter assignment or formula: Q5 = …, QL3 = …, QR1=…, QS2 = …
    if (text::iequals(w1.substr(0, 1), "Q") && (w1.size() == 1 || text::iequals(w1, "QL") || text::iequals(w1, "QR") ||
                                                text::iequals(w1, "QS"))) {
      std::size_t p = e;
      while (p < raw_.size() && is_digit(raw_[p])) ++p;
      std::size_t q = p;
      while (q < raw_.size() && is_blank(raw_[q])) ++q;
      if (p > e && q < raw_.size() && raw_[q] == '=') {
        rest_as(TokenKind::assignment, span(s, p));
        return true;
      }
    }
    if (text::iequals(w1, "FN")) {
      token(TokenKind::keyword, s, e, span(s, e));
      pos_ = e;
      skip_blanks();
      rest_as(TokenKind::assignment, span(s, e));
      return true;
    }
    if (text::iequals(w1, "M")) {
      // "M3", "M30": a block of M functions only. The verb token is empty; the M words follow.
      token(TokenKind::keyword, s, s, span(s, s));
      return true;
    }
    std::size_t after = e;
    while (after < raw_.size() && is_blank(raw_[after])) ++after;
    const std::size_t e2 = letters_end(after);
    const std::string_view w2 = raw_.substr(after, e2 - after);
    for (const Verbs& v : kVerbs) {
      if (!text::iequals(w1, v.first)) continue;
      if (!v.second.empty()) {
        if (!text::iequals(w2, v.second)) continue;
        token(TokenKind::keyword, s, e2, span(s, e2));
        pos_ = e2;
        return true;
      }
      // One-word verbs must stand alone ("L X+1", not "LX+1"): the next character is a blank,
      // the end, or (for L/LN/C…) an address letter directly after is not Klartext.
      if (e < raw_.size() && !is_blank(raw_[e]) && raw_[e] != ';') break;
      token(TokenKind::keyword, s, e, span(s, e));
      pos_ = e;
      return true;
    }
    if (indented_text(s, e)) return true;
    report(span(s, e), fmt::format("'{}' is not a Klartext block this version reads; the block is not followed",
                                   w1));
    token(TokenKind::keyword, s, e, span(s, e));
    pos_ = e;
    return items();
  }

  bool items() {
    while (true) {
      skip_blanks();
      if (pos_ >= raw_.size()) return ok_;
      if (b_.words.size() + b_.tokens.size() > kMaxBlockItems) {
        report(span(pos_, raw_.size()), "the block holds more than 10,000 items; the rest is not read", "PP-E110");
        return false;
      }
      const char c = raw_[pos_];
      const std::size_t s = pos_;
      if (c == ';') {
        token(TokenKind::line_comment, s, raw_.size(), span(s, s + 1));
        pos_ = raw_.size();
        continue;
      }
      if (c == '~') {  // the block continues on the next line
        token(TokenKind::keyword, s, s + 1, span(s, s + 1));
        ++pos_;
        continue;
      }
      if (c == '"' || c == '\'') {
        const std::size_t close = raw_.find(c, s + 1);
        const std::size_t e = close == std::string_view::npos ? raw_.size() : close + 1;
        if (close == std::string_view::npos) {
          report(span(s, e), "the quoted name is not closed on this line");
          ok_ = false;
        }
        token(TokenKind::keyword, s, e, span(s, e));
        pos_ = e;
        continue;
      }
      if (is_digit(c) || ((c == '+' || c == '-' || c == '.' || c == ',') && s + 1 < raw_.size() &&
                          (is_digit(raw_[s + 1]) || raw_[s + 1] == '.' || raw_[s + 1] == ','))) {
        std::size_t e = s + 1;
        while (e < raw_.size() && (is_digit(raw_[e]) || raw_[e] == '.' || raw_[e] == ',')) ++e;
        token(TokenKind::keyword, s, e, span(s, e));
        pos_ = e;
        continue;
      }
      if (is_alpha(c)) {
        std::size_t le = letters_end(s);
        // An address followed directly by a Q parameter: FQ50, X-Q1 has a sign, IXQ… is not Klartext.
        for (std::size_t k = s + 1; k < le; ++k)
          if ((raw_[k] == 'Q' || raw_[k] == 'q') &&
              ((k + 1 < raw_.size() && is_digit(raw_[k + 1])) ||
               (k + 2 < raw_.size() && (raw_[k + 1] == 'L' || raw_[k + 1] == 'R' || raw_[k + 1] == 'l' ||
                                        raw_[k + 1] == 'r') && is_digit(raw_[k + 2])))) {
            le = k;
            break;
          }
        std::size_t p = le;
        // A value: sign, then digits or a Q parameter.
        std::size_t v = p;
        if (v < raw_.size() && (raw_[v] == '+' || raw_[v] == '-')) ++v;
        const bool number = v < raw_.size() && (is_digit(raw_[v]) || ((raw_[v] == '.' || raw_[v] == ',') &&
                                                                      v + 1 < raw_.size() && is_digit(raw_[v + 1])));
        const bool param = !number && v < raw_.size() && (raw_[v] == 'Q' || raw_[v] == 'q');
        if (number) {
          std::size_t e = v;
          while (e < raw_.size() && (is_digit(raw_[e]) || raw_[e] == '.' || raw_[e] == ',')) ++e;
          word(s, le, p, e, ValueKind::number);
          continue;
        }
        if (param) {
          std::size_t e = v + 1;
          while (e < raw_.size() && is_alpha(raw_[e]) && e < v + 2) ++e;  // QL, QR, QS
          const std::size_t digits = e;
          while (e < raw_.size() && is_digit(raw_[e])) ++e;
          if (e > digits) {
            word(s, le, p, e, ValueKind::parameter);
            continue;
          }
        }
        // A keyword, with a trailing sign where Klartext writes one (DR+, SEQ-, R+).
        std::size_t e = le;
        if (e < raw_.size() && (raw_[e] == '+' || raw_[e] == '-') &&
            (e + 1 == raw_.size() || is_blank(raw_[e + 1]) || raw_[e + 1] == ';'))
          ++e;
        token(TokenKind::keyword, s, e, span(s, le));
        pos_ = e;
        continue;
      }
      // Anything else (parentheses of a formula in a FUNCTION block, '#' of a datum-table line,
      // ':' …) is kept as text of its own.
      std::size_t e = s + 1;
      while (e < raw_.size() && !is_blank(raw_[e])) ++e;
      token(TokenKind::keyword, s, e, span(s, e));
      pos_ = e;
    }
  }

  void word(std::size_t s, std::size_t name_end, std::size_t value_begin, std::size_t e, ValueKind kind) {
    Word w;
    w.span = span(s, e);
    w.name = span(s, name_end);
    w.value = span(value_begin, e);
    w.kind = kind;
    w.letter = static_cast<char>(std::toupper(static_cast<unsigned char>(raw_[s])));
    w.name_len = static_cast<std::uint8_t>(std::min<std::size_t>(255, name_end - s));
    // IX IY IZ IA IB IC IU IV IW (incremental axis words): index = 1 + the axis, for writers
    // that have the word but not the line (ModalTrack::axis_of).
    if (w.name_len == 2 && w.letter == 'I') {
      const int a = axis_index(static_cast<char>(std::toupper(static_cast<unsigned char>(raw_[s + 1]))));
      if (a >= 0) w.index = static_cast<std::uint8_t>(a + 1);
    }
    if (kind == ValueKind::number) {
      const std::string_view v = raw_.substr(value_begin, e - value_begin);
      w.whole = v.find_first_of(".,") == std::string_view::npos;
      if (!parse_number(v, w.number)) {
        report(w.span, fmt::format("'{}' is not a number", v));
        ok_ = false;
      }
    }
    b_.words.push_back(w);
    pos_ = e;
  }

  void report(Span at, std::string msg, std::string_view code = codes::kUnexpectedChar) {
    if (ctx_.sink != nullptr) report_at(ctx_, b_, at, Severity::error, code, std::move(msg));
  }

  Block& b_;
  const LexContext& ctx_;
  std::string_view raw_;
  std::size_t pos_ = 0;
  bool ok_ = true;
};

}  // namespace

bool parse_number(std::string_view t, double& out) {
  // from_chars takes no '+' and no ',': copy into a small buffer with '.'.
  char buf[64];
  std::size_t n = 0;
  std::size_t i = 0;
  if (!t.empty() && t[0] == '+') i = 1;
  if (t.size() - i >= sizeof buf || i >= t.size()) return false;
  for (; i < t.size(); ++i) buf[n++] = t[i] == ',' ? '.' : t[i];
  const auto r = std::from_chars(buf, buf + n, out);
  return r.ec == std::errc() && r.ptr == buf + n && std::isfinite(out);
}

Verb verb_of(const Block& b) {
  if (b.tokens.empty() && b.words.empty()) return Verb::none;
  if (b.tokens.empty()) return Verb::m_only;
  const Token& t = b.tokens.front();
  if (t.kind == TokenKind::line_comment) return Verb::comment;
  if (t.kind == TokenKind::assignment) return Verb::q_assign;
  if (t.span.begin == t.span.end) return Verb::m_only;
  const std::string_view s = b.text(t.span);
  for (const Verbs& v : kVerbs) {
    if (!text::iequals(s.substr(0, v.first.size()), v.first)) continue;
    if (v.second.empty()) {
      if (s.size() == v.first.size()) return v.verb;
      continue;
    }
    std::size_t p = v.first.size();
    while (p < s.size() && is_blank(s[p])) ++p;
    if (p > v.first.size() && text::iequals(s.substr(p), v.second)) return v.verb;
  }
  return Verb::other;
}

std::string_view to_string(Verb v) {
  switch (v) {
    case Verb::none: return "empty";
    case Verb::comment: return "comment";
    case Verb::begin_pgm: return "BEGIN PGM";
    case Verb::end_pgm: return "END PGM";
    case Verb::blk_form: return "BLK FORM";
    case Verb::tool_call: return "TOOL CALL";
    case Verb::tool_def: return "TOOL DEF";
    case Verb::l: return "L";
    case Verb::ln: return "LN";
    case Verb::lp: return "LP";
    case Verb::c: return "C";
    case Verb::cc: return "CC";
    case Verb::cr: return "CR";
    case Verb::ct: return "CT";
    case Verb::cp: return "CP";
    case Verb::rnd: return "RND";
    case Verb::chf: return "CHF";
    case Verb::appr: return "APPR";
    case Verb::dep: return "DEP";
    case Verb::cycl_def: return "CYCL DEF";
    case Verb::cycl_call: return "CYCL CALL";
    case Verb::call_lbl: return "CALL LBL";
    case Verb::call_pgm: return "CALL PGM";
    case Verb::lbl: return "LBL";
    case Verb::fn: return "FN";
    case Verb::q_assign: return "Q parameter";
    case Verb::plane: return "PLANE";
    case Verb::function: return "FUNCTION";
    case Verb::m_only: return "M";
    case Verb::stop: return "STOP";
    case Verb::tch_probe: return "TCH PROBE";
    case Verb::pattern_def: return "PATTERN DEF";
    case Verb::sel: return "SEL";
    case Verb::declare: return "DECLARE";
    case Verb::other: return "unknown";
  }
  return "unknown";
}

bool unread_text(const Block& b) {
  // Lexer::indented_text: an indented line that is no Klartext block, lexed without a report.
  return verb_of(b) == Verb::other && !b.raw.empty() && is_blank(b.raw[0]) && b.tokens.size() == 1 &&
         b.tokens.front().span.end == b.raw.size();
}

bool continued(std::string_view raw) {
  std::size_t e = raw.size();
  while (e > 0 && is_blank(raw[e - 1])) --e;
  return e > 0 && raw[e - 1] == '~';
}

int find_keyword(const Block& b, std::string_view name) {
  for (std::size_t i = 1; i < b.tokens.size(); ++i)
    if (b.tokens[i].kind == TokenKind::keyword && text::iequals(b.text(b.tokens[i].name), name))
      return static_cast<int>(i);
  return -1;
}

std::string_view token_text(const Block& b, int i) {
  return b.text(b.tokens[static_cast<std::size_t>(i)].span);
}

bool lex(const Dialect&, Block& block, const LexContext& ctx) { return Lexer(block, ctx).run(); }

}  // namespace postproc::gcode::klartext
