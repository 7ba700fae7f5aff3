// Heidenhain Klartext resolver (resolve.hpp): Q parameters, FN functions and formulas, labels,
// program-section repeats, subprograms and program calls, resolved into the literal program the
// TNC executes (TNC 640 User's Manual "Programming: subprograms and program section repeats",
// "Programming: Q parameters").
//
// - Q, QL and QR parameters are one value each (QS strings are skipped). A parameter the program
//   reads before it sets it holds a value from an earlier run, a cycle or the control (Q100–Q199,
//   FN 18 SYSREAD, FN 28 TABREAD): refused at the read (PP-E701) unless given with --set.
// - FN 0–8, FN 13 and formulas `Q1 = …` (+ − * / ^, parentheses, SIN COS TAN ASIN ACOS ATAN in
//   degrees, SQRT SQ ABS INT FRAC SGN NEG LN LOG EXP, PI) are evaluated.
// - FN 9–12 (`IF a EQU|NE|GT|LT b GOTO LBL n`) jump; FN 14 stops the program with an error (PP-E710).
// - `CALL LBL n` runs the section from LBL n to LBL 0 and returns; `CALL LBL n REP k` jumps back
//   to an earlier LBL n k times (a program section repeat) and then goes on after the call.
// - `CALL PGM name` runs name[.h] from the program's folder or --subprogram-dir and returns at its
//   END PGM; Q parameters are shared.
// - M2 / M30 end the program; lines after them run only when called.
// - Lines of a block continued with `~` (cycle definitions) are written as they are; their
//   Q assignments (the cycle's parameters) are executed.
#include <cmath>
#include <functional>
#include <tuple>
#include <map>
#include <numbers>
#include <optional>
#include <set>

#include <fmt/format.h>

#include "src/gcode/klartext.hpp"
#include "src/gcode/resolve/support.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode::resolver {
namespace {

using klartext::Verb;

struct Failure {
  std::string code, message;
  Span span;
};
struct Stop {};

constexpr double kDeg = std::numbers::pi / 180.0;

/// Recursive-descent evaluation of a Klartext formula or FN operand text.
class Expr {
 public:
  Expr(std::string_view s, std::uint32_t offset, const std::function<double(std::string_view, Span)>& read)
      : s_(s), off_(offset), read_(read) {}

