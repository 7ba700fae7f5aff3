// convert(): identity is byte for byte; --strip-comments and --renumber touch only what they must.
#include <gtest/gtest.h>

#include "postproc/gcode/convert.hpp"
#include "convert_run.hpp"
#include "support.hpp"

namespace {

using namespace pptest;

/// Runs convert() from memory into a temp file; commits only when there is no error, as the CLI does.
void convert(const std::string& name, const std::string& input, const gc::ConvertOptions& opt, Converted& c,
             bool lathe = false) {
  run_convert(dialect(name, lathe), input, opt, c);
  EXPECT_EQ(c.leftover, c.committed ? std::vector<std::string>{"out.nc"} : std::vector<std::string>{});
}

gc::ConvertOptions strip() {
  gc::ConvertOptions o;
  o.strip_comments = true;
  return o;
}
gc::ConvertOptions renumber(std::uint64_t start, std::uint64_t step) {
  gc::ConvertOptions o;
  o.renumber_start = start;
  o.renumber_step = step;
  return o;
}

TEST(Convert, IdentityIsByteForByte) {
  const std::vector<std::pair<std::string, std::string>> programs = {
      {"fanuc", "%\r\nO1000 (MAIN)\r\nN10 G0 X1.  Y.5 \t\r\n\r\n/2 G1 X-0.250 F+3\rM30\n%"},
      {"fanuc", "CAM LISTING LINE\n  another (leader) line\n%\nO1\nG0 X1\nM30\n%\n"},
      {"siemens", "%_N_A_MPF\n;$PATH=/_N_WKS_DIR\nN10 TRAORI\nN20 G1 X=AC(5) CR=5 ; c\nR1=5 DEF REAL A=1\n"},
      {"linuxcnc", "o100 sub\n  G 1 X 1.5 (c) ; d\no100 endsub\n#<a>=[1+2]\nM2"},
      {"heidenhain-iso", "N10 G01 X+10 Y-5 F200 *\n; note\n"},
      {"fanuc", ""},
      {"fanuc", "\n\n\n"},
  };
  for (const auto& [name, text] : programs) {
    Converted c;
    convert(name, text, {}, c);
    EXPECT_TRUE(c.committed) << text;
    EXPECT_EQ(c.out, text);
    EXPECT_EQ(c.result.bytes_in, text.size());
    EXPECT_EQ(c.result.changed_blocks, 0u);
    EXPECT_EQ(c.result.removed_blocks, 0u);
  }
}

TEST(Convert, IdentityOfRefusedInputReportsErrors) {
  Converted c;
  convert("fanuc", "G0 X1\nG1 X2 (open\n", {}, c);
  EXPECT_TRUE(c.sink.has_errors());
  EXPECT_FALSE(c.committed);
  EXPECT_EQ(c.sink.stored().at(0).code, "PP-E102");
  EXPECT_EQ(c.sink.stored().at(0).file, "in.nc");
  EXPECT_EQ(c.sink.stored().at(0).where.line, 2u);
  EXPECT_EQ(c.sink.stored().at(0).where.column, 7u);
}

TEST(Convert, StripCommentsFanuc) {
  const std::string in =
      "%\r\nO1000 (MAIN)\r\n(HEADER ONLY)\r\nN0005 G0 X0 Y0 (go)  \r\nN0010 G1 X1 (a)(b) Y2\tF100\r\n"
      "  (indented)\r\n\r\nG1 X2   \r\n/N20 G0 Z5\t(skip)\r\nN30 M30\r\n%\r\n";
  const std::string want =
      "%\r\nO1000\r\nN0005 G0 X0 Y0\r\nN0010 G1 X1 Y2\tF100\r\n\r\nG1 X2   \r\n/N20 G0 Z5\r\nN30 M30\r\n%\r\n";
  Converted c;
  convert("fanuc", in, strip(), c);
  ASSERT_TRUE(c.committed);
  EXPECT_EQ(c.out, want);
  EXPECT_EQ(c.result.blocks, 11u);
  EXPECT_EQ(c.result.removed_blocks, 2u);
  EXPECT_EQ(c.result.changed_blocks, 4u);
}

TEST(Convert, StripCommentsSemicolonDialects) {
  Converted s;
  convert("siemens", "; header\nN10 G1 X1 ; move\nMSG(\"keep; this\")\n", strip(), s);
  EXPECT_EQ(s.out, "N10 G1 X1\nMSG(\"keep; this\")\n");
  Converted l;
  convert("linuxcnc", "G0 X1 (a) ; b\n(only)\nG1 X2 F100", strip(), l);
  EXPECT_EQ(l.out, "G0 X1\nG1 X2 F100");
  Converted h;
  convert("heidenhain-iso", "G01 X1 * ; end\n", strip(), h);
  EXPECT_EQ(h.out, "G01 X1 *\n");
}

TEST(Convert, StripCommentsKeepsLinuxcncActiveComments) {
  // LinuxCNC (MSG,…), (DEBUG,…), (PRINT,…), (PROBEOPEN …) act like Siemens MSG(), which is kept.
  Converted c;
  convert("linuxcnc", "G0 X0\n(MSG, insert tool 2)\nG1 X1 F10 (DEBUG, x=#5420) (plain)\nM2\n", strip(), c);
  EXPECT_EQ(c.out, "G0 X0\n(MSG, insert tool 2)\nG1 X1 F10 (DEBUG, x=#5420)\nM2\n");
}

TEST(Convert, RenumberKeepsPaddingAndSkipsBlocksWithoutN) {
  const std::string in = "%\nO1000\nN0005 G0 X0\nG1 X1\nN0010 G1 X2 (c)\n/N20 G0 Z5\nN30 M30\n%\n";
  Converted c;
  convert("fanuc", in, renumber(10, 10), c);
  ASSERT_TRUE(c.committed);
  EXPECT_EQ(c.out, "%\nO1000\nN0010 G0 X0\nG1 X1\nN0020 G1 X2 (c)\n/N30 G0 Z5\nN40 M30\n%\n");
  Converted big;
  convert("fanuc", "N1 G0 X0\nN2 G1 X1\nN3 G1 X2\n", renumber(995, 5), big);
  EXPECT_EQ(big.out, "N995 G0 X0\nN1000 G1 X1\nN1005 G1 X2\n");
  Converted both;
  gc::ConvertOptions o = renumber(100, 1);
  o.strip_comments = true;
  convert("siemens", "N5 G0 X0 ; a\n; b\nN6 G1 X1\n", o, both);
  EXPECT_EQ(both.out, "N100 G0 X0\nN101 G1 X1\n");
}

TEST(Convert, RenumberRefusesJumps) {
  Converted go;
  convert("fanuc", "N10 G0 X0\nN20 IF [#1 GT 2] GOTO 10\nN30 M30\n", renumber(10, 10), go);
  EXPECT_FALSE(go.committed);
  ASSERT_TRUE(go.sink.has_errors());
  ASSERT_EQ(go.errors.size(), 1u);
  const auto& d = go.errors[0];
  EXPECT_EQ(d.code, "PP-E501");
  EXPECT_EQ(d.where.line, 2u);
  EXPECT_EQ(d.where.column, 5u);
  Converted m99;
  convert("fanuc", "N10 G0 X0\nN20 M99 P10\n", renumber(10, 10), m99);
  ASSERT_EQ(m99.errors.size(), 1u);
  EXPECT_EQ(m99.errors[0].code, "PP-E501");
  EXPECT_EQ(m99.errors[0].where.column, 5u);
  Converted lathe;
  convert("fanuc", "N10 G71 U2. R1.\nN20 G71 P30 Q40 U0.5 W0.1 F0.2\nN30 G0 X10\nN40 G1 Z-5\n", renumber(10, 10),
          lathe, true);
  ASSERT_EQ(lathe.errors.size(), 1u);
  EXPECT_EQ(lathe.errors[0].where.line, 2u);
  EXPECT_EQ(lathe.errors[0].where.column, 5u);
  Converted label;
  convert("siemens", "N10 MARK1: G0 X1\nN20 GOTOB MARK1\n", renumber(10, 10), label);
  EXPECT_TRUE(label.sink.has_errors());
}

TEST(Convert, RenumberAcceptsM99WithoutP) {
  // README: refused for "M99 P"; a plain M99 (return to the caller) names no sequence number.
  Converted c;
  convert("fanuc", "N1 G0 X0\nN2 M99\n", renumber(10, 10), c);
  EXPECT_EQ(c.out, "N10 G0 X0\nN20 M99\n");
}

TEST(Convert, RenumberAcceptsMillPeckDrilling) {
  // On a mill G73 is peck drilling: its P is a dwell and Q a peck depth, not sequence numbers.
  Converted c;
  convert("fanuc", "N1 G0 X0 Y0 Z10\nN2 G73 X1 Y1 Z-5 R1 Q2 P100 F100\nN3 G80\n", renumber(10, 10), c);
  EXPECT_EQ(c.out, "N10 G0 X0 Y0 Z10\nN20 G73 X1 Y1 Z-5 R1 Q2 P100 F100\nN30 G80\n");
}

TEST(Convert, LargeOutputIsFlushedCompletely) {
  std::string in;
  for (int i = 0; i < 60000; ++i) in += "N" + std::to_string(i) + " G1 X" + std::to_string(i % 97) + ".5 Y-12.345 Z7.5 F1200. (c)\n";
  ASSERT_GT(in.size(), 2u << 20);
  Converted c;
  convert("fanuc", in, {}, c);
  EXPECT_TRUE(c.out == in);
  Converted s;
  convert("fanuc", in, strip(), s);
  EXPECT_EQ(s.result.changed_blocks, 60000u);
  EXPECT_EQ(s.out.size(), in.size() - 60000u * 4);
}

}  // namespace
