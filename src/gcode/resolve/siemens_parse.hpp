#pragma once
// The Siemens resolver's expressions, parsed-line structures and statement scanning
// (siemens.cpp, the only file that includes it). Internal to src/gcode/resolve.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include "src/gcode/siemens_keywords.hpp"
#include "src/gcode/text.hpp"
#include "support.hpp"

namespace postproc::gcode::resolver::siemens_parse {

using text::iequals;
using text::upper;

constexpr std::size_t npos = static_cast<std::size_t>(-1);
constexpr double kPi = 3.14159265358979323846;
constexpr int kRCount = 1000;

constexpr bool is_digit(char c) { return c >= '0' && c <= '9'; }
constexpr bool is_alpha(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }
constexpr bool is_ident(char c) { return is_alpha(c) || is_digit(c) || c == '_'; }
constexpr bool is_blank(char c) { return c == ' ' || c == '\t'; }

/// An evaluation or parse failure: reported at `span` of the current line.
struct Fail {
  const char* code;
  Span span;
  std::string message;
};

// ------------------------------------------------------------------------------------------------
// Expressions
// ------------------------------------------------------------------------------------------------

enum class Op : std::uint8_t {
  num, rparam, rindirect, var, sysvar, neg, lnot, bnot,
  add, sub, mul, div, idiv, mod, eq, ne, gt, lt, ge, le, land, lor, lxor, band, bor, bxor, func
};
enum class Fn : std::uint8_t {
  sin, cos, tan, asin, acos, atan2, sqrt, abs, pot, trunc, round, roundup, ln, exp, minval, maxval, bound
};

struct Node {
  Op op = Op::num;
  Fn fn = Fn::sin;
  std::uint16_t count = 0;  ///< children (operands, arguments, array indices)
  std::uint32_t first = 0;  ///< first child in Pool::kids
  std::uint32_t name = 0;   ///< into Pool::names (var, sysvar, func)
  int r = 0;                ///< R parameter number
  double num = 0;
  Span span;
  std::uint16_t height = 1;  ///< of the subtree (the evaluator's recursion depth)
};

struct Pool {
  std::vector<Node> nodes;
  std::vector<std::uint32_t> kids;
  std::vector<std::string> names;
};

struct FnInfo {
  std::string_view name;
  Fn fn;
  int args;
};
constexpr FnInfo kFunctions[] = {
    {"SIN", Fn::sin, 1},     {"COS", Fn::cos, 1},       {"TAN", Fn::tan, 1},         {"ASIN", Fn::asin, 1},
    {"ACOS", Fn::acos, 1},   {"ATAN2", Fn::atan2, 2},   {"SQRT", Fn::sqrt, 1},       {"ABS", Fn::abs, 1},
    {"POT", Fn::pot, 1},     {"TRUNC", Fn::trunc, 1},   {"ROUND", Fn::round, 1},     {"ROUNDUP", Fn::roundup, 1},
    {"LN", Fn::ln, 1},       {"EXP", Fn::exp, 1},       {"MINVAL", Fn::minval, 2},   {"MAXVAL", Fn::maxval, 2},
    {"BOUND", Fn::bound, 3},
};

/// Recursive-descent parser over [begin, end) of a line; spans are positions in the line.
/// Operator priority as the Sinumerik manual lists it (highest first): NOT B_NOT; * / DIV MOD;
/// + -; B_AND; B_XOR; B_OR; AND; XOR; OR; <<; == <> > < >= <= (comparisons lowest: bracket them).
class Parser {
 public:
  Parser(std::string_view raw, std::uint32_t begin, std::uint32_t end, Pool& p) : s_(raw), i_(begin), end_(end), p_(p) {}

  std::uint32_t expr() { return compare(); }

