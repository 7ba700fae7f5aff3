// Lossless block lexer. Spans index the block's raw bytes; nothing is copied or normalised.
#include "postproc/gcode/lexer.hpp"

#include <charconv>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "src/gcode/klartext.hpp"
#include "src/gcode/number_text.hpp"
#include "src/gcode/rotary_direction.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode {
namespace {
using text::is_space;
using text::iequals;
using text::upper;

constexpr bool is_digit(char c) { return c >= '0' && c <= '9'; }
constexpr bool is_alpha(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }
constexpr bool is_ident(char c) { return is_alpha(c) || is_digit(c) || c == '_'; }

/// Fanuc macro B statement keywords (multi-letter in otherwise single-letter dialects).
constexpr std::string_view kFanucKeywords[] = {"IF", "GOTO", "WHILE", "THEN", "DO", "END"};

/// Siemens statements that take the rest of the line as their argument.
constexpr std::string_view kSiemensStatementKeywords[] = {
    "IF", "ELSE", "ENDIF", "WHILE", "ENDWHILE", "FOR", "TO", "ENDFOR", "LOOP", "ENDLOOP",
    "REPEAT", "UNTIL", "GOTO", "GOTOF", "GOTOB", "GOTOC", "CASE", "RET", "STOPRE"};
constexpr std::string_view kSiemensDeclarations[] = {"DEF", "PROC", "EXTERN", "DEFINE"};

class Lexer {
 public:
  Lexer(const Dialect& d, Block& b, const LexContext& ctx) : d_(d), b_(b), ctx_(ctx), s_(b.raw) {}

  bool run() {
    // A UTF-8 byte-order mark before the first line is not part of the program (the controllers'
    // editors write and skip it); the bytes stay in the line, so output keeps them.
    const bool bom = b_.line <= 1 && s_.size() >= 3 && s_.substr(0, 3) == "\xEF\xBB\xBF";
    std::uint32_t i = skip_space(bom ? 3 : 0);
    // '%' starts a line of its own kind: "%", "%_N_NAME_MPF", "%O1200(TITLE)".
    if (i < n() && s_[i] == '%') {
      std::uint32_t j = i + 1;
      while (j < n() && s_[j] != '(' && s_[j] != ';' && !is_space(s_[j]) &&
             !(d_.id != DialectId::siemens && (s_[j] == 'O' || s_[j] == 'o' || s_[j] == ':')))
        ++j;
      push_token(TokenKind::percent, {i, j}, {i, j});
      i = skip_space(j);
    }
    if (i < n() && s_[i] == '/') {
      std::uint32_t j = i + 1;
      if (j < n() && is_digit(s_[j])) {
        b_.block_delete_level = static_cast<std::uint8_t>(s_[j] - '0');
        ++j;
      }
      b_.block_delete = true;
      b_.block_delete_span = {i, j};
      i = skip_space(j);
    }
    bool first_item = true;
    // Only a line of more than kMaxBlockItems bytes can hold that many items (each takes a byte).
    const bool long_line = n() > kMaxBlockItems;
    while (i < n()) {
      if (long_line && b_.words.size() + b_.tokens.size() >= kMaxBlockItems) {
        // A real block has a few dozen words: a huge line of them (a program without line ends)
        // is refused once, here, rather than lexed into gigabytes of words and diagnostics.
        bad(i, "PP-E110", fmt::format("the block has more than {} words and statements", kMaxBlockItems),
            "a block holds one line of the program; check its line ends");
        return false;
      }
      const char c = s_[i];
      std::uint32_t next = 0;
      if (is_alpha(c) && !d_.multi_letter_identifiers) {
        next = letter_item(i, first_item);
      } else if (c == '(' && d_.paren_comments) {
        next = paren_comment(i);
      } else if (c == ';' && d_.semicolon_comments) {
        push_token(TokenKind::line_comment, {i, n()}, {i, n()});
        next = n();
      } else if (c == '*' && d_.star_block_end) {
        push_token(TokenKind::block_end, {i, i + 1}, {i, i + 1});
        next = i + 1;
      } else if (c == '%' && d_.star_block_end) {
        // Heidenhain ISO: "%NAME G71 *" opens and "N99999 %NAME G71 *" closes the program.
        std::uint32_t j = i + 1;
        while (j < n() && !is_space(s_[j]) && s_[j] != '*' && s_[j] != ';') ++j;
        push_token(TokenKind::percent, {i, j}, {i, j});
        next = j;
      } else if (c == ':' && first_item && d_.id == DialectId::fanuc) {
        next = program_number(i, i + 1);
      } else if (c == '#' && d_.hash_parameters) {
        next = hash_assignment(i);
      } else if (is_alpha(c) || (c == '_' && d_.multi_letter_identifiers)) {
        next = d_.multi_letter_identifiers ? siemens_item(i, first_item) : letter_item(i, first_item);
      } else if ((c == '@' || c == '^') && d_.id == DialectId::linuxcnc) {
        next = letter_item(i, first_item);  // LinuxCNC polar words: @ distance, ^ angle (degrees)
      } else if (c == ',' && d_.id == DialectId::fanuc && i + 1 < n() &&
                 (upper(s_[i + 1]) == 'C' || upper(s_[i + 1]) == 'R' || upper(s_[i + 1]) == 'A')) {
        next = comma_word(i);
      } else if (c == '$' && d_.multi_letter_identifiers && i + 1 < n() && (is_alpha(s_[i + 1]) || s_[i + 1] == '_')) {
        next = system_variable_write(i);
      } else {
        next = bad(i, "PP-E101", fmt::format("unexpected character '{}'", printable(c)),
                   "remove it or check the --dialect");
      }
      first_item = false;
      i = skip_space(next);
    }
    if (long_literal_) refuse_infinite_literals();
    return ok_;
  }