  double full() {
    const double v = sum();
    blanks();
    if (p_ < s_.size()) fail("unexpected text in the formula");
    return v;
  }
  double sum() {
    double v = product();
    while (true) {
      blanks();
      if (p_ < s_.size() && (s_[p_] == '+' || s_[p_] == '-')) {
        const char op = s_[p_++];
        const double r = product();
        v = op == '+' ? v + r : v - r;
      } else if (word("LEN")) {
        const double r = product();
        v = std::hypot(v, r);
      } else if (word("ANG")) {
        const double r = product();
        v = std::atan2(r, v) / kDeg;
      } else {
        return v;
      }
    }
  }
  double product() {
    double v = power();
    while (true) {
      blanks();
      if (p_ < s_.size() && (s_[p_] == '*' || s_[p_] == '/' || s_[p_] == '%')) {
        const char op = s_[p_++];
        const double r = power();
        if (op == '*') v *= r;
        else if (r == 0) fail("division by zero");
        else v = op == '/' ? v / r : std::fmod(v, r);
      } else if (word("DIV")) {
        const double r = power();
        if (r == 0) fail("division by zero");
        v /= r;
      } else {
        return v;
      }
    }
  }
  double power() {
    const double b = unary();
    blanks();
    if (p_ < s_.size() && s_[p_] == '^') {
      ++p_;
      const double e = power();
      const double v = std::pow(b, e);
      if (!std::isfinite(v)) fail("the power is not a finite number");
      return v;
    }
    return b;
  }
  double unary() {
    Nesting n(depth_);
    if (n.too_deep()) fail(too_deep_message(), "PP-E712");
    blanks();
    if (p_ >= s_.size()) fail("an operand is missing");
    if (s_[p_] == '+') return ++p_, unary();
    if (s_[p_] == '-') return ++p_, -unary();
    struct Fn {
      std::string_view name;
      double (*f)(double);
    };
    static const Fn kFns[] = {
        {"ASIN", [](double x) { return std::asin(x) / kDeg; }}, {"ACOS", [](double x) { return std::acos(x) / kDeg; }},
        {"ATAN", [](double x) { return std::atan(x) / kDeg; }}, {"SIN", [](double x) { return std::sin(x * kDeg); }},
        {"COS", [](double x) { return std::cos(x * kDeg); }},   {"TAN", [](double x) { return std::tan(x * kDeg); }},
        {"SQRT", [](double x) { return std::sqrt(x); }},        {"SQ", [](double x) { return x * x; }},
        {"ABS", [](double x) { return std::abs(x); }},          {"INT", [](double x) { return std::trunc(x); }},
        {"FRAC", [](double x) { return x - std::trunc(x); }},
        {"SGN", [](double x) { return x > 0 ? 1.0 : x < 0 ? -1.0 : 0.0; }},
        {"NEG", [](double x) { return -x; }},                   {"LN", [](double x) { return std::log(x); }},
        {"LOG", [](double x) { return std::log10(x); }},        {"EXP", [](double x) { return std::exp(x); }},
    };
    for (const Fn& f : kFns)
      if (word(f.name)) {
        const double v = f.f(unary());
        if (!std::isfinite(v)) fail(fmt::format("{} gives no finite value here", f.name), "PP-E707");
        return v;
      }
    if (word("PI")) return std::numbers::pi;
    if (s_[p_] == '(') {
      ++p_;
      const double v = sum();
      blanks();
      if (p_ >= s_.size() || s_[p_] != ')') fail("')' is missing");
      ++p_;
      return v;
    }
    if (s_[p_] == 'Q' || s_[p_] == 'q') {
      const std::size_t b = p_;
      ++p_;
      if (p_ < s_.size() && (text::upper(s_[p_]) == 'L' || text::upper(s_[p_]) == 'R')) ++p_;
      const std::size_t digits = p_;
      while (p_ < s_.size() && s_[p_] >= '0' && s_[p_] <= '9') ++p_;
      if (p_ == digits) fail("a Q parameter needs its number");
      return read_(s_.substr(b, p_ - b), span(b, p_));
    }
    const std::size_t b = p_;
    while (p_ < s_.size() && ((s_[p_] >= '0' && s_[p_] <= '9') || s_[p_] == '.' || s_[p_] == ',')) ++p_;
    double v = 0;
    if (p_ == b || !klartext::parse_number(s_.substr(b, p_ - b), v)) {
      p_ = b;
      fail("a number, a Q parameter, a function or '(' is expected");
    }
    return v;
  }

  [[noreturn]] void fail(std::string msg, std::string code = "PP-E702") const {
    throw Failure{std::move(code), std::move(msg), span(p_, std::min(s_.size(), p_ + 1))};
  }

 private:
  Span span(std::size_t a, std::size_t b) const {
    return {static_cast<std::uint32_t>(off_ + a), static_cast<std::uint32_t>(off_ + std::max(b, a + 1))};
  }
  void blanks() {
    while (p_ < s_.size() && (s_[p_] == ' ' || s_[p_] == '\t')) ++p_;
  }
  bool word(std::string_view w) {
    blanks();
    if (s_.size() - p_ < w.size() || !text::iequals(s_.substr(p_, w.size()), w)) return false;
    const std::size_t e = p_ + w.size();
    if (e < s_.size() && std::isalpha(static_cast<unsigned char>(s_[e]))) return false;
    p_ = e;
    return true;
  }

