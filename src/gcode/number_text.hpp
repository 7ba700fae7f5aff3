#pragma once
// Scanning and parsing of NC number literals ([+-]digits[.digits]); shared by lexer and writer.
#include <charconv>
#include <cstdint>
#include <string_view>

namespace postproc::gcode {

/// End of the number literal starting at `j` in `s`, or `j` if there is none. A literal is an
/// optional sign, digits, and an optional '.' with digits; at least one digit is required.
inline std::uint32_t scan_number(std::string_view s, std::uint32_t j, bool allow_space_after_sign) {
  const auto n = static_cast<std::uint32_t>(s.size());
  std::uint32_t k = j;
  if (k < n && (s[k] == '+' || s[k] == '-')) {
    ++k;
    if (allow_space_after_sign)
      while (k < n && (s[k] == ' ' || s[k] == '\t')) ++k;
  }
  std::uint32_t digits = 0;
  while (k < n && s[k] >= '0' && s[k] <= '9') { ++k; ++digits; }
  if (k < n && s[k] == '.') {
    ++k;
    while (k < n && s[k] >= '0' && s[k] <= '9') { ++k; ++digits; }
  }
  return digits == 0 ? j : k;
}

/// Parses a literal accepted by scan_number (spaces after the sign are skipped).
inline bool parse_number(std::string_view t, double& out) {
  bool neg = false;
  std::size_t k = 0;
  if (k < t.size() && (t[k] == '+' || t[k] == '-')) {
    neg = t[k] == '-';
    ++k;
    while (k < t.size() && (t[k] == ' ' || t[k] == '\t')) ++k;
  }
  double v = 0;
  const char* first = t.data() + k;
  const char* last = t.data() + t.size();
  // from_chars rejects "5." on some libraries; strip a trailing point, the value is the same.
  if (last > first && last[-1] == '.') --last;
  if (first == last) return false;
  auto r = std::from_chars(first, last, v);
  if (r.ec != std::errc() || r.ptr != last) return false;
  out = neg ? -v : v;
  return true;
}

}  // namespace postproc::gcode