  void skip() {
    while (i_ < end_ && is_blank(s_[i_])) ++i_;
  }
  std::uint32_t pos() {
    skip();
    return i_;
  }
  void set_pos(std::uint32_t p) { i_ = p; }
  [[nodiscard]] std::uint32_t end() const { return end_; }
  bool at_end() { return pos() >= end_; }
  char peek() { return pos() < end_ ? s_[i_] : '\0'; }
  bool accept(char c) {
    if (peek() != c) return false;
    ++i_;
    return true;
  }
  bool accept2(char a, char b) {
    skip();
    if (i_ + 1 < end_ && s_[i_] == a && s_[i_ + 1] == b) {
      i_ += 2;
      return true;
    }
    return false;
  }
  std::string_view peek_ident() {
    skip();
    std::uint32_t j = i_;
    if (j < end_ && (is_alpha(s_[j]) || s_[j] == '_'))
      while (j < end_ && is_ident(s_[j])) ++j;
    return s_.substr(i_, j - i_);
  }
  bool accept_kw(std::string_view kw) {
    const std::string_view id = peek_ident();
    if (id.empty() || !iequals(id, kw)) return false;
    i_ += static_cast<std::uint32_t>(id.size());
    return true;
  }
  std::string ident() {
    const std::string_view id = peek_ident();
    i_ += static_cast<std::uint32_t>(id.size());
    return upper(id);
  }
  void expect(char c, std::string_view what) {
    if (!accept(c)) fail_here(fmt::format("expected '{}' {}", c, what));
  }
  [[noreturn]] void fail_here(const std::string& what) {
    const std::uint32_t b = pos();
    throw Fail{"PP-E702", {b, std::max(b + 1, std::min(end_, b + 1))},
               fmt::format("syntax error: {} (at '{}'); correct the statement", what,
                           b < end_ ? s_.substr(b, end_ - b) : std::string_view("end of statement"))};
  }
  void expect_end(std::string_view what) {
    if (!at_end()) fail_here(fmt::format("unexpected text after {}", what));
  }

 private:
  [[noreturn]] void too_deep(std::uint32_t at) const { throw Fail{"PP-E712", {at, at + 1}, too_deep_message()}; }
  std::uint32_t add(Node n) {
    int height = 0;
    for (std::uint32_t k = 0; k < n.count; ++k) height = std::max<int>(height, p_.nodes[p_.kids[n.first + k]].height);
    if (height + 1 > kMaxExpressionDepth) too_deep(n.span.begin);
    n.height = static_cast<std::uint16_t>(height + 1);
    p_.nodes.push_back(n);
    return static_cast<std::uint32_t>(p_.nodes.size() - 1);
  }
  std::uint32_t binary(Op op, std::uint32_t l, std::uint32_t r) {
    Node n;
    n.op = op;
    n.count = 2;
    n.first = static_cast<std::uint32_t>(p_.kids.size());
    n.span = {p_.nodes[l].span.begin, p_.nodes[r].span.end};
    p_.kids.push_back(l);
    p_.kids.push_back(r);
    return add(n);
  }
  std::uint32_t with_kids(Node n, const std::vector<std::uint32_t>& kids) {
    n.count = static_cast<std::uint16_t>(kids.size());
    n.first = static_cast<std::uint32_t>(p_.kids.size());
    p_.kids.insert(p_.kids.end(), kids.begin(), kids.end());
    return add(n);
  }

  std::uint32_t compare() {
    std::uint32_t l = level(0);
    for (;;) {
      Op op;
      const std::uint32_t at = pos();
      if (accept2('=', '=')) op = Op::eq;
      else if (accept2('<', '>')) op = Op::ne;
      else if (accept2('<', '<'))
        throw Fail{"PP-E709", {at, at + 2}, "string concatenation '<<' is not evaluated by the resolver; compute the value outside the program"};
      else if (accept2('>', '=')) op = Op::ge;
      else if (accept2('<', '=')) op = Op::le;
      else if (accept('>')) op = Op::gt;
      else if (accept('<')) op = Op::lt;
      else return l;
      l = binary(op, l, level(0));
    }
  }

