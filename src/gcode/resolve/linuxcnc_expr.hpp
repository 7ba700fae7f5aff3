#pragma once
// rs274ngc expressions for the LinuxCNC resolver (linuxcnc.cpp): parsed once per line into a
// small stack program. Internal to src/gcode/resolve.
#include <algorithm>
#include <cctype>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>

#include "src/gcode/number_text.hpp"
#include "src/gcode/resolve/support.hpp"

namespace postproc::gcode::resolver::lcnc {

// Expressions
enum class Op : std::uint8_t {
  num, param, param_ind, named, add, sub, mul, div, mod, pow, eq, ne, gt, ge, lt, le, and_, or_, xor_,
  neg, abs, acos, asin, atan2, cos, exp, fix, fup, round, ln, sin, sqrt, tan, exists
};

struct Instr {
  Op op;
  double value = 0;  // num: the number; param: its index; named: name id
};

struct Code {
  std::vector<Instr> ops;
};

/// An error while evaluating: the diagnostic code and what happened.
struct EvalError {
  std::string code, what;
};

/// Applies a function or binary operator (op >= Op::add, not neg/exists) to the evaluation stack
/// `st` holding `sp` values, as rs274ngc does; throws EvalError on arithmetic LinuxCNC refuses.
void apply_operator(Op op, double* st, int& sp);

struct ParseError {
  std::size_t pos;
  std::string what;
  std::string code = "PP-E702";
};

/// Named parameters, interned: id → name (lower case, without #< >).
class Names {
 public:
  int id(const std::string& name) {
    auto [it, fresh] = ids_.emplace(name, static_cast<int>(names_.size()));
    if (fresh) names_.push_back(name);
    return it->second;
  }
  [[nodiscard]] const std::string& name(int id) const { return names_[static_cast<std::size_t>(id)]; }

 private:
  std::unordered_map<std::string, int> ids_;
  std::vector<std::string> names_;
};

class Parser {
 public:
  Parser(std::string_view s, Names& names) : s_(s), names_(names) {}
  /// A real value: number, parameter, [expression], function, or a signed real value.
  void real_value(Code& c) {
    const Nesting nest(depth_);
    if (nest.too_deep()) throw ParseError{pos_, too_deep_message(), "PP-E712"};
    skip();
    if (pos_ >= s_.size()) fail("a value is missing");
    const char ch = s_[pos_];
    if (ch == '-' || ch == '+') {
      ++pos_;
      real_value(c);
      if (ch == '-') c.ops.push_back({Op::neg});
      return;
    }
    if (ch == '[') {
      ++pos_;
      expression(c);
      expect(']');
      return;
    }
    if (ch == '#') {
      parameter(c);
      return;
    }
    if (std::isdigit(static_cast<unsigned char>(ch)) || ch == '.') {
      c.ops.push_back({Op::num, number()});
      return;
    }
    if (std::isalpha(static_cast<unsigned char>(ch))) {
      function(c);
      return;
    }
    fail(fmt::format("'{}' cannot start a value", ch));
  }
  /// The parameter reference at the cursor (#n, ##n, #[expr], #<name>), as an assignment target:
  /// returns the named id or pushes the index code; `named` tells which.
  bool target(Code& index, int& named_id) {
    skip();
    expect('#');
    skip();
    if (pos_ < s_.size() && s_[pos_] == '<') {
      named_id = name();
      return true;
    }
    real_value(index);
    return false;
  }
  void end() {
    skip();
    if (pos_ < s_.size()) fail(fmt::format("unexpected '{}'", s_.substr(pos_)));
  }
  [[nodiscard]] bool at_end() {
    skip();
    return pos_ >= s_.size();
  }
  [[nodiscard]] std::size_t pos() const { return pos_; }
  void skip() {
    while (pos_ < s_.size() && (s_[pos_] == ' ' || s_[pos_] == '\t')) ++pos_;
  }
  void expect(char c) {
    skip();
    if (pos_ >= s_.size() || s_[pos_] != c) fail(fmt::format("'{}' expected", c));
    ++pos_;
  }
  [[noreturn]] void fail(std::string what) const { throw ParseError{pos_, std::move(what)}; }