 private:
  [[nodiscard]] std::uint32_t n() const { return static_cast<std::uint32_t>(s_.size()); }
  [[nodiscard]] std::uint32_t skip_space(std::uint32_t i) const {
    while (i < n() && is_space(s_[i])) ++i;
    return i;
  }
  static std::string printable(char c) {
    if (static_cast<unsigned char>(c) < 32 || static_cast<unsigned char>(c) >= 127)
      return fmt::format("\\x{:02X}", static_cast<unsigned char>(c));
    return std::string(1, c);
  }

  /// A literal of more than 15 characters may have more than 15 digits, the only case that can
  /// read as ±inf (number_text.hpp): the block is checked for them at its end (not every block:
  /// the lexer's fast path stays as it was).
  void note_literal(std::uint32_t b, std::uint32_t e) {
    if (e > b + 15) long_literal_ = true;
  }

  /// A literal beyond the range of a double is refused at its word (PP-E205) rather than later
  /// as a word this dialect does not know; the word is dropped so that nothing reads ±inf.
  void refuse_infinite_literals() {
    std::erase_if(b_.words, [&](const Word& w) {
      if (w.kind != ValueKind::number || std::isfinite(w.number)) return false;
      out_of_range(w.value);
      return true;
    });
    if (b_.has_n && !std::isfinite(b_.n_number)) {
      out_of_range(b_.n_span);
      b_.has_n = false;
    }
  }

  void out_of_range(Span value) {
    ok_ = false;
    if (ctx_.sink)
      report_at(ctx_, b_, value, Severity::error, "PP-E205",
                fmt::format("the number '{}{}' is out of range (beyond ±1.8e308); correct the value",
                            s_.substr(value.begin, std::min<std::uint32_t>(value.size(), 40)), value.size() > 40 ? "…" : ""));
  }

  void push_token(TokenKind k, Span span, Span name) { b_.tokens.push_back(Token{span, k, name}); }

  std::uint32_t bad(std::uint32_t at, std::string_view code, const std::string& what, std::string_view fix,
                    std::uint32_t len = 1) {
    ok_ = false;
    if (ctx_.sink)
      report_at(ctx_, b_, {at, std::min(n(), at + len)}, Severity::error, code, fmt::format("{}; {}", what, fix));
    // Resynchronise at the next whitespace so one bad byte does not hide the rest of the block.
    std::uint32_t j = at + 1;
    while (j < n() && !is_space(s_[j])) ++j;
    return j;
  }

  std::uint32_t paren_comment(std::uint32_t i) {
    std::uint32_t j = i + 1;
    // Fanuc-family controls (Haas, Mori) accept nested parentheses inside a comment; LinuxCNC does not.
    const bool nests = d_.id == DialectId::fanuc;
    int depth = 1;
    for (; j < n(); ++j) {
      if (nests && s_[j] == '(') ++depth;
      if (s_[j] == ')' && --depth == 0) break;
    }
    if (j >= n()) {
      ok_ = false;
      if (ctx_.sink)
        report_at(ctx_, b_, {i, i + 1}, Severity::error, "PP-E102",
                  "comment '(' is not closed on this line; add ')' (comments cannot span lines)");
      push_token(TokenKind::paren_comment, {i, n()}, {i, n()});
      return n();
    }
    push_token(TokenKind::paren_comment, {i, j + 1}, {i + 1, j});
    return j + 1;
  }

