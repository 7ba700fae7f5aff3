// Modal interpreter: positions, arcs, offsets, 5-axis states, lathe modes, cycles and the located
// diagnostics of everything it refuses or does not resolve.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "support.hpp"

namespace {

using namespace pptest;
using gc::Axis;
using gc::MotionType;
constexpr double kTol = 1e-9;
constexpr double kPi = std::numbers::pi;

bool known(const gc::Motion& m, Axis a) { return (m.known & gc::bit(a)) != 0; }

#define EXPECT_VEC(v, x, y, z)       \
  do {                               \
    EXPECT_NEAR((v)[0], (x), kTol);  \
    EXPECT_NEAR((v)[1], (y), kTol);  \
    EXPECT_NEAR((v)[2], (z), kTol);  \
  } while (0)
#define EXPECT_XYZ(m, x, y, z) EXPECT_VEC((m).end, x, y, z)

/// Expects exactly one diagnostic `code`, at line:column.
void expect_diag(const Program& r, std::string_view code, std::uint64_t line, std::uint32_t column) {
  const gc::Diagnostic* d = r.find(code);
  ASSERT_NE(d, nullptr) << "no " << code << "; got " << r.all_codes();
  EXPECT_EQ(d->where.line, line) << code;
  EXPECT_EQ(d->where.column, column) << code;
  EXPECT_EQ(d->file, "t.nc");
}

TEST(Interpreter, AbsoluteAndIncremental) {
  const Program r(dialect("fanuc"), "G90 G0 X10 Y20 Z30\nG91 G1 X5 Y-5 F100\nG90 G1 X1\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  EXPECT_XYZ(r.motions[1], 15, 15, 30);
  EXPECT_VEC(r.motions[1].start, 10, 20, 30);
  EXPECT_EQ(r.motions[1].type, MotionType::linear);
  EXPECT_EQ(r.motions[1].column, 5u);  // the G1 word
  EXPECT_EQ(r.motions[1].line, 2u);
  EXPECT_XYZ(r.motions[2], 1, 15, 30);
  EXPECT_EQ(r.motions[2].programmed, gc::bit(Axis::x));
  EXPECT_DOUBLE_EQ(r.motions[2].feed, 100);
  EXPECT_TRUE(r.sink.stored().empty());
}

TEST(Interpreter, InchIsConvertedToMm) {
  const Program r(dialect("fanuc"), "G20 G0 X1 Y2\nG91 G1 X0.5 F10\nG21 G90 G1 X3\n");
  ASSERT_EQ(r.motions.size(), 3u);
  EXPECT_NEAR(r.motions[0].end[0], 25.4, kTol);
  EXPECT_NEAR(r.motions[0].end[1], 50.8, kTol);
  EXPECT_NEAR(r.motions[1].end[0], 38.1, kTol);
  EXPECT_NEAR(r.motions[1].feed, 254, kTol);
  EXPECT_TRUE(r.motions[1].inch_source);
  EXPECT_NEAR(r.motions[2].end[0], 3, kTol);
  EXPECT_FALSE(r.motions[2].inch_source);
}

TEST(Interpreter, ArcsByCentreInAllPlanes) {
  const Program r(dialect("fanuc"),
              "G17 G0 X0 Y0 Z0\nG2 X10 Y0 I5 J0 F100\nG0 X10 Y0\nG3 X0 Y10 I-10 J0\n"
              "G18 G0 X10 Y0 Z0\nG2 X0 Z10 I-10 K0\nG19 G0 X3 Y10 Z0\nG3 Y0 Z10 J-10 K0\n");
  ASSERT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const auto* half = r.at_line(2);
  ASSERT_NE(half, nullptr);
  EXPECT_EQ(half->type, MotionType::arc_cw);
  EXPECT_NEAR(half->arc.centre.x(), 5, kTol);
  EXPECT_NEAR(half->arc.centre.y(), 0, kTol);
  EXPECT_NEAR(half->arc.radius, 5, kTol);
  EXPECT_NEAR(half->arc.sweep, -kPi, kTol);
  const auto* q = r.at_line(4);
  EXPECT_NEAR(q->arc.centre.x(), 0, kTol);
  EXPECT_NEAR(q->arc.centre.y(), 0, kTol);
  EXPECT_NEAR(q->arc.sweep, kPi / 2, kTol);
  // G18: cw about +Y takes +X to +Z.
  const auto* zx = r.at_line(6);
  EXPECT_EQ(zx->plane, gc::Plane::zx);
  EXPECT_NEAR(zx->arc.centre.x(), 0, kTol);
  EXPECT_NEAR(zx->arc.centre.z(), 0, kTol);
  EXPECT_NEAR(zx->arc.sweep, -kPi / 2, kTol);
  EXPECT_XYZ(*zx, 0, 0, 10);
  // G19: ccw about +X takes +Y to +Z; the centre keeps X of the start.
  const auto* yz = r.at_line(8);
  EXPECT_NEAR(yz->arc.centre.x(), 3, kTol);
  EXPECT_NEAR(yz->arc.centre.y(), 0, kTol);
  EXPECT_NEAR(yz->arc.centre.z(), 0, kTol);
  EXPECT_NEAR(yz->arc.sweep, kPi / 2, kTol);
}

TEST(Interpreter, ArcsByRadiusPositiveAndNegative) {
  const Program r(dialect("fanuc"),
              "G0 X0 Y0\nG2 X10 Y10 R10\nG0 X0 Y0\nG2 X10 Y10 R-10\nG0 X0 Y0\nG3 X10 Y10 R10\n"
              "G0 X0 Y0\nG3 X10 Y10 R-10\n");
  ASSERT_TRUE(r.sink.stored().empty()) << r.all_codes();
  struct Want {
    int line;
    double cx, cy, sweep;
  } want[] = {{2, 10, 0, -kPi / 2}, {4, 0, 10, -3 * kPi / 2}, {6, 0, 10, kPi / 2}, {8, 10, 0, 3 * kPi / 2}};
  for (const auto& w : want) {
    const auto* m = r.at_line(static_cast<std::uint64_t>(w.line));
    ASSERT_NE(m, nullptr) << w.line;
    EXPECT_NEAR(m->arc.centre.x(), w.cx, kTol) << w.line;
    EXPECT_NEAR(m->arc.centre.y(), w.cy, kTol) << w.line;
    EXPECT_NEAR(m->arc.radius, 10, kTol) << w.line;
    EXPECT_NEAR(m->arc.sweep, w.sweep, kTol) << w.line;
    EXPECT_XYZ(*m, 10, 10, 0);
  }
}

TEST(Interpreter, FullCircleHelixAndTurns) {
  const Program r(dialect("linuxcnc"),
              "G0 X10 Y0 Z0\nG2 X10 Y0 I-5 J0 F100\nG3 X-10 Y0 Z-5 I-10 J0\nG0 X10 Y0 Z0\n"
              "G3 X10 Y0 Z-6 I-10 J0 P3\nG2 X0 Y-10 I-10 J0 P2\nM2\n");
  ASSERT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const auto* full = r.at_line(2);
  EXPECT_TRUE(full->arc.full_circle);
  EXPECT_NEAR(full->arc.sweep, -2 * kPi, kTol);
  EXPECT_NEAR(full->arc.centre.x(), 5, kTol);
  const auto* helix = r.at_line(3);
  EXPECT_XYZ(*helix, -10, 0, -5);
  EXPECT_NEAR(helix->arc.centre.x(), 0, kTol);
  EXPECT_NEAR(helix->arc.radius, 10, kTol);
  EXPECT_NEAR(helix->arc.centre.z(), 0, kTol);  // the start height
  EXPECT_NEAR(helix->arc.sweep, kPi, kTol);
  const auto* turns = r.at_line(5);
  EXPECT_EQ(turns->arc.turns, 3u);
  EXPECT_NEAR(turns->arc.sweep, 6 * kPi, kTol);
  EXPECT_XYZ(*turns, 10, 0, -6);
  const auto* p2 = r.at_line(6);
  EXPECT_EQ(p2->arc.turns, 2u);
  EXPECT_NEAR(p2->arc.sweep, -kPi / 2 - 2 * kPi, kTol);
}

TEST(Interpreter, ArcErrorsAreLocated) {
  const Program mismatch(dialect("fanuc"), "G0 X0 Y0\nN5 G2 X10 Y0 I4 J0\n");
  expect_diag(mismatch, "PP-E301", 2, 4);
  EXPECT_NE(mismatch.find("PP-E301")->message.find("4.000000 mm and at end 6.000000 mm"), std::string::npos);
  const Program same(dialect("fanuc"), "G0 X0 Y0\nG2 X0 Y0 R5\n");
  expect_diag(same, "PP-E301", 2, 1);
  const Program small(dialect("fanuc"), "G0 X0 Y0\nG1 X1\nG3 X11 Y0 R4\n");
  expect_diag(small, "PP-E301", 3, 1);
  const Program no_centre(dialect("linuxcnc"), "G0 X0 Y0 F100\nG2 X10 Y0\n");
  expect_diag(no_centre, "PP-E204", 2, 1);
  const Program p0(dialect("linuxcnc"), "G0 X0 Y0 F100\nG2 X10 Y0 I5 J0 P0\n");
  expect_diag(p0, "PP-E301", 2, 17);
  for (const Program* r : {&mismatch, &same, &small, &no_centre, &p0}) EXPECT_EQ(r->motions.size(), r == &small ? 2u : 1u);
}

// rs274 starts at feed rate 0: a feed move before any F is refused ("Cannot do G1 with zero feed
// rate", "Cannot make arc with zero feed rate", "Cannot feed with zero feed rate"; rs274 -g).
TEST(Interpreter, LinuxcncFeedMoveBeforeAnyFIsRefused) {
  for (const char* move : {"G1 X10", "G2 X2 Y0 R1", "G81 X1 Y1 Z-1 R1"}) {
    const Program r(dialect("linuxcnc"), std::string("G0 X0 Y0 Z5\n") + move + "\nM2\n");
    expect_diag(r, "PP-E207", 2, 1);
    EXPECT_EQ(r.motions.size(), 1u) << move;
    const Program with_f(dialect("linuxcnc"), std::string("G0 X0 Y0 Z5 F100\n") + move + "\nM2\n");
    EXPECT_FALSE(with_f.sink.has_errors()) << move << ": " << with_f.all_codes();
  }
}

TEST(Interpreter, FanucArcWithoutCentreMovesStraightUnlessParameterCir) {
  // Fanuc parameter 3403#5 CIR = 0 (factory setting): a G02/G03 block with neither I J K nor R
  // moves to its end point by linear interpolation; G02/G03 stays modal (the next block with R is an
  // arc). CIR = 1: alarm PS0022 (refused, PP-E204). Seen in production lathe programs (a modal G03
  // block with Z alone after an R arc).
  const Program straight(dialect("fanuc"), "G0 X0 Y0\nG2 X10 Y0 F100\nX10 Y10 R5\n");
  ASSERT_FALSE(straight.sink.has_errors()) << straight.all_codes();
  ASSERT_EQ(straight.motions.size(), 3u);
  EXPECT_EQ(straight.motions[1].type, MotionType::linear);
  EXPECT_NEAR(straight.motions[1].end[0], 10, 1e-12);
  EXPECT_EQ(straight.motions[2].type, MotionType::arc_cw);
  gc::DialectOptions cir;
  cir.arc_without_centre_alarm = true;
  const Program alarm(gc::make_dialect(gc::DialectId::fanuc, cir), "G0 X0 Y0\nG2 X10 Y0 F100\n");
  expect_diag(alarm, "PP-E204", 2, 1);
  EXPECT_EQ(alarm.motions.size(), 1u);
}

TEST(Interpreter, ZeroRadiusArcIsRefused) {
  // A full circle around its own start point has radius 0: an impossible arc (README: PP-E301).
  const Program r(dialect("fanuc"), "G0 X0 Y0\nG2 X0 Y0 I0 J0 F100\n");
  expect_diag(r, "PP-E301", 2, 1);
}

TEST(Interpreter, InchArcToleranceIsATenthOfAThou) {
  // interpreter_motion.cpp: inch programs are allowed 0.0002 in (0.00508 mm) instead of 0.002 mm.
  // (interpreter.hpp still calls arc_radius_tolerance_mm a tolerance "in mm" for both.)
  const Program mm(dialect("fanuc"), "G21 G0 X0 Y0\nG2 X2.543 Y0 I1.27 J0\n");  // radii 1.270 / 1.273 mm
  expect_diag(mm, "PP-E301", 2, 1);
  const Program inch_ok(dialect("fanuc"), "G20 G0 X0 Y0\nG2 X0.10011811 Y0 I0.05 J0\n");  // same, in inch
  EXPECT_FALSE(inch_ok.sink.has_errors()) << inch_ok.all_codes();
  const Program inch_bad(dialect("fanuc"), "G20 G0 X0 Y0\nG2 X0.10024 Y0 I0.05 J0\n");  // 0.00024 in apart
  expect_diag(inch_bad, "PP-E301", 2, 1);
}

TEST(Interpreter, LocalAndPositionOffsets) {
  const Program g52(dialect("fanuc"), "G0 X10 Y10 Z5\nG52 X5 Y0\nG1 X0 Y0 F100\n");
  ASSERT_EQ(g52.motions.size(), 2u);
  EXPECT_VEC(g52.motions[1].start, 5, 10, 5);
  EXPECT_XYZ(g52.motions[1], 0, 0, 5);
  EXPECT_NEAR(g52.motions[1].local_offset[0], 5, kTol);
  const Program g92(dialect("linuxcnc"), "G0 X10 Y0 Z0\nG92 X0\nG1 X5 F1\nG92.1\nG1 Y1\n");
  ASSERT_EQ(g92.motions.size(), 3u);
  EXPECT_VEC(g92.motions[1].start, 0, 0, 0);
  EXPECT_XYZ(g92.motions[1], 5, 0, 0);
  EXPECT_NEAR(g92.motions[1].position_offset[0], 10, kTol);
  EXPECT_XYZ(g92.motions[2], 15, 1, 0);
  EXPECT_NEAR(g92.motions[2].position_offset[0], 0, kTol);
}

TEST(Interpreter, SiemensTransAndItsReset) {
  const Program r(dialect("siemens"), "G0 X10 Y10 Z0\nTRANS X5\nG1 X0 F100\nATRANS Y2\nG1 Y0\nTRANS\nG1 X1\n");
  ASSERT_EQ(r.motions.size(), 4u) << r.all_codes();
  EXPECT_VEC(r.motions[1].start, 5, 10, 0);  // X10 in the base frame is X5 in the shifted one
  EXPECT_XYZ(r.motions[1], 0, 10, 0);
  EXPECT_NEAR(r.motions[2].local_offset[1], 2, kTol);
  EXPECT_XYZ(r.motions[2], 0, 0, 0);
  // TRANS without values drops the frame: the point (0,0) of the shifted frame is (5,2) again.
  const auto& after = r.motions[3];
  EXPECT_NEAR(after.local_offset[0], 0, kTol);
  EXPECT_XYZ(after, 1, 2, 0);
}

TEST(Interpreter, MachineFrameAndWorkOffsets) {
  const Program r(dialect("fanuc"), "G0 X1 Y1 Z1\nG53 G0 Z0\nG0 X2\nG54.1 P3\nG0 X1 Y2 Z3\n");
  ASSERT_EQ(r.motions.size(), 4u) << r.all_codes();
  EXPECT_EQ(r.motions[1].frame, gc::Frame::machine);
  EXPECT_EQ(r.motions[1].known, gc::bit(Axis::z));
  EXPECT_NEAR(r.motions[1].end[2], 0, kTol);
  EXPECT_EQ(r.motions[2].frame, gc::Frame::work);
  EXPECT_FALSE(known(r.motions[2], Axis::z));  // the work-frame Z after G53 is not known
  EXPECT_TRUE(known(r.motions[2], Axis::x));
  EXPECT_EQ(r.motions[3].work_offset.code10, 541);
  EXPECT_EQ(r.motions[3].work_offset.p, 3);
  const Program no_p(dialect("fanuc"), "G0 X0\nN2 G54.1\n");
  expect_diag(no_p, "PP-E204", 2, 4);
}

TEST(Interpreter, FiveAxisStates) {
  const Program f(dialect("fanuc"), "G0 X0 Y0 Z0\nG43.4 H7 Z10\nG1 X1 B10 C20 F100\nG49\nG1 X2\nG43.5 H2 X3\n");
  ASSERT_EQ(f.motions.size(), 5u);
  EXPECT_EQ(f.motions[1].tcp, gc::TcpMode::fanuc_g43_4);
  EXPECT_EQ(f.motions[1].tool_length_h, 7);
  EXPECT_TRUE(f.motions[2].tool_length_active);
  EXPECT_NEAR(f.motions[2].end[4], 10, kTol);
  EXPECT_NEAR(f.motions[2].end[5], 20, kTol);
  EXPECT_EQ(f.motions[3].tcp, gc::TcpMode::off);
  EXPECT_FALSE(f.motions[3].tool_length_active);
  EXPECT_EQ(f.motions[4].tcp, gc::TcpMode::fanuc_g43_5);
  const Program s(dialect("siemens"), "G0 X0 Y0 Z0\nTRAORI\nG1 X1 F100\nTRAFOOF\nG1 X2\nTRAORI(1)\nG1 X3\n");
  ASSERT_EQ(s.motions.size(), 4u);
  EXPECT_EQ(s.motions[1].tcp, gc::TcpMode::siemens_traori);
  EXPECT_EQ(s.motions[2].tcp, gc::TcpMode::off);
  EXPECT_EQ(s.motions[3].tcp, gc::TcpMode::siemens_traori);
  const Program h(dialect("heidenhain-iso"), "G0 X0 Y0 Z0 *\nM128 *\nG1 X1 F100 *\nM129 *\nG1 X2 *\n");
  ASSERT_EQ(h.motions.size(), 3u);
  EXPECT_EQ(h.motions[1].tcp, gc::TcpMode::heidenhain_m128);
  EXPECT_EQ(h.motions[2].tcp, gc::TcpMode::off);
  const Program m128_fanuc(dialect("fanuc"), "M128\nG0 X1\n");
  EXPECT_EQ(m128_fanuc.motions.at(0).tcp, gc::TcpMode::off);  // M128 means TCP only on Heidenhain
}

TEST(Interpreter, SiemensAddresses) {
  const Program r(dialect("siemens"),
              "G0 X0 Y0\nG2 X10 Y10 CR=10\nG0 X10 Y0\nG3 X0 Y10 I=AC(0) J=AC(0)\nG1 X=IC(5) Y=AC(3) F100\n");
  ASSERT_TRUE(r.sink.stored().empty()) << r.all_codes();
  ASSERT_EQ(r.motions.size(), 5u);
  EXPECT_NEAR(r.motions[1].arc.centre.x(), 10, kTol);
  EXPECT_NEAR(r.motions[1].arc.centre.y(), 0, kTol);
  EXPECT_NEAR(r.motions[1].arc.sweep, -kPi / 2, kTol);
  EXPECT_NEAR(r.motions[3].arc.centre.x(), 0, kTol);
  EXPECT_NEAR(r.motions[3].arc.centre.y(), 0, kTol);
  EXPECT_NEAR(r.motions[3].arc.sweep, kPi / 2, kTol);
  EXPECT_XYZ(r.motions[4], 5, 3, 0);
}

TEST(Interpreter, DiameterModes) {
  const Program l(dialect("linuxcnc"), "G18 G7 G0 X20 Z0\nG8 G1 X20 F1\n");
  ASSERT_EQ(l.motions.size(), 2u);
  EXPECT_NEAR(l.motions[0].end[0], 10, kTol);
  EXPECT_TRUE(l.motions[0].diameter_mode);
  EXPECT_NEAR(l.motions[1].end[0], 20, kTol);
  EXPECT_FALSE(l.motions[1].diameter_mode);
  const Program f(dialect("fanuc", true), "G0 X50 Z10\nG1 U-10 W-5 F0.1\nX20\nG18 G0 X20 Z0\nG2 X40 Z-10 R10\n");
  ASSERT_EQ(f.motions.size(), 5u) << f.all_codes();
  EXPECT_NEAR(f.motions[0].end[0], 25, kTol);
  EXPECT_NEAR(f.motions[1].end[0], 20, kTol);
  EXPECT_NEAR(f.motions[1].end[2], 5, kTol);
  EXPECT_NEAR(f.motions[2].end[0], 10, kTol);
  EXPECT_TRUE(f.motions[2].diameter_mode);
  const auto& arc = f.motions[4];  // radius 10 from X r10 Z0 to X r20 Z-10, cw: centre X r20 Z0
  EXPECT_NEAR(arc.arc.centre.x(), 20, kTol);
  EXPECT_NEAR(arc.arc.centre.z(), 0, kTol);
  EXPECT_NEAR(arc.arc.sweep, -kPi / 2, kTol);
}

TEST(Interpreter, FanucLatheStartsInG18) {
  // A Fanuc lathe powers up in G18 (Z-X plane); X/Z arcs without an explicit G18 are common.
  const Program r(dialect("fanuc", true), "G0 X20 Z0\nG2 X40 Z-10 R10 F0.1\n");
  ASSERT_EQ(r.motions.size(), 2u);
  EXPECT_EQ(r.motions[1].plane, gc::Plane::zx);
  EXPECT_NEAR(r.motions[1].arc.centre.x(), 20, kTol);
}

TEST(Interpreter, DrillCycleEndLevels) {
  const Program r(dialect("fanuc"), "G0 X0 Y0 Z50\nG99 G81 X10 Y10 Z-5 R2 F100\nX20\nG98 X30\nG80\nG0 Z60\n");
  ASSERT_EQ(r.motions.size(), 5u) << r.all_codes();  // G80 alone makes no motion
  EXPECT_EQ(r.motions[1].type, MotionType::drill_cycle);
  EXPECT_EQ(r.motions[1].cycle_code10, 810);
  EXPECT_NEAR(r.motions[1].cycle_r, 2, kTol);
  EXPECT_NEAR(r.motions[1].cycle_bottom, -5, kTol);
  EXPECT_XYZ(r.motions[1], 10, 10, 2);  // G99: back to R
  EXPECT_XYZ(r.motions[2], 20, 10, 2);
  EXPECT_XYZ(r.motions[3], 30, 10, 50);  // G98: back to the initial level
  EXPECT_EQ(r.motions[3].type, MotionType::drill_cycle);
  EXPECT_EQ(r.motions[3].column, 5u);
  EXPECT_EQ(r.motions[4].type, MotionType::rapid);
  EXPECT_XYZ(r.motions[4], 30, 10, 60);
  const Program inc(dialect("fanuc"), "G0 X0 Y0 Z50\nG91 G99 G81 X10 Y0 Z-7 R-40 F100\n");
  ASSERT_EQ(inc.motions.size(), 2u);
  EXPECT_NEAR(inc.motions[1].cycle_r, 10, kTol);
  EXPECT_NEAR(inc.motions[1].cycle_bottom, 3, kTol);
  EXPECT_XYZ(inc.motions[1], 10, 0, 10);
}

TEST(Interpreter, DrillAfterUnknownZKeepsZUnknown) {
  // After G28 Z the work-frame Z is unknown, so the G98 initial level (and the end Z) is unknown too.
  const Program r(dialect("fanuc"), "G0 X0 Y0 Z50\nG91 G28 Z0\nG90 G98 G81 X10 Y10 Z-5 R2 F100\n");
  const auto* m = r.at_line(3);
  ASSERT_NE(m, nullptr);
  EXPECT_FALSE(known(*m, Axis::z));
}

TEST(Interpreter, UnresolvedConstructsHaveStableCodes) {
  struct Case {
    const char* dialect;
    bool lathe;
    const char* program;
    const char* code;
    std::uint64_t line;
    std::uint32_t column;
  } cases[] = {
      {"fanuc", true, "G0 X50 Z2\nN10 G90\n", "PP-U201", 2, 5},
      // LinuxCNC G76 and G33.1 are read: tests/test_threading.cpp, test_lathe_cycles.cpp.
      {"siemens", false, "G0 X0 Z0\nG331 Z-10 K1\n", "PP-U202", 2, 1},
      {"fanuc", true, "G0 X10 Z0\nG76 X8.2 Z-20. P900 Q300 F1.5\n", "PP-U202", 2, 1},
      {"linuxcnc", false, "G0 X0 Y0\nG5.1 X1 Y1 I0.5 J0.5\n", "PP-U203", 2, 1},
      {"fanuc", false, "G0 X0 Y0 C0\nG12.1\nG1 X10 C5 F100\nG13.1\n", "PP-U204", 3, 1},
      {"fanuc", true, "G0 X0 Z0\nG112\nG1 X10 C5 F100\nG113\n", "PP-U204", 3, 1},
      {"siemens", false, "G0 X0 Y0\nN5 CYCLE83(100,2,1,-20,,-5)\n", "PP-U210", 2, 4},
      {"fanuc", false, "G0 X0\nN9 M98 P1000\n", "PP-U211", 2, 4},
      {"fanuc", false, "G0 X[#1+2.] Y#2\n", "PP-U213", 1, 4},
      {"siemens", false, "G0 Z=DEPTH+1\n", "PP-U213", 1, 4},
      {"fanuc", false, "#1=5\n", "PP-U214", 1, 1},
      {"linuxcnc", false, "G0 X0\n  #<r>=2\n", "PP-U214", 2, 3},
      {"fanuc", false, "G0 X1\nIF [#1 GT 2] GOTO 5\n", "PP-U212", 2, 1},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.program);
    const Program r(dialect(c.dialect, c.lathe), c.program);
    expect_diag(r, c.code, c.line, c.column);
    EXPECT_EQ(r.find(c.code)->severity, gc::Severity::warning);
    EXPECT_FALSE(r.sink.has_errors()) << r.all_codes();
  }
}

TEST(Interpreter, Cycle800IsATiltedPlane) {
  // README lists CYCLE800 under PP-U207 (tilted work plane), not PP-U210 (vendor cycles).
  const Program r(dialect("siemens"), "G0 X0 Y0\nN5 CYCLE800(1,\"TC\",0,57,0,0,0,30,0,0,0,0,0,1)\n");
  EXPECT_FALSE(r.sink.has_errors());
  expect_diag(r, "PP-U207", 2, 4);
}

TEST(Interpreter, UnresolvedMotionMakesPositionsUnknown) {
  const Program r(dialect("linuxcnc"), "G0 X0 Y0\nG5.1 X1 Y1 I0.5 J0.5\nG1 X2 F1\nG0 X3 Y3\n");
  ASSERT_EQ(r.motions.size(), 3u);
  EXPECT_TRUE(known(r.motions[1], Axis::x));
  EXPECT_FALSE(known(r.motions[1], Axis::y));  // still unknown after the spline
  EXPECT_TRUE(known(r.motions[2], Axis::y));   // re-established by an absolute move
  const Program cyc(dialect("siemens"), "G0 X0 Y0\nCYCLE800(1,\"TC\",0,57,0,0,0,30,0,0,0,0,0,1)\nG1 X1 F1\nCYCLE800()\nG1 X2\n");
  ASSERT_EQ(cyc.motions.size(), 3u);
  EXPECT_TRUE(cyc.motions[1].tilted_plane);
  EXPECT_FALSE(known(cyc.motions[1], Axis::y));
  EXPECT_FALSE(cyc.motions[2].tilted_plane);
}

TEST(Interpreter, ErrorsOnUnknownAndConflictingCodes) {
  const Program unknown(dialect("fanuc"), "G0 X0\nN10 G1.5 X1\n");
  expect_diag(unknown, "PP-E201", 2, 5);
  EXPECT_EQ(unknown.find("PP-E201")->length, 4u);
  EXPECT_EQ(unknown.find("PP-E201")->severity, gc::Severity::error);
  EXPECT_EQ(unknown.motions.size(), 1u);  // the refused block makes no motion
  const Program g43_4(dialect("linuxcnc"), "G43.4 H1\n");
  expect_diag(g43_4, "PP-E201", 1, 1);
  const Program two(dialect("linuxcnc"), "G0 G1 X1\n");
  expect_diag(two, "PP-E202", 1, 4);
  EXPECT_TRUE(two.motions.empty());
  const Program planes(dialect("siemens"), "G17 G18\n");
  expect_diag(planes, "PP-E202", 1, 5);
  // Fanuc (G code list, notes): of G codes of one group in one block, the last one is valid.
  const Program last(dialect("fanuc"), "G0 G1 X1 Z0 F100\nG17 G18 G2 X3 Z2 R2\n");
  ASSERT_FALSE(last.sink.has_errors()) << last.all_codes();
  ASSERT_EQ(last.motions.size(), 2u);
  EXPECT_EQ(last.motions[0].type, MotionType::linear);
  EXPECT_EQ(last.motions[1].plane, gc::Plane::zx);
  // G81 then G80 (both group 09): G80 is valid, the cycle is cancelled and the modal G01 moves; G01
  // with G81 (groups 01 and 09, one group here) stays refused.
  const Program cancel(dialect("fanuc"), "G0 X0 Y0 Z5.\nG1 X1. F100.\nG81 G80 X11. Z-1. R1.\n");
  ASSERT_FALSE(cancel.sink.has_errors()) << cancel.all_codes();
  ASSERT_EQ(cancel.motions.size(), 3u);
  EXPECT_EQ(cancel.motions[2].type, MotionType::linear);
  const Program across(dialect("fanuc"), "G0 X0 Y0 Z5.\nG1 G81 X1. Z-1. R1. F100.\n");
  expect_diag(across, "PP-E202", 2, 4);
  const Program twice(dialect("fanuc"), "G0 X1 X2\n");
  expect_diag(twice, "PP-E203", 1, 7);
  // LinuxCNC leaves no motion mode after G80 (Fanuc keeps G00/G01: test_reader_fanuc.cpp).
  const Program after_g80(dialect("linuxcnc"), "G0 X0 Y0 Z10\nG80 X1\n");
  expect_diag(after_g80, "PP-E204", 2, 5);
}

TEST(Interpreter, FanucWholeNumbersWithoutPoint) {
  // Fanuc standard input: X1 is one least increment (0.001 mm); unless the user said so, PP-U218 once.
  const Program unknown(dialect("fanuc", false, gc::Dialect::IntegerInput::unknown), "G0 X1 Y2.\nG1 X3 F100\n");
  ASSERT_EQ(unknown.motions.size(), 2u);
  EXPECT_NEAR(unknown.motions[0].end[0], 0.001, kTol);
  EXPECT_NEAR(unknown.motions[0].end[1], 2, kTol);
  EXPECT_NEAR(unknown.motions[1].end[0], 0.003, kTol);
  expect_diag(unknown, "PP-U218", 1, 4);
  EXPECT_EQ(unknown.sink.per_code().at("PP-U218"), 1u);  // once per program
  const Program increment(dialect("fanuc", false, gc::Dialect::IntegerInput::increment), "G20 G0 X1 A1\n");
  EXPECT_NEAR(increment.motions[0].end[0], 0.0001 * 25.4, kTol);
  EXPECT_NEAR(increment.motions[0].end[3], 0.001, kTol);  // degrees
  EXPECT_FALSE(increment.has("PP-U218"));
  const Program calculator(dialect("fanuc", false, gc::Dialect::IntegerInput::calculator), "G0 X1\n");
  EXPECT_NEAR(calculator.motions[0].end[0], 1, kTol);
  EXPECT_FALSE(calculator.has("PP-U218"));
  // Siemens and LinuxCNC read whole numbers as whole units.
  const Program lcnc(dialect("linuxcnc"), "G0 X1\n");
  EXPECT_NEAR(lcnc.motions[0].end[0], 1, kTol);
}

}  // namespace