 private:
  // Binary operators by precedence (rs274ngc): ** > * / MOD > + - > EQ NE GT GE LT LE > AND OR XOR.
  int binary(Op& op) {
    skip();
    if (pos_ >= s_.size()) return 0;
    const std::string_view r = s_.substr(pos_);
    auto word = [&](std::string_view w) {
      if (r.size() < w.size()) return false;
      for (std::size_t i = 0; i < w.size(); ++i)
        if (std::toupper(static_cast<unsigned char>(r[i])) != w[i]) return false;
      return true;
    };
    struct B { std::string_view text; Op op; int prec; };
    static constexpr B table[] = {{"**", Op::pow, 5}, {"*", Op::mul, 4},  {"/", Op::div, 4},  {"MOD", Op::mod, 4},
                                  {"+", Op::add, 3},  {"-", Op::sub, 3},  {"EQ", Op::eq, 2},  {"NE", Op::ne, 2},
                                  {"GT", Op::gt, 2},  {"GE", Op::ge, 2},  {"LT", Op::lt, 2},  {"LE", Op::le, 2},
                                  {"AND", Op::and_, 1}, {"OR", Op::or_, 1}, {"XOR", Op::xor_, 1}};
    for (const B& b : table)
      if (word(b.text)) {
        op = b.op;
        len_ = b.text.size();
        return b.prec;
      }
    return 0;
  }
  void expression(Code& c, int min_prec = 1) {
    real_value(c);
    for (;;) {
      Op op{};
      const int prec = binary(op);
      if (prec < min_prec || prec == 0) return;
      pos_ += len_;
      // ** is evaluated left to right in rs274ngc as well.
      expression(c, prec + 1);
      c.ops.push_back({op});
    }
  }
  /// The characters at the cursor that `part` accepts, spaces between them dropped (rs274ngc drops
  /// every space of a line before reading it: "1 0 . 5" is 10.5, "C O S" is COS).
  template <class Part>
  std::string spaced(Part part) {
    std::string t;
    while (pos_ < s_.size()) {
      std::size_t k = pos_;
      while (!t.empty() && k < s_.size() && (s_[k] == ' ' || s_[k] == '\t')) ++k;
      if (k >= s_.size() || !part(s_[k])) break;
      t += s_[k];
      pos_ = k + 1;
    }
    return t;
  }
  double number() {
    const std::size_t b = pos_;
    const std::string digits =
        spaced([](char ch) { return std::isdigit(static_cast<unsigned char>(ch)) || ch == '.'; });
    const std::string_view t = digits;
    if (t.empty()) return 0;
    double v = 0;
    if (!parse_number(t, v)) fail(fmt::format("'{}' is not a number", t));
    if (!std::isfinite(v))
      throw ParseError{b, fmt::format("the number '{}' is out of range (beyond ±1.8e308)", t.substr(0, 40)), "PP-E205"};
    return v;
  }
  int name() {
    expect('<');
    const std::size_t b = pos_;
    const std::size_t e = s_.find('>', pos_);
    if (e == std::string_view::npos) fail("'>' expected after the parameter name");
    std::string n;
    for (char ch : s_.substr(b, e - b))
      if (ch != ' ' && ch != '\t') n += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    if (n.empty()) fail("empty parameter name");
    pos_ = e + 1;
    return names_.id(n);
  }
  void parameter(Code& c) {
    expect('#');
    skip();
    if (pos_ < s_.size() && s_[pos_] == '<') {
      c.ops.push_back({Op::named, static_cast<double>(name())});
      return;
    }
    if (pos_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[pos_]))) {
      const double n = number();
      c.ops.push_back({Op::param, n});
      return;
    }
    real_value(c);  // ##1, #[expr]
    c.ops.push_back({Op::param_ind});
  }
  void function(Code& c) {
    const std::size_t b = pos_;
    std::string f = spaced([](char ch) { return std::isalpha(static_cast<unsigned char>(ch)) != 0; });
    for (char& ch : f) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    static const std::map<std::string, Op> unary = {
        {"ABS", Op::abs}, {"ACOS", Op::acos}, {"ASIN", Op::asin}, {"COS", Op::cos}, {"EXP", Op::exp},
        {"FIX", Op::fix}, {"FUP", Op::fup},   {"ROUND", Op::round}, {"LN", Op::ln}, {"SIN", Op::sin},
        {"SQRT", Op::sqrt}, {"TAN", Op::tan}};
    if (f == "ATAN") {
      expect('[');
      expression(c);
      expect(']');
      expect('/');
      expect('[');
      expression(c);
      expect(']');
      c.ops.push_back({Op::atan2});
      return;
    }
    if (f == "EXISTS") {
      expect('[');
      skip();
      expect('#');
      skip();
      c.ops.push_back({Op::exists, static_cast<double>(name())});
      expect(']');
      return;
    }
    const auto it = unary.find(f);
    if (it == unary.end()) {
      pos_ = b;
      fail(fmt::format("unknown function or operator '{}'", f));
    }
    expect('[');
    expression(c);
    expect(']');
    c.ops.push_back({it->second});
  }

  std::string_view s_;
  Names& names_;
  std::size_t pos_ = 0;
  std::size_t len_ = 0;
  int depth_ = 0;
};

}  // namespace postproc::gcode::resolver::lcnc
