#pragma once
// The Fanuc macro B resolver's expressions: parsed once per line into a node pool
// (fanuc.cpp, the only file that includes it). Internal to src/gcode/resolve.
#include <fmt/format.h>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>
#include "src/gcode/number_text.hpp"
#include "src/gcode/text.hpp"
#include "support.hpp"

namespace postproc::gcode::resolver::fanuc_expr {

constexpr bool is_digit(char c) { return c >= '0' && c <= '9'; }
constexpr bool is_alpha(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }
constexpr bool is_blank(char c) { return c == ' ' || c == '\t'; }
constexpr char up(char c) { return c >= 'a' && c <= 'z' ? static_cast<char>(c - 'a' + 'A') : c; }
constexpr double kPi = 3.14159265358979323846;

/// A failure while evaluating or parsing: reported at `span` of the current line.
struct Failure {
  std::string code;
  std::string message;
  Span span;
};

// ---------------------------------------------------------------------------------------------
// Expressions

enum class Op : std::uint8_t {
  num, var, var_ind, neg, group, add, sub, mul, div, bor, bxor, band, mod, eq, ne, gt, ge, lt, le, fn
};
enum class Fn : std::uint8_t { sin, cos, tan, asin, acos, atan, atan2, sqrt, abs, bin, bcd, round, fix, fup, ln, exp, pow, adp };

struct Node {
  Op op = Op::num;
  Fn fn = Fn::sin;
  std::int32_t a = -1, b = -1;
  double num = 0;  // literal, or the variable number of Op::var
  Span span;       // in the line's raw text
  std::uint16_t height = 1;  // of the subtree (the evaluator's recursion depth)
};

struct Value {
  double v = 0;
  bool vacant = false;
};

/// Parsed expressions of one line (node pool; an expression is a root index).
struct ExprPool {
  std::vector<Node> nodes;
};

class Parser {
 public:
  Parser(std::string_view raw, std::uint32_t begin, std::uint32_t end, ExprPool& pool)
      : s_(raw), i_(begin), end_(end), pool_(pool), base_(begin), limit_(end) {}

  std::uint32_t pos() const { return i_; }
  void skip() {
    while (i_ < end_ && is_blank(s_[i_])) ++i_;
  }
  bool at_end() {
    skip();
    return i_ >= end_;
  }
  char peek() {
    skip();
    return i_ < end_ ? s_[i_] : '\0';
  }
  std::string_view peek_word() {
    skip();
    std::uint32_t e = i_;
    while (e < end_ && is_alpha(s_[e])) ++e;
    return s_.substr(i_, e - i_);
  }
  bool accept_word(std::string_view w) {
    if (!text::iequals(peek_word(), w)) return false;
    i_ += static_cast<std::uint32_t>(w.size());
    return true;
  }
  [[noreturn]] void fail(std::string msg, std::uint32_t at) const {
    throw Failure{"PP-E702", std::move(msg), {at, at + 1}};
  }
  void expect(char c, std::string_view what) {
    if (peek() != c) fail(fmt::format("expected '{}' {}", c, what), i_);
    ++i_;
  }

  /// A whole expression up to `end_` (or a ',' / ']' when nested).
  std::int32_t expression() { return has_relop(i_, end_) ? logical() : arith(true); }

  /// A variable reference at '#'.
  std::int32_t variable() {
    const std::uint32_t start = i_;
    const Nesting nest(depth_);
    if (nest.too_deep()) too_deep(start);
    expect('#', "for a variable");
    skip();
    if (i_ < end_ && is_digit(s_[i_])) {
      const std::uint32_t digits = i_;
      while (i_ < end_ && is_digit(s_[i_])) ++i_;
      return add({Op::var, Fn::sin, -1, -1, literal(digits, i_), {start, i_}});
    }
    std::int32_t inner = -1;
    if (i_ < end_ && s_[i_] == '[') {
      inner = bracket();
    } else if (i_ < end_ && s_[i_] == '#') {
      inner = variable();
    } else {
      fail("'#' must be followed by a variable number, #[expression] or another #variable", start);
    }
    return add({Op::var_ind, Fn::sin, inner, -1, 0, {start, i_}});
  }

 private:
  [[noreturn]] void too_deep(std::uint32_t at) const { throw Failure{"PP-E712", too_deep_message(), {at, at + 1}}; }
  /// The digits [b, e) as a number: exact to double precision, or refused when beyond its range.
  double literal(std::uint32_t b, std::uint32_t e) const {
    double v = 0;
    if (lex_number(s_.substr(0, e), b, false, v) != e) fail("malformed number", b);
    if (!std::isfinite(v))
      throw Failure{"PP-E205", fmt::format("the number '{}' is out of range (beyond ±1.8e308)", s_.substr(b, std::min<std::uint32_t>(e - b, 40))), {b, e}};
    return v;
  }
  std::int32_t add(Node n) {
    const auto h = [&](std::int32_t k) { return k < 0 ? 0 : pool_.nodes[static_cast<std::size_t>(k)].height; };
    const int height = 1 + std::max(h(n.a), h(n.b));
    if (height > kMaxExpressionDepth) too_deep(n.span.begin);
    n.height = static_cast<std::uint16_t>(height);
    pool_.nodes.push_back(n);
    return static_cast<std::int32_t>(pool_.nodes.size() - 1);
  }