  std::string_view s_;
  std::uint32_t off_;
  const std::function<double(std::string_view, Span)>& read_;
  std::size_t p_ = 0;
  int depth_ = 0;
};

std::string upper_name(std::string_view n) {
  std::string u = text::upper(n);
  if (u.size() >= 2 && (u.front() == '"' || u.front() == '\'')) u = u.substr(1, u.size() - 2);
  return u;
}

/// A value as a Klartext word writes it: no exponent, up to 10 decimals, no trailing zeros.
std::string klartext_value(double v, bool sign) {
  std::string s = fmt::format("{:.10f}", v);
  while (!s.empty() && s.back() == '0') s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  if (s == "-0") s = "0";
  if (sign && s.front() != '-') s.insert(s.begin(), '+');
  return s;
}

class Runner {
 public:
  Runner(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r)
      : files_(files), out_(out), opt_(opt), sink_(sink), r_(r), guard_(opt),
        dialect_(make_dialect(DialectId::heidenhain)) {}

  void run() {
    file_ = &files_.main();
    pc_ = 0;
    try {
      while (step()) {
      }
    } catch (const Stop&) {
    }
  }

 private:
  struct Frame {
    SourceFile* file;
    std::size_t ret;
    bool program;  ///< CALL PGM (returns at END PGM) or CALL LBL (returns at LBL 0)
  };

  void report(Span span, Severity sev, std::string_view code, std::string message) {
    if (out_.depth() > 0) message += fmt::format(" ({})", out_.where());
    file_->report(pc_, span, sev, code, std::move(message));
  }
  [[noreturn]] void stop(const Failure& f) {
    Span s = f.span;
    if (s.end <= s.begin) s.end = s.begin + 1;
    report(s, Severity::error, f.code, f.message);
    throw Stop{};
  }

  bool readable(std::string_view name) const {
    const std::string key = upper_name(name);
    return q_.count(key) != 0 || opt_.set.count(key) != 0;
  }

  double read(std::string_view name, Span at) {
    const std::string key = upper_name(name);
    if (auto it = q_.find(key); it != q_.end()) return it->second;
    if (auto it = opt_.set.find(key); it != opt_.set.end()) {
      r_.used_settings[key] = it->second;
      return it->second;
    }
    const bool control = key.size() > 1 && key[1] >= '0' && key[1] <= '9' && std::stoi(key.substr(1)) >= 100 &&
                         std::stoi(key.substr(1)) < 200;
    throw Failure{"PP-E701",
                  fmt::format("{} is read here but the program does not set it before: {}; give its value with "
                              "--set '{}=…'",
                              key,
                              unknown_.count(key) ? "it holds a value the control reads while the program runs"
                              : control ? "Q100–Q199 are set by the control (tool data, cycle results)"
                                        : "it holds whatever an earlier program or cycle left",
                              key),
                  at};
  }
  void write(std::string_view name, double v) {
    const std::string key = upper_name(name);
    auto [it, fresh] = q_.try_emplace(key, v);
    if (fresh || it->second != v) guard_.changed();
    it->second = v;
    unknown_.erase(key);
  }
  void forget(std::string_view name) {
    const std::string key = upper_name(name);
    q_.erase(key);
    unknown_.insert(key);
    guard_.changed();
  }

  double eval(std::string_view text, std::uint32_t offset) {
    const std::function<double(std::string_view, Span)> rd = [this](std::string_view n, Span s) { return read(n, s); };
    Expr e(text, offset, rd);
    return e.full();
  }

  std::optional<std::size_t> label(SourceFile& f, const std::string& name) {
    auto& idx = labels_[f.index()];
    if (!idx) {
      idx = std::make_unique<std::map<std::string, std::size_t>>();
      for (std::size_t i = 0; i < f.lines(); ++i) {
        const std::string_view l = f.raw(i);
        if (l.find("LBL") == std::string_view::npos && l.find("lbl") == std::string_view::npos) continue;
        // Lexed into a block of its own: f.block() would reuse the block the caller still reads.
        Block b;
        b.raw = l;
        b.line = i + 1;
        DiagnosticSink quiet(0);
        (void)lex_block(dialect_, b, LexContext{"", &quiet});
        if (klartext::verb_of(b) != Verb::lbl || b.tokens.size() < 2) continue;
        idx->try_emplace(upper_name(klartext::token_text(b, 1)), i);
      }
    }
    if (auto it = idx->find(name); it != idx->end()) return it->second;
    return std::nullopt;
  }

