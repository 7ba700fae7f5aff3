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
  const Program r(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z10\nG1 F100\nG4 P1 X20\nG4 P0.5\nX30 Y5\nM2\n");
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

// rs274 2.9 stops on a D, E or H word that nothing in its block uses ("D word with no G41, …",
// "E word with no G70, G76, M66, M67 or M68 …", "H word with no G43 or G76 …"); each case below was
// run through rs274 -g. Its messages list fewer codes than it accepts: D is also taken by G70 and
// G72, E by G70. postproc accepted the refused ones.
TEST(ReaderLinuxcnc, UnusedDEHWordsRefusedAsRs274Does) {
  constexpr const char* kSub = "O100 SUB\nG1 X4 Z2\nO100 ENDSUB\nG21 G90 G18\nM3 S500\nG0 X10 Z5\n";
  const std::pair<const char*, std::uint32_t> refused[] = {{"G0 X1 D1", 7},    {"G0 X1 E1", 7},     {"G0 X1 H1", 7},
                                                           {"G49 H1", 5},      {"G43.1 Z1 H1", 10}, {"G71 Q100 X15 Z3 D1 E1", 20}};
  for (const auto& [block, column] : refused) {
    const Program r(dialect("linuxcnc"), std::string(kSub) + block + "\nG0 X1\nM2\n");
    expect_diag_at(r, "PP-E207", 7, column);
  }
  for (const char* block : {"G43 H0", "G96 D1000 S100", "M66 P0 E0 L0", "G70 Q100 X15 Z3 D0.5 E0.5",
                            "G72 Q100 X15 Z3 D1", "G76 P1 Z-5 I-0.1 J0.1 K0.5 H1 E0.1", "G41 D0 G1 X2 F10"}) {
    const Program r(dialect("linuxcnc"), std::string(kSub) + block + "\nG40\nG0 X1\nM2\n");
    EXPECT_EQ(r.find("PP-E207"), nullptr) << block << ": " << r.all_codes();
  }
}

// rs274 2.9 reads T, H and M with read_integer_value: within 0.0001 of a whole number the value is
// that number (T1.99995 is tool 2), else the program stops ("Non integer value for integer"); each
// case run through rs274 -g (tests/lcnc_samples_tools.tbl gives tool 2 a length). postproc took T2.6.
TEST(ReaderLinuxcnc, ToolLengthAndMWordsMustBeWholeNumbersAsRs274Reads) {
  for (const auto& [block, column] : std::vector<std::pair<std::string, std::uint32_t>>{
           {"T2.6 M6", 1}, {"T2 M6 G43 H1.6", 11}, {"M3.5 S100", 1}, {"M3 T1.0002", 4}}) {
    const Program r(dialect("linuxcnc"), "G21 G90\n" + block + "\nG0 X1\nM2\n");
    expect_diag_at(r, "PP-E207", 2, column);
  }
  // Within the tolerance: the whole number (tool 2's length applies to Z; M2.99995 starts the spindle).
  gc::Dialect d = dialect("linuxcnc");
  d.tool_lengths[2] = 5;
  const Program near(d, "G21 G90\nT1.99995 M6\nG43 H1.99995\nG0 Z10\nM2.99995 S100\nM2\n");
  EXPECT_EQ(near.find("PP-E207"), nullptr) << near.all_codes();
  ASSERT_EQ(near.motions.size(), 1u) << near.all_codes();
  EXPECT_TRUE(near.motions[0].known & gc::bit(Axis::z)) << near.all_codes();
  EXPECT_NEAR(near.motions[0].end[2], 10, kTol);  // program Z; the length is tool 2's, not tool 1's (unknown)
}

// LinuxCNC O codes, "Fanuc-Style Numbered Programs" (checked with rs274; random programs in
// tests/rs274_numbered_compare.py): M98 P<n> [L<k>] runs O<n> … M99 k times, #1–#30 global. An
// "O<n>" line alone where the main program runs is a program number rs274 runs through
// (tests/resolve/linuxcnc/reader_program_number.ngc).
TEST(ReaderLinuxcnc, FanucStyleNumberedProgramsAreFollowed) {
  // rs274: (1,1), (2,1) in O100, (2,2).
  const ResolvedProgram r(dialect("linuxcnc"), "O1000\nG21 G90\nG0 X1 Y1\nM98 P100\nG0 Y2\nM2\nO100\nG91 G0 X1\nG90\nM99\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  EXPECT_NEAR(r.motions[1].end[0], 2, kTol);
  EXPECT_NEAR(r.motions[2].end[0], 2, kTol);
  EXPECT_NEAR(r.motions[2].end[1], 2, kTol);
  // L3 and a nested call; #1 is global (rs274: X1 X2 X3, then Y1 Y2 from O200 called by O100 once, then X[#1] = 7).
  const ResolvedProgram n(dialect("linuxcnc"),
                          "G21 G90\nG0 X0 Y0\nM98 P100 L3\nM98 P150\nG0 X#1\nM30\nO100\nG91 G0 X1\nG90\nM99\n"
                          "O150\n#1 = 7\nM98 P200 L2\nM99\nO200\nG91 G0 Y1\nG90\nM99\n");
  ASSERT_EQ(n.motions.size(), 7u) << n.all_codes();
  EXPECT_NEAR(n.motions[3].end[0], 3, kTol);
  EXPECT_NEAR(n.motions[5].end[1], 2, kTol);
  EXPECT_NEAR(n.motions[6].end[0], 7, kTol);
  // Refused where rs274 stops or does not follow its own reference.
  expect_diag_at(ResolvedProgram(dialect("linuxcnc"), "G0 X0\nM98 P100 L0\nM30\nO100\nG0 X1\nM99\n"), "PP-E709", 2, 1);
  expect_diag_at(ResolvedProgram(dialect("linuxcnc"), "G0 X0\nO100\nG0 X1\nM99\n"), "PP-E708", 4, 1);  // endless
  expect_diag_at(ResolvedProgram(dialect("linuxcnc"), "G0 X0\nM98 P100\nM30\n"), "PP-E704", 2, 1);
  expect_diag_at(ResolvedProgram(dialect("linuxcnc"), "G0 X0\nM98 P100\nM30\no100 sub\nG0 X1\no100 endsub\n"),
                 "PP-E708", 2, 1);  // the styles do not mix
  expect_diag_at(ResolvedProgram(dialect("linuxcnc"), "M98 P200\nM30\nO100\nG0 X1\nM99\nO200\nM98 P100\nM99\n"),
                 "PP-E708", 7, 1);  // O100 lies before the first call that reaches it
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
  // M73 in the main program saves as M70 does (rs274: M73 G20 G91 M72 G0 X1 → X1 mm absolute);
  // nothing restores it at M2.
  const Program main_m73(dialect("linuxcnc"), "G21 G90\nG0 X0\nM73\nG20 G91\nM72\nG0 X1\nG0 X1\nM2\n");
  ASSERT_EQ(main_m73.motions.size(), 3u) << main_m73.all_codes();
  EXPECT_TRUE(main_m73.sink.stored().empty()) << main_m73.all_codes();
  EXPECT_NEAR(main_m73.motions[2].end[0], 1, kTol);
}

// LinuxCNC M-code reference "M73 Save and Autorestore Modal State" (and M70–M72), checked with rs274
// (tests/resolve/linuxcnc/reader_m73.ngc runs the same traps through rs274): the state M73 saves in a
// subroutine is restored when that call returns, by endsub or by return; units, distance mode,
// plane and F come back; the motion mode does not.
TEST(ReaderLinuxcnc, M73RestoresAtTheReturn) {
  const ResolvedProgram r(dialect("linuxcnc"),
                          "o<s> sub\nM73\nG20 G91 G18 F5\nG1 X1\no1 if [#1 GT 0]\no<s> return\no1 endif\nG1 X1\n"
                          "o<s> endsub\nG21 G90 G17 F100\nG0 X0 Y0 Z0\no<s> call [0]\nG1 X10\no<s> call [1]\n"
                          "G1 X20\nG2 X30 I5 J0\nM2\n");
  ASSERT_EQ(r.motions.size(), 7u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  EXPECT_NEAR(r.motions[1].end[0], 25.4, kTol);   // G20 G91 inside
  EXPECT_NEAR(r.motions[2].end[0], 50.8, kTol);
  EXPECT_NEAR(r.motions[3].end[0], 10, kTol);     // endsub: mm, absolute again
  EXPECT_NEAR(r.motions[3].feed, 100, kTol);
  EXPECT_NEAR(r.motions[4].end[0], 35.4, kTol);   // the second call returns early
  EXPECT_NEAR(r.motions[5].end[0], 20, kTol);     // return: mm, absolute again
  EXPECT_EQ(r.motions[6].plane, gc::Plane::xy);   // G17 again
  EXPECT_EQ(r.motions[6].type, MotionType::arc_cw);
}

// rs274: each call level has its own saved state — nested M73 restore their own; an M71 in the call
// cancels the restore; an M70 after M73 in the same call saves again and keeps the restore.
TEST(ReaderLinuxcnc, M73PerCallLevel) {
  const ResolvedProgram nested(dialect("linuxcnc"),
                               "o<inner> sub\nM73\nG21 G91\nG0 X1\no<inner> endsub\n"
                               "o<outer> sub\nM73\nG20\no<inner> call\nG0 X1\nG91\no<outer> endsub\n"
                               "G21 G90\nG0 X0 Y0 Z0\no<outer> call\nG0 X5\nG0 X5\n");
  ASSERT_EQ(nested.motions.size(), 5u) << nested.all_codes();
  EXPECT_NEAR(nested.motions[1].end[0], 1, kTol);      // inner: mm, incremental
  EXPECT_NEAR(nested.motions[2].end[0], 25.4, kTol);   // back in outer: inch, absolute
  EXPECT_NEAR(nested.motions[3].end[0], 5, kTol);      // back in main: mm, absolute
  EXPECT_NEAR(nested.motions[4].end[0], 5, kTol);
  const ResolvedProgram cancelled(dialect("linuxcnc"),
                                  "o<s> sub\nM73\nG91\nM71\no<s> endsub\nG21 G90\nG0 X0\no<s> call\nG0 X1\nG0 X1\n");
  ASSERT_EQ(cancelled.motions.size(), 3u) << cancelled.all_codes();
  EXPECT_NEAR(cancelled.motions[2].end[0], 2, kTol);   // still G91
  const ResolvedProgram resaved(dialect("linuxcnc"),
                                "o<s> sub\nM73\nG20\nM70\nG91\no<s> endsub\nG21 G90\nG0 X0\no<s> call\nG0 X1\nG0 X1\n");
  ASSERT_EQ(resaved.motions.size(), 3u) << resaved.all_codes();
  EXPECT_NEAR(resaved.motions[1].end[0], 25.4, kTol);  // G20 (the M70's state) and G90 restored
  EXPECT_NEAR(resaved.motions[2].end[0], 25.4, kTol);
  // An M72 in a call whose level saved nothing stops LinuxCNC, even after an M70 of the caller.
  const ResolvedProgram other_level(dialect("linuxcnc"),
                                    "o<t> sub\n  M72\no<t> endsub\nG21 G90\nM70\no<t> call\nG0 X1\n");
  expect_diag_at(other_level, "PP-E207", 2, 3);
  EXPECT_TRUE(other_level.motions.empty());
}

// A LinuxCNC main program has one saved state: where a restore finds another level's save in it
// (the caller's M70 … a subroutine's M73 … the caller's M72), the program is read per call level
// but --flatten cannot write it as one program (PP-E709 at the M72).
TEST(ReaderLinuxcnc, M73WithACallerSaveIsNotFlat) {
  const std::string text = "o<s> sub\nM73\nG20\no<s> endsub\nG21 G90\nG91\nM70\nG90\no<s> call\nM72\nG0 X1\nG0 X1\nM2\n";
  const ResolvedProgram r(dialect("linuxcnc"), text);
  ASSERT_EQ(r.motions.size(), 2u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  EXPECT_NEAR(r.motions[1].end[0], 2, kTol);  // the main program's save: mm, G91
  gc::DiagnosticSink sink;
  const gc::ResolvedProgram resolved = gc::resolve(text, "t.nc", dialect("linuxcnc"), {}, sink);
  ASSERT_EQ(resolved.not_flat.size(), 1u);
  EXPECT_EQ(resolved.not_flat.front().code, "PP-E709");
  EXPECT_EQ(resolved.not_flat.front().where.line, 10u);
  EXPECT_NE(resolved.text.find("M73 (postproc: call level 1)"), std::string::npos) << resolved.text;
  EXPECT_NE(resolved.text.find("M72 (postproc: call level 1)"), std::string::npos) << resolved.text;
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

// G92 where the position is unknown (after G28 the axes are at #5161…, which the program does not
// state): the program coordinates are known again, the shift is not. G52 replacing that shift
// (LinuxCNC G-code reference "G52") and G92.1 clearing it leave the position unknown; before, the
// old shift was taken as 0 and X came out shifted by it (found by a random comparison with rs274).
TEST(ReaderLinuxcnc, G92AtAnUnknownPositionLeavesTheShiftUnknown) {
  const Program r(dialect("linuxcnc"),
                  "G21 G90\nG0 X0 Y0 Z1\nG28\nG92 X0 Y0 Z0\nG0 X1\nG52 X5\nG0 Y1\nG92.1\nG0 Z2\nG0 X3 Y3\n");
  ASSERT_EQ(r.motions.size(), 5u) << r.all_codes();
  const gc::AxisMask xyz = 7;
  EXPECT_EQ(r.motions[1].position_offset_unknown, xyz);
  EXPECT_TRUE(r.motions[1].known & 1u);             // X1 in program coordinates
  EXPECT_FALSE(r.motions[2].known & 1u);            // G52 replaced a shift nobody knows
  EXPECT_EQ(r.motions[2].position_offset_unknown, 6u);
  EXPECT_FALSE(r.motions[3].known & 2u);            // G92.1: Y back in work coordinates, unknown
  EXPECT_EQ(r.motions[3].position_offset_unknown, 0u);
  EXPECT_EQ(r.motions[4].known & 3u, 3u);
}

// rs274 keeps the G92 shift in #5211–#5219: every G92 and G52 writes them, G92.1 clears them, G92.2
// keeps them, G92.3 applies them again (LinuxCNC G-code reference "G92.1, G92.2", "G92.3"). Before
// the program writes them they hold the var file's values: G92.3 then leaves the position unknown.
TEST(ReaderLinuxcnc, G92RestoreTakesTheLastWrittenShift) {
  const Program r(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z0\nG92 X5\nG92.2\nG0 X1\nG92.2\nG92.3\nG0 Z1\n"
                                       "G52 X5\nG92.2\nG92.3\nG0 Z2\nG92.1\nG92.3\nG0 Z3\n");
  ASSERT_EQ(r.motions.size(), 5u) << r.all_codes();
  EXPECT_NEAR(r.motions[2].position_offset[0], -5, kTol);  // G92.2 twice still keeps -5 (rs274: X6)
  EXPECT_NEAR(r.motions[2].end[0], 6, kTol);
  EXPECT_NEAR(r.motions[3].position_offset[0], 5, kTol);   // G52's value comes back
  EXPECT_NEAR(r.motions[3].end[0], -4, kTol);                // rs274: X-4 (work X1 less G52's 5)
  EXPECT_NEAR(r.motions[4].position_offset[0], 0, kTol);   // G92.1 cleared the parameters
  EXPECT_NEAR(r.motions[4].end[0], 1, kTol);
  const Program start(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z0\nG92.3\nG0 Z1\n");
  ASSERT_EQ(start.motions.size(), 2u);
  EXPECT_FALSE(start.motions[1].known & 1u) << "the var file's shift is not known";
}

// rs274: M72 restores whether a G92/G52 shift is applied (#5210): applied at M70 → the stored
// shift comes back as by G92.3; not applied → the shift in force is removed as by G92.2.
TEST(ReaderLinuxcnc, M72RestoresWhetherTheG92ShiftIsApplied) {
  const Program r(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z0\nM70\nG92 X5\nM72\nG0 Z1\n"
                                       "G92 X5\nM70\nG92.2\nM72\nG0 Z2\nG52 X3\nM70\nG92 X7\nM72\nG0 Z3\n");
  ASSERT_EQ(r.motions.size(), 4u) << r.all_codes();
  EXPECT_NEAR(r.motions[1].end[0], 0, kTol);   // rs274: X0, the shift removed
  EXPECT_NEAR(r.motions[1].position_offset[0], 0, kTol);
  EXPECT_NEAR(r.motions[2].end[0], 5, kTol);   // rs274: X5, G92 X5's shift applied again
  EXPECT_NEAR(r.motions[3].end[0], 7, kTol);   // the stored shift is G92 X7's, the last one written
  // G7: G10 L20's X is a diameter (rs274 SET_G5X_OFFSET(1, -5) for G10 L20 P1 X10 at X0).
  const Program dia(dialect("linuxcnc"), "G21 G18 G90\nG0 X0 Z0\nG7\nG10 L20 P1 X10\nG0 Z1\n");
  ASSERT_EQ(dia.motions.size(), 2u) << dia.all_codes();
  EXPECT_NEAR(dia.motions[1].end[0], 5, kTol);
}

// rs274: "J word missing in absolute center arc" — under G90.1 I J K are the centre's coordinates and
// both of the plane's are needed (LinuxCNC G-code reference "G90.1, G91.1").
TEST(ReaderLinuxcnc, AbsoluteCentreArcNeedsBothCentreWords) {
  const Program r(dialect("linuxcnc"), "G21 G90 G17\nG0 X0 Y0 Z0\nG90.1\nG2 X10 Y0 I5 F100\nG2 X0 Y0 I5 J0\n");
  expect_diag_at(r, "PP-E204", 4, 1);
  const Program ok(dialect("linuxcnc"), "G21 G90 G17\nG0 X0 Y0 Z0\nG90.1\nG2 X10 Y0 I5 J0 F100\n");
  ASSERT_EQ(ok.motions.size(), 2u) << ok.all_codes();
  EXPECT_NEAR(ok.motions[1].arc.centre[0], 5, kTol);
}

// rs274 convert_arc: "K word given for arc in xy plane", "J word … in xz plane", "I word … in yz plane".
TEST(ReaderLinuxcnc, CentreWordAlongThePlaneNormalIsRefused) {
  const char* programs[] = {"G17 G2 X2 Y0 I1 K0 F100\n", "G18 G2 X2 Z0 I1 J0 F100\n", "G19 G2 Y2 Z0 J1 I0 F100\n"};
  const char* words[] = {"K0", "J0", "I0"};
  for (int k = 0; k < 3; ++k) {
    const Program r(dialect("linuxcnc"), std::string("G21 G90\nG0 X0 Y0 Z0\n") + programs[k]);
    const gc::Diagnostic* d = r.find("PP-E301");
    ASSERT_NE(d, nullptr) << programs[k] << r.all_codes();
    EXPECT_EQ(d->where.line, 3u);
    EXPECT_EQ(d->where.column, std::string(programs[k]).find(words[k]) + 1) << "located at the word";
  }
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

// LinuxCNC G-code reference "Polar Coordinates" (the words act about the origin of the current
// coordinate system, in G17 only) and rs274's find_ends, checked on traps: G90 @ alone at the origin
// and G91 @ or ^ (even @0 / ^0) at the origin stop the program; G91 @ then ^ are two steps, so
// a distance that reaches 0 stops at the ^ step; G18 and G53 refuse polar words; under G7 the
// polar point is not doubled.
TEST(ReaderLinuxcnc, PolarWordsWhereRs274Refuses) {
  const Program at_origin(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0\nG0 @1\n");
  expect_diag_at(at_origin, "PP-E207", 3, 4);
  const Program angle_only(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0\nG0 ^30\n");
  EXPECT_FALSE(angle_only.has("PP-E207")) << angle_only.all_codes();
  const Program zero_step(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0\nG91 G0 ^0\n");
  expect_diag_at(zero_step, "PP-E207", 3, 8);
  const Program through(dialect("linuxcnc"), "G21 G90\nG0 X2 Y0\nG91 G0 @-2 ^30\n");
  expect_diag_at(through, "PP-E207", 3, 8);
  const Program to_origin(dialect("linuxcnc"), "G21 G90\nG0 X2 Y0\nG91 G0 @-2\n");
  ASSERT_EQ(to_origin.motions.size(), 2u) << to_origin.all_codes();
  EXPECT_NEAR(to_origin.motions[1].end[0], 0, kTol);
  const Program plane(dialect("linuxcnc"), "G21 G18 G90\nG0 X2 Y0 Z0\nG0 @1 ^30\n");
  expect_diag_at(plane, "PP-E207", 3, 4);
  const Program machine(dialect("linuxcnc"), "G21 G90\nG0 X2 Y0\nG53 G0 @1 ^30\n");
  expect_diag_at(machine, "PP-E207", 3, 8);
  const Program diameter(dialect("linuxcnc"), "G21 G17 G90 G7\nG0 X4 Y0 Z0\nG0 @1 ^0\nG91 G0 ^90\n");
  ASSERT_EQ(diameter.motions.size(), 3u) << diameter.all_codes();
  EXPECT_NEAR(diameter.motions[1].end[0], 1, kTol);  // rs274: STRAIGHT_TRAVERSE(1, 0, 0)
  EXPECT_NEAR(diameter.motions[2].end[1], 1, kTol);
}

// LinuxCNC G-code reference "Canned Cycles" (L repeats) and "Polar Coordinates"; rs274's
// convert_cycle_xy: under G91 each repeat first adds @ to the current point's distance from the
// origin of the current coordinates, then ^ to its angle (tests/resolve/linuxcnc/
// reader_polar_cycles.ngc runs the same traps through rs274). From X1.5 Y0, G91 ^60 L6 drills the
// 1.5 circle at 60°, 120° … 360°.
TEST(ReaderLinuxcnc, PolarCycleRepeatsStepFromHoleToHole) {
  const Program r(dialect("linuxcnc"), "G20 G17 G90\nG0 X1.5 Y0 Z0\nG91 G81 R.1 Z-.5 ^60 L6 F10\n"
                                       "G90 G0 X2 Y0 Z0\nG91 G81 R.1 Z-.5 @-.75 ^45 L4\nM2\n");
  ASSERT_EQ(r.motions.size(), 12u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  for (int k = 0; k < 6; ++k) {
    const double a = (k + 1) * 60.0 * 3.14159265358979323846 / 180.0;
    EXPECT_EQ(r.motions[1 + k].type, MotionType::drill_cycle);
    EXPECT_NEAR(r.motions[1 + k].end[0], 1.5 * 25.4 * std::cos(a), 1e-9) << k;
    EXPECT_NEAR(r.motions[1 + k].end[1], 1.5 * 25.4 * std::sin(a), 1e-9) << k;
    EXPECT_NEAR(r.motions[1 + k].end[2], 0.1 * 25.4, 1e-9);
    EXPECT_NEAR(r.motions[1 + k].cycle_bottom, -0.4 * 25.4, 1e-9);
  }
  // The distance 2 → 1.25 → 0.5 → -0.25 (the point turns to the far side) → -1 (rs274: 0.8839
  // 0.8839, 0 0.5, 0.1768 -0.1768, -0.5 0).
  EXPECT_NEAR(r.motions[8].end[0], 0.8839 * 25.4, 3e-3);
  EXPECT_NEAR(r.motions[9].end[1], 0.5 * 25.4, 1e-9);
  EXPECT_NEAR(r.motions[10].end[0], 0.1768 * 25.4, 3e-3);
  EXPECT_NEAR(r.motions[10].end[1], -0.1768 * 25.4, 3e-3);
  EXPECT_NEAR(r.motions[11].end[0], -0.5 * 25.4, 1e-9);
  EXPECT_NEAR(r.motions[11].end[1], 0, 1e-9);
  // G90: the one hole L times; @ alone at the origin takes angle 0 in a cycle (no refusal).
  const Program g90(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z0\nG81 R1 Z-1 @3 F10\nG81 R1 Z-1 @1 ^90 L2\n");
  ASSERT_EQ(g90.motions.size(), 4u) << g90.all_codes();
  EXPECT_NEAR(g90.motions[1].end[0], 3, kTol);
  EXPECT_NEAR(g90.motions[2].end[1], 1, kTol);
  EXPECT_NEAR(g90.motions[3].end[1], 1, kTol);
  // Zero steps take no direction: @0 ^0 at the origin drills there; a real step there stops.
  const Program zero(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z0\nG91 G81 R1 Z-1 @0 ^0 L2 F10\n");
  EXPECT_EQ(zero.motions.size(), 3u) << zero.all_codes();
  const Program origin(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z0\nG91 G81 R1 Z-1 ^30 L2 F10\n");
  expect_diag_at(origin, "PP-E207", 3, 16);
  // The polar origin is that of the current coordinates (G92 included).
  const Program g92(dialect("linuxcnc"), "G21 G90\nG0 X3 Y0 Z0\nG92 X1\nG91 G81 R1 Z-1 ^90 L2 F100\n");
  ASSERT_EQ(g92.motions.size(), 3u) << g92.all_codes();
  EXPECT_NEAR(g92.motions[1].end[0], 0, kTol);
  EXPECT_NEAR(g92.motions[1].end[1], 1, kTol);
  EXPECT_NEAR(g92.motions[2].end[0], -1, kTol);
}

// rs274 reads L as an integer and refuses a fraction ("Non integer value for integer"), a negative
// count and L0 ("Cannot do zero repeats of cycle"); a block that starts a cycle needs R and Z
// ("R clearance plane unspecified in cycle", "Z value unspecified in xy plane canned cycle"). R and
// Z are kept as written: a G91 block without R after a G90 one takes R from the initial level.
TEST(ReaderLinuxcnc, CycleWordsRs274Refuses) {
  for (const char* l : {"L0", "L-1", "L1.5", "L2.0001"}) {
    const Program r(dialect("linuxcnc"), std::string("G21 G90\nG0 X2 Y0 Z5\nG81 R1 Z-1 F10 X1 ") + l + "\n");
    expect_diag_at(r, "PP-E207", 3, 19);
    EXPECT_EQ(r.motions.size(), 1u) << l;
  }
  const Program near(dialect("linuxcnc"), "G21 G90\nG0 X2 Y0 Z5\nG91 G81 R1 Z-1 F10 X1 L1.99991\n");
  EXPECT_EQ(near.motions.size(), 3u) << near.all_codes();
  const Program no_r(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z5\nG81 X1 Z-1 F10\n");
  expect_diag_at(no_r, "PP-E207", 3, 1);
  const Program no_z(dialect("linuxcnc"), "G21 G90\nG0 X0 Y0 Z5\nG81 X1 R1 Z-1 F10\nG82 X2 R1 P1\n");
  expect_diag_at(no_z, "PP-E207", 4, 1);
  EXPECT_EQ(no_z.motions.size(), 2u);
  const Program kept(dialect("linuxcnc"), "G21 G90\nG0 X10 Y0 Z5\nG98 G81 R1 Z-1 @3 ^30 F10\nG91 ^30 L2\n");
  ASSERT_EQ(kept.motions.size(), 4u) << kept.all_codes();
  EXPECT_NEAR(kept.motions[2].end[2], 6, kTol);  // R1 from the initial level 5 (rs274: 6)
  EXPECT_NEAR(kept.motions[2].cycle_bottom, 5, kTol);
  EXPECT_NEAR(kept.motions[3].end[1], 3, kTol);  // 3 at 90°
}

// Editors on Windows write a UTF-8 byte-order mark; the controllers skip it.
TEST(ReaderLinuxcnc, ByteOrderMarkIsSkipped) {
  const Program r(dialect("linuxcnc"), "\xEF\xBB\xBFG21 G90\nG0 X1\nM2\n");
  ASSERT_EQ(r.motions.size(), 1u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const Program f(dialect("fanuc"), "\xEF\xBB\xBF%\nO1000\nG90 G0 X1.\n%\n");
  EXPECT_EQ(f.motions.size(), 1u) << f.all_codes();
}

// G10 L2 of the active system with R, or with X or Y: the current point's X and Y both change in
// program coordinates (rotation; rs274 after "G10 L2 P1 R30 … G10 L2 P1 R0" reports X3.8301
// Y3.3660 for the point that was X5 Y1): both are unknown until programmed again; Z stays known.
TEST(ReaderLinuxcnc, G10L2RotationLeavesXAndYUnknown) {
  const Program r(dialect("linuxcnc"),
                  "G21 G17 G90\nG10 L2 P1 R30\nG0 X1 Y1 Z10\nG10 L20 P1 X5\nG0 Z5\nG10 L2 P1 R0\nG0 Z4\n"
                  "G10 L2 P1 X2\nG0 X0 Y0\nG10 L2 P1 Y3\nG0 Z3\nM2\n");
  ASSERT_EQ(r.motions.size(), 5u) << r.all_codes();
  const gc::AxisMask xy = gc::bit(gc::Axis::x) | gc::bit(gc::Axis::y);
  EXPECT_EQ(r.motions[1].known & xy, xy);  // L20 X5 under the rotation: X5 Y1, as rs274
  EXPECT_NEAR(r.motions[1].end[0], 5, 1e-9);
  EXPECT_EQ(r.motions[2].line, 7u);
  EXPECT_EQ(r.motions[2].known & xy, 0);
  EXPECT_TRUE(r.motions[2].known & gc::bit(gc::Axis::z));
  EXPECT_EQ(r.motions[3].known & xy, xy);
  EXPECT_EQ(r.motions[4].known & xy, 0);
}

}  // namespace