  static bool is_relop(std::string_view w) {
    return text::iequals(w, "EQ") || text::iequals(w, "NE") || text::iequals(w, "GT") || text::iequals(w, "GE") || text::iequals(w, "LT") || text::iequals(w, "LE");
  }
  /// True when [from, to) holds a comparison at bracket depth 0 (a condition).
  /// Skips bracketed parts through the table of matching brackets, so that every nesting level
  /// does not scan the text inside it again: linear in the length of the line.
  bool has_relop(std::uint32_t from, std::uint32_t to) {
    for (std::uint32_t j = from; j < to;) {
      const char c = s_[j];
      if (c == '[') {
        const std::uint32_t close = close_of(j);
        if (close >= to) return false;  // not closed here: nothing more at depth 0
        j = close + 1;
        continue;
      }
      if (c == ']') return false;
      if (is_alpha(c)) {
        std::uint32_t e = j;
        while (e < to && is_alpha(s_[e])) ++e;
        if (is_relop(s_.substr(j, e - j))) return true;
        j = e;
        continue;
      }
      ++j;
    }
    return false;
  }
  /// The ']' matching the '[' at `open`, or end_ when it is not closed before end_.
  std::uint32_t matching(std::uint32_t open) {
    const std::uint32_t close = close_of(open);
    return close < end_ ? close : end_;
  }
  /// Matching brackets of the whole range [base_, limit_), found in one pass on first use.
  std::uint32_t close_of(std::uint32_t open) {
    if (close_.empty()) {
      close_.assign(limit_ - base_ + 1, limit_);
      std::vector<std::uint32_t> stack;
      for (std::uint32_t j = base_; j < limit_; ++j) {
        if (s_[j] == '[') stack.push_back(j);
        if (s_[j] == ']' && !stack.empty()) {
          close_[stack.back() - base_] = j;
          stack.pop_back();
        }
      }
    }
    return open >= base_ && open < limit_ ? close_[open - base_] : limit_;
  }

  std::int32_t bracket() {
    const std::uint32_t start = i_;
    expect('[', "");
    const std::uint32_t close = matching(start);
    if (close >= end_) fail("'[' is not closed; add ']'", start);
    const std::uint32_t saved_end = end_;
    end_ = close;
    const std::int32_t e = expression();
    if (!at_end()) fail(fmt::format("unexpected '{}' in the expression", s_.substr(i_, 1)), i_);
    end_ = saved_end;
    i_ = close + 1;
    return add({Op::group, Fn::sin, e, -1, 0, {start, i_}});
  }

