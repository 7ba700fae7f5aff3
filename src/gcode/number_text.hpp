#pragma once
// Scanning and parsing of NC number literals ([+-]digits[.digits]); shared by lexer and writer.
// The common case (≤ 15 significant digits, ≤ 22 decimals) is converted exactly with one division
// (both operands are exact doubles, so the quotient is correctly rounded); anything else falls
// back to std::from_chars.
#include <charconv>
#include <cstdint>
#include <string_view>

namespace postproc::gcode {

inline constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                    1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

/// Scans a literal at `j` and converts it. Returns the end, or `j` if there is no literal (a literal
/// needs at least one digit). `out` is set only when a literal was found; `has_point` (optional)
/// tells whether it was written with a decimal point.
[[gnu::always_inline]] inline std::uint32_t lex_number(std::string_view s, std::uint32_t j, bool allow_space_after_sign,
                                                      double& out, bool* has_point = nullptr) {
  const char* const base = s.data();
  const char* const end = base + s.size();
  const char* c = base + j;
  bool neg = false;
  if (c < end && (*c == '+' || *c == '-')) {
    neg = *c == '-';
    ++c;
    if (allow_space_after_sign)
      while (c < end && (*c == ' ' || *c == '\t')) ++c;
  }
  const char* const digits_begin = c;
  // Signed accumulator: converts to double in one instruction; ≤ 15 digits cannot overflow it.
  std::int64_t mant = 0;
  while (c < end && static_cast<unsigned>(*c - '0') < 10u) mant = mant * 10 + (*c++ - '0');
  const char* const int_end = c;
  long decimals = 0;
  const bool point = c < end && *c == '.';
  if (point) {
    const char* const frac_begin = ++c;
    while (c < end && static_cast<unsigned>(*c - '0') < 10u) mant = mant * 10 + (*c++ - '0');
    decimals = c - frac_begin;
  }
  const long digits = (int_end - digits_begin) + decimals;
  if (digits == 0) return j;
  double v;
  if (digits <= 15 && decimals <= 22) {
    v = static_cast<double>(mant) / kPow10[decimals];  // both exact: one correctly rounded division
  } else {
    const char* last = c;
    if (last[-1] == '.') --last;
    if (digits_begin == last || std::from_chars(digits_begin, last, v).ec != std::errc()) return j;
  }
  if (has_point) *has_point = point;
  out = neg ? -v : v;
  return static_cast<std::uint32_t>(c - base);
}

/// End of the number literal starting at `j` in `s`, or `j` if there is none.
inline std::uint32_t scan_number(std::string_view s, std::uint32_t j, bool allow_space_after_sign) {
  double ignored = 0;
  return lex_number(s, j, allow_space_after_sign, ignored);
}

/// Parses a text that must be exactly one literal.
inline bool parse_number(std::string_view t, double& out) {
  return !t.empty() && lex_number(t, 0, true, out) == t.size();
}

}  // namespace postproc::gcode
