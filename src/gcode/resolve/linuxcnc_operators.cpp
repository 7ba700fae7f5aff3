// rs274ngc operators and functions of the LinuxCNC resolver: degrees for trigonometry, rs274ngc's
// equality tolerance, and the arithmetic errors LinuxCNC stops on (PP-E707).
#include <cmath>

#include "src/gcode/resolve/linuxcnc_expr.hpp"

namespace postproc::gcode::resolver::lcnc {
namespace {
constexpr double kDeg = 3.14159265358979323846 / 180.0;

std::string_view name_of(Op op) {
  switch (op) {
    case Op::add: return "sum";
    case Op::sub: return "difference";
    case Op::mul: return "product";
    case Op::div: return "quotient";
    case Op::pow: return "power (**)";
    case Op::exp: return "EXP";
    case Op::tan: return "TAN";
    default: return "result";
  }
}

void apply(Op op, double* st, int& sp);
}  // namespace

void apply_operator(Op op, double* st, int& sp) {
  apply(op, st, sp);
  // Overflow is an error at the expression, never an 'inf' word or a NaN in a comparison.
  if (!std::isfinite(st[sp - 1]))
    throw EvalError{"PP-E707", fmt::format("the {} overflows (beyond ±1.8e308)", name_of(op))};
}

namespace {
void apply(Op op, double* st, int& sp) {
  if (op >= Op::abs) {
    double& x = st[sp - 1];
    switch (op) {
      case Op::abs: x = std::fabs(x); break;
      case Op::acos:
        if (x < -1 || x > 1) throw EvalError{"PP-E707", fmt::format("ACOS of {} (outside −1 … 1)", x)};
        x = std::acos(x) / kDeg;
        break;
      case Op::asin:
        if (x < -1 || x > 1) throw EvalError{"PP-E707", fmt::format("ASIN of {} (outside −1 … 1)", x)};
        x = std::asin(x) / kDeg;
        break;
      case Op::atan2: {
        const double xx = st[--sp];
        st[sp - 1] = std::atan2(st[sp - 1], xx) / kDeg;
        break;
      }
      case Op::cos: x = std::cos(x * kDeg); break;
      case Op::exp: x = std::exp(x); break;
      case Op::fix: x = std::floor(x); break;
      case Op::fup: x = std::ceil(x); break;
      case Op::round: x = std::round(x); break;
      case Op::ln:
        if (x <= 0) throw EvalError{"PP-E707", fmt::format("LN of {} (not positive)", x)};
        x = std::log(x);
        break;
      case Op::sin: x = std::sin(x * kDeg); break;
      case Op::sqrt:
        if (x < 0) throw EvalError{"PP-E707", fmt::format("SQRT of {} (negative)", x)};
        x = std::sqrt(x);
        break;
      case Op::tan: x = std::tan(x * kDeg); break;
      default: break;
    }
    return;
  }
  const double b = st[--sp];
  double& a = st[sp - 1];
  switch (op) {
    case Op::add: a += b; break;
    case Op::sub: a -= b; break;
    case Op::mul: a *= b; break;
    case Op::div:
      if (b == 0) throw EvalError{"PP-E707", "division by zero"};
      a /= b;
      break;
    case Op::mod: {
      if (b == 0) throw EvalError{"PP-E707", "MOD by zero"};
      a = std::fmod(a, b);
      if (a < 0) a += std::fabs(b);
      break;
    }
    case Op::pow:
      if (a < 0 && std::floor(b) != b) throw EvalError{"PP-E707", fmt::format("{} ** {} (negative base, fractional power)", a, b)};
      a = std::pow(a, b);
      break;
    case Op::eq: a = std::fabs(a - b) < 1e-6 ? 1 : 0; break;  // rs274ngc's TOLERANCE_EQUAL
    case Op::ne: a = std::fabs(a - b) < 1e-6 ? 0 : 1; break;
    case Op::gt: a = a > b ? 1 : 0; break;
    case Op::ge: a = a >= b ? 1 : 0; break;
    case Op::lt: a = a < b ? 1 : 0; break;
    case Op::le: a = a <= b ? 1 : 0; break;
    case Op::and_: a = (a != 0 && b != 0) ? 1 : 0; break;
    case Op::or_: a = (a != 0 || b != 0) ? 1 : 0; break;
    case Op::xor_: a = ((a != 0) != (b != 0)) ? 1 : 0; break;
    default: break;
  }
}

}  // namespace

}  // namespace postproc::gcode::resolver::lcnc
