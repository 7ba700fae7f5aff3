// Number literal styles: detection from source text and formatting of new values.
#include "postproc/gcode/number_style.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "src/gcode/number_text.hpp"

namespace postproc::gcode {
namespace {

constexpr bool is_digit(char c) { return c >= '0' && c <= '9'; }

/// Skips address letters, '=' and blanks in front of a literal.
std::string_view strip_address(std::string_view s) {
  std::size_t i = 0;
  while (i < s.size() && ((s[i] >= 'A' && s[i] <= 'Z') || (s[i] >= 'a' && s[i] <= 'z') || s[i] == '=' ||
                          s[i] == ' ' || s[i] == '\t'))
    ++i;
  return s.substr(i);
}

/// A literal split into its parts; blanks (LinuxCNC "- 1.5") are dropped.
struct Parts {
  bool negative = false;
  bool plus = false;
  std::string_view int_digits;   ///< views into the literal (digits are contiguous)
  std::string_view frac_digits;
  bool point = false;
};

bool split(std::string_view s, Parts& p) {
  std::size_t i = 0;
  auto skip_blanks = [&] {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
  };
  skip_blanks();
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) {
    p.negative = s[i] == '-';
    p.plus = s[i] == '+';
    ++i;
    skip_blanks();
  }
  const std::size_t int_begin = i;
  while (i < s.size() && is_digit(s[i])) ++i;
  p.int_digits = s.substr(int_begin, i - int_begin);
  if (i < s.size() && s[i] == '.') {
    p.point = true;
    ++i;
    const std::size_t frac_begin = i;
    while (i < s.size() && is_digit(s[i])) ++i;
    p.frac_digits = s.substr(frac_begin, i - frac_begin);
  }
  skip_blanks();
  return i == s.size() && !(p.int_digits.empty() && p.frac_digits.empty());
}

/// Applies the style to a fixed-precision rendering (sign, integer digits, fraction digits).
std::string finish(bool negative, std::string_view int_digits, std::string_view frac, const NumberStyle& st,
                   bool point_required) {
  if (!st.trailing_zeros)
    while (!frac.empty() && frac.back() == '0') frac.remove_suffix(1);
  const bool zero = int_digits.find_first_not_of('0') == std::string_view::npos &&
                    frac.find_first_not_of('0') == std::string_view::npos;
  if (zero) negative = false;  // never "-0"
  if (int_digits.empty()) int_digits = "0";
  if (!st.leading_zero && !frac.empty() && int_digits == "0") int_digits = {};
  std::string out;
  out.reserve(int_digits.size() + frac.size() + 3);
  if (negative) {
    out += '-';
  } else if (st.plus_sign) {
    out += '+';
  }
  out += int_digits;
  if (!frac.empty()) {
    out += '.';
    out += frac;
  } else if (point_required || st.trailing_point) {
    out += '.';
  }
  return out;
}

}  // namespace

NumberStyle detect_style(std::string_view literal) {
  NumberStyle st;
  Parts p;
  if (!split(strip_address(literal), p)) return st;
  st.plus_sign = p.plus;
  st.leading_zero = !p.int_digits.empty();
  st.decimals = static_cast<int>(p.frac_digits.size());
  st.trailing_point = p.point && p.frac_digits.empty();
  st.trailing_zeros = !p.frac_digits.empty() && p.frac_digits.back() == '0';
  return st;
}

std::string format_number(double v, const NumberStyle& src, int min_decimals, bool decimal_point_required) {
  const int d = std::max(src.decimals, min_decimals);
  // fmt rounds the exact binary value correctly; only the text is post-processed.
  const std::string fixed = fmt::format("{:.{}f}", std::abs(v), d);
  const std::string_view f(fixed);
  const auto dot = f.find('.');
  return finish(std::signbit(v), f.substr(0, dot), dot == std::string_view::npos ? std::string_view() : f.substr(dot + 1),
                src, decimal_point_required);
}

std::string format_counts(std::int64_t counts, int decimals, const NumberStyle& src, bool decimal_point_required) {
  const bool negative = counts < 0;
  // Magnitude as unsigned so that INT64_MIN does not overflow.
  const std::uint64_t mag = negative ? std::uint64_t{0} - static_cast<std::uint64_t>(counts)
                                     : static_cast<std::uint64_t>(counts);
  char buf[24];
  const auto written = std::to_chars(buf, buf + sizeof buf, mag);
  std::string_view digits(buf, static_cast<std::size_t>(written.ptr - buf));
  const auto d = static_cast<std::size_t>(std::max(decimals, 0));
  std::string padded;
  if (digits.size() <= d) {
    padded.assign(d + 1 - digits.size(), '0');
    padded += digits;
    digits = padded;
  }
  return finish(negative, digits.substr(0, digits.size() - d), digits.substr(digits.size() - d), src,
                decimal_point_required);
}

bool literal_counts(std::string_view literal, int decimals, std::int64_t& out) {
  Parts p;
  if (decimals < 0 || !split(literal, p)) return false;
  const auto d = static_cast<std::size_t>(decimals);
  std::string_view frac = p.frac_digits;
  // Digits beyond the requested precision must be zeros, or the value is not a whole count.
  if (frac.size() > d) {
    if (frac.find_first_not_of('0', d) != std::string_view::npos) return false;
    frac = frac.substr(0, d);
  }
  // The integer digits, the fraction digits and zeros up to `decimals` places: at most 18
  // significant digits (leading zeros do not count).
  std::int64_t v = 0;
  std::size_t significant = 0;
  const auto digit = [&](char c) {
    if (significant == 0 && c == '0') return;
    if (++significant <= 18) v = v * 10 + (c - '0');
  };
  for (char c : p.int_digits) digit(c);
  for (char c : frac) digit(c);
  for (std::size_t k = frac.size(); k < d && significant <= 18; ++k) digit('0');
  if (significant > 18) return false;
  out = p.negative ? -v : v;
  return true;
}

std::string pad_decimals(std::string_view literal, int decimals) {
  std::string out(literal);
  while (!out.empty() && (out.back() == ' ' || out.back() == '\t')) out.pop_back();
  const auto dot = out.find('.');
  const int have = dot == std::string::npos ? 0 : static_cast<int>(out.size() - dot - 1);
  if (have >= decimals) return out;
  if (dot == std::string::npos) out += '.';
  out.append(static_cast<std::size_t>(decimals - have), '0');
  return out;
}

bool represents(std::string_view text, double v, double tol) {
  std::string compact;
  for (char c : strip_address(text))
    if (c != ' ' && c != '\t') compact += c;
  double x = 0;
  return parse_number(compact, x) && std::abs(x - v) <= tol;
}

}  // namespace postproc::gcode