  // Binary keyword levels, lowest first: OR, XOR, AND, B_OR, B_XOR, B_AND.
  std::uint32_t level(int k) {
    static constexpr std::string_view kw[] = {"OR", "XOR", "AND", "B_OR", "B_XOR", "B_AND"};
    static constexpr Op ops[] = {Op::lor, Op::lxor, Op::land, Op::bor, Op::bxor, Op::band};
    if (k == 6) return additive();
    std::uint32_t l = level(k + 1);
    while (accept_kw(kw[k])) l = binary(ops[k], l, level(k + 1));
    return l;
  }
  std::uint32_t additive() {
    std::uint32_t l = multiplicative();
    for (;;) {
      if (accept('+')) l = binary(Op::add, l, multiplicative());
      else if (accept('-')) l = binary(Op::sub, l, multiplicative());
      else return l;
    }
  }
  std::uint32_t multiplicative() {
    std::uint32_t l = unary();
    for (;;) {
      if (accept('*')) l = binary(Op::mul, l, unary());
      else if (accept('/')) l = binary(Op::div, l, unary());
      else if (accept_kw("DIV")) l = binary(Op::idiv, l, unary());
      else if (accept_kw("MOD")) l = binary(Op::mod, l, unary());
      else return l;
    }
  }
  std::uint32_t unary() {
    const std::uint32_t at = pos();
    const Nesting nest(depth_);
    if (nest.too_deep()) too_deep(at);
    Op op;
    if (accept('-')) op = Op::neg;
    else if (accept('+')) return unary();
    else if (accept_kw("NOT")) op = Op::lnot;
    else if (accept_kw("B_NOT")) op = Op::bnot;
    else return primary();
    const std::uint32_t a = unary();
    Node n;
    n.op = op;
    n.span = {at, p_.nodes[a].span.end};
    return with_kids(n, {a});
  }

  std::uint32_t number() {
    const std::uint32_t b = i_;
    std::uint32_t j = i_;
    while (j < end_ && (is_digit(s_[j]) || s_[j] == '.')) ++j;
    std::string text(s_.substr(b, j - b));
    // Sinumerik exponent: 1.5EX3, 2EX-4.
    if (j + 2 < end_ + 1 && j + 1 < end_ && upper(s_[j]) == 'E' && upper(s_[j + 1]) == 'X') {
      std::uint32_t k = j + 2;
      std::string ex;
      if (k < end_ && (s_[k] == '-' || s_[k] == '+')) ex += s_[k++];
      const std::uint32_t ds = k;
      while (k < end_ && is_digit(s_[k])) ex += s_[k++];
      if (k > ds) {
        text += 'e';
        text += ex;
        j = k;
      }
    }
    char* endp = nullptr;
    const double v = std::strtod(text.c_str(), &endp);
    if (text.empty() || endp != text.c_str() + text.size() || text == ".") {
      i_ = b;
      fail_here("malformed number");
    }
    if (!std::isfinite(v))
      throw Fail{"PP-E205", {b, j}, fmt::format("the number '{}' is out of range (beyond ±1.8e308); correct the value", s_.substr(b, std::min<std::uint32_t>(j - b, 40)))};
    if (j < end_ && (is_alpha(s_[j]) || s_[j] == '_')) {
      i_ = j;
      fail_here("a number is directly followed by a name");
    }
    i_ = j;
    Node n;
    n.op = Op::num;
    n.num = v;
    n.span = {b, j};
    return add(n);
  }

  /// `[e, e, …]` at i_ (after a name): the index expressions.
  std::vector<std::uint32_t> indices() {
    std::vector<std::uint32_t> idx;
    expect('[', "");
    do idx.push_back(expr());
    while (accept(','));
    expect(']', "closing the index");
    return idx;
  }