  /// Program number after 'O' or ':' at `digits`; `i` is the start of the token.
  std::uint32_t program_number(std::uint32_t i, std::uint32_t digits) {
    std::uint32_t j = digits;
    while (j < n() && is_digit(s_[j])) ++j;
    if (j == digits)
      return bad(i, "PP-E103", "program number without digits",
                 "write the program number (e.g. O1234) or remove the placeholder text", j - i + 1);
    push_token(TokenKind::program_number, {i, j}, {digits, j});
    return j;
  }

  /// End of a bracketed expression starting at `i` (s_[i] == open); 0 on error.
  std::uint32_t match_bracket(std::uint32_t i, char open, char close) {
    int depth = 0;
    bool in_string = false;
    for (std::uint32_t j = i; j < n(); ++j) {
      const char c = s_[j];
      if (c == '"') in_string = !in_string;
      if (in_string) continue;
      if (c == open) ++depth;
      if (c == close && --depth == 0) return j + 1;
    }
    return 0;
  }

  /// Parses a value after an address (at `i`). Fills `w.value`, `w.kind`, `w.number`. Returns end or 0.
  std::uint32_t value(std::uint32_t i, Word& w) {
    if (d_.spaces_inside_words) i = skip_space(i);
    if (i >= n()) return 0;
    std::uint32_t j = i;
    // A sign may precede a parameter or expression: X-#1, X-[#1+2].
    std::uint32_t k = j;
    if (s_[k] == '-' || s_[k] == '+') k = d_.spaces_inside_words ? skip_space(k + 1) : k + 1;
    if (k < n() && s_[k] == '[') {
      const std::uint32_t e = match_bracket(k, '[', ']');
      if (e == 0) return 0;
      w.kind = ValueKind::expression;
      w.value = {j, e};
      return e;
    }
    if (k < n() && s_[k] == '#' && d_.hash_parameters) {
      const std::uint32_t e = parameter_ref_end(k);
      if (e == 0) return 0;
      w.kind = ValueKind::parameter;
      w.value = {j, e};
      return e;
    }
    // LinuxCNC unary functions as values: X sin[30]
    if (k < n() && is_alpha(s_[k]) && d_.o_word_control) {
      std::uint32_t e = k;
      while (e < n() && is_alpha(s_[e])) ++e;
      if (e < n() && s_[e] == '[') {
        const std::uint32_t m = match_bracket(e, '[', ']');
        if (m == 0) return 0;
        w.kind = ValueKind::expression;
        w.value = {j, m};
        return m;
      }
      return 0;
    }
    if (d_.id == DialectId::fanuc || d_.id == DialectId::linuxcnc) return spaced_number(j, w);
    bool point = false;
    const std::uint32_t e = lex_number(s_, j, d_.spaces_inside_words, w.number, &point);
    note_literal(j, e);
    w.whole = !point;
    if (e == j) return 0;
    w.kind = ValueKind::number;
    w.value = {j, e};
    return e;
  }

  /// Fanuc `,C` `,R` `,A` (chamfer, corner rounding, direct-drawing angle): a two-character address,
  /// never an axis.
  std::uint32_t comma_word(std::uint32_t i) {
    Word w;
    w.letter = upper(s_[i + 1]);
    w.name = {i, i + 2};
    w.name_len = 2;
    const std::uint32_t e = value(i + 2, w);
    if (e == 0) return missing_value(i);
    w.span = {i, e};
    b_.words.push_back(w);
    return e;
  }

  /// Fanuc, LinuxCNC: true when blanks at `e` are followed by more digits of the same number ("X1 0.5").
  [[nodiscard]] bool spaced_digits_follow(std::uint32_t e) const {
    if ((d_.id != DialectId::fanuc && d_.id != DialectId::linuxcnc) || e >= n() || !is_space(s_[e])) return false;
    // One blank and then the next word's letter is the common case: no scan.
    std::uint32_t k = e + 1;
    if (k < n() && is_space(s_[k])) k = skip_space(k);
    return k < n() && (is_digit(s_[k]) || s_[k] == '.');
  }