  void emit(std::span<const Edit> edits) {
    if (!out_.emit(*file_, pc_, edits)) {
      report({0, static_cast<std::uint32_t>(std::max<std::size_t>(1, file_->raw(pc_).size()))}, Severity::error,
             "PP-E705", fmt::format("the program executes {}: a loop that does not end?", runaway_limits(opt_)));
      throw Stop{};
    }
  }

  void jump_back(std::size_t target, Span at) {
    if (!guard_.back_jump(file_->index(), out_.depth(), target)) {
      report(at, Severity::error, "PP-E705", LoopGuard::no_progress_message());
      throw Stop{};
    }
    pc_ = target;
  }

  /// Returns false when the program has ended.
  bool step() {
    if (pc_ >= file_->lines()) return leave_file();
    if (!guard_.step(out_.emitted())) {
      report({0, 1}, Severity::error, "PP-E705", guard_.silent_message());
      throw Stop{};
    }
    const Block& b = file_->block(pc_);
    const bool ok = file_->lexed_ok(pc_);
    if (continuation_) {
      continuation_ = continued(b);
      try {
        if (klartext::verb_of(b) == Verb::q_assign) {
          assign(b);
          emit(parameter_value(b));
        } else {
          emit({});
        }
      } catch (const Failure& f) {
        stop(f);
      }
      ++pc_;
      return true;
    }
    if (!ok) {  // reported by the lexer; the interpreter reports nothing more
      emit({});
      ++pc_;
      return true;
    }
    continuation_ = continued(b);
    const bool params_open = cycle_open_;
    cycle_open_ = klartext::verb_of(b) == Verb::cycl_def || (params_open && klartext::verb_of(b) == Verb::q_assign);
    try {
      switch (klartext::verb_of(b)) {
        case Verb::end_pgm:
          if (!stack_.empty()) return leave_file();
          emit({});
          return false;
        case Verb::lbl:
          if (b.tokens.size() >= 2 && upper_name(klartext::token_text(b, 1)) == "0" && !stack_.empty() &&
              !stack_.back().program) {
            ret();
            return true;
          }
          ++pc_;
          return true;
        case Verb::q_assign:
          assign(b);
          // A parameter line of the cycle just defined is part of its definition: written (with the
          // value of a formula) so that the interpreter sees the cycle's parameters.
          if (params_open) emit(parameter_value(b));
          ++pc_;
          return true;
        case Verb::fn: return fn(b);
        case Verb::call_lbl: return call_lbl(b);
        case Verb::call_pgm: return call_pgm(b);
        default: break;
      }
      std::vector<Edit> edits;
      for (const Word& w : b.words) {
        if (w.kind != ValueKind::parameter) continue;
        const std::string_view v = b.text(w.value);
        const bool neg = v.front() == '-';
        const bool sign = v.front() == '+' || v.front() == '-';
        const std::string_view q = sign ? v.substr(1) : v;
        // A word whose parameter the program does not set (Q120–Q122 after PLANE … STAY: the rotary
        // angles the control computes from its kinematics; Q108 the tool radius) is passed on as
        // written: the interpreter leaves that coordinate unknown with a warning at the word. Only
        // this block depends on it; formulas, conditions and cycle parameters still refuse (read).
        if (!readable(q)) continue;
        double x = read(q, w.value);
        if (neg) x = -x;
        edits.push_back({w.value, klartext_value(x, sign)});
      }
      emit(edits);
      for (const Word& w : b.words)
        if (w.letter == 'M' && w.name_len == 1 && (w.number == 2 || w.number == 30)) return false;
    } catch (const Failure& f) {
      stop(f);
    }
    ++pc_;
    return true;
  }

  static bool continued(const Block& b) { return klartext::continued(b.raw); }