  std::uint32_t primary() {
    skip();
    if (i_ >= end_) fail_here("a value is missing");
    const std::uint32_t b = i_;
    const char c = s_[i_];
    if (is_digit(c) || c == '.') return number();
    if (c == '(') {
      ++i_;
      const std::uint32_t e = expr();
      expect(')', "closing the bracket");
      p_.nodes[e].span = {b, i_};
      return e;
    }
    if (c == '"')
      throw Fail{"PP-E709", {b, b + 1}, "string values are not evaluated by the resolver; use a numeric value"};
    if (c == '\'') {
      // 'H1F' hexadecimal, 'B101' binary constants.
      const auto close = s_.find('\'', b + 1);
      if (close == std::string_view::npos || close >= end_ || close < b + 3) fail_here("malformed constant");
      const char kind = upper(s_[b + 1]);
      const std::string digits(s_.substr(b + 2, close - b - 2));
      char* endp = nullptr;
      const long long v = std::strtoll(digits.c_str(), &endp, kind == 'H' ? 16 : 2);
      if ((kind != 'H' && kind != 'B') || endp != digits.c_str() + digits.size()) fail_here("malformed constant");
      i_ = static_cast<std::uint32_t>(close + 1);
      Node n;
      n.op = Op::num;
      n.num = static_cast<double>(v);
      n.span = {b, i_};
      return add(n);
    }
    if (c == '$') {
      std::uint32_t j = b + 1;
      while (j < end_ && is_ident(s_[j])) ++j;
      if (j < end_ && s_[j] == '[') {
        int depth = 0;
        for (; j < end_; ++j) {
          if (s_[j] == '[') ++depth;
          if (s_[j] == ']' && --depth == 0) break;
        }
        if (j >= end_) fail_here("'[' of a system variable is not closed");
        ++j;
      }
      std::string key;
      for (std::uint32_t k = b; k < j; ++k)
        if (!is_blank(s_[k])) key += upper(s_[k]);
      i_ = j;
      Node n;
      n.op = Op::sysvar;
      n.name = static_cast<std::uint32_t>(p_.names.size());
      p_.names.push_back(std::move(key));
      n.span = {b, j};
      return add(n);
    }
    if (!is_alpha(c) && c != '_') fail_here("a value is expected");
    const std::string name = ident();
    const std::uint32_t after = i_;
    if (peek() == '(') {
      ++i_;
      std::vector<std::uint32_t> args;
      if (!accept(')')) {
        do args.push_back(expr());
        while (accept(','));
        expect(')', "closing the argument list");
      }
      for (const FnInfo& f : kFunctions)
        if (f.name == name) {
          if (static_cast<int>(args.size()) != f.args)
            throw Fail{"PP-E702", {b, i_}, fmt::format("syntax error: {} takes {} argument(s), not {}; correct the call", name, f.args, args.size())};
          Node n;
          n.op = Op::func;
          n.fn = f.fn;
          n.span = {b, i_};
          return with_kids(n, args);
        }
      throw Fail{"PP-E709", {b, i_}, fmt::format("function {}(…) is not evaluated by the resolver; replace it by its value", name)};
    }
    i_ = after;
    if (name == "R" && peek() == '[') {
      const std::vector<std::uint32_t> idx = indices();
      if (idx.size() != 1) throw Fail{"PP-E702", {b, i_}, "syntax error: R[…] takes one index; write R[n]"};
      Node n;
      n.op = Op::rindirect;
      n.span = {b, i_};
      return with_kids(n, idx);
    }
    if (name.size() >= 2 && name[0] == 'R' && std::all_of(name.begin() + 1, name.end(), is_digit)) {
      const int r = std::atoi(name.c_str() + 1);
      if (r >= kRCount) throw Fail{"PP-E703", {b, after}, fmt::format("{} does not exist (R0 to R{}); use a lower number", name, kRCount - 1)};
      Node n;
      n.op = Op::rparam;
      n.r = r;
      n.span = {b, after};
      return add(n);
    }
    if (name == "TRUE" || name == "FALSE") {
      Node n;
      n.op = Op::num;
      n.num = name == "TRUE" ? 1 : 0;
      n.span = {b, after};
      return add(n);
    }
    std::vector<std::uint32_t> idx;
    if (peek() == '[') idx = indices();
    Node n;
    n.op = Op::var;
    n.name = static_cast<std::uint32_t>(p_.names.size());
    p_.names.push_back(name);
    n.span = {b, idx.empty() ? after : i_};
    return with_kids(n, idx);
  }