  /// Fanuc and LinuxCNC read a number with blanks anywhere in it ("X 1 0 . 5" is X10.5): the Fanuc
  /// tape reader ignores spaces (B-64484EN "Tape code": SP is disregarded in significant
  /// information); rs274ngc removes blanks and tabs outside comments before it reads a line
  /// (checked against rs274: tests/resolve/linuxcnc/reader_spaced_words.ngc). The value span runs
  /// from the first to the last character of the number.
  std::uint32_t spaced_number(std::uint32_t i, Word& w) {
    const std::uint32_t j = skip_space(i);
    char buf[64];
    std::size_t len = 0;
    std::uint32_t last = j;
    bool digit = false;
    std::uint32_t k = j;
    if (k < n() && (s_[k] == '-' || s_[k] == '+')) {
      buf[len++] = s_[k++];
      last = k;
    }
    bool full = false;
    for (; k < n(); ++k) {
      const char c = s_[k];
      if (is_space(c)) continue;
      if (!is_digit(c) && c != '.') break;
      if (len == sizeof buf) {
        full = true;  // longer than any real value: read as a plain literal (out of range or exact)
        break;
      }
      buf[len++] = c;
      last = k + 1;
      digit = digit || is_digit(c);
    }
    bool point = false;
    double v = 0;
    note_literal(0, static_cast<std::uint32_t>(len));
    if (full || !digit || lex_number(std::string_view(buf, len), 0, false, v, &point) != len) {
      // Not one number ("X1..2"): read what a plain literal gives, as without blanks.
      const std::uint32_t e = lex_number(s_, i, false, v, &point);
      note_literal(i, e);
      if (e == i) return 0;
      w.kind = ValueKind::number;
      w.number = v;
      w.whole = !point;
      w.value = {i, e};
      return e;
    }
    w.kind = ValueKind::number;
    w.number = v;
    w.whole = !point;
    w.value = {j, last};
    return last;
  }

  /// End of `#123`, `#<name>`, `##1`, `#[expr]`, or 0.
  std::uint32_t parameter_ref_end(std::uint32_t i) {
    // LinuxCNC reads the line without its blanks: "# 1", "# # 2", "#1 0" are #1, ##2, #10.
    const bool spaced = d_.spaces_inside_words;
    std::uint32_t j = i;
    while (j < n() && s_[j] == '#') j = spaced ? skip_space(j + 1) : j + 1;
    if (j >= n()) return 0;
    if (s_[j] == '<') {
      const std::uint32_t e = static_cast<std::uint32_t>(s_.find('>', j));
      return e == static_cast<std::uint32_t>(std::string_view::npos) ? 0 : e + 1;
    }
    if (s_[j] == '[') return match_bracket(j, '[', ']');
    const std::uint32_t start = j;
    std::uint32_t end = j;
    while (j < n() && is_digit(s_[j])) {
      end = ++j;
      if (spaced) j = skip_space(j);
    }
    return end == start ? 0 : end;
  }

  /// `#1=expr`, `#<name>=expr`: the right-hand side runs to a comment or the end of the block.
  std::uint32_t hash_assignment(std::uint32_t i) {
    const std::uint32_t name_end = parameter_ref_end(i);
    if (name_end == 0)
      return bad(i, "PP-E104", "malformed parameter reference", "write #123, #<name> or #[expression]");
    std::uint32_t j = skip_space(name_end);
    if (j >= n() || s_[j] != '=')
      return bad(i, "PP-E105", "parameter reference outside a word or assignment",
                 "assign it (#1=5) or use it as a word value (X#1)", name_end - i);
    // LinuxCNC reads one value after '=' (rs274ngc read_real_value: a number, a parameter, a
    // bracketed expression or a function, each after any signs); words and further assignments may
    // follow on the line ("#1 = 7 G1 X#1": the move takes #1 as it was before the line). Fanuc's
    // statement runs to the end of the block.
    const std::uint32_t value_end = d_.id == DialectId::linuxcnc ? real_value_end(j + 1) : 0;
    j = value_end != 0 ? value_end : rest_of_statement(j + 1);
    push_token(TokenKind::assignment, {i, j}, {i, name_end});
    return j;
  }

  /// LinuxCNC: the end of one value from `j` (spaces and signs first): a number (digits and one
  /// point, no exponent), a parameter reference, `[…]`, a function `NAME[…]` or `ATAN[…]/[…]`.
  /// 0 when the text there is none of these (the statement's parser then says what is wrong).
  std::uint32_t real_value_end(std::uint32_t j) {
    j = skip_space(j);
    while (j < n() && (s_[j] == '+' || s_[j] == '-')) j = skip_space(j + 1);
    if (j >= n()) return 0;
    const char c = s_[j];
    if (c == '[') return match_bracket(j, '[', ']');
    if (c == '#') return parameter_ref_end(j);
    // rs274 drops every space before it reads a line: "1 0 . 5" is 10.5, "A T A N" is ATAN.
    const auto next_in = [&](std::uint32_t k, auto part) {
      if (k < n() && part(s_[k])) return k + 1;
      const std::uint32_t m = d_.spaces_inside_words ? skip_space(k) : k;
      return m < n() && m > k && part(s_[m]) ? m + 1 : 0u;
    };
    if (is_alpha(c)) {
      std::string name;
      std::uint32_t k = j;
      for (std::uint32_t m; (m = next_in(k, is_alpha)) != 0; k = m) name += upper(s_[m - 1]);
      const bool atan = name == "ATAN";
      k = skip_space(k);
      if (k >= n() || s_[k] != '[') return 0;
      std::uint32_t e = match_bracket(k, '[', ']');
      if (e == 0 || !atan) return e;
      k = skip_space(e);
      if (k >= n() || s_[k] != '/') return 0;
      k = skip_space(k + 1);
      return k < n() && s_[k] == '[' ? match_bracket(k, '[', ']') : 0;
    }
    if (!is_digit(c) && c != '.') return 0;
    std::uint32_t k = j;
    bool point = false;
    const auto digit_or_point = [&point](char ch) { return is_digit(ch) || (ch == '.' && !point); };
    for (std::uint32_t m; (m = next_in(k, digit_or_point)) != 0; k = m) point = point || s_[m - 1] == '.';
    return k;
  }

