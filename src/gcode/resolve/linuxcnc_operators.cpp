// rs274ngc operators and functions of the LinuxCNC resolver: degrees for trigonometry, rs274ngc's
// equality tolerance, and the arithmetic errors LinuxCNC stops on (PP-E707).
//
// Matched bit for bit against rs274 2.9 on x86-64 (tests/rs274_expression_compare.py): the
// trigonometric functions run in long double with rs274's long-double π ((x · π) / 180, then
// rounded to double), so SIN[30] is 0.5 and ACOS[0.5] is 60 exactly, as on the control (FIX, FUP,
// ROUND and MOD of such values then agree); EQ / NE compare within 0.0001; ROUND adds ±0.5 and
// truncates.
#include <cmath>
#include <limits>

#include "src/gcode/resolve/linuxcnc_expr.hpp"

namespace postproc::gcode::resolver::lcnc {
namespace {
constexpr long double kPi = 3.141592653589793238462643383279502884L;
/// rs274ngc's TOLERANCE_EQUAL: EQ is |a − b| < 0.0001 (rs274 2.9: 1 EQ 1.00005 is 1, 0 EQ 0.0001 is 0).
constexpr double kToleranceEqual = 0.0001;

double from_degrees(double deg, long double (*f)(long double)) {
  return static_cast<double>(f(static_cast<long double>(deg) * kPi / 180.0L));
}
double to_degrees(long double rad) { return static_cast<double>(rad * 180.0L / kPi); }
long double sin_l(long double v) { return std::sin(v); }
long double cos_l(long double v) { return std::cos(v); }
long double tan_l(long double v) { return std::tan(v); }

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
        x = to_degrees(std::acos(static_cast<long double>(x)));
        break;
      case Op::asin:
        if (x < -1 || x > 1) throw EvalError{"PP-E707", fmt::format("ASIN of {} (outside −1 … 1)", x)};
        x = to_degrees(std::asin(static_cast<long double>(x)));
        break;
      case Op::atan2: {
        const double xx = st[--sp];
        st[sp - 1] = to_degrees(std::atan2(static_cast<long double>(st[sp - 1]), static_cast<long double>(xx)));
        break;
      }
      case Op::cos: x = from_degrees(x, cos_l); break;
      case Op::exp: x = std::exp(x); break;
      case Op::fix: x = std::floor(x); break;
      case Op::fup: x = std::ceil(x); break;
      case Op::round: {
        // rs274ngc: (int)(x ± 0.5), so ROUND[0.49999999999999994] is 1 (the sum rounds up to 1.0).
        const double r = std::trunc(x + (x < 0 ? -0.5 : 0.5));
        if (r > std::numeric_limits<int>::max() || r < std::numeric_limits<int>::min())
          throw EvalError{"PP-E707", fmt::format("ROUND of {} (beyond ±2147483647, where LinuxCNC's integer "
                                                 "conversion has no defined result)", x)};
        x = r;
        break;
      }
      case Op::ln:
        if (x <= 0) throw EvalError{"PP-E707", fmt::format("LN of {} (not positive)", x)};
        x = std::log(x);
        break;
      case Op::sin: x = from_degrees(x, sin_l); break;
      case Op::sqrt:
        if (x < 0) throw EvalError{"PP-E707", fmt::format("SQRT of {} (negative)", x)};
        x = std::sqrt(x);
        break;
      case Op::tan: x = from_degrees(x, tan_l); break;
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
    case Op::eq: a = std::fabs(a - b) < kToleranceEqual ? 1 : 0; break;
    case Op::ne: a = std::fabs(a - b) < kToleranceEqual ? 0 : 1; break;
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
