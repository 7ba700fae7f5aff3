// Resolver for the fanuc dialect (see include/postproc/gcode/resolve.hpp): runs a Fanuc Macro B
// program as the control would and writes the literal program it executes.
//
// Model (Fanuc 0i/30i, default parameters):
// - #0 vacant; #1–#33 locals (one set per G65 level, the main program has its own); #100–#499
//   common, vacant at start (cleared at power-off; --set '#100=…' gives a start value);
//   #500–#999 retained common: a value the program did not assign is what the control kept from
//   earlier runs, so reading it needs --set (PP-E701); #1000 and up are system variables, read
//   only with --set (PP-E701). Writes: #3000 raises an alarm (PP-E710); #3001/#3002 (clocks),
//   #3003/#3004 (single-block / feed-hold suppression) and #3901/#3902 (part counts) are stored
//   and dropped (they do not change motion); any other system variable write is refused (PP-E709).
// - Vacant: 0 in arithmetic and GT/GE/LT/LE; EQ/NE against a vacant value test vacancy; `#2=#1`
//   copies vacancy; a word whose value is a bare vacant variable (`X#1`, `X-#1`, `X[#1]`) is
//   omitted from the block, as the control does.
// - Angles in degrees; ATAN (both forms) in 0…360, ASIN in 270…360 ∪ 0…90, ACOS in 0…180 (NAT=0);
//   ROUND rounds half away from zero, FIX truncates, FUP rounds away from zero; MOD rounds both
//   operands to integers; AND/OR/XOR are bitwise on integers (logical on conditions); ADP returns
//   its argument (G65 argument values are taken as written, not in input increments).
// - G65 arguments: specification I, and specification II for repeated I/J/K (I1 J1 K1 I2 …).
//   G65 … L n repeats the call n times, each with fresh locals from the arguments.
// - G66 P… L… <arguments> (modal call): from the next block on, every block with an axis word
//   calls the macro after its move, with G66's arguments, until G67; moves inside the macro called
//   that way do not call it again. G66.1 (a call after every block) is refused (PP-E709).
// - Subprogram targets: O#### / :#### in the same file, else a file O#### (or O####.nc) in
//   opt.search_dirs. M98 P<repeats 4 digits><program 4 digits> (packed form) is used when P has more
//   than 4 digits, there is no L, and no program with the full number exists.
// - A block delete '/' is taken as switched off: the block runs (PP-W702 when it holds a
//   statement, since the switch could change the flow).
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

#include "src/gcode/text.hpp"
#include "fanuc_expr.hpp"
#include "support.hpp"

namespace postproc::gcode::resolver {
namespace {

using namespace fanuc_expr;

// ---------------------------------------------------------------------------------------------
// Line plans: what a line does, parsed once per (file, line).

enum class ItemKind : std::uint8_t { word, assign, if_goto, if_then, while_do, do_loop, end_loop, go_to, program_number, percent, other };

struct Item {
  ItemKind kind = ItemKind::other;
  Span span;             // the whole item
  Span value;            // word: its value span
  char letter = 0;       // word letter
  bool literal = true;   // word: a literal number
  double number = 0;     // word: literal value; DO/END: loop number; program number
  std::int32_t e1 = -1;  // word value / rhs / condition / goto target
  std::int32_t e2 = -1;  // assignment target (a var node) / THEN target
  std::int32_t e3 = -1;  // THEN value
};

struct LinePlan {
  bool plain = true;  // nothing to evaluate: emitted as is
  bool statement = false;
  std::vector<Item> items;
  ExprPool pool;
  Span n_span, delete_span;
  bool has_n = false, block_delete = false;
  std::uint32_t raw_size = 0;
  std::optional<std::size_t> loop_end;  // WHILE/DO: the line of the matching END
  std::optional<Failure> error;          // a syntax error, reported when the line runs
};

struct Loop {
  int id = 0;
  std::size_t begin = 0, end = 0;  // the WHILE/DO line and its END line
};

struct Var {
  double v = 0;
  bool set = false;
};
using Locals = std::array<Var, 34>;

struct Frame {
  SourceFile* file = nullptr;
  std::size_t start = 0;        // the sub's first line (its O line when it has one)
  SourceFile* ret_file = nullptr;
  std::size_t ret_line = 0;     // the caller's call line
  int repeats_left = 0;
  bool macro = false;           // G65: own locals
  bool modal = false;           // called by a G66 modal call
  Locals args{};                // G65: the arguments (re-set on each repetition)
  std::vector<Loop> loops;
};

struct Stop {};  // the run ended (normally or after an error)

class Runner {
 public:
  Runner(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r)
      : files_(files), out_(out), opt_(opt), sink_(sink), r_(r) {}

  void run();

 private:
  // --- plans
  LinePlan* plan(SourceFile& f, std::size_t line);
  void compile(SourceFile& f, std::size_t line, LinePlan& p);
  void parse_statement(const Block& b, const Token& t, LinePlan& p, Item& it);

  // --- evaluation
  Value eval(const LinePlan& p, std::int32_t n);
  Value read_var(double index, Span span);
  void write_var(const LinePlan& p, double index, Value v, Span span);
  int var_number(double index, Span span) const;
  [[noreturn]] void arith_error(std::string msg, Span span) const { throw Failure{"PP-E707", std::move(msg), span}; }
  bool cond(const LinePlan& p, std::int32_t n) { return eval(p, n).v != 0; }

  // --- execution
  void step();
  void call(bool macro, double program, int repeats, const Locals& args, const LinePlan& p, const Item& at,
            std::string callee);
  void do_return(std::optional<double> to_n, Span span);
  std::optional<std::size_t> find_end(SourceFile& f, std::size_t from, int id, Span span);
  std::size_t goto_n(SourceFile& f, double n, std::size_t from, Span span);
  struct Target {
    SourceFile* file;
    std::size_t line;
  };
  std::optional<Target> find_program(double number);
  std::optional<std::size_t> program_line(SourceFile& f, double number);
  void emit(SourceFile& f, std::size_t line, std::span<const Edit> edits);
  void finish_tape();
  void fail(const Failure& e);
  void report(Span span, Severity sev, std::string_view code, std::string message);