  /// End of a statement's text: up to a comment (outside brackets/strings) or the end of line,
  /// with trailing spaces excluded.
  std::uint32_t rest_of_statement(std::uint32_t j) {
    int depth = 0;
    bool in_string = false;
    std::uint32_t e = j;
    for (; e < n(); ++e) {
      const char c = s_[e];
      if (c == '"') in_string = !in_string;
      if (in_string) continue;
      if (c == '[') ++depth;
      if (c == ']') --depth;
      if (depth <= 0 && ((c == '(' && d_.paren_comments) || (c == ';' && d_.semicolon_comments))) break;
    }
    while (e > j && is_space(s_[e - 1])) --e;
    return e;
  }

  /// Fanuc / LinuxCNC / Heidenhain: a single letter and a value, or a statement keyword.
  std::uint32_t letter_item(std::uint32_t i, bool first_item) {
    const char L = upper(s_[i]);
    // Fast path for the common case, a letter directly followed by a literal (X-12.5, G1, N10).
    if (i + 1 < n() && L != 'O') {
      const char c = s_[i + 1];
      if ((static_cast<unsigned>(c - '0') < 10u || c == '-' || c == '.' || c == '+')) {
        double v = 0;
        bool point = false;
        const std::uint32_t e = lex_number(s_, i + 1, d_.spaces_inside_words, v, &point);
        note_literal(i + 1, e);
        if (e != i + 1 && (e >= n() || (s_[e] != '.' && !is_digit(s_[e]))) && !spaced_digits_follow(e)) {
          if (L == 'N' && first_item && !b_.has_n) {
            b_.has_n = true;
            b_.n_span = {i, e};
            b_.n_number = v;
            return e;
          }
          Word& w = b_.words.emplace_back();
          w.span = {i, e};
          w.name = {i, i + 1};
          w.value = {i + 1, e};
          w.letter = L;
          w.number = v;
          w.whole = !point;
          return e;
        }
      }
    }
    // Multi-letter statement keywords (Fanuc macro B: IF/GOTO/WHILE/DO/END/THEN).
    if (d_.id == DialectId::fanuc && i + 1 < n() && is_alpha(s_[i + 1])) {
      std::uint32_t e = i;
      while (e < n() && is_alpha(s_[e])) ++e;
      const std::string_view word = s_.substr(i, e - i);
      for (std::string_view kw : kFanucKeywords)
        if (iequals(word, kw)) {
          // IF/WHILE take a bracketed condition; the whole statement runs to a comment or EOL.
          const std::uint32_t end = rest_of_statement(e);
          push_token(TokenKind::control_flow, {i, end}, {i, e});
          return end;
        }
      // Custom macro external output (Fanuc "External output commands": POPEN, BPRNT[…], DPRNT[…],
      // PCLOS): data sent to a reader/punch or file, no effect on the motion. Kept as written; the
      // bracket of BPRNT/DPRNT holds text and #variables and ends at its closing ']'.
      if (iequals(word, "POPEN") || iequals(word, "PCLOS")) {
        push_token(TokenKind::keyword, {i, e}, {i, e});
        return e;
      }
      if ((iequals(word, "DPRNT") || iequals(word, "BPRNT")) && e < n() && s_[e] == '[') {
        const std::uint32_t end = match_bracket(e, '[', ']');
        if (end == 0) return bad(i, "PP-E107", fmt::format("{}[ not closed", word), "close the bracket: DPRNT[text #1[53]]");
        push_token(TokenKind::keyword, {i, end}, {i, e});
        return end;
      }
    }
    if (L == 'O' && d_.o_word_control) return o_word(i);
    if (L == 'O' && d_.id != DialectId::siemens) {
      return program_number(i, d_.spaces_inside_words ? skip_space(i + 1) : i + 1);
    }
    Word w;
    w.letter = L;
    w.name = {i, i + 1};
    const std::uint32_t e = value(i + 1, w);
    if (e == 0) return missing_value(i);
    w.span = {i, e};
    if (L == 'N' && first_item && w.kind == ValueKind::number && !b_.has_n) {
      b_.has_n = true;
      b_.n_span = w.span;
      b_.n_number = w.number;
      return e;
    }
    b_.words.push_back(w);
    return e;
  }

