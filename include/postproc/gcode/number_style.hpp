#pragma once
/// @file
/// How an NC number literal is written — sign, leading zero, decimals, trailing point, trailing
/// zeros — detected from the source text, and formatting of new values in the same style, so a
/// rewritten word looks like its neighbours and keeps its meaning on the control (Fanuc reads a
/// whole number without a point as increments: X10 = 10 µm, X10. = 10 mm).

#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>

namespace postproc::gcode {

/// The written form of one literal.
struct NumberStyle {
  bool plus_sign = false;       ///< "+3": non-negative values carry an explicit '+'
  bool leading_zero = true;     ///< false for ".5" / "-.5"
  int decimals = 0;             ///< digits written after the point ("-49.650" → 3, "10." → 0)
  bool trailing_point = false;  ///< "10.": a point with no digit after it
  bool trailing_zeros = false;  ///< "-49.650": fixed width; a trailing zero was written
};

/// Style of a literal. Leading address letters, '=' and blanks are skipped, so "X-49.650",
/// "-49.650" and "X=10." work alike. Text without digits gives the default style.
[[nodiscard]] NumberStyle detect_style(std::string_view literal);

/// Formats `v` (program units) in the style `src` with max(src.decimals, min_decimals) decimals,
/// correctly rounded. Trailing zeros are trimmed unless `src.trailing_zeros` (then fixed width);
/// never "-0"; '+' kept if the source had one; ".5" if the source omitted the leading zero; a
/// point is written on whole numbers when `decimal_point_required` or the source wrote "10.".
[[nodiscard]] std::string format_number(double v, const NumberStyle& src, int min_decimals,
                                        bool decimal_point_required);

/// Formats the exact decimal counts·10^-decimals in the style `src` (the style's own decimals are
/// ignored: `decimals` is the precision). No floating point is involved, so sums of printed
/// values are exact.
[[nodiscard]] std::string format_counts(std::int64_t counts, int decimals, const NumberStyle& src,
                                        bool decimal_point_required);

/// The literal's value in units of 10^-decimals, exactly. False when the text is not a plain
/// literal, has non-zero digits beyond `decimals`, or does not fit in 18 digits.
[[nodiscard]] bool literal_counts(std::string_view literal, int decimals, std::int64_t& out);

/// Writes `literal` with at least `decimals` decimals by appending a point and zeros; the digits
/// written stay as they are, so the value is unchanged ("10" → "10.0000", "-.5" → "-.5000").
[[nodiscard]] std::string pad_decimals(std::string_view literal, int decimals);

/// True when `text` (a literal, optionally after an address letter) reads as a value within `tol`
/// of `v`. For tests and checks.
[[nodiscard]] bool represents(std::string_view text, double v, double tol);

/// 10^n, the scale of n output decimals: exact table values for 0 ≤ n ≤ 22 (what std::pow gives
/// there, without its cost in the per-word paths), std::pow otherwise.
[[nodiscard]] inline double decimal_scale(int n) {
  static constexpr double kPowers[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                       1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  return n >= 0 && n <= 22 ? kPowers[n] : std::pow(10.0, n);
}

}  // namespace postproc::gcode
