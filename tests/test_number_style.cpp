// Number styles: detection from source literals, formatting of new values in the same style.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "postproc/gcode/number_style.hpp"
#include "src/gcode/number_text.hpp"

namespace {

namespace gc = postproc::gcode;

struct StyleCase {
  const char* text;
  bool plus, leading_zero;
  int decimals;
  bool trailing_point, trailing_zeros;
};

TEST(NumberStyle, DetectsFromLiterals) {
  const StyleCase cases[] = {
      {"X-49.650", false, true, 3, false, true}, {"-49.65", false, true, 2, false, false},
      {".5", false, false, 1, false, false},     {"-.25", false, false, 2, false, false},
      {"10.", false, true, 0, true, false},      {"+3", true, true, 0, false, false},
      {"10", false, true, 0, false, false},      {"X=10.0", false, true, 1, false, true},
      {"0.000", false, true, 3, false, true},    {" - 1.5", false, true, 1, false, false},
      {"Y+.125", true, false, 3, false, false},
  };
  for (const auto& c : cases) {
    const gc::NumberStyle s = gc::detect_style(c.text);
    EXPECT_EQ(s.plus_sign, c.plus) << c.text;
    EXPECT_EQ(s.leading_zero, c.leading_zero) << c.text;
    EXPECT_EQ(s.decimals, c.decimals) << c.text;
    EXPECT_EQ(s.trailing_point, c.trailing_point) << c.text;
    EXPECT_EQ(s.trailing_zeros, c.trailing_zeros) << c.text;
  }
}

struct FormatCase {
  double v;
  const char* style;
  int min_decimals;
  bool point_required;
  const char* want;
};

TEST(NumberStyle, FormatsInTheSourceStyle) {
  const FormatCase cases[] = {
      {1.5, "-49.650", 0, false, "1.500"},        // fixed width kept
      {1.5, "-49.65", 0, false, "1.5"},           // trimmed
      {1.23456, "1.5", 3, false, "1.235"},        // precision raised to min_decimals
      {1.23456, "1.5000", 2, false, "1.2346"},    // never lowered below the source's
      {-0.0001, "1.000", 0, false, "0.000"},      // never "-0"
      {-0.0004, "1.5", 3, false, "0"},
      {-0.0004, "1.5", 3, true, "0."},
      {0.5, ".25", 0, false, ".5"},               // leading zero omitted as in the source
      {-0.5, ".25", 0, false, "-.5"},
      {2.5, ".25", 0, false, "2.5"},
      {10, "10.", 0, false, "10."},               // the source wrote a trailing point
      {10, "10", 0, false, "10"},
      {10, "10", 3, true, "10."},                 // Fanuc: X10 would be 10 µm
      {10.25, "10", 0, true, "10."},              // 0 decimals: rounded (ties to even on the binary value)
      {3, "+3", 0, false, "+3"},
      {-3, "+3", 0, false, "-3"},
      {2.675, "1.00", 0, false, "2.67"},          // 2.675 is 2.67499999… in binary: correct rounding
      {1.0005, "1.000", 0, false, "1.000"},       // 1.000499999…
      {123456.78949, "1.5", 3, false, "123456.789"},
      {-0.00049, "1.000", 0, false, "0.000"},
  };
  for (const auto& c : cases)
    EXPECT_EQ(gc::format_number(c.v, gc::detect_style(c.style), c.min_decimals, c.point_required), c.want)
        << c.v << " in style " << c.style;
}

TEST(NumberStyle, FormattedValuesReadBackWithinHalfADigit) {
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<double> value(-2000.0, 2000.0);
  const char* styles[] = {"1.5", "-49.650", ".5", "10.", "+3", "10", "0.0001"};
  for (int i = 0; i < 20000; ++i) {
    const double v = value(rng) / (i % 7 == 0 ? 1000.0 : 1.0);
    const char* st = styles[i % 7];
    const int min = i % 5;
    const gc::NumberStyle s = gc::detect_style(st);
    const std::string text = gc::format_number(v, s, min, i % 2 == 0);
    const int d = std::max(s.decimals, min);
    EXPECT_TRUE(gc::represents(text, v, 0.5 * std::pow(10.0, -d) * (1 + 1e-9) + 1e-12))
        << v << " → " << text << " (" << d << " decimals)";
    if (!text.empty() && text[0] == '-') {
      EXPECT_FALSE(gc::represents(text, 0.0, 0.0)) << "negative zero " << text;
    }
  }
}

TEST(NumberStyle, FormatsExactCounts) {
  const gc::NumberStyle trimmed = gc::detect_style("1.5");
  const gc::NumberStyle fixed = gc::detect_style("1.000");
  const gc::NumberStyle bare = gc::detect_style(".5");
  EXPECT_EQ(gc::format_counts(12345, 3, trimmed, false), "12.345");
  EXPECT_EQ(gc::format_counts(12300, 3, trimmed, false), "12.3");
  EXPECT_EQ(gc::format_counts(12000, 3, trimmed, false), "12");
  EXPECT_EQ(gc::format_counts(12000, 3, trimmed, true), "12.");
  EXPECT_EQ(gc::format_counts(12000, 3, fixed, false), "12.000");
  EXPECT_EQ(gc::format_counts(-500, 3, bare, false), "-.5");
  EXPECT_EQ(gc::format_counts(-1, 4, trimmed, false), "-0.0001");
  EXPECT_EQ(gc::format_counts(0, 3, fixed, false), "0.000");
  EXPECT_EQ(gc::format_counts(7, 0, gc::detect_style("+3"), false), "+7");
  EXPECT_EQ(gc::format_counts(INT64_MIN, 0, trimmed, false), "-9223372036854775808");
}

TEST(NumberStyle, ReadsLiteralsAsExactCounts) {
  std::int64_t c = 0;
  ASSERT_TRUE(gc::literal_counts("-12.5", 3, c));
  EXPECT_EQ(c, -12500);
  ASSERT_TRUE(gc::literal_counts("12.3450", 3, c));
  EXPECT_EQ(c, 12345);
  EXPECT_FALSE(gc::literal_counts("12.3456", 3, c));  // does not fit the precision
  ASSERT_TRUE(gc::literal_counts(".5", 1, c));
  EXPECT_EQ(c, 5);
  ASSERT_TRUE(gc::literal_counts("10.", 0, c));
  EXPECT_EQ(c, 10);
  ASSERT_TRUE(gc::literal_counts("+3", 3, c));
  EXPECT_EQ(c, 3000);
  ASSERT_TRUE(gc::literal_counts("- 1.5", 2, c));  // LinuxCNC allows a blank after the sign
  EXPECT_EQ(c, -150);
  EXPECT_FALSE(gc::literal_counts("[#1]", 3, c));
  EXPECT_FALSE(gc::literal_counts("1234567890123456789", 3, c));
}

TEST(NumberStyle, PadsDecimalsWithoutChangingDigits) {
  EXPECT_EQ(gc::pad_decimals("10", 4), "10.0000");
  EXPECT_EQ(gc::pad_decimals("-.5", 4), "-.5000");
  EXPECT_EQ(gc::pad_decimals("10.", 4), "10.0000");
  EXPECT_EQ(gc::pad_decimals("+1.25", 3), "+1.250");
  EXPECT_EQ(gc::pad_decimals("1.23456", 4), "1.23456");  // already finer: unchanged
  EXPECT_EQ(gc::pad_decimals("- 1.5", 2), "- 1.50");
}

TEST(NumberStyle, Represents) {
  EXPECT_TRUE(gc::represents("X10.5", 10.5, 0));
  EXPECT_TRUE(gc::represents("-.25", -0.25, 0));
  EXPECT_TRUE(gc::represents("10.5", 10.6, 0.11));
  EXPECT_FALSE(gc::represents("10.5", 10.6, 0.01));
  EXPECT_FALSE(gc::represents("X[#1]", 1, 1));
}

}  // namespace