  std::uint32_t missing_value(std::uint32_t i) {
    std::uint32_t e = i + 1;
    while (e < n() && is_ident(s_[e])) ++e;
    return bad(i, "PP-E106", fmt::format("'{}' is not a word this dialect ({}) knows", s_.substr(i, e - i), d_.name),
               "an address letter must be followed by a number, #parameter or [expression]; check --dialect",
               e - i);
  }

  /// LinuxCNC o-word: o100 sub / o<name> call [args] / o101 if [cond] …
  std::uint32_t o_word(std::uint32_t i) {
    std::uint32_t j = d_.spaces_inside_words ? skip_space(i + 1) : i + 1;
    std::uint32_t name_end = j;
    if (j < n() && s_[j] == '<') {
      const auto e = s_.find('>', j);
      if (e == std::string_view::npos)
        return bad(i, "PP-E107", "o-word name '<' not closed", "write o<name>", n() - i);
      name_end = static_cast<std::uint32_t>(e + 1);
    } else if (j < n() && (s_[j] == '#' || s_[j] == '[')) {
      name_end = s_[j] == '#' ? parameter_ref_end(j) : match_bracket(j, '[', ']');
      if (name_end == 0) return bad(i, "PP-E107", "malformed o-word number", "write o100 or o<name>");
    } else {
      while (name_end < n() && is_digit(s_[name_end])) ++name_end;
      if (name_end == j) return bad(i, "PP-E107", "o-word without a number or name", "write o100 or o<name>");
    }
    const std::uint32_t end = rest_of_statement(name_end);
    push_token(TokenKind::control_flow, {i, end}, {i, name_end});
    return end;
  }