namespace {

TEST(Interpreter, ToolVectorsUnderTraoriAndG43_5) {
  // Siemens A3/B3/C3 (missing components 0) and Fanuc G43.5 I J K give a unit tool axis per block.
  const Program s(dialect("siemens"),
                  "G17 G0 X0 Y0 Z0\nTRAORI\nG1 X10 A3=0 B3=3 C3=4 F500\nORIMKS\nX20\nTRAFOOF\nG1 X1 A3=1\n");
  ASSERT_EQ(s.motions.size(), 4u);
  EXPECT_TRUE(s.motions[1].tool_vector_known);
  EXPECT_NEAR(s.motions[1].tool_vector.y(), 0.6, kTol);
  EXPECT_NEAR(s.motions[1].tool_vector.z(), 0.8, kTol);
  EXPECT_FALSE(s.motions[1].orientation_machine_frame);
  EXPECT_FALSE(s.motions[2].tool_vector_known);  // not programmed in that block
  EXPECT_TRUE(s.motions[2].orientation_machine_frame);
  EXPECT_FALSE(s.motions[3].tool_vector_known);  // A3 without TRAORI is no tool vector
  const Program f(dialect("fanuc"), "G17 G0 X0 Y0 Z0\nG43.5 H1 X1 I0 J0 K2\nG1 X2 I1 J1 K0 F100\nG2 X4 I1 J0\n");
  ASSERT_EQ(f.motions.size(), 4u);
  EXPECT_NEAR(f.motions[1].tool_vector.z(), 1, kTol);
  EXPECT_NEAR(f.motions[2].tool_vector.x(), std::sqrt(0.5), kTol);
  EXPECT_NEAR(f.motions[2].tool_vector.y(), std::sqrt(0.5), kTol);
  EXPECT_FALSE(f.motions[3].tool_vector_known);  // on an arc I J K are the centre
  EXPECT_NEAR(f.motions[3].arc.centre.x(), 3, kTol);
}

}  // namespace

namespace {

TEST(Interpreter, FanucQIsALengthOnlyInDrillingCycles) {
  // G5.1 Q1 is a mode switch, not 1 µm; G83 Q500 is a peck depth of 0.5 mm under standard input.
  const Program mode_switch(dialect("fanuc", false, gc::Dialect::IntegerInput::unknown),
                            "G21 G0 X0. Y0. Z10.\nG5.1 Q1\nG1 X1. F100.\n");
  EXPECT_FALSE(mode_switch.has("PP-U218")) << mode_switch.all_codes();
  const Program peck(dialect("fanuc", false, gc::Dialect::IntegerInput::unknown),
                     "G21 G0 X0. Y0. Z10.\nG5.1 Q1\nG99 G83 X1. Y1. Z-5. R2. Q500 F100.\n");
  expect_diag(peck, "PP-U218", 3, 26);
}

}  // namespace