  std::string_view s_;
  std::uint32_t i_, end_;
  Pool& p_;
  int depth_ = 0;
};

// ------------------------------------------------------------------------------------------------
// Parsed lines
// ------------------------------------------------------------------------------------------------

enum class VType : std::uint8_t { real, integer, boolean, chr, string, axis, frame };

inline std::optional<VType> type_of(std::string_view t) {
  if (t == "REAL") return VType::real;
  if (t == "INT") return VType::integer;
  if (t == "BOOL") return VType::boolean;
  if (t == "CHAR") return VType::chr;
  if (t == "STRING") return VType::string;
  if (t == "AXIS") return VType::axis;
  if (t == "FRAME") return VType::frame;
  return std::nullopt;
}
inline bool numeric(VType t) { return t == VType::real || t == VType::integer || t == VType::boolean; }
inline std::string_view type_name(VType t) {
  switch (t) {
    case VType::real: return "REAL";
    case VType::integer: return "INT";
    case VType::boolean: return "BOOL";
    case VType::chr: return "CHAR";
    case VType::string: return "STRING";
    case VType::axis: return "AXIS";
    case VType::frame: return "FRAME";
  }
  return "?";
}

/// The left side of an assignment (or a FOR variable).
struct Target {
  enum Kind : std::uint8_t { rconst, rindirect, var, sysvar } kind = rconst;
  int r = 0;
  std::string name;                 ///< upper case
  std::vector<std::uint32_t> index; ///< R[…] index or array indices
  Span span;
};

struct Assign {
  Target target;
  std::uint32_t expr = 0;
  Span span;
};

struct WordSub {
  Span edit;     ///< the bytes replaced by the value
  char letter = 0;
  std::uint32_t expr = 0;
};

struct DeclVar {
  std::string name;
  Span span;
  std::vector<std::uint32_t> dims;
  std::vector<std::uint32_t> init;  ///< one (scalar or REP) or a list
  bool rep = false;
};
struct Decl {
  VType type = VType::real;
  std::vector<DeclVar> vars;
  Span span;
};

struct Param {
  std::string name;
  VType type = VType::real;
  bool by_ref = false;
  std::vector<std::uint32_t> dims;
};
struct ProcHeader {
  std::string name;
  std::vector<Param> params;
};

struct Call {
  enum Kind : std::uint8_t { lword, named, explicit_call } kind = named;
  std::string name;  ///< upper case: "L100", "PART1"
  Span span;         ///< deleted when the call is followed
  std::vector<std::optional<std::uint32_t>> args;  ///< empty argument: nullopt
  bool has_args = false;
};

enum class Ctl : std::uint8_t {
  none, if_block, if_goto, else_, endif, while_, endwhile, for_, endfor, repeat, until, loop, endloop, go, ret, case_
};
enum class GoKind : std::uint8_t { forward, backward, both, quiet };

struct Jump {
  GoKind kind = GoKind::forward;
  bool is_n = false;
  double n = 0;
  std::string label;
  Span span;
};

struct Item {
  enum Kind : std::uint8_t { assign, word, decl, setal, call } kind;
  std::uint32_t index;
};

struct Line {
  bool trivial = true;      ///< nothing to evaluate: emitted as written
  bool lex_failed = false;  ///< the lexer rejects the line: report through SourceFile::block
  bool lexed_ok = true;     ///< SourceFile::report may be used (no spurious lexer errors)
  std::optional<Fail> error;
  Pool pool;
  std::vector<Item> items;
  std::vector<Assign> assigns;
  std::vector<WordSub> subs;
  std::vector<Decl> decls;
  std::vector<Call> calls;
  std::vector<std::uint32_t> setal;  ///< SETAL argument expressions
  std::vector<Span> deletes;         ///< statements removed from the emitted line
  Ctl ctl = Ctl::none;
  Span ctl_span;
  std::uint32_t cond = 0;
  Jump jump;
  /// CASE (cond) OF value GOTOx target …: each value's expression and jump; DEFAULT's jump.
  std::vector<std::pair<std::uint32_t, Jump>> cases;
  std::optional<Jump> case_default;
  Target for_var;
  std::uint32_t for_from = 0, for_to = 0;
  std::string label;
  bool has_label = false;
  bool end_program = false;  ///< M30 / M2
  bool m17 = false;
  Span m17_span;
  bool has_proc = false;
  ProcHeader proc;
  bool has_p = false;        ///< P word: repeat count of a call on the line
  Span p_span;
  std::optional<std::uint32_t> p_expr;
  double p_value = 1;
  bool mcall = false;
  int others = 0;            ///< items left in the emitted line besides call candidates and P
  bool executable = false;   ///< anything but comments / % / blanks
};

/// Finds `kw` as a whole identifier at bracket depth 0 in [b, e); npos when absent.
inline std::uint32_t find_keyword(std::string_view s, std::uint32_t b, std::uint32_t e, std::initializer_list<std::string_view> kws,
                           std::string_view* which = nullptr) {
  int depth = 0;
  bool str = false;
  for (std::uint32_t j = b; j < e; ++j) {
    const char c = s[j];
    if (c == '"') str = !str;
    if (str) continue;
    if (c == '(' || c == '[') ++depth;
    if (c == ')' || c == ']') --depth;
    if (depth == 0 && (is_alpha(c) || c == '_') && (j == b || !(is_ident(s[j - 1]) || s[j - 1] == '$'))) {
      std::uint32_t k = j;
      while (k < e && is_ident(s[k])) ++k;
      const std::string_view id = s.substr(j, k - j);
      for (std::string_view kw : kws)
        if (iequals(id, kw)) {
          if (which) *which = kw;
          return j;
        }
      j = k - 1;
    }
  }
  return static_cast<std::uint32_t>(-1);
}

/// End of a Siemens value after '=' (whitespace or ';' at depth 0).
inline std::uint32_t value_end(std::string_view s, std::uint32_t v) {
  int depth = 0;
  bool str = false;
  std::uint32_t e = v;
  for (; e < s.size(); ++e) {
    const char c = s[e];
    if (c == '"') str = !str;
    if (str) continue;
    if (c == '(' || c == '[') ++depth;
    if (c == ')' || c == ']') --depth;
    if (depth <= 0 && (is_blank(c) || c == ';')) break;
  }
  return e;
}

/// Names the lexer reports as calls or keywords that are controller functions, never subprograms.
inline bool builtin_name(std::string_view n) { return siemens_builtin_name(n); }



/// Multi-letter addresses written with '=' that the lexer reports as assignments.
inline bool address_name(const std::string& n) {
  static const std::unordered_set<std::string> kNames = {
      "TURN", "ADIS", "ADISPOS", "OFFN", "FAD", "CHF", "CHR", "RND", "RNDM", "ANG", "SPOS", "SPOSA", "DISR", "DISRP",
      "DISCL", "FR", "FRC", "FRCM", "FB", "PL", "SPN", "SPP", "MEAS", "MEAW", "STOPRE", "PM", "PR", "SD", "PO",
      "PW", "SR", "SRA", "ST", "STA", "CFTCP", "DL", "DISC", "NR", "QU", "LF", "DITE", "DITS", "ALF", "SPI", "GP"};
  return kNames.count(n) != 0;
}

/// A statement the block lexer cannot read as written, found by scan_statements.
struct Masked {
  enum Kind : std::uint8_t { assign, call, word } kind = assign;
  Span span;   ///< the whole statement
  Span name;   ///< target / address
  Span value;  ///< after '='
};

inline bool op_keyword(std::string_view id, bool unary_too) {
  for (std::string_view k : {"DIV", "MOD", "AND", "OR", "XOR", "B_AND", "B_OR", "B_XOR"})
    if (iequals(id, k)) return true;
  return unary_too && (iequals(id, "NOT") || iequals(id, "B_NOT"));
}

/// End of a value after '=' at `v`, continued across blanks next to an operator
/// (`R1=R2 + 3`, `R1=7 DIV 2`): the block lexer stops at the first blank.
inline std::uint32_t extended_end(std::string_view raw, std::uint32_t v) {
  const auto n = static_cast<std::uint32_t>(raw.size());
  std::uint32_t e = value_end(raw, v);
  for (;;) {
    std::uint32_t q = e;
    while (q < n && is_blank(raw[q])) ++q;
    if (q >= n || raw[q] == ';' || q == e) return e;
    const char prev = raw[e - 1];
    bool prev_op = std::string_view("+-*/<>=(,").find(prev) != std::string_view::npos;
    if (!prev_op && is_ident(prev)) {
      std::uint32_t k = e;
      while (k > v && is_ident(raw[k - 1])) --k;
      prev_op = op_keyword(raw.substr(k, e - k), true);
    }
    bool next_op = std::string_view("+-*/<>=").find(raw[q]) != std::string_view::npos;
    if (!next_op && (is_alpha(raw[q]) || raw[q] == '_')) {
      std::uint32_t k = q;
      while (k < n && is_ident(raw[k])) ++k;
      next_op = op_keyword(raw.substr(q, k - q), false) && k < n && (is_blank(raw[k]) || raw[k] == '(');
    }
    if (!prev_op && !next_op) return e;
    e = std::max(value_end(raw, q), q + 1);
  }
}

inline bool two_letter_address(std::string_view l) {
  for (std::string_view k : {"CR", "AP", "RP", "AR", "CT", "IP", "TU", "SF", "FA", "OS"})
    if (iequals(l, k)) return true;
  return false;
}

/// Finds `NAME[…]=…`, `R[…]=…`, `$VAR=…`, `CALL "NAME"` and assignments or address values with
/// blanks inside their expression: the statements to mask before lexing.
inline void scan_statements(std::string_view raw, std::vector<Masked>& out) {
  static constexpr std::string_view kRestOfLine[] = {"IF", "WHILE", "UNTIL", "FOR", "DEF", "PROC", "GOTOF", "GOTOB",
                                                     "GOTO", "GOTOC", "CASE", "EXTERN", "DEFINE", "ELSE", "ENDIF"};
  const auto n = static_cast<std::uint32_t>(raw.size());
  std::uint32_t j = 0;
  while (j < n) {
    while (j < n && is_blank(raw[j])) ++j;
    if (j >= n || raw[j] == ';') return;
    const std::uint32_t start = j;
    std::uint32_t k = j;
    if (raw[k] == '$') ++k;
    const std::uint32_t letters_begin = k;
    while (k < n && (is_alpha(raw[k]) || raw[k] == '_')) ++k;
    const std::uint32_t letters_end = k;
    while (k < n && is_ident(raw[k])) ++k;
    const std::string_view id = raw.substr(start, k - start);
    for (std::string_view kw : kRestOfLine)
      if (iequals(id, kw)) return;
    if (iequals(id, "CALL")) {
      std::uint32_t q = k;
      while (q < n && is_blank(raw[q])) ++q;
      if (q < n && raw[q] == '"') {
        const auto close = raw.find('"', q + 1);
        if (close != std::string_view::npos) {
          out.push_back({Masked::call, {start, static_cast<std::uint32_t>(close + 1)}, {start, k}, {}});
          j = static_cast<std::uint32_t>(close + 1);
          continue;
        }
      }
    }
    if (k > letters_begin) {
      std::uint32_t q = k;
      const bool bracket = q < n && raw[q] == '[';
      if (bracket) {
        int depth = 0;
        for (; q < n; ++q) {
          if (raw[q] == '[') ++depth;
          if (raw[q] == ']' && --depth == 0) break;
        }
        if (q < n) ++q;
      }
      const std::uint32_t name_end = q;
      while (q < n && is_blank(raw[q])) ++q;
      if (q < n && raw[q] == '=' && !(q + 1 < n && raw[q + 1] == '=')) {
        std::uint32_t v = q + 1;
        while (v < n && is_blank(raw[v])) ++v;
        const std::uint32_t e = extended_end(raw, v);
        const std::string_view letters = raw.substr(letters_begin, letters_end - letters_begin);
        const bool sys = raw[start] == '$';
        const bool address = !sys && !bracket &&
                             ((letters.size() == 1 && upper(letters[0]) != 'R') || two_letter_address(letters));
        if (sys || bracket || e != value_end(raw, v)) {
          out.push_back({address ? Masked::word : Masked::assign, {start, e}, {start, name_end}, {v, e}});
        }
        j = std::max(e, j + 1);
        continue;
      }
    }
    j = std::max(value_end(raw, j), j + 1);
  }
}

}  // namespace postproc::gcode::resolver::siemens_parse