  /// Siemens: identifiers may be multi-letter; addresses may carry '=' and extended digits.
  std::uint32_t siemens_item(std::uint32_t i, bool first_item) {
    std::uint32_t e = i;
    while (e < n() && (is_alpha(s_[e]) || s_[e] == '_')) ++e;
    const std::string_view letters = s_.substr(i, e - i);
    // Identifier with digits (CYCLE800, R12, A3, L54, G642, X10): split letters and digits.
    std::uint32_t d = e;
    while (d < n() && is_ident(s_[d])) ++d;
    const std::uint32_t after = skip_space(d);
    const bool equals = after < n() && s_[after] == '=' && !(after + 1 < n() && s_[after + 1] == '=');
    // Sinumerik accepts blanks between a cycle name and its argument list: CYCLE90 (-17,…).
    const std::uint32_t open = letters.size() >= 2 ? after : d;
    const bool paren = open < n() && s_[open] == '(';
    const bool label = d < n() && s_[d] == ':' && (first_item || only_n_before(i)) && !(d + 1 < n() && s_[d + 1] == '=');

    if (label && letters.size() >= 2) {
      push_token(TokenKind::label, {i, d + 1}, {i, d});
      return d + 1;
    }
    const std::string_view ident = s_.substr(i, d - i);
    if (d < n() && s_[d] == '[') {
      // An indexed assignment: an array element (AR[1,2]=…) or a computed R parameter (R[R1]=…).
      const std::uint32_t m = match_bracket(d, '[', ']');
      const std::uint32_t eq = m == 0 ? m : skip_space(m);
      if (m != 0 && eq < n() && s_[eq] == '=' && !(eq + 1 < n() && s_[eq + 1] == '=')) {
        const std::uint32_t v = skip_space(eq + 1);
        const std::uint32_t end = siemens_expression_end(v);
        if (end == v) return bad(i, "PP-E109", fmt::format("'{}[…]=' without a value", ident), "write a value after '='");
        push_token(TokenKind::assignment, {i, end}, {i, d});
        return end;
      }
    }
    if (iequals(ident, "CALL") && after < n() && s_[after] == '"') {
      // CALL "NAME": a subprogram call by name.
      const auto close = s_.find('"', after + 1);
      if (close == std::string_view::npos)
        return bad(after, "PP-E108", "the subprogram name after CALL is not closed", "close it with '\"'");
      push_token(TokenKind::call, {i, static_cast<std::uint32_t>(close + 1)}, {i, d});
      return static_cast<std::uint32_t>(close + 1);
    }
    for (std::string_view kw : kSiemensDeclarations)
      if (iequals(ident, kw)) {
        const std::uint32_t end = rest_of_statement(d);
        push_token(TokenKind::declaration, {i, end}, {i, d});
        return end;
      }
    for (std::string_view kw : kSiemensStatementKeywords)
      if (iequals(ident, kw)) {
        const std::uint32_t end = rest_of_statement(d);
        push_token(TokenKind::control_flow, {i, end}, {i, d});
        return end;
      }
    if (paren) {
      const std::uint32_t m = match_bracket(open, '(', ')');
      if (m == 0)
        return bad(i, "PP-E108", fmt::format("'(' after {} is not closed", ident), "close the argument list",
                   d - i + 1);
      push_token(TokenKind::call, {i, m}, {i, d});
      return m;
    }
    if (equals) {
      // Address with '=' (X=10, A3=0.5, CR=5, R1=2) or a variable assignment (NAME=expr).
      std::uint32_t v = skip_space(after + 1);
      std::uint32_t end = siemens_expression_end(v);
      if (end == v) return bad(i, "PP-E109", fmt::format("'{}=' without a value", ident), "write a value after '='");
      const bool is_address = (letters.size() <= 2 && (letters.size() == 1 || is_siemens_two_letter(letters))) ||
                              (d == e && is_siemens_motion_address(letters));
      if (!is_address || (letters.size() == 1 && upper(letters[0]) == 'R')) {
        push_token(TokenKind::assignment, {i, end}, {i, d});
        return end;
      }
      Word w;
      w.letter = upper(s_[i]);
      w.name = {i, d};
      w.name_len = static_cast<std::uint8_t>(d - i);
      w.index = extended_index(e, d);
      w.has_equals = true;
      w.value = {v, end};
      const std::string_view text = s_.substr(v, end - v);
      note_literal(v, end);
      if (std::uint32_t ne = scan_number(text, 0, false); ne == text.size() && ne > 0 && parse_number(text, w.number)) {
        w.kind = ValueKind::number;
      } else if ((text.size() > 3 && iequals(text.substr(0, 3), "AC(")) || direction_of(text) != RotaryDirection::none) {
        // AC(…), and Sinumerik absolute positions of a modulo rotary axis with a direction (DC, ACP, ACN).
        w.kind = ValueKind::absolute_fn;
      } else if (text.size() > 3 && iequals(text.substr(0, 3), "IC(")) {
        w.kind = ValueKind::incremental_fn;
      } else if (!text.empty() && text[0] == '"') {
        w.kind = ValueKind::string;
      } else {
        w.kind = ValueKind::expression;
      }
      w.span = {i, end};
      b_.words.push_back(w);
      return end;
    }
    if (letters.size() >= 2) {
      push_token(TokenKind::keyword, {i, d}, {i, d});
      return d;
    }
    // Single letter followed by a number: X10.5, G1, N10, L54 (letters.size() == 1 here).
    Word w;
    w.letter = upper(s_[i]);
    w.name = {i, i + 1};
    const std::uint32_t v_end = value(i + 1, w);
    if (v_end == 0) return missing_value(i);
    w.span = {i, v_end};
    if (w.letter == 'N' && first_item && w.kind == ValueKind::number && !b_.has_n) {
      b_.has_n = true;
      b_.n_span = w.span;
      b_.n_number = w.number;
      return v_end;
    }
    b_.words.push_back(w);
    return v_end;
  }

  /// Siemens `$NAME=…` / `$NAME[…]=…`: a system variable written (an assignment token).
  std::uint32_t system_variable_write(std::uint32_t i) {
    std::uint32_t d = i + 1;
    while (d < n() && (is_ident(s_[d]) || s_[d] == '_')) ++d;
    std::uint32_t q = d;
    if (q < n() && s_[q] == '[') {
      q = match_bracket(q, '[', ']');
      if (q == 0) return bad(i, "PP-E108", "'[' is not closed", "close the index with ']'", d - i + 1);
    }
    const std::uint32_t eq = skip_space(q);
    if (!(eq < n() && s_[eq] == '=' && !(eq + 1 < n() && s_[eq + 1] == '=')))
      return bad(i, "PP-E101", "unexpected character '$'", "a system variable can only be written here: $NAME=value",
                 q - i);
    const std::uint32_t v = skip_space(eq + 1);
    const std::uint32_t end = siemens_expression_end(v);
    if (end == v) return bad(i, "PP-E109", "a system variable write without a value", "write a value after '='");
    push_token(TokenKind::assignment, {i, end}, {i, d});
    return end;
  }

