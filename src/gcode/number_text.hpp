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
/// needs at least one digit). `out` is set only when a literal was found.
inline std::uint32_t lex_number(std::string_view s, std::uint32_t j, bool allow_space_after_sign, double& out,
                                bool* has_point = nullptr) {
  const auto n = static_cast<std::uint32_t>(s.size());
  std::uint32_t k = j;
  bool neg = false;
  if (k < n && (s[k] == '+' || s[k] == '-')) {
    neg = s[k] == '-';
    ++k;
    if (allow_space_after_sign)
      while (k < n && (s[k] == ' ' || s[k] == '\t')) ++k;
  }
  const std::uint32_t digits_begin = k;
  std::uint64_t mant = 0;
  const char* p = s.data();
  std::uint32_t int_end = k;
  while (int_end < n && static_cast<unsigned>(p[int_end] - '0') < 10u) {
    mant = mant * 10 + static_cast<std::uint64_t>(p[int_end] - '0');
    ++int_end;
  }
  k = int_end;
  std::uint32_t decimals = 0;
  if (has_point) *has_point = k < n && p[k] == '.';
  if (k < n && p[k] == '.') {
    ++k;
    const std::uint32_t frac_begin = k;
    while (k < n && static_cast<unsigned>(p[k] - '0') < 10u) {
      mant = mant * 10 + static_cast<std::uint64_t>(p[k] - '0');
      ++k;
    }
    decimals = k - frac_begin;
  }
  const std::uint32_t digits = (int_end - digits_begin) + decimals;
  if (digits == 0) return j;
  double v;
  // Exact when the mantissa fits in 53 bits (no overflow: ≤ 19 digits) and 10^decimals is exact.
  if (digits <= 19 && mant <= (std::uint64_t{1} << 53) && decimals <= 22) {
    v = static_cast<double>(mant) / kPow10[decimals];
  } else {
    const char* first = p + digits_begin;
    const char* last = p + k;
    if (last[-1] == '.') --last;
    if (first == last || std::from_chars(first, last, v).ec != std::errc()) return j;
  }
  out = neg ? -v : v;
  return k;
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