  std::int32_t logical() {
    std::int32_t l = relation();
    for (;;) {
      const std::uint32_t at = i_;
      Op op{};
      if (accept_word("AND")) op = Op::band;
      else if (accept_word("OR")) op = Op::bor;
      else if (accept_word("XOR")) op = Op::bxor;
      else return l;
      const std::int32_t r = relation();
      l = add({op, Fn::sin, l, r, 0, {pool_.nodes[static_cast<std::size_t>(l)].span.begin, i_}});
      (void)at;
    }
  }
  std::int32_t relation() {
    const std::int32_t l = arith(false);
    const std::string_view w = peek_word();
    Op op{};
    if (text::iequals(w, "EQ")) op = Op::eq;
    else if (text::iequals(w, "NE")) op = Op::ne;
    else if (text::iequals(w, "GT")) op = Op::gt;
    else if (text::iequals(w, "GE")) op = Op::ge;
    else if (text::iequals(w, "LT")) op = Op::lt;
    else if (text::iequals(w, "LE")) op = Op::le;
    else return l;
    i_ += 2;
    const std::int32_t r = arith(false);
    return add({op, Fn::sin, l, r, 0, {pool_.nodes[static_cast<std::size_t>(l)].span.begin, i_}});
  }
  std::int32_t arith(bool logic) {
    std::int32_t l = term(logic);
    for (;;) {
      Op op{};
      const char c = peek();
      if (c == '+') { op = Op::add; ++i_; }
      else if (c == '-') { op = Op::sub; ++i_; }
      else if (logic && accept_word("OR")) op = Op::bor;
      else if (logic && accept_word("XOR")) op = Op::bxor;
      else return l;
      const std::int32_t r = term(logic);
      l = add({op, Fn::sin, l, r, 0, {pool_.nodes[static_cast<std::size_t>(l)].span.begin, i_}});
    }
  }
  std::int32_t term(bool logic) {
    std::int32_t l = unary(logic);
    for (;;) {
      Op op{};
      const char c = peek();
      const std::uint32_t at = i_;
      if (c == '*') { op = Op::mul; ++i_; }
      else if (c == '/') { op = Op::div; ++i_; }
      else if (accept_word("MOD")) op = Op::mod;
      else if (logic && accept_word("AND")) op = Op::band;
      else return l;
      const std::int32_t r = unary(logic);
      l = add({op, Fn::sin, l, r, 0, {at, i_}});
    }
  }
  std::int32_t unary(bool logic) {
    const char c = peek();
    const std::uint32_t start = i_;
    const Nesting nest(depth_);
    if (nest.too_deep()) too_deep(start);
    if (c == '-') {
      ++i_;
      const std::int32_t a = unary(logic);
      return add({Op::neg, Fn::sin, a, -1, 0, {start, i_}});
    }
    if (c == '+') {
      ++i_;
      return unary(logic);
    }
    return primary();
  }
  std::int32_t primary() {
    const char c = peek();
    const std::uint32_t start = i_;
    if (c == '#') return variable();
    if (c == '[') return bracket();
    if (is_digit(c) || c == '.') {
      bool digits = false;
      while (i_ < end_ && is_digit(s_[i_])) { ++i_; digits = true; }
      if (i_ < end_ && s_[i_] == '.') {
        ++i_;
        while (i_ < end_ && is_digit(s_[i_])) { ++i_; digits = true; }
      }
      if (!digits) fail("a lone '.' is not a number", start);
      return add({Op::num, Fn::sin, -1, -1, literal(start, i_), {start, i_}});
    }
    if (is_alpha(c)) {
      const std::string_view w = peek_word();
      static constexpr std::pair<std::string_view, Fn> kFns[] = {
          {"SIN", Fn::sin},   {"COS", Fn::cos},     {"TAN", Fn::tan},   {"ASIN", Fn::asin}, {"ACOS", Fn::acos},
          {"ATAN", Fn::atan}, {"ATN", Fn::atan},    {"SQRT", Fn::sqrt}, {"SQR", Fn::sqrt},  {"ABS", Fn::abs},
          {"BIN", Fn::bin},   {"BCD", Fn::bcd},     {"ROUND", Fn::round}, {"RND", Fn::round}, {"FIX", Fn::fix},
          {"FUP", Fn::fup},   {"LN", Fn::ln},       {"EXP", Fn::exp},   {"POW", Fn::pow},   {"ADP", Fn::adp}};
      for (const auto& [name, fn] : kFns) {
        if (!text::iequals(w, name)) continue;
        i_ += static_cast<std::uint32_t>(w.size());
        if (peek() != '[') fail(fmt::format("{} needs its argument in brackets: {}[…]", name, name), i_);
        const std::uint32_t open = i_;
        const std::uint32_t close = matching(open);
        if (close >= end_) fail("'[' is not closed; add ']'", open);
        ++i_;
        const std::uint32_t saved_end = end_;
        end_ = close;
        std::int32_t a = expression();
        std::int32_t b = -1;
        if (peek() == ',') {
          ++i_;
          b = expression();
        }
        if (!at_end()) fail(fmt::format("unexpected '{}' in the argument of {}", s_.substr(i_, 1), name), i_);
        end_ = saved_end;
        i_ = close + 1;
        Fn f = fn;
        if (f == Fn::atan) {
          if (b < 0 && peek() == '/') {
            // ATAN[a]/[b]
            const std::uint32_t slash = i_;
            ++i_;
            if (peek() == '[') {
              b = bracket();
            } else {
              i_ = slash;
            }
          }
          if (b >= 0) f = Fn::atan2;
        } else if (f == Fn::pow) {
          if (b < 0) fail("POW takes two arguments: POW[base,exponent]", start);
        } else if (b >= 0) {
          fail(fmt::format("{} takes one argument", name), start);
        }
        return add({Op::fn, f, a, b, 0, {start, i_}});
      }
      fail(fmt::format("'{}' is not a Fanuc macro function or operator", w), start);
    }
    if (i_ >= end_) fail("an operand is missing at the end of the expression", end_ > 0 ? end_ - 1 : 0);
    fail(fmt::format("unexpected '{}' in the expression", s_.substr(i_, 1)), i_);
  }

  std::string_view s_;
  std::uint32_t i_, end_;
  ExprPool& pool_;
  std::uint32_t base_, limit_;
  std::vector<std::uint32_t> close_;  // [open − base_] → its ']' (limit_ when unmatched)
  int depth_ = 0;
};

}  // namespace postproc::gcode::resolver::fanuc_expr