  FileSet& files_;
  Emitter& out_;
  const ResolveOptions& opt_;
  DiagnosticSink& sink_;
  ResolvedProgram& r_;

  std::vector<std::vector<std::unique_ptr<LinePlan>>> plans_;               // [file][line]
  std::vector<std::unique_ptr<std::unordered_map<std::uint64_t, std::size_t>>> programs_;  // [file] O number → line
  std::vector<Frame> frames_;
  /// A G66 modal call in effect: the macro every block with a move calls after it.
  struct ModalCall {
    double program = 0;
    int repeats = 1;
    Locals args{};
  };
  std::optional<ModalCall> modal_;
  std::string modal_callee_;
  std::vector<Locals> locals_;
  std::array<Var, 1000> common_{};  // #100–#999
  std::unordered_map<int, double> system_;  // system variables written by the program
  SourceFile* file_ = nullptr;
  std::size_t pc_ = 0;
  std::vector<Edit> edits_;
  std::vector<std::uint8_t> action_;  // per item: 0 keep, 1 delete, 2 replace
  std::vector<std::string> text_;
  std::vector<double> vals_;
  bool warned_block_delete_ = false;
};

// ---------------------------------------------------------------------------------------------

LinePlan* Runner::plan(SourceFile& f, std::size_t line) {
  auto& v = plans_[f.index()];
  if (v.size() < f.lines()) v.resize(f.lines());
  if (!v[line]) {
    auto p = std::make_unique<LinePlan>();
    try {
      compile(f, line, *p);
    } catch (const Failure& e) {
      LinePlan bad;
      bad.plain = false;
      bad.error = e;
      *p = std::move(bad);
    }
    v[line] = std::move(p);
  }
  return v[line].get();
}

void Runner::compile(SourceFile& f, std::size_t line, LinePlan& p) {
  const Block& b = f.block(line);
  p.raw_size = static_cast<std::uint32_t>(b.raw.size());
  p.has_n = b.has_n;
  p.n_span = b.n_span;
  p.block_delete = b.block_delete;
  p.delete_span = b.block_delete_span;
  std::size_t wi = 0, ti = 0;
  while (wi < b.words.size() || ti < b.tokens.size()) {
    const bool take_word =
        ti >= b.tokens.size() || (wi < b.words.size() && b.words[wi].span.begin < b.tokens[ti].span.begin);
    Item it;
    if (take_word) {
      const Word& w = b.words[wi++];
      it.kind = ItemKind::word;
      it.span = w.span;
      it.value = w.value;
      it.letter = w.letter;
      if (w.kind == ValueKind::number) {
        it.number = w.number;
        if ((w.letter == 'M' && (w.number == 98 || w.number == 99 || w.number == 30 || w.number == 2)) ||
            (w.letter == 'G' && (w.number == 65 || w.number == 66 || w.number == 67 || w.number == 66.1)))
          p.plain = false;
      } else {
        it.literal = false;
        p.plain = false;
        Parser ps(b.raw, w.value.begin, w.value.end, p.pool);
        it.e1 = ps.expression();
        if (!ps.at_end()) ps.fail("unexpected text after the value", ps.pos());
      }
    } else {
      const Token& t = b.tokens[ti++];
      it.span = t.span;
      switch (t.kind) {
        case TokenKind::assignment: {
          it.kind = ItemKind::assign;
          p.plain = false;
          p.statement = true;
          Parser ps(b.raw, t.span.begin, t.span.end, p.pool);
          it.e2 = ps.variable();
          ps.expect('=', "after the variable");
          if (ps.at_end()) ps.fail("the assignment has no value", ps.pos());
          it.e1 = ps.expression();
          if (!ps.at_end()) ps.fail("unexpected text after the expression (one statement per block)", ps.pos());
          break;
        }
        case TokenKind::control_flow:
          p.plain = false;
          p.statement = true;
          parse_statement(b, t, p, it);
          break;
        case TokenKind::program_number: {
          it.kind = ItemKind::program_number;
          p.plain = false;
          double n = 0;
          for (char c : b.text(t.name)) n = n * 10 + (c - '0');
          it.number = n;
          break;
        }
        case TokenKind::percent:
          it.kind = ItemKind::percent;
          p.plain = false;
          break;
        default:
          it.kind = ItemKind::other;
          break;
      }
    }
    p.items.push_back(it);
  }
}

void Runner::parse_statement(const Block& b, const Token& t, LinePlan& p, Item& it) {
  Parser ps(b.raw, t.span.begin, t.span.end, p.pool);
  const std::string_view kw = b.text(t.name);
  ps.accept_word(kw);
  auto loop_number = [&](std::string_view what) {
    ps.skip();
    const std::uint32_t at = ps.pos();
    const std::int32_t e = ps.expression();
    const Node& n = p.pool.nodes[static_cast<std::size_t>(e)];
    if (n.op != Op::num || (n.num != 1 && n.num != 2 && n.num != 3))
      throw Failure{"PP-E702", fmt::format("{} takes a loop number 1, 2 or 3", what), {at, ps.pos() > at ? ps.pos() : at + 1}};
    return n.num;
  };
  if (text::iequals(kw, "IF")) {
    if (ps.peek() != '[') ps.fail("IF needs its condition in brackets: IF [#1 GT 0] GOTO 10", ps.pos());
    it.e1 = ps.expression();  // the bracket (the rest is a keyword)
    if (ps.accept_word("GOTO")) {
      it.kind = ItemKind::if_goto;
      if (ps.at_end()) ps.fail("GOTO needs a sequence number", ps.pos());
      it.e2 = ps.expression();
    } else if (ps.accept_word("THEN")) {
      it.kind = ItemKind::if_then;
      if (ps.peek() != '#') ps.fail("THEN must be followed by an assignment #i=…", ps.pos());
      it.e2 = ps.variable();
      ps.expect('=', "after the variable");
      if (ps.at_end()) ps.fail("the assignment has no value", ps.pos());
      it.e3 = ps.expression();
    } else {
      ps.fail("IF […] must be followed by GOTO n or THEN #i=…", ps.pos());
    }
  } else if (text::iequals(kw, "WHILE")) {
    it.kind = ItemKind::while_do;
    if (ps.peek() != '[') ps.fail("WHILE needs its condition in brackets: WHILE [#1 LT 10] DO 1", ps.pos());
    it.e1 = ps.expression();
    if (!ps.accept_word("DO")) ps.fail("WHILE […] must be followed by DO m", ps.pos());
    it.number = loop_number("DO");
  } else if (text::iequals(kw, "DO")) {
    it.kind = ItemKind::do_loop;
    it.number = loop_number("DO");
  } else if (text::iequals(kw, "END")) {
    it.kind = ItemKind::end_loop;
    it.number = loop_number("END");
  } else if (text::iequals(kw, "GOTO")) {
    it.kind = ItemKind::go_to;
    if (ps.at_end()) ps.fail("GOTO needs a sequence number", ps.pos());
    it.e1 = ps.expression();
  } else {
    ps.fail(fmt::format("'{}' cannot start a statement", kw), t.span.begin);
  }
  if (!ps.at_end()) ps.fail("unexpected text after the statement", ps.pos());
}

// ---------------------------------------------------------------------------------------------

std::string system_variable_name(int n) {
  if (n >= 1000 && n < 1100) return "interface input signal";
  if (n >= 1100 && n < 1200) return "interface output signal";
  if (n >= 2000 && n < 3000) return "tool offset";
  if (n >= 10000 && n < 20000) return "tool offset";
  if (n == 3000) return "alarm";
  if (n == 3001 || n == 3002) return "clock";
  if (n == 3003 || n == 3004) return "automatic-operation control";
  if (n == 3005) return "setting data";
  if (n == 3006) return "stop with message";
  if (n == 3007) return "mirror image state";
  if (n == 3011 || n == 3012) return "date and time";
  if (n == 3901 || n == 3902) return "part count";
  if (n >= 4001 && n < 4400) return "modal information";
  if (n >= 5001 && n < 5021) return "block end position";
  if (n >= 5021 && n < 5041) return "machine position";
  if (n >= 5041 && n < 5061) return "workpiece position";
  if (n >= 5061 && n < 5081) return "skip position";
  if (n >= 5081 && n < 5101) return "tool length offset value";
  if (n >= 5101 && n < 5201) return "servo position deviation";
  if (n >= 5201 && n < 5401) return "work offset";
  if (n >= 5401 && n < 5501) return "tool feed timer on Haas controls";
  if (n >= 5501 && n < 5601) return "total tool timer on Haas controls";
  if (n >= 7001 && n < 8000) return "extended work offset";
  return "system variable";
}

int Runner::var_number(double index, Span span) const {
  const double r = std::round(index);
  if (std::fabs(index - r) > 1e-6 || r < 0 || r > 99999999)
    throw Failure{"PP-E703", fmt::format("#[{}] is not a variable number (a whole number from 0)", format_value(index, 'P')), span};
  return static_cast<int>(r);
}

Value Runner::read_var(double index, Span span) {
  const int n = var_number(index, span);
  if (n == 0) return {0, true};
  if (n <= 33) {
    const Var& v = locals_.back()[static_cast<std::size_t>(n)];
    return {v.set ? v.v : 0, !v.set};
  }
  const std::string key = n < 1000 && common_[static_cast<std::size_t>(n)].set ? std::string() : fmt::format("#{}", n);
  if (n >= 100 && n <= 999) {
    Var& v = common_[static_cast<std::size_t>(n)];
    if (v.set) return {v.v, false};
    if (auto it = opt_.set.find(key); it != opt_.set.end()) {
      r_.used_settings[key] = it->second;
      v = {it->second, true};
      return {v.v, false};
    }
    if (n < 500) return {0, true};
    throw Failure{"PP-E701",
                  fmt::format("#{} is a retained common variable the program reads before assigning it: the control "
                              "keeps its value from earlier runs; give its value with --set '#{}=…'",
                              n, n),
                  span};
  }
  if (n < 1000)
    throw Failure{"PP-E703",
                  fmt::format("#{} is not a Fanuc Macro B variable (locals #1–#33, common #100–#499 and #500–#999, "
                              "system #1000 and up); check the variable number",
                              n),
                  span};
  if (auto it = system_.find(n); it != system_.end()) return {it->second, false};
  if (auto it = opt_.set.find(key); it != opt_.set.end()) {
    r_.used_settings[key] = it->second;
    return {it->second, false};
  }
  throw Failure{"PP-E701",
                fmt::format("#{} is filled by the control at run time ({}); give its value with --set '#{}=…'", n,
                            system_variable_name(n), n),
                span};
}

void Runner::write_var(const LinePlan& p, double index, Value v, Span span) {
  const int n = var_number(index, span);
  if (n == 0) throw Failure{"PP-E703", "#0 is always vacant and cannot be assigned; assign another variable", span};
  if (n <= 33) {
    locals_.back()[static_cast<std::size_t>(n)] = {v.vacant ? 0 : v.v, !v.vacant};
    return;
  }
  if (n >= 100 && n <= 999) {
    common_[static_cast<std::size_t>(n)] = {v.vacant ? 0 : v.v, !v.vacant};
    return;
  }
  if (n < 1000)
    throw Failure{"PP-E703", fmt::format("#{} is not a Fanuc Macro B variable (locals #1–#33, common #100–#499 and #500–#999)", n), span};
  if (n == 3000) {
    // The alarm message is the comment that follows on the line.
    std::string msg;
    for (const Item& it : p.items)
      if (it.kind == ItemKind::other && it.span.begin >= span.begin) {
        const std::string_view raw = file_->raw(pc_);
        const std::string_view c = it.span.of(raw);
        if (c.size() >= 2 && c.front() == '(') msg = std::string(c.substr(1, c.size() - 2));
        break;
      }
    const double num = v.vacant ? 0 : v.v;
    throw Failure{"PP-E710",
                  fmt::format("the program raises alarm {} ({}){} here: #3000 stops the control with an alarm; "
                              "change the values that lead to it (or the --set values that were given)",
                              format_value(num, 'P'), format_value(3000 + num, 'P'), msg.empty() ? "" : " " + msg),
                  span};
  }
  if (n == 3001 || n == 3002 || n == 3003 || n == 3004 || n == 3901 || n == 3902) {
    // Clocks, automatic-operation control and part counts: no effect on the motion.
    system_[n] = v.vacant ? 0 : v.v;
    return;
  }
  throw Failure{"PP-E709",
                fmt::format("writing #{} ({}) changes control state this resolver does not model; write the values "
                            "as NC words (e.g. G10 for offsets) or remove the assignment",
                            n, system_variable_name(n)),
                span};
}

std::int64_t to_int(double v) { return static_cast<std::int64_t>(std::llround(v)); }

Value Runner::eval(const LinePlan& p, std::int32_t idx) {
  const Node& n = p.pool.nodes[static_cast<std::size_t>(idx)];
  switch (n.op) {
    case Op::num: return {n.num, false};
    case Op::var: return read_var(n.num, n.span);
    case Op::var_ind: return read_var(eval(p, n.a).v, n.span);
    case Op::group: return eval(p, n.a);
    case Op::neg: {
      const Value a = eval(p, n.a);
      return {-a.v, a.vacant};
    }
    case Op::fn: {
      const double a = eval(p, n.a).v;
      const double b = n.b >= 0 ? eval(p, n.b).v : 0;
      constexpr double d2r = kPi / 180.0;
      auto wrap360 = [](double deg) { return deg < 0 ? deg + 360 : deg; };
      switch (n.fn) {
        case Fn::sin: return {std::sin(a * d2r), false};
        case Fn::cos: return {std::cos(a * d2r), false};
        case Fn::tan: {
          const double c = std::cos(a * d2r);
          if (std::fabs(c) < 1e-12) arith_error(fmt::format("TAN[{}] is undefined (the angle is 90° + k·180°)", format_value(a, 'P')), n.span);
          return {std::sin(a * d2r) / c, false};
        }
        case Fn::asin:
          if (a < -1 - 1e-12 || a > 1 + 1e-12) arith_error(fmt::format("ASIN[{}]: the argument must be from -1 to 1", format_value(a, 'P')), n.span);
          return {wrap360(std::asin(std::clamp(a, -1.0, 1.0)) / d2r), false};
        case Fn::acos:
          if (a < -1 - 1e-12 || a > 1 + 1e-12) arith_error(fmt::format("ACOS[{}]: the argument must be from -1 to 1", format_value(a, 'P')), n.span);
          return {std::acos(std::clamp(a, -1.0, 1.0)) / d2r, false};
        case Fn::atan: return {wrap360(std::atan(a) / d2r), false};
        case Fn::atan2:
          if (a == 0 && b == 0) arith_error("ATAN[0]/[0] is undefined", n.span);
          return {wrap360(std::atan2(a, b) / d2r), false};
        case Fn::sqrt:
          if (a < 0) arith_error(fmt::format("SQRT[{}]: the square root of a negative number", format_value(a, 'P')), n.span);
          return {std::sqrt(a), false};
        case Fn::abs: return {std::fabs(a), false};
        case Fn::bin: {  // BCD → binary
          std::int64_t v = to_int(a), out = 0, scale = 1;
          if (v < 0) arith_error("BIN of a negative value", n.span);
          while (v > 0) {
            const std::int64_t digit = v & 0xF;
            if (digit > 9) arith_error(fmt::format("BIN[{}]: not a BCD value (a nibble above 9)", format_value(a, 'P')), n.span);
            out += digit * scale;
            scale *= 10;
            v >>= 4;
          }
          return {static_cast<double>(out), false};
        }
        case Fn::bcd: {  // binary → BCD
          std::int64_t v = to_int(a), out = 0;
          if (v < 0) arith_error("BCD of a negative value", n.span);
          for (int shift = 0; v > 0; shift += 4, v /= 10) out |= (v % 10) << shift;
          return {static_cast<double>(out), false};
        }
        case Fn::round: return {std::round(a), false};
        case Fn::fix: return {std::trunc(a), false};
        case Fn::fup: {
          const double t = std::trunc(a);
          return {t == a ? a : (a > 0 ? t + 1 : t - 1), false};
        }
        case Fn::ln:
          if (a <= 0) arith_error(fmt::format("LN[{}]: the logarithm of a value that is not positive", format_value(a, 'P')), n.span);
          return {std::log(a), false};
        case Fn::exp: {
          const double v = std::exp(a);
          if (!std::isfinite(v)) arith_error(fmt::format("EXP[{}] overflows", format_value(a, 'P')), n.span);
          return {v, false};
        }
        case Fn::pow: {
          if (a < 0 && b != std::trunc(b)) arith_error("POW of a negative base to a fractional exponent", n.span);
          if (a == 0 && b < 0) arith_error("POW[0,negative] divides by zero", n.span);
          const double v = std::pow(a, b);
          if (!std::isfinite(v)) arith_error("POW overflows", n.span);
          return {v, false};
        }
        case Fn::adp: return {a, false};
      }
      return {0, false};
    }
    default: break;
  }
  const Value a = eval(p, n.a);
  const Value b = eval(p, n.b);
  auto eq = [&] {
    if (a.vacant || b.vacant) return a.vacant == b.vacant;
    return std::fabs(a.v - b.v) <= 1e-12 * std::max({1.0, std::fabs(a.v), std::fabs(b.v)});
  };
  switch (n.op) {
    case Op::add: return {a.v + b.v, false};
    case Op::sub: return {a.v - b.v, false};
    case Op::mul: return {a.v * b.v, false};
    case Op::div:
      if (b.v == 0) arith_error("division by zero", n.span);
      return {a.v / b.v, false};
    case Op::mod: {
      const std::int64_t x = to_int(a.v), y = to_int(b.v);
      if (y == 0) arith_error("MOD by zero", n.span);
      return {static_cast<double>(x % y), false};
    }
    case Op::band: return {static_cast<double>(to_int(a.v) & to_int(b.v)), false};
    case Op::bor: return {static_cast<double>(to_int(a.v) | to_int(b.v)), false};
    case Op::bxor: return {static_cast<double>(to_int(a.v) ^ to_int(b.v)), false};
    case Op::eq: return {eq() ? 1.0 : 0.0, false};
    case Op::ne: return {eq() ? 0.0 : 1.0, false};
    case Op::gt: return {a.v > b.v ? 1.0 : 0.0, false};
    case Op::ge: return {a.v >= b.v ? 1.0 : 0.0, false};
    case Op::lt: return {a.v < b.v ? 1.0 : 0.0, false};
    case Op::le: return {a.v <= b.v ? 1.0 : 0.0, false};
    default: return {0, false};
  }
}

// ---------------------------------------------------------------------------------------------

void Runner::report(Span span, Severity sev, std::string_view code, std::string message) {
  if (out_.depth() > 0) message += fmt::format(" ({})", out_.where());
  file_->report(pc_, span, sev, code, std::move(message));
}

void Runner::fail(const Failure& e) {
  Span s = e.span;
  if (s.end <= s.begin) s.end = s.begin + 1;
  report(s, Severity::error, e.code, e.message);
}

void Runner::emit(SourceFile& f, std::size_t line, std::span<const Edit> edits) {
  if (!out_.emit(f, line, edits)) {
    report({0, static_cast<std::uint32_t>(std::max<std::size_t>(1, f.raw(line).size()))}, Severity::error, "PP-E705",
           fmt::format("the program executes more than {} blocks: a loop that does not end? Check the loop's "
                       "condition (or raise the block limit)",
                       opt_.max_blocks));
    throw Stop{};
  }
}

std::optional<std::size_t> Runner::program_line(SourceFile& f, double number) {
  auto& idx = programs_[f.index()];
  if (!idx) {
    idx = std::make_unique<std::unordered_map<std::uint64_t, std::size_t>>();
    for (std::size_t i = 0; i < f.lines(); ++i) {
      const std::string_view l = f.raw(i);
      std::size_t q = l.find_first_not_of(" \t");
      if (q == std::string_view::npos) continue;
      if (l[q] == '%') q = l.find_first_not_of(" \t", q + 1);
      if (q == std::string_view::npos || q + 1 >= l.size()) continue;
      if (!((l[q] == 'O' || l[q] == 'o' || l[q] == ':') && is_digit(l[q + 1]))) continue;
      std::uint64_t n = 0;
      for (std::size_t j = q + 1; j < l.size() && is_digit(l[j]); ++j) n = n * 10 + static_cast<std::uint64_t>(l[j] - '0');
      idx->emplace(n, i);
    }
  }
  if (number < 0) return std::nullopt;
  auto it = idx->find(static_cast<std::uint64_t>(number));
  if (it == idx->end()) return std::nullopt;
  return it->second;
}

std::optional<Runner::Target> Runner::find_program(double number) {
  if (auto l = program_line(*file_, number)) return Target{file_, *l};
  if (file_ != &files_.main())
    if (auto l = program_line(files_.main(), number)) return Target{&files_.main(), *l};
  const auto n = static_cast<std::uint64_t>(number);
  std::vector<std::string> names;
  for (const std::string& base : {fmt::format("O{:04d}", n), fmt::format("O{}", n)})
    for (const char* ext : {"", ".nc", ".NC"}) {
      std::string c = base + ext;
      if (std::find(names.begin(), names.end(), c) == names.end()) names.push_back(std::move(c));
    }
  SourceFile* f = files_.find(names);
  if (!f) return std::nullopt;
  if (plans_.size() <= f->index()) {
    plans_.resize(f->index() + 1);
    programs_.resize(f->index() + 1);
  }
  if (auto l = program_line(*f, number)) return Target{f, *l};
  // No O line: the body starts after the leading '%' line, if any.
  for (std::size_t i = 0; i < f->lines(); ++i) {
    const std::string_view l = f->raw(i);
    const std::size_t q = l.find_first_not_of(" \t");
    if (q == std::string_view::npos) continue;
    return Target{f, l[q] == '%' ? i + 1 : i};
  }
  return Target{f, 0};
}

std::size_t Runner::goto_n(SourceFile& f, double n, std::size_t from, Span span) {
  if (auto l = f.find_n(n, from, true)) return *l;
  if (auto l = f.find_n(n, 0, true)) return *l;
  throw Failure{"PP-E704",
                fmt::format("sequence number N{} is not in {}: the jump has no target; add the N number or correct "
                            "the jump",
                            format_value(n, 'N'), f.name()),
                span};
}

std::optional<std::size_t> Runner::find_end(SourceFile& f, std::size_t from, int id, Span span) {
  for (std::size_t i = from + 1; i < f.lines(); ++i) {
    const std::string_view l = f.raw(i);
    // Cheap filter: END / DO need the letters.
    if (l.find_first_of("EeDd") == std::string_view::npos) continue;
    LinePlan* p = plan(f, i);
    for (const Item& it : p->items) {
      if ((it.kind == ItemKind::while_do || it.kind == ItemKind::do_loop) && static_cast<int>(it.number) == id)
        throw Failure{"PP-E708",
                      fmt::format("DO {} is opened again at line {} before its END {}: loops with the same number "
                                  "cannot nest; number nested loops 1, 2, 3",
                                  id, i + 1, id),
                      span};
      if (it.kind == ItemKind::end_loop && static_cast<int>(it.number) == id) return i;
    }
  }
  throw Failure{"PP-E708", fmt::format("DO {} has no END {} after it in {}; add END {}", id, id, f.name(), id), span};
}

void Runner::call(bool macro, double program, int repeats, const Locals& args, const LinePlan& p, const Item& at,
                  std::string callee) {
  (void)p;
  if (static_cast<int>(frames_.size()) - 1 >= opt_.max_call_depth)
    throw Failure{"PP-E706",
                  fmt::format("{} nests calls {} deep, more than the limit {}: a call that never returns? (Fanuc "
                              "controls allow 4 macro and 10 subprogram levels)",
                              callee, frames_.size(), opt_.max_call_depth),
                  at.span};
  std::optional<Target> t = find_program(program);
  if (!t) {
    std::string dirs;
    for (const std::string& d : opt_.search_dirs) dirs += (dirs.empty() ? "" : ", ") + d;
    throw Failure{"PP-E704",
                  fmt::format("program O{:04d} is not in {} nor a file O{:04d}[.nc] in the search folders ({}); "
                              "add the subprogram or its file",
                              static_cast<std::uint64_t>(program), file_->name(), static_cast<std::uint64_t>(program),
                              dirs.empty() ? "none" : dirs),
                  at.span};
  }
  out_.push_call(CallFrame{file_->name(), pc_ + 1, std::move(callee)});
  Frame fr;
  fr.file = t->file;
  fr.start = t->line;
  fr.ret_file = file_;
  fr.ret_line = pc_;
  fr.repeats_left = repeats;
  fr.macro = macro;
  if (macro) {
    fr.args = args;
    locals_.push_back(args);
  }
  frames_.push_back(std::move(fr));
  file_ = t->file;
  pc_ = t->line;
}

void Runner::do_return(std::optional<double> to_n, Span span) {
  Frame& fr = frames_.back();
  if (!to_n && fr.repeats_left > 1) {
    --fr.repeats_left;
    fr.loops.clear();
    if (fr.macro) locals_.back() = fr.args;
    file_ = fr.file;
    pc_ = fr.start;
    return;
  }
  SourceFile* rf = fr.ret_file;
  const std::size_t rl = fr.ret_line;
  if (fr.macro) locals_.pop_back();
  frames_.pop_back();
  out_.pop_call();
  file_ = rf;
  pc_ = rl + 1;
  if (to_n) pc_ = goto_n(*rf, *to_n, rl + 1, span);
}

void Runner::finish_tape() {
  // The run ended in the main program: the closing '%' passes through.
  SourceFile& m = files_.main();
  for (std::size_t i = (file_ == &m ? pc_ + 1 : m.lines()); i < m.lines(); ++i) {
    const std::string_view l = m.raw(i);
    const std::size_t q = l.find_first_not_of(" \t");
    if (q != std::string_view::npos && l[q] == '%') {
      static const std::vector<Edit> none;
      emit(m, i, none);
      return;
    }
  }
}

// Executes the line at (file_, pc_) and moves pc_.
void Runner::step() {
  SourceFile& f = *file_;
  const std::size_t line = pc_;
  LinePlan& p = *plan(f, line);
  if (p.error) throw *p.error;
  if (p.plain && !modal_) {  // (under G66 a plain move still calls the macro)
    static const std::vector<Edit> none;
    emit(f, line, none);
    ++pc_;
    return;
  }
  Frame& fr = frames_.back();
  const bool in_sub = frames_.size() > 1;
  if (p.block_delete && p.statement && !warned_block_delete_) {
    warned_block_delete_ = true;
    report(p.delete_span, Severity::warning, "PP-W702",
           "block delete '/' on a macro statement: resolved with the block-delete switch off (the block runs)");
  }
  action_.assign(p.items.size(), 0);
  text_.resize(p.items.size());
  enum class Next { advance, jump, end_run, stop, ret, call, stop_main_m99 } next = Next::advance;
  std::size_t jump_to = 0;
  std::optional<double> ret_n;
  Span ret_span;
  // Word values as evaluated (for M/G/P/L).
  std::optional<std::size_t> g65, g66, g67, m98, m99, p_word, l_word;
  bool moves = false;  // an axis word with a value (G66 calls after such a block)
  std::vector<double>& vals = vals_;
  vals.assign(p.items.size(), 0.0);
  for (std::size_t k = 0; k < p.items.size(); ++k) {
    const Item& it = p.items[k];
    switch (it.kind) {
      case ItemKind::word: {
        double v = it.number;
        if (!it.literal) {
          const Value x = eval(p, it.e1);
          if (x.vacant) {
            action_[k] = 1;  // a vacant variable: the address is omitted
            vals[k] = NAN;
            continue;
          }
          v = x.v;
          action_[k] = 2;
          text_[k] = format_value(v, it.letter);
        }
        vals[k] = v;
        if (it.letter == 'G' && std::fabs(v - 66.1) < 1e-9)
          throw Failure{"PP-E709",
                        "G66.1 (a macro call after every block) is not supported by the resolver; call the macro with "
                        "G65 where it is needed instead",
                        it.span};
        if (it.letter == 'G' && v == 65) g65 = k;
        if (it.letter == 'G' && v == 66) g66 = k;
        if (it.letter == 'G' && v == 67) g67 = k;
        if (std::string_view("XYZABCUVW").find(it.letter) != std::string_view::npos) moves = true;
        if (it.letter == 'M' && v == 98) m98 = k;
        if (it.letter == 'M' && v == 99) m99 = k;
        if (it.letter == 'M' && (v == 30 || v == 2) && next == Next::advance) next = Next::end_run;
        if (it.letter == 'P' && !p_word) p_word = k;
        if (it.letter == 'L' && !l_word) l_word = k;
        break;
      }
      case ItemKind::assign: {
        const Node& target = p.pool.nodes[static_cast<std::size_t>(it.e2)];
        const double index = target.op == Op::var ? target.num : eval(p, target.a).v;
        write_var(p, index, eval(p, it.e1), target.span);
        action_[k] = 1;
        break;
      }
      case ItemKind::if_then:
        if (cond(p, it.e1)) {
          const Node& target = p.pool.nodes[static_cast<std::size_t>(it.e2)];
          const double index = target.op == Op::var ? target.num : eval(p, target.a).v;
          write_var(p, index, eval(p, it.e3), target.span);
        }
        action_[k] = 1;
        break;
      case ItemKind::if_goto:
        if (cond(p, it.e1)) {
          next = Next::jump;
          jump_to = goto_n(f, eval(p, it.e2).v, line + 1, it.span);
        }
        action_[k] = 1;
        break;
      case ItemKind::go_to:
        next = Next::jump;
        jump_to = goto_n(f, eval(p, it.e1).v, line + 1, it.span);
        action_[k] = 1;
        break;
      case ItemKind::while_do:
      case ItemKind::do_loop: {
        const int id = static_cast<int>(it.number);
        if (!p.loop_end) p.loop_end = find_end(f, line, id, it.span);
        const bool again = !fr.loops.empty() && fr.loops.back().begin == line;
        const bool go = it.kind == ItemKind::do_loop || cond(p, it.e1);
        if (go) {
          if (!again) fr.loops.push_back({id, line, *p.loop_end});
        } else {
          if (again) fr.loops.pop_back();
          next = Next::jump;
          jump_to = *p.loop_end + 1;
        }
        action_[k] = 1;
        break;
      }
      case ItemKind::end_loop: {
        const int id = static_cast<int>(it.number);
        if (fr.loops.empty() || fr.loops.back().id != id || fr.loops.back().end != line)
          throw Failure{"PP-E708",
                        fr.loops.empty() || fr.loops.back().end == line
                            ? fmt::format("END {} without a WHILE […] DO {} before it; add the DO or remove the END", id, id)
                            : fmt::format("END {} closes DO {} opened at line {}: loops must close innermost first "
                                          "(END {} before END {})",
                                          id, fr.loops.back().id, fr.loops.back().begin + 1, fr.loops.back().id, id),
                        it.span};
        next = Next::jump;
        jump_to = fr.loops.back().begin;
        action_[k] = 1;
        break;
      }
      case ItemKind::program_number:
        if (in_sub && line == fr.start) action_[k] = 1;
        break;
      case ItemKind::percent:
        if (in_sub)
          throw Failure{"PP-E708",
                        fmt::format("the subprogram reaches the end of its tape ('%') without M99; add M99 at its end"),
                        it.span};
        next = Next::stop;
        break;
      default: break;
    }
  }
  // Calls and returns.
  Locals args{};
  std::string callee;
  double program = 0;
  int repeats = 1;
  bool macro = false;
  if (g67) {
    action_[*g67] = 1;
    modal_.reset();
  }
  const char* const call_code = g65 ? "G65" : g66 ? "G66" : "M98";
  if ((g65 && g66) || ((g65 || g66) && m98))
    throw Failure{"PP-E709", "a block with two calls (G65, G66, M98): write one per block", p.items[g66 ? *g66 : *m98].span};
  if (g65 || g66 || m98) {
    const Item& at = p.items[g65 ? *g65 : g66 ? *g66 : *m98];
    if (!p_word || std::isnan(vals[*p_word]))
      throw Failure{"PP-E702", fmt::format("{} needs the program number: P####", call_code), at.span};
    program = vals[*p_word];
    if (l_word) {
      if (std::isnan(vals[*l_word])) repeats = 1;
      else repeats = static_cast<int>(std::llround(vals[*l_word]));
    }
    if (m98 && !l_word && !g65) {
      const Item& pw = p.items[*p_word];
      const std::string_view pt = pw.value.of(f.raw(line));
      if (pw.literal && pt.size() > 4 && program > 9999 && !find_program(program)) {
        repeats = static_cast<int>(program / 10000);
        program = std::fmod(program, 10000);
        if (repeats == 0) repeats = 1;
      }
    }
    macro = g65 || g66;
    callee = fmt::format("{} P{}", call_code, format_value(program, 'P'));
    if (macro) {
      const std::size_t head = g65 ? *g65 : *g66;
      // Argument specification I (II for repeated I/J/K); G L N O P are not arguments.
      static constexpr int kSpec1[26] = {1, 2, 3, 7, 8, 9, 0, 11, 4, 5, 6, 0, 13, 0, 0, 0, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26};
      int ijk_group = -1;
      int last_ijk = 3;
      for (std::size_t k = 0; k < p.items.size(); ++k) {
        const Item& it = p.items[k];
        if (it.kind != ItemKind::word) continue;
        action_[k] = 1;
        if (k == head || k == *p_word || (l_word && k == *l_word)) continue;
        const char L = it.letter;
        if (L < 'A' || L > 'Z' || kSpec1[L - 'A'] == 0) {
          if (L == 'G' || L == 'M')
            throw Failure{"PP-E709",
                          fmt::format("{} must be alone in its block with its arguments; put other codes in their own "
                                      "block",
                                      call_code),
                          it.span};
          throw Failure{"PP-E702", fmt::format("{} is not a {} argument address", L, call_code), it.span};
        }
        int var = kSpec1[L - 'A'];
        if (L == 'I' || L == 'J' || L == 'K') {
          const int pos = L - 'I';
          if (pos <= last_ijk) ++ijk_group;
          last_ijk = pos;
          var = 4 + 3 * ijk_group + pos;
          if (var > 33) throw Failure{"PP-E702", "more than 10 I/J/K argument groups", it.span};
        }
        if (!std::isnan(vals[k])) args[static_cast<std::size_t>(var)] = {vals[k], true};
      }
    } else {
      action_[*m98] = 1;
      action_[*p_word] = 1;
      if (l_word) action_[*l_word] = 1;
    }
    if (repeats < 1) repeats = 0;
    if (g66) {
      // The mode is set; the calls come after the moves of the blocks that follow.
      modal_ = ModalCall{program, repeats, args};
      modal_callee_ = callee;
    } else {
      next = Next::call;
    }
  } else if (m99) {
    action_[*m99] = 1;
    if (p_word) {
      action_[*p_word] = 1;
      ret_n = vals[*p_word];
    }
    ret_span = p.items[*m99].span;
    if (in_sub) {
      next = Next::ret;
    } else if (ret_n) {
      next = Next::jump;
      jump_to = goto_n(f, *ret_n, line + 1, ret_span);
    } else {
      next = Next::stop_main_m99;
    }
  }
  // Edits, in source order; a deleted item takes the blanks before it (or after it at the start).
  // edits_ keeps its elements (and their strings' capacity) from line to line.
  std::size_t ne = 0;
  auto add_edit = [&](Span s, std::string_view text) {
    if (ne == edits_.size()) edits_.emplace_back();
    Edit& e = edits_[ne++];
    e.span = s;
    e.text.assign(text);
  };
  std::uint32_t first_kept = p.raw_size;
  for (std::size_t k = 0; k < p.items.size(); ++k)
    if (action_[k] != 1) {
      first_kept = p.items[k].span.begin;
      break;
    }
  if (first_kept == p.raw_size) {
    add_edit({0, p.raw_size}, {});  // nothing left to execute: the line goes
  } else {
    const std::string_view raw = f.raw(line);
    std::uint32_t last_end = 0;
    const std::uint32_t lead = p.has_n ? p.n_span.end : (p.block_delete ? p.delete_span.end : 0);
    for (std::size_t k = 0; k < p.items.size(); ++k) {
      const Item& it = p.items[k];
      if (action_[k] == 2) {
        add_edit(it.value, text_[k]);
        last_end = it.value.end;
      } else if (action_[k] == 1) {
        Span s = it.span;
        if (s.begin < first_kept && s.begin >= lead) {
          while (s.end < raw.size() && is_blank(raw[s.end])) ++s.end;
        } else {
          while (s.begin > last_end && is_blank(raw[s.begin - 1])) --s.begin;
        }
        add_edit(s, {});
        last_end = s.end;
      }
    }
  }
  emit(f, line, std::span<const Edit>(edits_.data(), ne));
  if (next == Next::advance && modal_ && moves && !g66 && modal_->repeats > 0 &&
      std::none_of(frames_.begin(), frames_.end(), [](const Frame& x) { return x.modal; })) {
    // G66 in effect: the macro runs after this block's move (not from inside a macro it called).
    const ModalCall mc = *modal_;
    call(true, mc.program, mc.repeats, mc.args, p, p.items.front(), modal_callee_);
    frames_.back().modal = true;
    return;
  }
  switch (next) {
    case Next::advance: ++pc_; break;
    case Next::jump: {
      // Leaving loops whose range does not hold the target (GOTO out of a loop).
      while (!fr.loops.empty() && (jump_to < fr.loops.back().begin || jump_to > fr.loops.back().end)) fr.loops.pop_back();
      pc_ = jump_to;
      break;
    }
    case Next::end_run: finish_tape(); throw Stop{};
    case Next::stop: throw Stop{};
    case Next::ret: do_return(ret_n, ret_span); break;
    case Next::call:
      if (repeats == 0) {
        ++pc_;
        break;
      }
      call(macro, program, repeats, args, p, p.items[g65 ? *g65 : *m98], callee);
      break;
    case Next::stop_main_m99:
      report(ret_span, Severity::warning, "PP-W701", "M99 in the main program repeats it forever; resolved once");
      throw Stop{};
  }
}

void Runner::run() {
  SourceFile& m = files_.main();
  plans_.resize(1);
  programs_.resize(1);
  locals_.emplace_back();
  frames_.push_back(Frame{&m, 0, nullptr, 0, 1, false, false, {}, {}});
  file_ = &m;
  pc_ = 0;
  // Tape leader: text before the first '%' is not executed (when a program follows the '%').
  std::optional<std::size_t> first_percent;
  for (std::size_t i = 0; i < m.lines(); ++i) {
    const std::string_view l = m.raw(i);
    const std::size_t q = l.find_first_not_of(" \t");
    if (q == std::string_view::npos) continue;
    if (l[q] == '%') first_percent = i;
    break;
  }
  if (!first_percent) {
    for (std::size_t i = 0; i < m.lines(); ++i) {
      const std::string_view l = m.raw(i);
      const std::size_t q = l.find_first_not_of(" \t");
      if (q != std::string_view::npos && l[q] == '%') {
        for (std::size_t j = i + 1; j < m.lines(); ++j)
          if (m.raw(j).find_first_not_of(" \t") != std::string_view::npos) {
            first_percent = i;
            break;
          }
        break;
      }
    }
  }
  static const std::vector<Edit> none;
  try {
    if (first_percent) {
      for (std::size_t i = 0; i <= *first_percent; ++i) emit(m, i, none);
      pc_ = *first_percent + 1;
    }
    for (;;) {
      if (pc_ >= file_->lines()) {
        if (frames_.size() > 1) {
          report({0, 1}, Severity::error, "PP-E708",
                 fmt::format("the subprogram runs past the end of {} without M99; add M99 at its end", file_->name()));
          pc_ = file_->lines() ? file_->lines() - 1 : 0;
        }
        return;
      }
      try {
        step();
      } catch (const Failure& e) {
        fail(e);
        return;
      }
    }
  } catch (const Stop&) {
  }
}

}  // namespace

void resolve_fanuc(FileSet& files, Emitter& out, const ResolveOptions& opt, DiagnosticSink& sink, ResolvedProgram& r) {
  Runner run(files, out, opt, sink, r);
  run.run();
}

}  // namespace postproc::gcode::resolver