  /// The edit that writes a parameter line's value as a literal when it is a formula.
  std::vector<Edit> parameter_value(const Block& b) {
    const Token& t = b.tokens.front();
    const std::string_view s = b.text(t.span);
    const std::size_t eq = s.find('=');
    std::string_view rhs = s.substr(eq + 1);
    std::size_t end = std::min(rhs.find(';'), rhs.find('~'));
    if (end == std::string_view::npos) end = rhs.size();
    std::size_t begin = 0;
    while (begin < end && (rhs[begin] == ' ' || rhs[begin] == '\t')) ++begin;
    while (end > begin && (rhs[end - 1] == ' ' || rhs[end - 1] == '\t')) --end;
    double v = 0;
    if (klartext::parse_number(rhs.substr(begin, end - begin), v)) return {};
    const auto at = static_cast<std::uint32_t>(t.span.begin + eq + 1);
    return {Edit{{at + static_cast<std::uint32_t>(begin), at + static_cast<std::uint32_t>(end)},
                 klartext_value(q_.at(upper_name(b.text(t.name))), true)}};
  }

  bool leave_file() {
    if (stack_.empty()) return false;
    ret();
    return true;
  }
  void ret() {
    const Frame f = stack_.back();
    stack_.pop_back();
    out_.pop_call();
    file_ = f.file;
    pc_ = f.ret;
    guard_.changed();
  }

  void assign(const Block& b) {
    // "Q5 = formula" (the statement token spans the whole text after the block number).
    const Token& t = b.tokens.front();
    const std::string_view s = b.text(t.span);
    const std::size_t eq = s.find('=');
    std::string_view rhs = s.substr(eq + 1);
    const std::size_t semi = rhs.find(';');
    if (semi != std::string_view::npos) rhs = rhs.substr(0, semi);
    if (const std::size_t tilde = rhs.find('~'); tilde != std::string_view::npos) rhs = rhs.substr(0, tilde);
    const std::string_view name = b.text(t.name);
    if (text::upper(name).starts_with("QS")) return;  // a string parameter: no value of ours
    const double v = eval(rhs, static_cast<std::uint32_t>(t.span.begin + eq + 1));
    write(name, v);
  }

  bool fn(const Block& b) {
    // "FN n: …": the assignment token holds everything after "FN".
    const Token& t = b.tokens.size() > 1 ? b.tokens[1] : b.tokens.front();
    const std::string_view s = b.text(t.span);
    const std::size_t colon = s.find(':');
    double n = -1;
    std::string_view num = s.substr(0, colon == std::string_view::npos ? 0 : colon);
    while (!num.empty() && (num.back() == ' ' || num.back() == '\t')) num.remove_suffix(1);
    if (colon == std::string_view::npos || !klartext::parse_number(num, n))
      throw Failure{"PP-E702", "FN needs its number and ':' (FN 0: Q1 = …)", t.span};
    const std::string_view body = s.substr(colon + 1);
    const auto at = static_cast<std::uint32_t>(t.span.begin + colon + 1);
    const int fn = static_cast<int>(n);
    switch (fn) {
      case 0: case 1: case 2: case 3: case 4: case 5: case 6: case 7: case 8: case 13: {
        // FN 5/6/7 write their function before the operand: "Q1 = SQRT Q2", "Q1 = SIN Q2".
        const std::size_t eq = body.find('=');
        std::string_view lhs = body.substr(0, eq == std::string_view::npos ? 0 : eq);
        while (!lhs.empty() && (lhs.front() == ' ')) lhs.remove_prefix(1);
        while (!lhs.empty() && (lhs.back() == ' ')) lhs.remove_suffix(1);
        if (eq == std::string_view::npos || lhs.empty())
          throw Failure{"PP-E702", fmt::format("FN {} needs 'Qn = …'", fn), t.span};
        std::string_view rhs = body.substr(eq + 1);
        if (const auto semi = rhs.find(';'); semi != std::string_view::npos) rhs = rhs.substr(0, semi);
        write(lhs, eval(rhs, static_cast<std::uint32_t>(at + eq + 1)));
        break;
      }
      case 9: case 10: case 11: case 12: return fn_jump(b, fn, body, at);
      case 14:
        throw Failure{"PP-E710", "FN 14 stops the program with an error message here (the control's own stop)", t.span};
      case 18: case 28: {  // SYSREAD / TABREAD: the parameter gets a value the control reads
        const std::size_t q = text::upper(body).find('Q');
        const std::size_t eq = body.find('=');
        if (q != std::string_view::npos && eq != std::string_view::npos && q < eq) {
          std::string_view name = body.substr(q, eq - q);
          while (!name.empty() && name.back() == ' ') name.remove_suffix(1);
          forget(name);
        }
        break;
      }
      case 15: case 16: case 19: case 20: case 29: case 37: case 38: break;  // output, PLC, waits: no motion, no value
      default:
        throw Failure{"PP-E709",
                      fmt::format("FN {} is not followed by this version (it writes machine data or reads tables)", fn),
                      t.span};
    }
    ++pc_;
    return true;
  }

