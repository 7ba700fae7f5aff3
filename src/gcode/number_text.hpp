#pragma once
// Scanning and parsing of NC number literals ([+-]digits[.digits]); shared by lexer and writer.
// The common case (≤ 15 significant digits, ≤ 22 decimals) is converted exactly with one division
// (both operands are exact doubles, so the quotient is correctly rounded); anything else falls
// back to std::from_chars (correctly rounded for any number of digits). A literal beyond the range
// of a double reads as ±infinity (the lexer refuses it, PP-E205); one below the smallest
// subnormal reads as ±0, its correctly rounded value.
#include <charconv>
#include <cstdint>
#include <limits>
#include <string_view>

namespace postproc::gcode {

inline constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                    1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

/// Scans a literal at `j` and converts it. Returns the end, or `j` if there is no literal (a literal
/// needs at least one digit). Any digit string is read without overflow (±inf beyond ±1.8e308). `out` is set only when a literal was found; `has_point` (optional)
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
  // Unsigned accumulator (wraps, never overflows: its value is used only for ≤ 15 digits, which it
  // holds exactly); converted through int64 (one instruction).
  std::uint64_t mant = 0;
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
    v = static_cast<double>(static_cast<std::int64_t>(mant)) / kPow10[decimals];  // both exact: one correctly rounded division
  } else {
    const char* last = c;
    if (last[-1] == '.') --last;
    if (digits_begin == last) return j;
    const std::from_chars_result r = std::from_chars(digits_begin, last, v, std::chars_format::fixed);
    if (r.ec == std::errc::result_out_of_range) {
      // Too large, or too small for a subnormal: ±inf when a digit before the point is non-zero.
      bool large = false;
      for (const char* k = digits_begin; k < int_end; ++k) large = large || *k != '0';
      v = large ? std::numeric_limits<double>::infinity() : 0.0;
    } else if (r.ec != std::errc() || r.ptr != last) {
      return j;
    }
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
