// The Fanuc macro B resolver: line plans (each source line compiled once), variables and
// expression evaluation (see fanuc_runner.hpp).
#include "fanuc_runner.hpp"

namespace postproc::gcode::resolver::fanuc_run {

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
            (w.letter == 'G' && (w.number == 65 || w.number == 66 || w.number == 67 || w.number == 66.1 ||
                                 w.number == 20 || w.number == 21)))  // (G20/G21: the runner tracks the unit)
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

namespace {

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

}  // namespace

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
  // A new value is progress for the loop guard (the same value written again is not).
  const auto store = [&](Var& slot) {
    const Var nv{v.vacant ? 0 : v.v, !v.vacant};
    if (slot.v != nv.v || slot.set != nv.set) guard_.changed();
    slot = nv;
  };
  if (n <= 33) {
    store(locals_.back()[static_cast<std::size_t>(n)]);
    return;
  }
  if (n >= 100 && n <= 999) {
    store(common_[static_cast<std::size_t>(n)]);
    return;
  }
  guard_.changed();
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

Value Runner::eval(const LinePlan& p, std::int32_t idx) {
  const Node& n = p.pool.nodes[static_cast<std::size_t>(idx)];
  // Integer operands (MOD, AND/OR/XOR, BIN, BCD) must be exact integers of a 64-bit control word.
  const auto to_int = [&](double v) {
    if (!integer_range(v))
      arith_error(fmt::format("'{}': the operand {} is too large for an integer operation (beyond ±2^53)",
                              n.span.of(file_->raw(pc_)).substr(0, 60), format_value(v, 'P')),
                  n.span);
    return static_cast<std::int64_t>(std::llround(v));
  };
  // Overflow is an error at the expression that produced it, never an 'inf' word.
  const auto finite = [&](double v, std::string_view what) -> Value {
    if (!std::isfinite(v))
      arith_error(fmt::format("'{}': the {} overflows (beyond ±1.8e308)", n.span.of(file_->raw(pc_)).substr(0, 60), what),
                  n.span);
    return {v, false};
  };
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
          return finite(std::sin(a * d2r) / c, "TAN");
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
          if (v >= 1'000'000'000'000'000) arith_error("BCD of a value with more than 15 digits (beyond a 64-bit BCD word)", n.span);
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
    case Op::add: return finite(a.v + b.v, "sum");
    case Op::sub: return finite(a.v - b.v, "difference");
    case Op::mul: return finite(a.v * b.v, "product");
    case Op::div:
      if (b.v == 0) arith_error("division by zero", n.span);
      return finite(a.v / b.v, "quotient");
    case Op::mod: {
      const std::int64_t x = to_int(a.v), y = to_int(b.v);
      if (y == 0) arith_error("MOD by zero", n.span);
      if (y == -1) return {0.0, false};  // x % -1 is 0 (and INT64_MIN % -1 would trap)
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

}  // namespace postproc::gcode::resolver::fanuc_run