  bool fn_jump(const Block& b, int fn, std::string_view body, std::uint32_t at) {
    // "IF a EQU b GOTO LBL n" (FN 9), NE (10), GT (11), LT (12).
    const std::string up = text::upper(body);
    const std::size_t i = up.find("IF");
    static constexpr std::string_view kOps[] = {"EQU", "NE", "GT", "LT"};
    const std::string_view op = kOps[fn - 9];
    std::size_t o = std::string::npos;
    for (std::size_t k = i + 2; k + op.size() <= up.size(); ++k)
      if (up.compare(k, op.size(), op) == 0 && up[k - 1] == ' ' &&
          (k + op.size() == up.size() || up[k + op.size()] == ' ')) {
        o = k;
        break;
      }
    const std::size_t g = up.find("GOTO");
    const std::size_t l = up.find("LBL", g == std::string::npos ? 0 : g);
    if (i == std::string::npos || o == std::string::npos || g == std::string::npos || l == std::string::npos || g < o)
      throw Failure{"PP-E702", fmt::format("FN {} needs 'IF a {} b GOTO LBL n'", fn, op), b.tokens.back().span};
    const double a = eval(body.substr(i + 2, o - i - 2), static_cast<std::uint32_t>(at + i + 2));
    const double c = eval(body.substr(o + op.size(), g - o - op.size()), static_cast<std::uint32_t>(at + o + op.size()));
    const bool jump = fn == 9 ? a == c : fn == 10 ? a != c : fn == 11 ? a > c : a < c;
    if (!jump) {
      ++pc_;
      return true;
    }
    std::string_view name = body.substr(l + 3);
    if (const auto semi = name.find(';'); semi != std::string_view::npos) name = name.substr(0, semi);
    while (!name.empty() && name.front() == ' ') name.remove_prefix(1);
    while (!name.empty() && name.back() == ' ') name.remove_suffix(1);
    const auto target = label(*file_, upper_name(name));
    if (!target) throw Failure{"PP-E704", fmt::format("label {} is not in this program", name), b.tokens.back().span};
    if (*target <= pc_) jump_back(*target + 1, b.tokens.back().span);
    else pc_ = *target + 1;
    return true;
  }

  bool call_lbl(const Block& b) {
    if (b.tokens.size() < 2) throw Failure{"PP-E702", "CALL LBL needs the label", b.tokens.front().span};
    const std::string name = upper_name(klartext::token_text(b, 1));
    const auto target = label(*file_, name);
    const Span at = b.tokens[1].span;
    if (!target) throw Failure{"PP-E704", fmt::format("LBL {} is not in this program", name), at};
    const int rep = klartext::find_keyword(b, "REP");
    double k = 0;
    if (rep >= 0) {
      if (static_cast<std::size_t>(rep) + 1 >= b.tokens.size() ||
          !klartext::parse_number(klartext::token_text(b, rep + 1).substr(
                                      0, klartext::token_text(b, rep + 1).find('/')),
                                  k))
        throw Failure{"PP-E702", "REP needs the number of repetitions", b.tokens[static_cast<std::size_t>(rep)].span};
    }
    if (rep >= 0 && k > 0) {
      if (*target >= pc_)
        throw Failure{"PP-E709",
                      "CALL LBL … REP to a label after the call is not followed by this version (a program section "
                      "repeat goes back to an earlier label)",
                      at};
      const auto key = std::make_tuple(file_->index(), out_.depth(), pc_);
      auto [it, fresh] = reps_.try_emplace(key, static_cast<long>(k));
      if (it->second > 0) {
        --it->second;
        guard_.changed();
        jump_back(*target + 1, at);
        return true;
      }
      reps_.erase(it);
      ++pc_;
      return true;
    }
    if (stack_.size() >= static_cast<std::size_t>(opt_.max_call_depth))
      throw Failure{"PP-E706", fmt::format("subprogram calls nest deeper than {}", opt_.max_call_depth), at};
    stack_.push_back({file_, pc_ + 1, false});
    out_.push_call({file_->name(), pc_ + 1, fmt::format("CALL LBL {}", name)});
    pc_ = *target + 1;
    guard_.changed();
    return true;
  }

