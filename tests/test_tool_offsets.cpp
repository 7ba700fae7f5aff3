// Tool length offsets and cutter radius compensation: where the programmed point lands when the
// controller adds the tool (G43 H / G43.1 / G43.2 / G49, Sinumerik T/D), read as the controller
// does or refused at the move that depends on what the program does not state.
#include <gtest/gtest.h>

#include <fstream>

#include "postproc/gcode/tool_table.hpp"
#include "support.hpp"

namespace {

using namespace pptest;
using gc::Axis;
constexpr double kTol = 1e-9;

bool known(const gc::Motion& m, Axis a) { return (m.known & gc::bit(a)) != 0; }

void expect_diag_line(const Program& r, std::string_view code, std::uint64_t line) {
  const gc::Diagnostic* d = r.find(code);
  ASSERT_NE(d, nullptr) << "no " << code << "; got " << r.all_codes();
  EXPECT_EQ(d->where.line, line) << code;
}

gc::Dialect with_tools(std::string_view name, std::map<std::uint32_t, double> lengths,
                       std::map<std::uint32_t, double> radii = {}) {
  gc::DialectOptions o;
  o.integer_input = gc::Dialect::IntegerInput::calculator;
  o.tool_lengths = std::move(lengths);
  o.tool_radii = std::move(radii);
  return *gc::make_dialect(name, o);
}

// rs274 with a tool table (T1 Z50, T2 Z100; values scaled here to mm): G43 H1 alone does not move
// the machine — the program Z of the current point becomes 10 − 50; G43 H2 → 10 − 100; G43.1 Z3
// → 7; G43.2 H1 adds 50 → 10 − 53; G49 → 10. "G43.1 Z50" is an offset, not a rapid.
TEST(ToolOffsets, LinuxcncOffsetChangesShiftProgramZ) {
  const auto d = with_tools("linuxcnc", {{1, 50}, {2, 100}});
  const Program r(d, "G21 G90 G17\nT1 M6\nG0 X0 Y0 Z10\nG43 H1\nG0 X5\nG43 H2\nG0 X6\nG43.1 Z3\nG0 X7\n"
                     "G43.2 H1\nG0 X8\nG49\nG0 X9\nG43\nG0 X10\nM2\n");
  ASSERT_EQ(r.motions.size(), 7u) << r.all_codes();
  const double z[] = {10, -40, -90, 7, -43, 10, -40};
  for (std::size_t i = 0; i < 7; ++i) {
    EXPECT_TRUE(known(r.motions[i], Axis::z)) << i;
    EXPECT_NEAR(r.motions[i].end[2], z[i], kTol) << "move " << i;
  }
  EXPECT_NEAR(r.motions[3].tool_length, 3, kTol);
  EXPECT_TRUE(r.motions[3].tool_length_known);
  EXPECT_EQ(r.motions[6].tool_length_h, 1u);  // G43 without H: the tool loaded by M6
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
}

// M72 and the tool length offset, checked with rs274 -t (T1 Z50, T2 Z100 scaled to mm; the trap
// program tests/resolve/linuxcnc/reader_m72_tool_length.ngc runs without a table): rs274 records
// group 8 as G49 for a zero offset and G43 otherwise, and M72 applies the recorded code again only
// where it differs from the one in force. Saved G43.1 Z2, then G49: M72 is "G43" with the tool in
// the spindle (T1: 50), not the saved 2. Saved G43 H2 (100), then G43.1 Z3: both G43, the 3 stays.
// Before, M72 put back the saved value (10 − 2 and 10 − 100): a silent misread of Z.
TEST(ToolOffsets, M72AppliesTheRecordedGroup8CodeOnlyWhereItDiffers) {
  const auto d = with_tools("linuxcnc", {{1, 50}, {2, 100}});
  const Program r(d, "G21 G90 G17\nT1 M6\nG0 X0 Y0 Z10\nG43.1 Z2\nM70\nG49\nM72\nG0 X1\n"
                     "G43 H2\nM70\nG43.1 Z3\nM72\nG0 X2\nM2\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  EXPECT_NEAR(r.motions[1].end[2], 10 - 50, kTol);
  EXPECT_EQ(r.motions[1].tool_length_h, 1u);
  EXPECT_NEAR(r.motions[2].end[2], 10 - 3, kTol);  // the machine has not moved: 10 − the offset in force
  EXPECT_NEAR(r.motions[2].tool_length, 3, kTol);
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
}

// rs274 2.9 stops on a G43.2 without H ("G43.2: No axes specified and H word missing"), with H and
// axis words ("Can not have both H and axis words") and with axis words alone ("Requested tool -1
// not found in the tool table"); postproc read the last as an added offset.
TEST(ToolOffsets, G43_2RefusedWhereRs274Stops) {
  const auto d = with_tools("linuxcnc", {{1, 50}});
  for (const char* block : {"G43.2", "G43.2 H1 Z1", "G43.2 Z1", "G43.2 H1 G0 X5"}) {
    const Program r(d, std::string("G21 G90\nT1 M6\nG0 X0 Z10\n") + block + "\nG0 X1\nM2\n");
    expect_diag_line(r, "PP-E207", 4);
  }
  const Program ok(d, "G21 G90\nT1 M6\nG0 X0 Z10\nG43.2 H1\nG0 X1\nM2\n");
  EXPECT_EQ(ok.find("PP-E207"), nullptr) << ok.all_codes();
  ASSERT_EQ(ok.motions.size(), 2u);
  EXPECT_NEAR(ok.motions[1].end[2], 10 - 50, kTol);
}

// LinuxCNC G-code reference "G10 L1 Set Tool Table" (checked with rs274 -t): G10 L1 P1 Z5 writes
// tool 1's length (program units, G91 or not); the offset in force changes at the next G43 only.
// G10 L10/L11 compute the entry from the machine position, unknown here: Z after G43 is unknown.
// Fanuc G10 L10/L11 write the geometry/wear of H: the sum is not known, so neither is Z.
// Before, the written length was ignored and the tool table file's used (a silent misread).
TEST(ToolOffsets, G10WritesTheToolTable) {
  const auto d = with_tools("linuxcnc", {{1, 10}, {2, 20}});
  const Program r(d, "G21 G90 G17\nG0 X0 Y0 Z0\nG43 H1\nG91 G10 L1 P1 Z5\nG90 G0 X1\nG43 H1\nG0 X2\n"
                     "G20 G10 L1 P2 Z1\nG21 G43 H2\nG0 X3\nG10 L10 P1 Z3\nG43 H1\nG0 X4\nG43 H2\nG0 X5\n");
  ASSERT_EQ(r.motions.size(), 6u) << r.all_codes();
  EXPECT_NEAR(r.motions[1].end[2], -10, kTol);  // the table changed, the offset in force did not
  EXPECT_NEAR(r.motions[2].end[2], -5, kTol);   // rs274: Z-5 after G43 H1
  EXPECT_NEAR(r.motions[3].end[2], -25.4, kTol);  // 1 in
  EXPECT_FALSE(known(r.motions[4], Axis::z));   // L10: from the machine position
  EXPECT_NEAR(r.motions[5].end[2], -25.4, kTol);
  const auto f = with_tools("fanuc", {{1, 10}});
  const Program fr(f, "G21 G90 G17\nG0 X0 Y0 Z0\nG10 L10 P1 R5.\nG43 H1 Z10.\nG0 X1.\n");
  ASSERT_EQ(fr.motions.size(), 3u) << fr.all_codes();
  EXPECT_FALSE(fr.motions[1].tool_length_known);
  EXPECT_TRUE(fr.motions[1].tool_length_rewritten) << "compensation must not take the machine file's H1";
  EXPECT_FALSE(fr.motions[0].tool_length_rewritten);
}

// Without the length, Z is unknown after the change: a rapid without Z is left unknown, a feed
// move without Z is refused at its line (PP-U219); an absolute Z in the G43 block is exact.
TEST(ToolOffsets, UnknownLengthRefusesTheFirstMoveThatDependsOnIt) {
  const Program r(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z10\nG43 H7\nG0 X5\nG1 X6 F100\nG1 Z1\nG1 X7\n");
  ASSERT_EQ(r.motions.size(), 5u) << r.all_codes();
  EXPECT_FALSE(known(r.motions[1], Axis::z));
  const gc::Diagnostic* d = r.find("PP-U219");
  ASSERT_NE(d, nullptr) << r.all_codes();
  EXPECT_EQ(d->where.line, 5u);
  EXPECT_TRUE(known(r.motions[4], Axis::z));
  const Program ok(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z10\nG43 H7 Z50\nG1 X6 F100\n");
  EXPECT_FALSE(ok.has("PP-U219")) << ok.all_codes();
  EXPECT_NEAR(ok.motions[2].end[2], 50, kTol);
}

// Fanuc 0i-MF operator's manual, "Tool length compensation (G43, G44, G49)", with the factory setting
// of parameter 5006#6 (TOS = 0): the change is a Z movement in its own block, so the tip stays at the
// program Z; a feed move right after it (which would blend that Z travel in) is refused at its line;
// the usual G43 H1 Z50. is exact.
TEST(ToolOffsets, FanucChangeWithoutZIsUnknownUntilZIsProgrammed) {
  const auto d = with_tools("fanuc", {{1, 50}});
  const Program r(d, "G90 G0 X0 Y0 Z10.\nG43 H1\nG1 X5. F100.\nG43 H1 Z20.\nG1 X6.\n");
  expect_diag_line(r, "PP-U219", 3);
  ASSERT_EQ(r.motions.size(), 4u) << r.all_codes();
  EXPECT_TRUE(known(r.motions[1], Axis::z));
  EXPECT_NEAR(r.motions[1].end[2], 10, kTol);
  EXPECT_NEAR(r.motions[2].end[2], 20, kTol);
  const Program rapid(d, "G90 G0 X0 Y0 Z10.\nG49\nG0 X5.\nG1 X6. F100.\n");
  EXPECT_FALSE(rapid.has("PP-U219")) << rapid.all_codes();
  EXPECT_EQ(r.sink.per_code().at("PP-U219"), 1u);
}

// Sinumerik: a new D (or T) is applied with the next Z travel; a move without Z after it is refused.
TEST(ToolOffsets, SiemensDChangeMakesZUnknown) {
  const Program r(dialect("siemens"), "G0 X0 Y0 Z10\nT1 D1\nG1 X5 F100\nG0 Z20\nG1 X6\n");
  const gc::Diagnostic* d = r.find("PP-U219");
  ASSERT_NE(d, nullptr) << r.all_codes();
  EXPECT_EQ(d->where.line, 3u);
  ASSERT_EQ(r.motions.size(), 4u);
  EXPECT_TRUE(known(r.motions[3], Axis::z));
}

// Cutter radius compensation: refused at the first feed move under a non-zero or unknown radius;
// D0, a zero radius in the tool table and LinuxCNC G41.1 D0 are exact and pass.
TEST(ToolOffsets, CutterCompensationNeedsAZeroRadius) {
  const Program fanuc(dialect("fanuc"), "G90 G0 X0 Y0\nG41 D1 G1 X10. F100.\nG1 Y10.\nG40 G1 X0\n");
  const gc::Diagnostic* d = fanuc.find("PP-U220");
  ASSERT_NE(d, nullptr) << fanuc.all_codes();
  EXPECT_EQ(d->where.line, 2u);
  EXPECT_EQ(fanuc.sink.per_code().at("PP-U220"), 1u);
  const Program d0(dialect("fanuc"), "G90 G0 X0 Y0\nG41 D0 G1 X10. F100.\nG40 G1 X0\n");
  EXPECT_FALSE(d0.has("PP-U220")) << d0.all_codes();
  const Program table(with_tools("fanuc", {}, {{3, 0.0}}), "G90 G0 X0 Y0\nG42 D3 G1 X10. F100.\n");
  EXPECT_FALSE(table.has("PP-U220")) << table.all_codes();
  // LinuxCNC computes the tool-centre path where the radius is known (test_cutter_offset.cpp); a tool
  // the table does not give stays refused, and a second G41.1 while compensation is on is refused as
  // rs274 refuses it ("Cannot turn cutter radius comp on when on").
  const Program lcnc(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0\nG41.1 D0 G1 X10 F100\nG41.1 D6 G1 X0\n");
  EXPECT_FALSE(lcnc.has("PP-U220")) << lcnc.all_codes();
  ASSERT_NE(lcnc.find("PP-E220"), nullptr) << lcnc.all_codes();
  EXPECT_EQ(lcnc.find("PP-E220")->where.line, 4u);
  const Program lcnc7(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0\nG41 D7 G1 X10 F100\n");
  ASSERT_NE(lcnc7.find("PP-U220"), nullptr) << lcnc7.all_codes();
  EXPECT_EQ(lcnc7.find("PP-U220")->where.line, 3u);
  const Program siemens(dialect("siemens"), "T1 D0\nG0 X0 Y0 Z5\nG41 G1 X10 F100\n");
  EXPECT_FALSE(siemens.has("PP-U220")) << siemens.all_codes();
}

TEST(ToolOffsets, LinuxcncToolTableFile) {
  const fs::path dir = fs::temp_directory_path() / ("pp_tooltable_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "tool.tbl") << "T1 P1 Z50 D10 ;first\n\nT2 P2 Z+100.5 D0 ;second\r\nT3 P3 D0.8 Q2\n";
  std::ofstream(dir / "bad.tbl") << "T1 P1 Z50\nT2 Zabc\n";
  gc::DialectOptions o;
  gc::DiagnosticSink sink;
  ASSERT_TRUE(gc::read_linuxcnc_tool_table((dir / "tool.tbl").string(), o, sink));
  EXPECT_NEAR(o.tool_lengths.at(1), 50, kTol);
  EXPECT_NEAR(o.tool_lengths.at(2), 100.5, kTol);
  EXPECT_NEAR(o.tool_radii.at(1), 5, kTol);
  EXPECT_NEAR(o.tool_radii.at(2), 0, kTol);
  EXPECT_EQ(o.tool_orientations.at(3), 2);  // Q: the lathe tool orientation
  EXPECT_EQ(o.tool_orientations.count(1), 0u);
  gc::DialectOptions bad;
  EXPECT_FALSE(gc::read_linuxcnc_tool_table((dir / "bad.tbl").string(), bad, sink));
  ASSERT_FALSE(sink.stored().empty());
  EXPECT_EQ(sink.stored().back().code, "PP-E208");
  EXPECT_EQ(sink.stored().back().where.line, 2u);
  EXPECT_EQ(sink.stored().back().where.column, 4u);
  fs::remove_all(dir);
}

}  // namespace