  /// True when only an N word (and blanks) precede position i.
  [[nodiscard]] bool only_n_before(std::uint32_t i) const {
    return b_.has_n && b_.words.empty() && b_.tokens.empty() && skip_space(b_.n_span.end) == i;
  }
  static bool is_siemens_two_letter(std::string_view l) {
    constexpr std::string_view kTwo[] = {"CR", "AP", "RP", "AR", "CT", "IP", "TU", "SF", "FA", "OS"};
    for (auto k : kTwo)
      if (iequals(l, k)) return true;
    return false;
  }
  /// Sinumerik multi-letter motion addresses (840D sl Fundamentals, "Motion commands"): helix turns,
  /// chamfer and rounding. They are words of the block, not variable assignments.
  static bool is_siemens_motion_address(std::string_view l) {
    constexpr std::string_view kNames[] = {"TURN", "CHF", "CHR", "RND", "RNDM"};
    for (auto k : kNames)
      if (iequals(l, k)) return true;
    return false;
  }
  std::uint8_t extended_index(std::uint32_t from, std::uint32_t to) const {
    unsigned v = 0;
    for (std::uint32_t k = from; k < to && v < 100; ++k)
      if (is_digit(s_[k])) v = v * 10 + static_cast<unsigned>(s_[k] - '0');
    return static_cast<std::uint8_t>(v);
  }
  /// Siemens value after '=': runs to whitespace at bracket depth 0 (or a comment), and on across
  /// blanks next to an operator (`R1 = 2 * 4`, `R1=7 DIV 2`) as the Sinumerik reads it — the same rule
  /// as the resolver's (src/gcode/resolve/siemens_parse.hpp, extended_end), so that check and convert
  /// read one program alike.
  std::uint32_t siemens_expression_end(std::uint32_t v) {
    std::uint32_t e = siemens_value_end(v);
    for (;;) {
      const std::uint32_t q = skip_space(e);
      if (q >= n() || q == e || s_[q] == ';' || e == v) return e;
      const char prev = s_[e - 1];
      bool prev_op = std::string_view("+-*/<>=(,").find(prev) != std::string_view::npos;
      if (!prev_op && is_ident(prev)) {
        std::uint32_t k = e;
        while (k > v && is_ident(s_[k - 1])) --k;
        prev_op = operator_keyword(s_.substr(k, e - k), true);
      }
      bool next_op = std::string_view("+-*/<>=").find(s_[q]) != std::string_view::npos;
      if (!next_op && (is_alpha(s_[q]) || s_[q] == '_')) {
        std::uint32_t k = q;
        while (k < n() && is_ident(s_[k])) ++k;
        next_op = operator_keyword(s_.substr(q, k - q), false) && k < n() && (is_space(s_[k]) || s_[k] == '(');
      }
      if (!prev_op && !next_op) return e;
      e = std::max(siemens_value_end(q), q + 1);
    }
  }
  static bool operator_keyword(std::string_view id, bool unary_too) {
    for (std::string_view k : {"DIV", "MOD", "AND", "OR", "XOR", "B_AND", "B_OR", "B_XOR"})
      if (iequals(id, k)) return true;
    return unary_too && (iequals(id, "NOT") || iequals(id, "B_NOT"));
  }
  std::uint32_t siemens_value_end(std::uint32_t v) {
    int depth = 0;
    bool in_string = false;
    std::uint32_t e = v;
    for (; e < n(); ++e) {
      const char c = s_[e];
      if (c == '"') in_string = !in_string;
      if (in_string) continue;
      if (c == '(' || c == '[') ++depth;
      if (c == ')' || c == ']') --depth;
      if (depth <= 0 && (is_space(c) || c == ';')) break;
    }
    return e;
  }

  const Dialect& d_;
  Block& b_;
  const LexContext& ctx_;
  std::string_view s_;
  bool ok_ = true;
  bool long_literal_ = false;
};

}  // namespace

void report_at(const LexContext& ctx, const Block& block, Span span, Severity sev, std::string_view code,
               std::string message) {
  if (!ctx.sink) return;
  Diagnostic d;
  d.severity = sev;
  d.code = std::string(code);
  d.file = std::string(ctx.file);
  d.where = {block.line, span.begin + 1};
  d.message = std::move(message);
  set_source_line(d, block.raw);
  d.length = std::max<std::uint32_t>(1, span.size());
  ctx.sink->report(std::move(d));
}

bool lex_block(const Dialect& dialect, Block& block, const LexContext& ctx) {
  block.words.clear();
  block.tokens.clear();
  block.has_n = false;
  block.block_delete = false;
  block.block_delete_level = 0;
  if (dialect.id == DialectId::heidenhain) return klartext::lex(dialect, block, ctx);
  return Lexer(dialect, block, ctx).run();
}

}  // namespace postproc::gcode