  bool call_pgm(const Block& b) {
    // CALL PGM name | path\name.h
    const Span at = b.tokens.size() > 1 ? b.tokens[1].span : b.tokens.front().span;
    if (klartext::find_keyword(b, "SELECTED") >= 0 || b.tokens.size() < 2)
      throw Failure{"PP-E709", "the called program is not named in this block (SEL PGM)", at};
    std::string_view name = b.raw.substr(b.tokens[1].span.begin);
    if (const auto semi = name.find(';'); semi != std::string_view::npos) name = name.substr(0, semi);
    while (!name.empty() && (name.back() == ' ' || name.back() == '\t')) name.remove_suffix(1);
    if (!name.empty() && (name.front() == '"' || name.front() == '\'')) name = name.substr(1, name.size() - 2);
    const std::size_t slash = name.find_last_of("\\/:");
    std::string base(slash == std::string_view::npos ? name : name.substr(slash + 1));
    std::vector<std::string> candidates{base};
    if (!text::upper(base).ends_with(".H")) {
      candidates.push_back(base + ".h");
      candidates.push_back(base + ".H");
    }
    SourceFile* f = files_.find(candidates);
    if (f == nullptr)
      throw Failure{"PP-E704",
                    fmt::format("the called program '{}' is not found next to the program or in --subprogram-dir", base),
                    at};
    if (stack_.size() >= static_cast<std::size_t>(opt_.max_call_depth))
      throw Failure{"PP-E706", fmt::format("program calls nest deeper than {}", opt_.max_call_depth), at};
    stack_.push_back({file_, pc_ + 1, true});
    out_.push_call({file_->name(), pc_ + 1, fmt::format("CALL PGM {}", base)});
    file_ = f;
    pc_ = 0;
    guard_.changed();
    return true;
  }

  FileSet& files_;
  Emitter& out_;
  const ResolveOptions& opt_;
  DiagnosticSink& sink_;
  ResolvedProgram& r_;
  LoopGuard guard_;
  Dialect dialect_;
  SourceFile* file_ = nullptr;
  std::size_t pc_ = 0;
  bool continuation_ = false;
  bool cycle_open_ = false;  ///< the lines just read define a cycle (its Q parameters follow)
  std::vector<Frame> stack_;
  std::map<std::string, double> q_;
  std::set<std::string> unknown_;
  std::map<std::uint32_t, std::unique_ptr<std::map<std::string, std::size_t>>> labels_;
  std::map<std::tuple<std::uint32_t, std::size_t, std::size_t>, long> reps_;
};

}  // namespace

void resolve_heidenhain(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink,
                        ResolvedProgram& r) {
  Runner run(files, out, opt, sink, r);
  run.run();
}

bool klartext_needs(const Block& b) {
  switch (klartext::verb_of(b)) {
    case Verb::fn:
    case Verb::q_assign:
    case Verb::lbl:
    case Verb::call_lbl:
    case Verb::call_pgm: return true;
    default: break;
  }
  for (const Word& w : b.words)
    if (w.kind == ValueKind::parameter) return true;
  return false;
}

}  // namespace postproc::gcode::resolver
