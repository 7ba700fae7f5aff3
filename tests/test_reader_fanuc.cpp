// Fanuc dialect, reader round 2 (issue 16): every construct is read as a Fanuc 0i/30i runs it, or
// refused at its word. Each test names the manual section its expected answer comes from:
// B-64484EN = FANUC Series 30i/31i/32i-MODEL B Operator's Manual (Common to Lathe/Machining Center),
// B-64694EN = FANUC Series 0i-MODEL F Plus Operator's Manual, B-64304EN = Series 0i-MODEL D.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "postproc/compensation/compensate.hpp"
#include "postproc/contour/path.hpp"
#include "postproc/gcode/resolve.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/machine/machine.hpp"
#include "sample_machine.hpp"
#include "support.hpp"

namespace {

using namespace pptest;
using gc::Axis;
using gc::MotionType;
constexpr double kTol = 1e-9;
constexpr double kDeg = std::numbers::pi / 180.0;

bool known(const gc::Motion& m, Axis a) { return (m.known & gc::bit(a)) != 0; }

#define EXPECT_XYZ(m, x, y, z)          \
  do {                                  \
    EXPECT_NEAR((m).end[0], (x), kTol); \
    EXPECT_NEAR((m).end[1], (y), kTol); \
    EXPECT_NEAR((m).end[2], (z), kTol); \
  } while (0)

// ---- 1. G16/G15 polar coordinate command --------------------------------------------------------

// B-64484EN II "Polar coordinate command (G15, G16)" (Series 16/18-C: section 9.2): G90 makes the
// work origin the pole, X (first axis of G17) is the radius, Y the angle counterclockwise from +X;
// an omitted radius keeps the distance from the pole; G91 on the angle adds to the current angle
// (the manual's bolt-hole example N1–N5 with G91 Y120.).
TEST(ReaderFanuc, PolarG90BoltHoles) {
  const Program r(dialect("fanuc"),
                  "G17 G90 G0 X0 Y0 Z5.\nG16\nG1 X100. Y30. F200.\nY150.\nG91 Y120.\nG15 G90 G1 X5. Y5.\n");
  ASSERT_EQ(r.motions.size(), 5u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  EXPECT_XYZ(*r.at_line(3), 100 * std::cos(30 * kDeg), 100 * std::sin(30 * kDeg), 5);
  EXPECT_XYZ(*r.at_line(4), 100 * std::cos(150 * kDeg), 100 * std::sin(150 * kDeg), 5);
  EXPECT_XYZ(*r.at_line(5), 100 * std::cos(270 * kDeg), 100 * std::sin(270 * kDeg), 5);
  EXPECT_TRUE(known(*r.at_line(5), Axis::x) && known(*r.at_line(5), Axis::y));
  EXPECT_TRUE(r.at_line(3)->words_transformed);
  EXPECT_XYZ(*r.at_line(6), 5, 5, 5);  // G15: Cartesian again
  EXPECT_FALSE(r.at_line(6)->words_transformed);
}

// Same section: the first axis of the selected plane is the radius — G18 (Zp Xp): Z radius, X angle
// measured from +Z toward +X; G19 (Yp Zp): Y radius, Z angle.
TEST(ReaderFanuc, PolarG18AndG19Planes) {
  const Program r(dialect("fanuc"), "G90 G0 X0 Y0 Z0\nG18 G16 G1 Z10. X90. F100.\nG19 Y20. Z30.\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  EXPECT_XYZ(*r.at_line(2), 10, 0, 0);
  EXPECT_XYZ(*r.at_line(3), 10, 20 * std::cos(30 * kDeg), 20 * std::sin(30 * kDeg));
}

// Same section: an omitted angle keeps the current angle (radius from the work origin in G90);
// an axis outside the plane stays Cartesian.
TEST(ReaderFanuc, PolarOmittedAngleAndNormalAxis) {
  const Program r(dialect("fanuc"), "G90 G0 X10. Y10. Z0\nG16 G1 X20. Z-3. F100.\n");
  ASSERT_EQ(r.motions.size(), 2u) << r.all_codes();
  EXPECT_XYZ(*r.at_line(2), 20 * std::cos(45 * kDeg), 20 * std::sin(45 * kDeg), -3);
}

// Same section: a radius in G91 makes the current position the pole; this version refuses it at
// the radius word (PP-U230) and the plane position becomes unknown.
TEST(ReaderFanuc, PolarIncrementalRadiusRefused) {
  const Program r(dialect("fanuc"), "G90 G0 X0 Y0\nG16 G91 G1 X10. Y45. F100.\nG15 G90 G0 X1. Y2.\n");
  expect_diag_at(r, "PP-U230", 2, 12);
  EXPECT_EQ(r.at_line(2), nullptr);
  EXPECT_XYZ(*r.at_line(3), 1, 2, 0);
}

// Same section, drilling example: the hole positions of G81 are polar, Z (hole axis) is not.
TEST(ReaderFanuc, PolarDrillingCycle) {
  const Program r(dialect("fanuc"), "G17 G90 G0 X0 Y0 Z10.\nG16\nG81 X100. Y30. Z-20. R-5. F200.\nY150.\nG80 G15\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  const auto& h = *r.at_line(3);
  EXPECT_EQ(h.type, MotionType::drill_cycle);
  EXPECT_NEAR(h.end[0], 100 * std::cos(30 * kDeg), kTol);
  EXPECT_NEAR(h.end[1], 100 * std::sin(30 * kDeg), kTol);
  EXPECT_NEAR(h.cycle_bottom, -20, kTol);
  EXPECT_NEAR(r.at_line(4)->end[0], 100 * std::cos(150 * kDeg), kTol);
}

// ---- 2. G51 scaling, G51.1 programmable mirror image ----------------------------------------------

// B-64484EN II "Scaling (G50, G51)": G51 X Y Z P does not move (X Y Z are the centre); the scale
// factor's unit and per-axis use are parameters (No. 5400#7 SCR, #6 XSC, 5411), so this version
// refuses each motion while scaling is active (PP-U231) and reads after G50 again.
TEST(ReaderFanuc, ScalingRefusedWhileActive) {
  const Program r(dialect("fanuc"), "G90 G0 X1. Y1.\nG51 X0 Y0 P2.\nG1 X10. Y10. F100.\nG50\nG1 X5. Y6.\n");
  ASSERT_EQ(r.motions.size(), 2u) << r.all_codes();
  EXPECT_XYZ(r.motions[0], 1, 1, 0);  // the G51 block is not a move
  expect_diag_at(r, "PP-U231", 3, 4);
  EXPECT_EQ(r.at_line(3), nullptr);
  EXPECT_XYZ(*r.at_line(5), 5, 6, 0);
  EXPECT_TRUE(known(*r.at_line(5), Axis::x));
}

// B-64484EN II "Programmable mirror image (G50.1, G51.1)": G51.1 X10. mirrors X about x = 10; the block
// does not move; a mirrored single plane axis reverses G02/G03; G50.1 X0 cancels.
TEST(ReaderFanuc, MirrorAbsoluteLinesAndArcs) {
  const Program r(dialect("fanuc"),
                  "G17 G90 G0 X0 Y0\nG51.1 X10.\nG1 X20. Y5. F100.\nG2 X30. Y15. R10.\nG50.1 X0\nG1 X1. Y1.\n");
  ASSERT_EQ(r.motions.size(), 4u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  EXPECT_XYZ(*r.at_line(3), 0, 5, 0);  // 2*10 - 20
  const auto& arc = *r.at_line(4);
  EXPECT_EQ(arc.type, MotionType::arc_ccw);
  EXPECT_XYZ(arc, -10, 15, 0);
  // The mirrored arc is the mirror of the programmed one (cw from (20,5) to (30,15), R10: centre (30,5)).
  EXPECT_NEAR(arc.arc.centre[0], -10, 1e-9);
  EXPECT_NEAR(arc.arc.centre[1], 5, 1e-9);
  EXPECT_TRUE(arc.words_transformed);
  EXPECT_XYZ(*r.at_line(6), 1, 1, 0);
  EXPECT_FALSE(r.at_line(6)->words_transformed);
}

// Same section: I J of a mirrored arc are mirrored with it (centre offset -I after an absolute move).
TEST(ReaderFanuc, MirrorArcCentreWords) {
  const Program r(dialect("fanuc"), "G90 G0 X0 Y0\nG51.1 Y0\nG1 X10. Y10. F100.\nG3 X20. Y20. I10. J0\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  const auto& arc = *r.at_line(4);
  EXPECT_EQ(arc.type, MotionType::arc_cw);  // G3 mirrored in Y only → clockwise
  EXPECT_XYZ(arc, 20, -20, 0);
  EXPECT_NEAR(arc.arc.centre[0], 20, 1e-9);
  EXPECT_NEAR(arc.arc.centre[1], -10, 1e-9);
}

// Same section: incremental moves of a mirrored axis are mirrored about the control's programmed
// position, which this version does not follow: refused at the word (PP-U232).
TEST(ReaderFanuc, MirrorIncrementalRefused) {
  const Program r(dialect("fanuc"), "G90 G0 X0 Y0\nG51.1 X5.\nG91 G1 X2. Y3. F100.\nG90 G1 X1. Y1.\n");
  expect_diag_at(r, "PP-U232", 3, 8);
  EXPECT_EQ(r.at_line(3), nullptr);
  EXPECT_XYZ(*r.at_line(4), 9, 1, 0);
}

// ---- 3. G29 return from reference position --------------------------------------------------------

// B-64484EN II "Return from reference position (G29)": the named axes go through the intermediate
// point of the last G28 to the commanded point; in G91 the command is measured from the
// intermediate point. Axes not named do not move.
TEST(ReaderFanuc, G29ThroughIntermediatePoint) {
  const Program r(dialect("fanuc"), "G90 G0 X10. Y10. Z50.\nG28 X20. Y30.\nG29 X5. Y6.\nG91 G28 Z10.\nG29 Z-5.\n");
  const auto* g29 = r.at_line(3);
  ASSERT_NE(g29, nullptr) << r.all_codes();
  EXPECT_EQ(g29->type, MotionType::rapid);
  EXPECT_NEAR(g29->start[0], 20, kTol);
  EXPECT_NEAR(g29->start[1], 30, kTol);
  EXPECT_XYZ(*g29, 5, 6, 50);
  EXPECT_TRUE(known(*g29, Axis::x) && known(*g29, Axis::y) && known(*g29, Axis::z));
  const auto* inc = r.at_line(5);
  ASSERT_NE(inc, nullptr);
  EXPECT_NEAR(inc->end[2], 55, kTol);  // intermediate Z 60, then -5
  EXPECT_TRUE(known(*inc, Axis::z));
  EXPECT_FALSE(r.has("PP-U234")) << r.all_codes();
}

// Same section: G91 G29 for an axis without a known intermediate point is refused (PP-U234).
TEST(ReaderFanuc, G29IncrementalWithoutIntermediateRefused) {
  const Program r(dialect("fanuc"), "G90 G0 X10. Y10.\nG28 Z0\nG91 G29 X5.\n");
  expect_diag_at(r, "PP-U234", 3, 5);
  ASSERT_NE(r.at_line(3), nullptr);
  EXPECT_FALSE(known(*r.at_line(3), Axis::x));
}

// ---- 6. Rounding of a variable used in an address ------------------------------------------------

gc::ResolvedProgram resolved(std::string_view text, gc::DiagnosticSink& sink) {
  return gc::resolve(text, "t.nc", gc::make_dialect(gc::DialectId::fanuc), {}, sink);
}

// B-64484EN "Custom macro — Variables" (rounding of values): a variable used in an address is rounded
// to the address's least input increment (IS-B: 0.001 mm, 0.0001 in, 0.001 deg); the variable
// itself, and arithmetic with it, keep the full value.
TEST(ReaderFanuc, VariableInAddressRoundedToIncrement) {
  gc::DiagnosticSink sink;
  const auto r = resolved("#1=1.23456\nG0 X#1 Y[#1*2] A#1\n#2=#1*1000\nG1 Z#2 F100.\n", sink);
  EXPECT_FALSE(sink.has_errors());
  EXPECT_NE(r.text.find("G0 X1.235 Y2.469 A1.235"), std::string::npos) << r.text;
  EXPECT_NE(r.text.find("G1 Z1234.56 F100."), std::string::npos) << r.text;
}

TEST(ReaderFanuc, VariableInAddressRoundedInInch) {
  gc::DiagnosticSink sink;
  const auto r = resolved("G20\n#1=1.23456\nG0 X#1 Z-#1\n", sink);
  EXPECT_NE(r.text.find("G0 X1.2346 Z-1.2346"), std::string::npos) << r.text;
}

// Same section: G65 arguments are values passed to the macro, not addresses — not rounded.
TEST(ReaderFanuc, MacroArgumentsNotRounded) {
  gc::DiagnosticSink sink;
  const auto r = resolved("O1\n#5=1.23456\nG65 P9001 A#5\nM30\nO9001\nG0 X[#1*1000]\nM99\n", sink);
  EXPECT_FALSE(sink.has_errors());
  EXPECT_NE(r.text.find("G0 X1234.56"), std::string::npos) << r.text;
}

// Whole-number addresses (M S T H D P L): a variable's value is rounded to the nearest whole number,
// half away from zero (M#1 with #1 = 3.5 runs M4; "M03 S#1" with #1 = 1000.5 runs S1001), and written
// without a decimal point; a literal with one there is alarm PS0007 (M3.0, T1.5: "illegal use of
// decimal point"), refused at the word — except H as a G65 argument.
TEST(ReaderFanuc, WholeNumberAddressesRoundedAndLiteralDecimalsRefused) {
  gc::DiagnosticSink sink;
  const auto r = resolved("#1=3.5\n#2=1.6\n#3=1000.5\n#4=-2.5\nT#2 M6\nG43 H#2 Z5.\nM#1 S#3\nM#4\n", sink);
  EXPECT_FALSE(sink.has_errors());
  EXPECT_NE(r.text.find("T2 M6\nG43 H2 Z5.\nM4 S1001\nM-3"), std::string::npos) << r.text;
  for (const auto& [text, column] : std::vector<std::pair<std::string, std::uint32_t>>{
           {"G0 X0 Y0\nT1.5 M6\n", 1}, {"G0 X0 Y0\nM3.0 S1000\n", 1}, {"G0 X0 Y0\nG43 H1. Z5.\n", 5}}) {
    const Program p(dialect("fanuc"), text);
    expect_diag_at(p, "PP-E207", 2, column);
  }
  const Program call(dialect("fanuc"), "G0 X0 Y0\nG65 P9010 H1.5 A2.\n");
  EXPECT_EQ(call.find("PP-E207"), nullptr) << call.all_codes();
}

// ---- 7. Arc with both R and I J K ------------------------------------------------------------------

// B-64484EN II "Circular interpolation (G02, G03)": with R and I J K in one block, R is used and
// I J K are ignored.
TEST(ReaderFanuc, ArcRadiusWinsOverCentreWords) {
  const Program r(dialect("fanuc"), "G17 G90 G0 X0 Y0\nG2 X10. Y0 R5. I3. J7. F100.\n");
  ASSERT_EQ(r.motions.size(), 2u) << r.all_codes();
  const auto& a = r.motions[1];
  EXPECT_NEAR(a.arc.centre[0], 5, kTol);
  EXPECT_NEAR(a.arc.centre[1], 0, kTol);
  EXPECT_NEAR(a.arc.radius, 5, kTol);
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
}

// LinuxCNC docs G-code "G2, G3 Arc": radius format and centre format are exclusive; both is an error.
TEST(ReaderFanuc, LinuxcncArcRadiusAndCentreIsAnError) {
  const Program r(dialect("linuxcnc"), "G17 G90 G0 X0 Y0\nG2 X10 Y0 R5 I5 F100\n");
  expect_diag_at(r, "PP-E301", 2, 11);
  EXPECT_EQ(r.at_line(2), nullptr);
}

// ---- 8. Power-on motion mode, G80 ------------------------------------------------------------------

// B-64484EN II "G code list" / parameter 3402#0 (G01): the power-on group-01 mode is G00 (factory
// setting) or G01; axis words before any motion G move in it.
TEST(ReaderFanuc, PowerOnMotionIsG00OrG01ByParameter) {
  const Program rapid(dialect("fanuc"), "G90 X10. Y5.\n");
  ASSERT_EQ(rapid.motions.size(), 1u) << rapid.all_codes();
  EXPECT_EQ(rapid.motions[0].type, MotionType::rapid);
  EXPECT_XYZ(rapid.motions[0], 10, 5, 0);
  gc::DialectOptions o;
  o.integer_input = gc::Dialect::IntegerInput::calculator;
  o.power_on_motion = 1;
  const Program linear(gc::make_dialect(gc::DialectId::fanuc, o), "G90 X10. Y5. F100.\n");
  ASSERT_EQ(linear.motions.size(), 1u) << linear.all_codes();
  EXPECT_EQ(linear.motions[0].type, MotionType::linear);
  // LinuxCNC powers on in G80: axis words need a motion G first.
  const Program lc(dialect("linuxcnc"), "G90 X10 Y5\n");
  expect_diag_at(lc, "PP-E204", 1, 5);
}

// B-64484EN II "Canned cycle for drilling": canned cycles are group 09, G80 cancels them and the
// group-01 mode (G00/G01) active before the cycle applies to the next axis words.
TEST(ReaderFanuc, G80ReturnsToPreviousGroup01Motion) {
  const Program r(dialect("fanuc"),
                  "G90 G1 X0 Y0 Z10. F100.\nG81 X5. Y5. Z-1. R1.\nG80\nX7. Y7.\nG0 Z20.\nG81 X1. Y1. Z-1. R1.\n"
                  "G80 X2.\n");
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  ASSERT_NE(r.at_line(4), nullptr);
  EXPECT_EQ(r.at_line(4)->type, MotionType::linear);
  EXPECT_XYZ(*r.at_line(4), 7, 7, 10);
  ASSERT_NE(r.at_line(7), nullptr);
  EXPECT_EQ(r.at_line(7)->type, MotionType::rapid);
  EXPECT_NEAR(r.at_line(7)->end[0], 2, kTol);
}

// ---- 4. Chamfer and corner rounding ----------------------------------------------------------------

// B-64484EN II "Chamfering and corner rounding (,C ,R)": ,C / ,R on a G01 moves the end of that block
// and the start of the next. ",C" and ",R" are lexed as their own address (never a C axis or an arc
// radius); both motions are refused at the word (PP-U233); the end of the next block is exact again.
TEST(ReaderFanuc, CornerRoundingBuiltOrRefusedAtItsWord) {
  // Between two straight moves the rounding is built (tests/test_corners.cpp); before an arc it is
  // refused at its word and the arc's start is moved by it, so the arc is refused too.
  const Program built(dialect("fanuc"), "G90 G0 X0 Y0\nG1 X10. ,R2. F100.\nY10.\nX20.\n");
  EXPECT_FALSE(built.has("PP-U233")) << built.all_codes();
  ASSERT_NE(built.at_line(2), nullptr);
  EXPECT_EQ(built.at_line(2)->type, gc::MotionType::arc_ccw);
  EXPECT_XYZ(*built.at_line(2), 10, 2, 0);
  const Program r(dialect("fanuc"), "G90 G0 X0 Y0\nG1 X10. ,R2. F100.\nG3 X20. Y10. R10.\nG1 X30. Y10.\n");
  expect_diag_at(r, "PP-U233", 2, 9);
  EXPECT_EQ(r.at_line(2), nullptr);
  EXPECT_EQ(r.at_line(3), nullptr);  // its start is moved by the rounding
  ASSERT_NE(r.at_line(4), nullptr) << r.all_codes();
  EXPECT_XYZ(*r.at_line(4), 30, 10, 0);
  EXPECT_TRUE(known(*r.at_line(4), Axis::x) && known(*r.at_line(4), Axis::y));
  EXPECT_NEAR(r.at_line(4)->start[1], 10, kTol);
  EXPECT_EQ(r.sink.count(gc::Severity::error), 0u);
  const Lexed l(dialect("fanuc"), "G1 X10. ,C1.5 Y2.");
  ASSERT_TRUE(l.ok);
  ASSERT_EQ(l.block.words.size(), 4u);
  EXPECT_EQ(l.of(l.block.words[2].name), ",C");
  EXPECT_DOUBLE_EQ(l.block.words[2].number, 1.5);
}

// B-64484EN II (lathe) "Direct drawing dimension programming" / "Chamfering and corner R": on a lathe
// G01, R (corner), I/K (chamfer) and A (angle) change the corner; refused at the word (PP-U233). An
// angle makes the omitted axis unknown.
TEST(ReaderFanuc, LatheDirectDrawingRefused) {
  // (G01 along one axis with I/K/R is the chamfer / corner R format and is built: tests/test_corners.cpp.)
  const Program r(dialect("fanuc", true), "G0 X20. Z0\nG1 X30. Z-10. R2. F0.2\nX40.\nG1 X60. A30.\nZ-40.\nZ-50.\n");
  expect_diag_at(r, "PP-U233", 2, 15);
  EXPECT_EQ(r.at_line(2), nullptr);
  EXPECT_EQ(r.at_line(3), nullptr);
  EXPECT_EQ(r.at_line(4), nullptr);
  EXPECT_EQ(r.at_line(5), nullptr);  // the block after the angle block closes the direct drawing
  const auto* last = r.at_line(6);
  ASSERT_NE(last, nullptr) << r.all_codes();
  EXPECT_FALSE(known(*last, Axis::x));  // X after "X60. A30." then Z-40 is not known here
  EXPECT_TRUE(known(*last, Axis::z));
}

// ---- 5. G10 -------------------------------------------------------------------------------------------

// B-64484EN II "Changing workpiece coordinate system by programmed command (G10)": G10 L2 P1 writes
// the G54 offset, G10 L20 P1 the G54.1 P1 offset (not LinuxCNC's "set the current position"); G10
// never moves. Writing the active frame's offset makes its named axes unknown (old value unknown),
// writing another frame's offset changes nothing.
TEST(ReaderFanuc, G10WritesOffsetTablesNeverMoves) {
  const Program r(dialect("fanuc"),
                  "G54 G90 G0 X1. Y2. Z3.\nG10 L2 P2 X50.\nG1 Z4. F100.\nG10 L20 P1 X7.\nG1 Z5.\nG10 L2 P1 X9.\n"
                  "G1 Z6.\n");
  EXPECT_EQ(r.motions.size(), 4u) << r.all_codes();
  EXPECT_TRUE(known(*r.at_line(3), Axis::x));  // G55 written: G54 unchanged
  EXPECT_NEAR(r.at_line(3)->end[0], 1, kTol);
  EXPECT_TRUE(known(*r.at_line(5), Axis::x));  // G54.1 P1 written: not active
  EXPECT_NEAR(r.at_line(5)->end[0], 1, kTol);
  EXPECT_FALSE(known(*r.at_line(7), Axis::x));  // G54 itself written
  EXPECT_TRUE(known(*r.at_line(7), Axis::y));
  const Program ext(dialect("fanuc"), "G54.1 P3 G90 G0 X1. Y2.\nG10 L20 P3 Y0\nG1 X2. F100.\n");
  EXPECT_FALSE(known(*ext.at_line(3), Axis::y));
  EXPECT_TRUE(known(*ext.at_line(3), Axis::x));
  // LinuxCNC (docs G10 L20): the current position takes the given value.
  const Program lc(dialect("linuxcnc"), "G54 G90 G0 X1 Y2\nG10 L20 P1 X7\nG1 Y3 F100\n");
  EXPECT_TRUE(known(*lc.at_line(3), Axis::x));
  EXPECT_NEAR(lc.at_line(3)->end[0], 7, kTol);
}

// ---- 10. False refusals ----------------------------------------------------------------------------

// B-64484EN "Tape code" (ISO): a space is disregarded in significant information, so "X 1 0 . 5" is
// X10.5 on a Fanuc.
TEST(ReaderFanuc, SpacesInsideNumbers) {
  const Program r(dialect("fanuc"), "G 0 X 1 0 . 5 Y - 2.\nN2 0 G1 X1 1. F 100.\n");
  ASSERT_EQ(r.motions.size(), 2u) << r.all_codes();
  EXPECT_XYZ(r.motions[0], 10.5, -2, 0);
  EXPECT_XYZ(r.motions[1], 11, -2, 0);
  EXPECT_EQ(r.sink.count(gc::Severity::error), 0u) << r.all_codes();
}

// B-64484EN "Label skip" / tape leader: listing text before the program (a CAM listing header without
// '%') is not part of the program; skipped with a note (PP-N003), and the program reads normally.
TEST(ReaderFanuc, ListingHeaderBeforeProgramNumber) {
  const Program r(dialect("fanuc"),
                  "==========\nInformation listing created by :  user\nDate  :  8/3/2006\n==========\nO0001\n"
                  "G90 G0 X1. Y2.\nM30\n");
  EXPECT_EQ(r.sink.count(gc::Severity::error), 0u) << r.all_codes();
  EXPECT_TRUE(r.has("PP-N003"));
  ASSERT_EQ(r.motions.size(), 1u);
  EXPECT_EQ(r.motions[0].line, 6u);
  // NC blocks before the O number are not a listing: read (no leader).
  const Program nc(dialect("fanuc"), "G90 G0 X1.\nO0001\nG0 X2.\n");
  EXPECT_FALSE(nc.has("PP-N003"));
  EXPECT_EQ(nc.motions.size(), 2u);
}

// Same rule when the program needs macro resolution (the resolver skips the listing too).
TEST(ReaderFanuc, ListingHeaderBeforeMacroProgram) {
  gc::DiagnosticSink sink;
  const auto r = resolved("==========\nInformation listing created by :  user\n==========\nO0001\n#1=2.\nG0 X#1\nM30\n",
                          sink);
  EXPECT_FALSE(sink.has_errors());
  EXPECT_NE(r.text.find("G0 X2."), std::string::npos) << r.text;
}

// M98 P5001 finds O5001 in a file named 5001.nc / O5001.nc / o5001 (any case) in the program's folder.
TEST(ReaderFanuc, SubprogramFileNames) {
  for (const char* name : {"5001.nc", "O5001.NC", "o5001", "5001.tap"}) {
    TempDir dir;
    write_file(dir.file(name), "O5001\nG0 X7.\nM99\n");
    write_file(dir.file("main.nc"), "O1\nM98 P5001\nM30\n");
    gc::DiagnosticSink sink;
    gc::ResolveOptions opt;
    opt.search_dirs.push_back(dir.path().string());
    const auto r = gc::resolve(read_file(dir.file("main.nc")), dir.file("main.nc"),
                               gc::make_dialect(gc::DialectId::fanuc), opt, sink);
    EXPECT_FALSE(sink.has_errors()) << name;
    EXPECT_NE(r.text.find("G0 X7."), std::string::npos) << name << ": " << r.text;
  }
}

// B-64484EN "G code system" (lathe): in system B absolute/incremental is G90/G91 and U/W are not
// incremental X/Z; in system A G91 does not exist (the message names --gcode-system B).
TEST(ReaderFanuc, LatheGCodeSystemB) {
  gc::DialectOptions o;
  o.lathe = true;
  o.gcode_system = 'B';
  o.integer_input = gc::Dialect::IntegerInput::calculator;
  const gc::Dialect b = gc::make_dialect(gc::DialectId::fanuc, o);
  const Program r(b, "G90 G0 X20. Z5.\nG91 G1 X-4. Z-10. F0.2\nG90 G1 U2.\n");
  ASSERT_NE(r.at_line(2), nullptr) << r.all_codes();
  EXPECT_NEAR(r.at_line(2)->end[0], 8, kTol);  // diameter 20 - 4 = 16: radius 8
  EXPECT_NEAR(r.at_line(2)->end[2], -5, kTol);
  expect_diag_at(r, "PP-U235", 3, 8);
  ASSERT_NE(r.at_line(3), nullptr);
  EXPECT_NEAR(r.at_line(3)->end[0], 8, kTol);  // X unchanged: U is not incremental X in system B
  const Program a(dialect("fanuc", true), "G91 G1 X2.\n");
  const gc::Diagnostic* d = a.find("PP-E201");
  ASSERT_NE(d, nullptr);
  EXPECT_NE(d->message.find("--gcode-system B"), std::string::npos);
  // System A: G90 is the turning cycle; a G90 alone (a system-B "absolute") is refused with the hint.
  const Program g90(dialect("fanuc", true), "G90 G54\n");
  const gc::Diagnostic* t = g90.find("PP-U201");
  ASSERT_NE(t, nullptr) << g90.all_codes();
  EXPECT_EQ(t->where.column, 1u);
  EXPECT_NE(t->message.find("--gcode-system B"), std::string::npos);
}

// B-64484EN "G code system" (lathe; parameters GSB/GSC No. 3401): system A has no G90/G91 modes and
// feeds by G98/G99; systems B/C use G90/G91 and G94/G95, and G98/G99 there only choose the canned
// cycle return level. With the system not stated ('?', the CLI's "auto"), the reader takes it from a
// block that only one system reads without contradiction, says so (PP-N004), and refuses a program
// that shows both (PP-E209).
TEST(ReaderFanuc, LatheGCodeSystemReadOffTheProgram) {
  gc::DialectOptions o;
  o.lathe = true;
  o.gcode_system = '?';
  o.integer_input = gc::Dialect::IntegerInput::calculator;
  const gc::Dialect autod = gc::make_dialect(gc::DialectId::fanuc, o);
  // "G90 G0" in one block: system B (absolute); G91 then makes X incremental.
  const Program b(autod, "G0 X30. Z10.\nG90 G0 X20. Z5.\nG91 G1 X-4. Z-10. F0.2\n");
  expect_diag_at(b, "PP-N004", 2, 1);
  EXPECT_FALSE(b.sink.has_errors()) << b.all_codes();
  ASSERT_NE(b.at_line(3), nullptr) << b.all_codes();
  EXPECT_NEAR(b.at_line(3)->end[0], 8, kTol);  // diameter 20 - 4 = 16: radius 8
  EXPECT_NEAR(b.at_line(3)->end[2], -5, kTol);
  // "G95" alone: feed per revolution of systems B/C (system A has no G95).
  const Program b2(autod, "G21 G95\nG0 X20. Z5.\nG1 Z-10. F0.2\n");
  expect_diag_at(b2, "PP-N004", 1, 5);
  ASSERT_NE(b2.at_line(3), nullptr) << b2.all_codes();
  EXPECT_EQ(b2.at_line(3)->feed_mode, gc::FeedMode::per_rev);
  // "G99 G1 … F": feed per revolution of system A; U is then incremental X.
  const Program a(autod, "G0 X20. Z5.\nG99 G1 U-4. W-10. F0.2\n");
  expect_diag_at(a, "PP-N004", 2, 1);
  ASSERT_NE(a.at_line(2), nullptr) << a.all_codes();
  EXPECT_NEAR(a.at_line(2)->end[0], 8, kTol);
  EXPECT_NEAR(a.at_line(2)->end[2], -5, kTol);
  // Nothing decides: system A, the factory setting, without a note.
  const Program none(autod, "G0 X20. Z5.\nG1 Z-10. F0.2\n");
  EXPECT_EQ(none.find("PP-N004"), nullptr);
  EXPECT_FALSE(none.sink.has_errors()) << none.all_codes();
  // Both: refused at the later evidence, naming the earlier one (a Mazak-style mix of G90 and G99).
  const Program both(autod, "G00 G90 X20. Z5.\nG96 S200\nG01 G99 X10. F.03\n");
  expect_diag_at(both, "PP-E209", 3, 5);
  const gc::Diagnostic* e = both.find("PP-E209");
  ASSERT_NE(e, nullptr);
  EXPECT_NE(e->message.find("line 1"), std::string::npos) << e->message;
  EXPECT_NE(e->message.find("--gcode-system"), std::string::npos) << e->message;
  // "G00 G90 G99": G99 is a return level beside absolute mode in B; the block is evidence for B.
  const Program mixed(autod, "G00 G90 G99 X20. Z5.\n");
  expect_diag_at(mixed, "PP-N004", 1, 5);
  EXPECT_FALSE(mixed.sink.has_errors()) << mixed.all_codes();
}

// A lathe post for a radius-programmed machine writes X as a radius: the refused arc says that it
// closes so and names --diameter-axis none (B-64484EN "Diameter and radius programming").
TEST(ReaderFanuc, LatheArcThatClosesInRadiusNamesTheSetting) {
  // From X1.055 (diameter) to X1.0143 Z+.0407 around I-.0407: a quarter circle only if X is a radius.
  const Program r(dialect("fanuc", true), "G20\nG0 X1.055 Z4.7043\nG3 X1.0143 Z4.745 I-.0407 K0. F.02\n");
  const gc::Diagnostic* d = r.find("PP-E301");
  ASSERT_NE(d, nullptr) << r.all_codes();
  EXPECT_NE(d->message.find("--diameter-axis none"), std::string::npos) << d->message;
  gc::DialectOptions o;
  o.lathe = true;
  o.integer_input = gc::Dialect::IntegerInput::calculator;
  gc::Dialect radius = gc::make_dialect(gc::DialectId::fanuc, o);
  radius.diameter_axis = 0;
  const Program ok(radius, "G20\nG0 X1.055 Z4.7043\nG3 X1.0143 Z4.745 I-.0407 K0. F.02\n");
  EXPECT_FALSE(ok.sink.has_errors()) << ok.all_codes();
  // An arc that closes neither way carries no hint.
  const Program bad(dialect("fanuc", true), "G0 X20. Z0.\nG3 X30. Z-3. I5. K0. F.1\n");
  const gc::Diagnostic* b = bad.find("PP-E301");
  ASSERT_NE(b, nullptr) << bad.all_codes();
  EXPECT_EQ(b->message.find("--diameter-axis"), std::string::npos) << b->message;
}

// ---- Writers -----------------------------------------------------------------------------------------

/// compensate through a sample machine (with errors): the output, or the refusal.
struct Compensated {
  std::string out;
  gc::DiagnosticSink sink;
};
void compensate(std::string_view program, Compensated& r) {
  const postproc::machine::Machine m = pptest::sample_machine("trunnion_ac_fanuc.toml");
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  postproc::comp::CompensateOptions opt;
  opt.tool_version = "test";
  opt.header = false;
  auto mem = postproc::io::OutputFile::memory();
  postproc::comp::compensate_program({program, "t.nc", d, m}, opt, mem, r.sink);
  r.out = mem.take();
}

// Under G16 the words are radius and angle (B-64484EN "Polar coordinate command"): a corrected
// Cartesian end point must not be written into them, so compensate refuses the block (PP-E601);
// the same move in Cartesian words is compensated.
TEST(ReaderFanuc, CompensateRefusesPolarWords) {
  Compensated polar;
  compensate("%\nO1\nG90 G54 G0 X0 Y0 Z50. A0 C0\nG16\nG1 X100. Y30. Z10. F500.\nG15\nM30\n%\n", polar);
  const gc::Diagnostic* e = nullptr;
  for (const auto& d : polar.sink.stored())
    if (d.severity == gc::Severity::error) e = &d;
  ASSERT_NE(e, nullptr) << polar.out;
  EXPECT_EQ(e->code, "PP-E601");
  EXPECT_EQ(e->where.line, 5u);
  Compensated plain;
  compensate("%\nO1\nG90 G54 G0 X0 Y0 Z50. A0 C0\nG1 X86.603 Y50. Z10. F500.\nM30\n%\n", plain);
  EXPECT_FALSE(plain.sink.has_errors());
  EXPECT_FALSE(plain.out.empty());
}

// Custom macro B external output (B-64484EN "External output commands": POPEN, BPRNT, DPRNT,
// PCLOS) sends data to a reader/punch or file: no motion. The bracket of DPRNT holds text and
// variables with their format ([53]); parentheses there are text, not a comment.
TEST(ReaderFanuc, ExternalOutputCommandsHaveNoMotion) {
  const Program r(dialect("fanuc"), "POPEN\nDPRNT[X#5041[44]*Y#5042[44] (A)]\nBPRNT[C**X#100[3]]\nPCLOS\nG0 X1. Y2.\n");
  EXPECT_FALSE(r.sink.has_errors()) << r.all_codes();
  EXPECT_EQ(r.sink.stored().size(), 0u) << r.all_codes();
  ASSERT_EQ(r.motions.size(), 1u);
  EXPECT_NEAR(r.motions[0].end[1], 2, 1e-12);
  const Program open(dialect("fanuc"), "DPRNT[X#1\nG0 X1.\n");
  expect_diag_at(open, "PP-E107", 1, 1);
}

}  // namespace
