// Reader round 2, LinuxCNC and the dwell of every dialect: each construct is read as the controller
// runs it (expected values from LinuxCNC 2.9's own interpreter `rs274 -g`, as noted per test, and the
// LinuxCNC G-code / M-code reference) or refused at its line.
#include <gtest/gtest.h>

#include <cmath>

#include "support.hpp"

namespace {

using namespace pptest;
using gc::Axis;
using gc::MotionType;
constexpr double kTol = 1e-9;

// LinuxCNC G-code reference "G4 Dwell": P is the time; rs274 runs "G4 P1 X20" as DWELL(1) then
// STRAIGHT_FEED to X20 in the modal G1.
TEST(ReaderLinuxcnc, DwellAxisWordsBelongToTheModalMotion) {
  const Program r(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z10\nG1 F100\nG4 P1 X20\nG4 P0.5\nX30 Y5\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  EXPECT_EQ(r.motions[1].line, 4u);
  EXPECT_EQ(r.motions[1].type, MotionType::linear);
  EXPECT_NEAR(r.motions[1].end[0], 20, kTol);
  EXPECT_NEAR(r.motions[2].end[1], 5, kTol);
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
}

// Fanuc 0i-MF operator's manual, "Dwell (G04)": G04 X (s) / P (ms); on lathes U too. X is never a
// position there; another axis word in the block is refused rather than guessed.
TEST(ReaderLinuxcnc, FanucDwellXIsATimeAndOtherAxesAreRefused) {
  const Program r(dialect("fanuc"), "G90 G1 X1 Y1 F100\nG04 X200.\nG04 X1. Y5.\n");
  ASSERT_EQ(r.motions.size(), 1u) << r.all_codes();
  EXPECT_NEAR(r.motions[0].end[0], 1, kTol);
  expect_diag_at(r, "PP-E206", 3, 9);
  const Program lathe(dialect("fanuc", true), "G0 X20. Z5.\nG04 U1.5\nG1 Z0 F0.1\n");
  ASSERT_EQ(lathe.motions.size(), 2u) << lathe.all_codes();
  EXPECT_NEAR(lathe.motions[1].end[0], 10, kTol);  // X stays at diameter 20: U was the dwell
}

// Sinumerik Fundamentals, "Dwell time (G4)": G4 F/S in a block of its own.
TEST(ReaderLinuxcnc, SiemensDwellWithAxisWordsIsRefused) {
  const Program r(dialect("siemens"), "G1 X1 F100\nG4 F2 X5\n");
  expect_diag_at(r, "PP-E206", 2, 7);
  ASSERT_EQ(r.motions.size(), 1u);
}

// rs274: G2 I5 J0 with no end words is a full circle (ARC_FEED ending at its start).
TEST(ReaderLinuxcnc, FullCircleByCentreOnly) {
  for (const char* d : {"linuxcnc", "fanuc"}) {
    const Program r(dialect(d), "G21 G90 G17\nG0 X0 Y0 Z0\nG2 I5 J0 F100\nG3 I-5\n");
    ASSERT_EQ(r.motions.size(), 3u) << d << r.all_codes();
    EXPECT_EQ(r.motions[1].type, MotionType::arc_cw);
    EXPECT_NEAR(r.motions[1].arc.centre[0], 5, kTol);
    EXPECT_NEAR(std::abs(r.motions[1].arc.sweep), 2 * 3.14159265358979323846, 1e-9);
    EXPECT_NEAR(r.motions[2].arc.centre[0], -5, kTol);
  }
}

// rs274: the interpreter starts in G99 (R plane); the initial level of G98 is the Z before the
// first of a chain of cycles (G81 … G98 G82 retracts to 20, not to the R plane it stands on).
TEST(ReaderLinuxcnc, CannedCycleRetractLevels) {
  const Program r(dialect("linuxcnc"),
                  "G21 G90\nG0 X0 Y0 Z20\nG81 X1 Y1 R2 Z-5 F100\nX2\nG98 G82 X3 R2 Z-5 P1\nX4\nG80\nG0 X5\n");
  ASSERT_EQ(r.motions.size(), 6u) << r.all_codes();
  EXPECT_NEAR(r.motions[1].end[2], 2, kTol);
  EXPECT_NEAR(r.motions[2].end[2], 2, kTol);
  EXPECT_NEAR(r.motions[3].end[2], 20, kTol);
  EXPECT_NEAR(r.motions[4].end[2], 20, kTol);
  const Program fanuc(dialect("fanuc"), "G90 G0 X0 Y0 Z20.\nG81 X1. Y1. R2. Z-5. F100.\n");
  ASSERT_EQ(fanuc.motions.size(), 2u);
  EXPECT_NEAR(fanuc.motions[1].end[2], 20, kTol);  // Fanuc powers on in G98
}

// rs274: L repeats the hole; under G91 the plane move is repeated, R and the bottom are computed
// once from the block's start (Z10 R-2 Z-5: every hole from 8 down to 3, back to 8); under G90 the
// same hole is drilled again. Fanuc K is the same repeat count (B-64484EN "Canned cycle": K, number
// of repeats) and a plain number even with standard (increment) input.
TEST(ReaderLinuxcnc, DrillingRepeatCount) {
  const Program r(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z10\nG91 G99 G81 X10 Y5 R-2 Z-5 L3 F100\n"
                                       "G90 G80\nG0 X0\nG98 G81 X1 Y1 R2 Z-1 L2\n");
  ASSERT_EQ(r.motions.size(), 7u) << r.all_codes();
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(r.motions[1 + k].end[0], 10.0 * (k + 1), kTol);
    EXPECT_NEAR(r.motions[1 + k].end[1], 5.0 * (k + 1), kTol);
    EXPECT_NEAR(r.motions[1 + k].end[2], 8, kTol);
    EXPECT_NEAR(r.motions[1 + k].cycle_bottom, 3, kTol);
  }
  EXPECT_NEAR(r.motions[5].end[0], 1, kTol);
  EXPECT_NEAR(r.motions[6].end[0], 1, kTol);
  EXPECT_NEAR(r.motions[6].end[2], 8, kTol);
  const Program f(dialect("fanuc", false, gc::Dialect::IntegerInput::increment),
                  "G90 G0 X0 Y0 Z10.\nG91 G99 G81 X10. Y5. R-2. Z-5. K3 F100.\nG80\n");
  ASSERT_EQ(f.motions.size(), 4u) << f.all_codes();
  EXPECT_NEAR(f.motions[3].end[0], 30, kTol);
}

// LinuxCNC M-code reference "M70–M73", checked with rs274: M72 restores units, distance modes,
// plane, feed mode and F, G98/G99 and the tool length offset; not the motion mode.
TEST(ReaderLinuxcnc, ModalStateSaveAndRestore) {
  const Program r(dialect("linuxcnc"),
                  "G21 G90 G17 G94 F100\nG0 X0 Y0 Z10\nM70\nG91 G43.1 Z2 G98\nG1 X1\nM72\nG1 X2\nG81 X3 R1 Z-1\n");
  ASSERT_EQ(r.motions.size(), 4u) << r.all_codes();
  EXPECT_NEAR(r.motions[1].end[0], 1, kTol);  // G91
  EXPECT_NEAR(r.motions[1].end[2], 8, kTol);  // Z10 under a 2 mm dynamic offset
  EXPECT_NEAR(r.motions[2].end[0], 2, kTol);  // G90 again
  EXPECT_NEAR(r.motions[2].end[2], 10, kTol); // the offset is gone again
  EXPECT_NEAR(r.motions[3].end[2], 1, kTol);  // G99 restored: the hole ends at R
  const Program bad(dialect("linuxcnc"), "G0 X0\nM70\nM71\nM72\n");
  expect_diag_at(bad, "PP-E207", 4, 1);
  const Program auto_restore(dialect("linuxcnc"), "G0 X0\nM73\n");
  expect_diag_at(auto_restore, "PP-U222", 2, 1);
}

// rs274: G92 X10 at X0 then G52 X5 gives a G92 offset of 5 (G52 replaces it), G92.1 clears both.
TEST(ReaderLinuxcnc, G52AndG92ShareOneOffset) {
  const Program r(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z1\nG92 X10\nG0 X11\nG52 X5\nG0 X1\nG92.1\nG0 X2\n");
  ASSERT_EQ(r.motions.size(), 4u) << r.all_codes();
  EXPECT_NEAR(r.motions[1].position_offset[0], -10, kTol);
  EXPECT_NEAR(r.motions[2].position_offset[0], 5, kTol);
  EXPECT_NEAR(r.motions[2].local_offset[0], 0, kTol);
  EXPECT_NEAR(r.motions[3].position_offset[0], 0, kTol);
}

// LinuxCNC refuses G53 in G91; Fanuc series disagree: refused everywhere.
TEST(ReaderLinuxcnc, G53UnderG91IsRefused) {
  for (const char* d : {"linuxcnc", "fanuc"}) {
    const Program r(dialect(d), "G21 G90\nG0 X1 Y1\nG91 G53 G0 X1\n");
    expect_diag_at(r, "PP-E207", 3, 5);
    EXPECT_EQ(r.motions.size(), 1u) << d;
  }
}

// rs274 stops at a feed move after G93 → G94 without a new F, and at a G93 feed move without F.
TEST(ReaderLinuxcnc, InverseTimeFeedRules) {
  const Program r(dialect("linuxcnc"), "G21 G90\nG0 X1 Y1\nG93 G1 X2 F10\nG94\nG1 X3\n");
  expect_diag_at(r, "PP-E207", 5, 1);
  const Program g93(dialect("linuxcnc"), "G21 G90\nG0 X1 Y1\nG93 G1 X2 F10\nX3\n");
  expect_diag_at(g93, "PP-E207", 4, 1);
  const Program ok(dialect("linuxcnc"), "G21 G90\nG0 X1 Y1\nG93 G1 X2 F10\nG94 G1 X3 F200\nG0 X4\n");
  EXPECT_EQ(ok.motions.size(), 4u) << ok.all_codes();
  EXPECT_FALSE(ok.has("PP-E207"));
}

// LinuxCNC G-code reference "Polar Coordinates", checked with rs274: @ distance, ^ angle in XY;
// absolute from the origin (a missing word keeps the current one), G91 adds to the current point's.
TEST(ReaderLinuxcnc, PolarWords) {
  const Program r(dialect("linuxcnc"), "G21 G90\nG0 @10 ^90\nG1 @5 ^0 F100\nG91 G1 @1 ^90\nG90 G0 X3 Y4\nG0 ^0\n");
  ASSERT_EQ(r.motions.size(), 5u) << r.all_codes();
  EXPECT_NEAR(r.motions[0].end[0], 0, 1e-12);
  EXPECT_NEAR(r.motions[0].end[1], 10, kTol);
  EXPECT_NEAR(r.motions[1].end[0], 5, kTol);
  EXPECT_NEAR(r.motions[2].end[0], 0, 1e-12);
  EXPECT_NEAR(r.motions[2].end[1], 6, kTol);
  EXPECT_NEAR(r.motions[4].end[0], 5, kTol);
  EXPECT_NEAR(r.motions[4].end[1], 0, kTol);
  const Program mixed(dialect("linuxcnc"), "G21 G90\nG0 X3 Y4\nG0 @1 X1\n");
  expect_diag_at(mixed, "PP-E207", 3, 4);
  const Program origin(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0\nG91 G0 @1\n");
  expect_diag_at(origin, "PP-E207", 3, 8);
}

// Editors on Windows write a UTF-8 byte-order mark; the controllers skip it.
TEST(ReaderLinuxcnc, ByteOrderMarkIsSkipped) {
  const Program r(dialect("linuxcnc"), "\xEF\xBB\xBFG21 G90\nG0 X1\n");
  ASSERT_EQ(r.motions.size(), 1u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const Program f(dialect("fanuc"), "\xEF\xBB\xBF%\nO1000\nG90 G0 X1.\n%\n");
  EXPECT_EQ(f.motions.size(), 1u) << f.all_codes();
}

}  // namespace
