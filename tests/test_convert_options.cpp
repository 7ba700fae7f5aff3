// convert --decimals and --units: which words change, how they are written, what is refused.
#include <gtest/gtest.h>

#include <cmath>

#include "convert_run.hpp"

namespace {

using namespace pptest;

gc::ConvertOptions decimals(std::initializer_list<std::pair<char, int>> letters) {
  gc::ConvertOptions o;
  for (auto [L, d] : letters) o.min_decimals[static_cast<std::size_t>(L - 'A')] = static_cast<std::int8_t>(d);
  return o;
}

TEST(ConvertDecimals, PadsShorterLiteralsAndCountsTheRest) {
  const std::string in = "G21 G90\nG0 X1 Y2.5 Z-.5 A10.\nG1 X1.23456 Y2.50000 F100\nG1 X[#1+1] Y3\nM2\n";
  Converted c;
  run_convert("linuxcnc", in, decimals({{'X', 4}, {'Y', 4}, {'Z', 4}, {'A', 3}}), c);
  ASSERT_TRUE(c.committed);
  EXPECT_EQ(c.out, "G21 G90\nG0 X1.0000 Y2.5000 Z-.5000 A10.000\nG1 X1.23456 Y2.50000 F100\nG1 X[#1+1] Y3.0000\nM2\n");
  EXPECT_EQ(c.result.decimals_raised, 5u);
  EXPECT_EQ(c.result.decimals_finer, 2u);      // X1.23456, Y2.50000: precision is never lowered
  EXPECT_EQ(c.result.decimals_expression, 1u); // X[#1+1], warned as PP-U213
  EXPECT_EQ(c.result.changed_blocks, 2u);
  bool warned = false;
  for (const auto& d : c.sink.stored()) warned = warned || (d.code == "PP-U213" && d.where.line == 4);
  EXPECT_TRUE(warned);
}

TEST(ConvertDecimals, SiemensAcArgumentAndUntouchedBlocks) {
  Converted c;
  run_convert("siemens", "N10 G1 X=AC(5) Y2.1234 ; c\nN20 G0 Z100.000\n", decimals({{'X', 3}, {'Y', 3}, {'Z', 3}}), c);
  ASSERT_TRUE(c.committed);
  EXPECT_EQ(c.out, "N10 G1 X=AC(5.000) Y2.1234 ; c\nN20 G0 Z100.000\n");
}

TEST(ConvertUnits, InsertsTheUnitWordAfterTheHeaderWithTheFilesEol) {
  const std::string in = "%\r\nO1000 (PART)\r\n(SETUP)\r\nG0 X10. Y-2.5\r\nM30\r\n%\r\n";
  Converted c;
  run_convert("fanuc", in, units_option(gc::Units::inch), c);
  ASSERT_TRUE(c.committed) << (c.errors.empty() ? "" : c.errors[0].message);
  EXPECT_EQ(c.out, "%\r\nO1000 (PART)\r\n(SETUP)\r\nG20\r\nG0 X0.3937 Y-0.0984\r\nM30\r\n%\r\n");
  EXPECT_EQ(c.result.inserted_lines, 1u);
  Converted mm;
  run_convert("fanuc", in, units_option(gc::Units::mm), mm);
  EXPECT_EQ(mm.out, "%\r\nO1000 (PART)\r\n(SETUP)\r\nG21\r\nG0 X10. Y-2.5\r\nM30\r\n%\r\n");
  Converted heid;
  run_convert("heidenhain-iso", "N10 G0 X25.4 *\n", units_option(gc::Units::inch), heid);
  EXPECT_EQ(heid.out, "G70 *\nN10 G0 X1 *\n");
}

TEST(ConvertUnits, ChangesUnitWordsPerDialect) {
  Converted f;
  run_convert("fanuc", "G21 G90\nG1 X25.4 Y-12.700 F254.\n", units_option(gc::Units::inch), f);
  EXPECT_EQ(f.out, "G20 G90\nG1 X1. Y-0.5000 F10.\n");
  Converted l;
  run_convert("linuxcnc", "g20\ng1 x1 y.5 f10\n", units_option(gc::Units::mm), l);
  EXPECT_EQ(l.out, "g21\ng1 x25.4 y12.7 f254\n");
  // Sinumerik G70/G71 change geometry only; feeds follow G700/G710.
  Converted s;
  run_convert("siemens", "N1 G71\nN2 G1 X25.4 F100\nN3 G710 G1 X50.8 F254\n", units_option(gc::Units::inch), s);
  EXPECT_EQ(s.out, "N1 G70\nN2 G1 X1 F100\nN3 G700 G1 X2 F10\n");
  Converted same;
  run_convert("fanuc", "G21\nG1 X1.5 F100.\n", units_option(gc::Units::mm), same);
  EXPECT_EQ(same.out, "G21\nG1 X1.5 F100.\n");
  EXPECT_EQ(same.result.changed_blocks, 0u);
}

TEST(ConvertUnits, ScalesEveryLengthWordButNotAnglesOrInverseTime) {
  const std::string in =
      "G21 G90 G17\nG0 X0 Y0 Z10.\nG2 X10. Y0 I5. J0 F100.\nG3 X0 Y0 R5.\nG52 X25.4\nG92 X0\n"
      "G99 G83 X1. Y1. Z-5.08 R2.54 Q1.27 F50.8\nG80\nG93 G1 X2.54 A90. F3.\nG94 G4 P500\nG10 L2 P1 X2.54\nM30\n";
  const std::string want =
      "G20 G90 G17\nG0 X0 Y0 Z0.3937\nG2 X0.3937 Y0 I0.1969 J0 F3.937\nG3 X0 Y0 R0.1969\nG52 X1.\nG92 X0\n"
      "G99 G83 X0.0394 Y0.0394 Z-0.2 R0.1 Q0.05 F2.\nG80\nG93 G1 X0.1 A90. F3.\nG94 G4 P500\nG10 L2 P1 X0.1\n"
      "M30\n";
  Converted c;
  run_convert("fanuc", in, units_option(gc::Units::inch), c);
  ASSERT_TRUE(c.committed) << (c.errors.empty() ? "" : c.errors[0].message);
  EXPECT_EQ(c.out, want);
}

/// Interpreted end points of two programs agree within `tol` mm (and arc centres, drill levels).
void expect_same_motions(const Program& a, const Program& b, double tol) {
  ASSERT_EQ(a.motions.size(), b.motions.size()) << a.all_codes() << " | " << b.all_codes();
  for (std::size_t i = 0; i < a.motions.size(); ++i) {
    const gc::Motion &m = a.motions[i], &n = b.motions[i];
    EXPECT_EQ(m.type, n.type) << "motion " << i;
    for (int k = 0; k < gc::kAxisCount; ++k) {
      if (m.known & (1u << k)) {
        EXPECT_NEAR(m.end[k], n.end[k], gc::is_rotary(k) ? 1e-12 : tol) << "motion " << i;
      }
    }
    if (m.type == gc::MotionType::arc_cw || m.type == gc::MotionType::arc_ccw) {
      EXPECT_LE((m.arc.centre - n.arc.centre).norm(), 4 * tol) << "motion " << i;  // R arcs amplify
    }
    if (m.type == gc::MotionType::drill_cycle) {
      EXPECT_NEAR(m.cycle_r, n.cycle_r, tol);
      EXPECT_NEAR(m.cycle_bottom, n.cycle_bottom, tol);
    }
    if (m.feed_known && m.feed_mode != gc::FeedMode::inverse_time) {
      EXPECT_NEAR(m.feed, n.feed, 1e-4 * m.feed);
    }
  }
}

TEST(ConvertUnits, RoundTripReproducesPositionsWithinThePrintedResolution) {
  std::string in = "%\nO1234\nG21 G90 G17 G94\nG0 X12.345 Y-67.891 Z25.\nG1 Z-1.234 F350.\n";
  in += "G2 X32.345 Y-67.891 I10. J0\nG3 X22.345 Y-57.891 R10.\nG91 G1 X0.013 Y-0.007\n";
  for (int i = 0; i < 150; ++i) in += "X0.013 Y0.007\n";  // rounding of increments must not add up
  in += "G3 X-5.5 Y5.5 I-5.5 J0\nG90 G0 Z5.\nG98 G81 X1.111 Y2.222 Z-3.333 R1.\nX4.444\nG80\nM30\n%\n";
  const gc::Dialect d = dialect("fanuc");
  Converted inch;
  run_convert("fanuc", in, units_option(gc::Units::inch), inch);
  ASSERT_TRUE(inch.committed) << (inch.errors.empty() ? "" : inch.errors[0].message);
  Converted back;
  run_convert("fanuc", inch.out, units_option(gc::Units::mm), back);
  ASSERT_TRUE(back.committed) << (back.errors.empty() ? "" : back.errors[0].message);
  const Program original(d, in), converted(d, inch.out), returned(d, back.out);
  // Every inch value has at least 4 decimals: within half of 0.0001 in.
  const double half_digit = 0.5e-4 * 25.4;
  expect_same_motions(original, converted, half_digit + 1e-9);
  expect_same_motions(original, returned, half_digit + 1e-9);
  EXPECT_NE(inch.out.find("G20"), std::string::npos);
  EXPECT_NE(back.out.find("G21"), std::string::npos);
}

TEST(ConvertUnits, RefusesWhatItCannotConvertExactly) {
  struct Case {
    const char* dialect;
    bool lathe;
    const char* program;
    std::uint64_t line;
  };
  const Case cases[] = {
      {"fanuc", false, "G21\n#1=5.\nG1 X1.\n", 2},              // parameter assignment
      {"fanuc", false, "G21\nG1 X#1\n", 2},                     // parameter as a length
      {"linuxcnc", false, "G21\nG1 X[1+2] F100\n", 2},          // expression
      {"fanuc", true, "G21\nG71 U2. R1.\n", 2},                 // turning cycle
      {"siemens", false, "G71\nN10 CYCLE83(10,0,1,-20)\n", 2},  // cycle arguments
      {"fanuc", false, "G21\nG1 X10. Q5.\n", 2},                // Q of unknown meaning
      {"fanuc", false, "G21\nG96 S200\n", 2},                   // surface speed m/min
      {"fanuc", false, "G21\nM98 P100\n", 2},                   // subprogram call
      {"fanuc", false, "G21\nIF [#1 GT 2.] GOTO 10\n", 2},      // control flow
  };
  for (const auto& k : cases) {
    Converted c;
    run_convert(k.dialect, k.program, units_option(gc::Units::inch), c, k.lathe);
    EXPECT_TRUE(c.refused_with("PP-E502")) << k.program;
    EXPECT_TRUE(c.error_on_line(k.line)) << k.program;
    EXPECT_TRUE(c.out.empty()) << k.program;
  }
  // The same constructs in a program that is already in the target units need no conversion.
  Converted same;
  run_convert("fanuc", "G20\n#1=5.\nG1 X#1\n", units_option(gc::Units::inch), same);
  EXPECT_TRUE(same.committed);
}

TEST(ConvertUnits, RefusesWhenTheConvertedArcNoLongerCloses) {
  // The arc's start and end radius differ by 0.004 mm: within the interpreter's tolerance in inches
  // (0.00508 mm), beyond it in mm (0.002 mm and 0.1 %), so the converted program would be refused.
  const std::string in = "G20 G90 G17\nG0 X0 Y0\nG2 X0.20016 Y0 I0.1 J0 F10.\nM30\n";
  Converted c;
  run_convert("fanuc", in, units_option(gc::Units::mm), c);
  ASSERT_TRUE(c.refused_with("PP-E502"));
  EXPECT_TRUE(c.error_on_line(3));
  EXPECT_NE(c.errors[0].message.find("PP-E301"), std::string::npos);
}


TEST(ConvertUnits, FanucWholeNumbersFollowTheIntegerInputSetting) {
  using In = gc::Dialect::IntegerInput;
  const std::string in = "G21\nG1 X100 Y2.5 F100.\n";
  Converted unknown;
  run_convert(fanuc_input(In::unknown), in, units_option(gc::Units::inch), unknown);
  EXPECT_TRUE(unknown.refused_with("PP-E502"));  // X100 is 0.1 mm or 100 mm: not guessed
  EXPECT_TRUE(unknown.error_on_line(2));
  Converted increment;
  run_convert(fanuc_input(In::increment), in, units_option(gc::Units::inch), increment);
  EXPECT_EQ(increment.out, "G20\nG1 X0.0039 Y0.0984 F3.937\n");  // 0.1 mm
  Converted calculator;
  run_convert(fanuc_input(In::calculator), in, units_option(gc::Units::inch), calculator);
  EXPECT_EQ(calculator.out, "G20\nG1 X3.937 Y0.0984 F3.937\n");  // 100 mm
}

TEST(ConvertDecimals, FanucWholeNumbersKeepTheirValue) {
  using In = gc::Dialect::IntegerInput;
  const std::string in = "G1 X100 Y2.5 Z0\n";
  const auto opt = decimals({{'X', 4}, {'Y', 4}, {'Z', 4}});
  Converted unknown;
  run_convert(fanuc_input(In::unknown), in, opt, unknown);
  EXPECT_EQ(unknown.out, "G1 X100 Y2.5000 Z0.0000\n");  // left as written: its value is not known
  EXPECT_EQ(unknown.result.decimals_integer, 1u);
  Converted increment;
  run_convert(fanuc_input(In::increment), in, opt, increment);
  EXPECT_EQ(increment.out, "G1 X0.1000 Y2.5000 Z0.0000\n");
  Converted calculator;
  run_convert(fanuc_input(In::calculator), in, opt, calculator);
  EXPECT_EQ(calculator.out, "G1 X100.0000 Y2.5000 Z0.0000\n");
}

}  // namespace
