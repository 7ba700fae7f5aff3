// Lathe turning cycles (issue 16, area "lathe"): LinuxCNC G70 / G71 / G72 (.1) expanded into the
// moves rs274 makes; what is not reproduced is refused at its line (docs/lathe-cycles.md).
// The expected moves follow the LinuxCNC G-code reference (linuxcnc.org/docs/html/gcode/
// g-code.html, sections "G70 Lathe finishing cycle" and "G71 G72 Lathe roughing cycles"); whole
// programs are also compared move for move with rs274 by tests/rs274_compare.sh (lathe_*.ngc).
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "postproc/gcode/resolve.hpp"
#include "support.hpp"

namespace {

namespace gc = postproc::gcode;
using pptest::dialect;

/// A LinuxCNC program run as the CLI runs it (resolved first: the profile is an O-word sub).
struct LatheRun : pptest::ResolvedProgram {
  explicit LatheRun(std::string program) : ResolvedProgram(dialect("linuxcnc"), std::move(program)) {}
  [[nodiscard]] std::vector<const gc::Motion*> of_line(std::uint64_t line) const {
    std::vector<const gc::Motion*> out;
    for (const auto& m : motions)
      if (m.line == line) out.push_back(&m);
    return out;
  }
};

constexpr double kEps = 1e-6;

// Profile used below (diameter mode): X10 Z0 → Z-10 → X20 Z-20 → X30 Z-30, approached from X40 Z5.
const char* kProfile =
    "G18 G21 G90 G7\n"   // 1
    "G0 X40 Z5\n"        // 2
    "F200\n"             // 3
    "O100 sub\n"         // 4
    "G1 X10 Z0\n"        // 5
    "G1 Z-10\n"          // 6
    "G1 X20 Z-20\n"      // 7
    "G1 X30 Z-30\n"      // 8
    "O100 endsub\n";     // 9

TEST(LatheCyclesLinuxcnc, G70FollowsTheProfileAfterRapidsToTheStartAndTheProfileStart) {
  // LinuxCNC docs, G70: a rapid to X/Z, a rapid to the start of the profile, then the path of Q
  // with G1/G2/G3; the tool is left at the end of the profile. X is a diameter under G7
  // (Motion::end holds the radius).
  LatheRun r(std::string(kProfile) + "G70 Q100 X44 Z6\nX50\nM2\n");
  ASSERT_EQ(r.sink.count(gc::Severity::error), 0u) << r.sink.stored().front().message;
  const auto ms = r.of_line(10);
  ASSERT_EQ(ms.size(), 6u);
  const double want[6][2] = {{22, 6}, {22, 6}, {5, 0}, {5, -10}, {10, -20}, {15, -30}};
  const gc::MotionType type[6] = {gc::MotionType::rapid,  gc::MotionType::rapid,  gc::MotionType::rapid,
                                  gc::MotionType::linear, gc::MotionType::linear, gc::MotionType::linear};
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(ms[i]->type, type[i]) << i;
    EXPECT_NEAR(ms[i]->end[0], want[i][0], kEps) << i;
    EXPECT_NEAR(ms[i]->end[2], want[i][1], kEps) << i;
    EXPECT_EQ(ms[i]->line, 10u);
    EXPECT_EQ(ms[i]->column, 1u);
  }
  // rs274 leaves G1 active: the following "X50" is a feed move to radius 25.
  const auto next = r.of_line(11);
  ASSERT_EQ(next.size(), 1u);
  EXPECT_EQ(next[0]->type, gc::MotionType::linear);
  EXPECT_NEAR(next[0]->end[0], 25, kEps);
  EXPECT_NEAR(next[0]->end[2], -30, kEps);
}

TEST(LatheCyclesLinuxcnc, G71CutsLayersAlongZStepIRetractRKeepingDFromTheProfile) {
  // LinuxCNC docs, G71: layers along Z, I = cutting increment, R = retract distance, D = the
  // distance kept from the profile. The first layer is at the start X (radius 20): it ends where
  // the last element offset by D = 2 ends, Z = -30 + 2·sin(atan(1/2))·… = -30 + 2/√5, then
  // retracts R = 1 at 45° (+X, +Z), returns along Z and steps I = 0.5 down.
  LatheRun r(std::string(kProfile) + "G71 Q100 D2 I0.5 R1\nM2\n");
  ASSERT_EQ(r.sink.count(gc::Severity::error), 0u) << r.sink.stored().front().message;
  const auto ms = r.of_line(10);
  ASSERT_GE(ms.size(), 8u);
  // preliminary rapid, rapid to the profile start, rapid into the first layer
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(ms[i]->type, gc::MotionType::rapid);
    EXPECT_NEAR(ms[i]->end[0], 20, kEps);
    EXPECT_NEAR(ms[i]->end[2], 5, kEps);
  }
  const double z_end = -30 + 2 / std::sqrt(5.0);
  EXPECT_EQ(ms[3]->type, gc::MotionType::linear);
  EXPECT_NEAR(ms[3]->end[0], 20, kEps);
  EXPECT_NEAR(ms[3]->end[2], z_end, kEps);
  EXPECT_EQ(ms[4]->type, gc::MotionType::rapid);
  EXPECT_NEAR(ms[4]->end[0], 21, kEps);
  EXPECT_NEAR(ms[4]->end[2], z_end + 1, kEps);
  EXPECT_NEAR(ms[5]->end[0], 21, kEps);
  EXPECT_NEAR(ms[5]->end[2], 4, kEps);
  EXPECT_NEAR(ms[6]->end[0], 20, kEps);
  EXPECT_NEAR(ms[6]->end[2], 5, kEps);
  // Next layer at 19.5, entered on the offset approach line (from X20 Z5 to X5 Z0, offset by 2).
  EXPECT_NEAR(ms[7]->end[0], 19.5, kEps);
  // Every feed move stays at or outside the profile offset: the last move ends on the offset
  // profile's end, lifted to the start X (docs: "the tool stops at the end of the profile,
  // including the distance specified in D").
  EXPECT_EQ(ms.back()->type, gc::MotionType::linear);
  EXPECT_NEAR(ms.back()->end[0], 20, kEps);
  EXPECT_NEAR(ms.back()->end[2], z_end, kEps);
}

TEST(LatheCyclesLinuxcnc, G72KeepsDistanceDFromAFacingProfile) {
  // LinuxCNC docs, G72: the facing cycle, profile monotonic in X; "The D number is used to keep a
  // distance from the final profile". Here the start lies beyond the face, so the cycle follows
  // the profile at distance D (as rs274 does; lathe_g72.ngc is compared move for move). Radius
  // mode (G8): X as written.
  LatheRun r(
      "G18 G21 G90 G8\nG0 X32 Z2\nF150\n"
      "O200 sub\nG1 X30 Z0\nG1 X20 Z-1\nG1 X10 Z-4\nG1 X0 Z-8\nO200 endsub\n"
      "G72 Q200 D0.3 I0.8 R0.4\nM2\n");
  ASSERT_EQ(r.sink.count(gc::Severity::error), 0u) << r.sink.stored().front().message;
  const auto ms = r.of_line(10);
  ASSERT_EQ(ms.size(), 8u);  // preliminary rapid, rapid to the start, then the offset profile
  // The first feed move ends at the profile's first point moved 0.3 along the normal of the first
  // element (from X30 Z0 to X20 Z-1) towards +Z.
  const Eigen::Vector2d dir = Eigen::Vector2d(20 - 30, -1 - 0).normalized();  // (x, z)
  const Eigen::Vector2d normal(-dir.y(), dir.x());                              // towards +Z
  const Eigen::Vector2d want = Eigen::Vector2d(30, 0) + 0.3 * (normal.y() > 0 ? normal : -normal);
  EXPECT_EQ(ms[2]->type, gc::MotionType::linear);
  EXPECT_NEAR(ms[2]->end[0], want.x(), kEps);
  EXPECT_NEAR(ms[2]->end[2], want.y(), kEps);
  // Convex corners are rounded with arcs of radius D about the profile's corners (X20 Z-1, X10 Z-4).
  EXPECT_EQ(ms[4]->type, gc::MotionType::arc_cw);
  EXPECT_NEAR(ms[4]->arc.radius, 0.3, 1e-6);
  EXPECT_NEAR(ms[4]->arc.centre[0], 20, kEps);
  EXPECT_NEAR(ms[4]->arc.centre[2], -1, kEps);
  EXPECT_EQ(ms[6]->type, gc::MotionType::arc_cw);
  EXPECT_NEAR(ms[6]->arc.centre[0], 10, kEps);
  EXPECT_NEAR(ms[6]->arc.centre[2], -4, kEps);
}

TEST(LatheCyclesLinuxcnc, CycleUnderG91IsNotFollowed) {
  // rs274 (LinuxCNC 2.9) runs G71 under G91, reading the profile as increments; this version does
  // not reproduce that and refuses the block instead (a warning: the controller runs it).
  LatheRun r(std::string(kProfile) + "G91\nG71 Q100\nM2\n");
  const gc::Diagnostic* d = r.find("PP-U250");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->where.line, 11u);
  EXPECT_EQ(d->where.column, 1u);
  EXPECT_EQ(r.sink.count(gc::Severity::error), 0u);
}

TEST(LatheCyclesLinuxcnc, G71PocketOnlyVariantSkipsTheFirstRoughingPass) {
  // LinuxCNC docs, G71-G72: G71.2 cuts only what G71.1 left (the pockets). kProfile has none: after
  // the rapids to the cycle's start and to the offset profile's start, G71.2 only follows the
  // profile offset by D and rises to the start's level (rs274 2.9, radii: X5.2 Z0, Z-9.9528,
  // X10.1789 Z-19.9106, X15.1789 Z-29.9106, X20; Motion::end holds the radius).
  LatheRun r(std::string(kProfile) + "G0 X40 Z5\nG71.2 Q100 D0.2\nM2\n");
  EXPECT_EQ(r.sink.count(gc::Severity::warning), 0u);
  const auto ms = r.of_line(11);
  ASSERT_EQ(ms.size(), 7u);
  const double want[7][2] = {{20, 5}, {20, 5}, {5.2, 0}, {5.2, -9.9528}, {10.1789, -19.9106}, {15.1789, -29.9106},
                             {20, -29.9106}};
  for (std::size_t i = 0; i < ms.size(); ++i) {
    EXPECT_EQ(ms[i]->type, i < 3 ? gc::MotionType::rapid : gc::MotionType::linear) << i;
    EXPECT_NEAR(ms[i]->end[0], want[i][0], 1e-4) << i;
    EXPECT_NEAR(ms[i]->end[2], want[i][1], 1e-4) << i;
  }
}

TEST(LatheCyclesLinuxcnc, RefusedWhereRs274RefusesIt) {
  // LinuxCNC docs, G71-G72 "It is an error if": the ZX plane is not selected, Q names no
  // subroutine, the profile is not monotonic.
  {
    LatheRun r(std::string(kProfile) + "G17\nG71 Q100\nM2\n");
    const gc::Diagnostic* d = r.find("PP-E250");
    ASSERT_NE(d, nullptr);
    EXPECT_EQ(d->where.line, 11u);
  }
  {
    LatheRun r(std::string(kProfile) + "G71 Q101\nM2\n");
    const gc::Diagnostic* d = r.find("PP-E250");
    ASSERT_NE(d, nullptr);
    EXPECT_EQ(d->where.line, 10u);
  }
  {
    LatheRun r("G18 G21 G90 G7\nG0 X40 Z5\nF200\nO100 sub\nG1 X10 Z0\nG1 Z-10\nG1 X20 Z5\nO100 endsub\nG71 Q100\nM2\n");
    const gc::Diagnostic* d = r.find("PP-E250");
    ASSERT_NE(d, nullptr);
    EXPECT_EQ(d->where.line, 9u);
    EXPECT_NE(d->message.find("Not monotonic"), std::string::npos) << d->message;
  }
}

TEST(LatheCyclesLinuxcnc, StatementsInsideTheProfileAreExecuted) {
  // rs274 (convert_g7x) runs the profile subroutine as a call: its assignments take effect (here
  // #1 = 5 makes the first point X5 under G7, a radius of 2.5) and its O-word control flow runs; only
  // a lathe cycle inside the profile is refused (PP-E251, at that line).
  LatheRun r("G18 G21 G90 G7\nG0 X40 Z5\nF200\nO100 sub\n#1 = 5\nG1 X#1 Z0\nO1 repeat [2]\nG1 Z[#<_z> - 5]\n"
             "O1 endrepeat\nO100 endsub\nG70 Q100\nM2\n");
  ASSERT_EQ(r.sink.count(gc::Severity::error), 0u) << r.all_codes();
  const auto ms = r.of_line(11);
  ASSERT_EQ(ms.size(), 5u) << r.all_codes();
  EXPECT_NEAR(ms[2]->end[0], 2.5, kEps);
  EXPECT_NEAR(ms[3]->end[2], -5, kEps);
  EXPECT_NEAR(ms[4]->end[2], -10, kEps);
  LatheRun nested("G18 G21 G90 G7\nG0 X40 Z5\nF200\nO100 sub\nG1 X10 Z0\nG70 Q100\nO100 endsub\nG71 Q100\nM2\n");
  const gc::Diagnostic* d = nested.find("PP-E251");
  ASSERT_NE(d, nullptr) << nested.all_codes();
  EXPECT_EQ(d->where.line, 6u);
}

TEST(LatheCyclesLinuxcnc, ProfileValuesFromParametersAreSubstituted) {
  // The profile's words are evaluated with the parameters as they are when the cycle runs; as in a
  // call, the caller's local named parameters are not visible there (rs274: "Named parameter #<d>
  // not defined"), global ones are.
  LatheRun r("G18 G21 G90 G8\n#<_d> = 7\nG0 X20 Z5\nF100\nO100 sub\nG1 X#<_d> Z0\nG1 Z-10\nO100 endsub\nG70 Q100\nM2\n");
  ASSERT_EQ(r.sink.count(gc::Severity::error), 0u) << r.sink.stored().front().message;
  const auto ms = r.of_line(9);
  ASSERT_EQ(ms.size(), 4u);
  EXPECT_NEAR(ms[2]->end[0], 7, kEps);
  EXPECT_NEAR(ms[3]->end[0], 7, kEps);
  EXPECT_NEAR(ms[3]->end[2], -10, kEps);
  LatheRun local("G18 G21 G90 G8\n#<d> = 7\nG0 X20 Z5\nF100\nO100 sub\nG1 X#<d> Z0\nG1 Z-10\nO100 endsub\nG70 Q100\nM2\n");
  const gc::Diagnostic* d = local.find("PP-E703");
  ASSERT_NE(d, nullptr) << local.all_codes();
  EXPECT_EQ(d->where.line, 6u);
}

// rs274's convert_g7x sets the current position to each profile point: #<_x> (a radius under G7)
// and #<_z> read in the profile are its last point, starting at the cycle's X Z. Where that point is
// not known (no X on the cycle block, a cycle under G91), reading them is refused.
TEST(LatheCyclesLinuxcnc, ProfilePositionParameters) {
  LatheRun r("G18 G21 G90 G7\nG0 X60 Z5\nF100\nO300 sub\nG1 X10 Z0\nG1 X[#<_x> * 2 + 4] Z-5\n"
             "G1 X30 Z[#5422 - 5]\nO300 endsub\nG70 Q300 X60 Z5\nM2\n");
  ASSERT_EQ(r.sink.count(gc::Severity::error), 0u) << r.all_codes();
  const auto ms = r.of_line(9);
  ASSERT_GE(ms.size(), 3u);
  EXPECT_NEAR(ms[ms.size() - 2]->end[0], 7, kEps);  // rs274: STRAIGHT_FEED(7, 0, -5)
  EXPECT_NEAR(ms.back()->end[2], -10, kEps);
  LatheRun unknown("G18 G21 G90 G7\nG0 X60 Z5\nF100\nO300 sub\nG1 X[#<_x> + 1] Z0\nO300 endsub\nG70 Q300\nM2\n");
  expect_diag_at(unknown, "PP-E701", 5, 5);
}

TEST(LatheCyclesLinuxcnc, CornerFinishesOfTheProfile) {
  // LinuxCNC docs, G71-G72: "Each motion command may also include an optional A- or C- number"
  // rounding (fillet of radius A) or chamfering the corner at the block's end. The fillet of radius
  // 1 between Z-10 (X5, radius mode) and the line to X10 Z-12 touches the first line at Z-9.3230
  // and turns clockwise about X6 Z-9.3230 (rs274 2.9: ARC_FEED(-10.2514, 5.6286, -9.3230, 6, -1)).
  {
    LatheRun r("G18 G21 G90 G8\nG0 X20 Z5\nF100\nO100 sub\nG1 X5 Z0\nG1 Z-10 A1\nG1 X10 Z-12\nO100 endsub\n"
               "G70 Q100\nM2\n");
    EXPECT_EQ(r.sink.count(gc::Severity::warning), 0u);
    const auto ms = r.of_line(9);
    ASSERT_EQ(ms.size(), 6u);
    EXPECT_NEAR(ms[3]->end[2], -9.3230, 1e-4);
    EXPECT_EQ(ms[4]->type, gc::MotionType::arc_cw);
    EXPECT_NEAR(ms[4]->end[2], -10.2514, 1e-4);
    EXPECT_NEAR(ms[4]->end[0], 5.6286, 1e-4);
    EXPECT_NEAR(ms[4]->arc.centre[0], 6, 1e-9);
    EXPECT_NEAR(ms[4]->arc.radius, 1, 1e-9);
    EXPECT_NEAR(ms[5]->end[0], 10, 1e-9);
  }
  {
    // C: a straight between the two points where that fillet would touch.
    LatheRun r("G18 G21 G90 G8\nG0 X20 Z5\nF100\nO100 sub\nG1 X5 Z0\nG1 Z-10 C1\nG1 X10 Z-12\nO100 endsub\n"
               "G70 Q100\nM2\n");
    const auto ms = r.of_line(9);
    ASSERT_EQ(ms.size(), 6u);
    EXPECT_EQ(ms[4]->type, gc::MotionType::linear);
    EXPECT_NEAR(ms[4]->end[2], -10.2514, 1e-4);
  }
  {
    // rs274: "Both A and C parameters on a corner".
    LatheRun r("G18 G21 G90 G8\nG0 X20 Z5\nF100\nO100 sub\nG1 X5 Z0\nG1 Z-10 A1 C1\nG1 X10 Z-12\nO100 endsub\n"
               "G70 Q100\nM2\n");
    expect_diag_at(r, "PP-E250", 9, 1);
    EXPECT_TRUE(r.of_line(9).empty());
  }
}

TEST(LatheCyclesLinuxcnc, ProfileFormsNotReproducedAreRefusedAtTheCycle) {
  // An R arc under G90.1 is not reproduced.
  {
    LatheRun r("G18 G21 G90 G8 G90.1\nG0 X20 Z5\nF100\nO100 sub\nG1 X5 Z0\nG3 X10 Z-5 R5\nO100 endsub\n"
               "G70 Q100\nM2\n");
    const gc::Diagnostic* d = r.find("PP-U250");
    ASSERT_NE(d, nullptr);
    EXPECT_EQ(d->where.line, 8u);
    EXPECT_NE(d->message.find("G90.1"), std::string::npos) << d->message;
  }
}

TEST(LatheCyclesLinuxcnc, ArcsOfTheProfileAreFollowedWithTheirCentres) {
  // G70 with D = 0 draws the profile's arcs as written: G3 X20 Z-15 K-5 from X10 Z-10 (G7:
  // radius 5 → 10) turns counter-clockwise about X5 Z-15 (K incremental, G91.1).
  LatheRun r("G18 G21 G90 G7\nG0 X40 Z5\nF100\nO100 sub\nG1 X10 Z0\nG1 Z-10\nG3 X20 Z-15 K-5\nG1 Z-25\n"
             "O100 endsub\nG70 Q100\nM2\n");
  ASSERT_EQ(r.sink.count(gc::Severity::error), 0u) << r.sink.stored().front().message;
  const auto ms = r.of_line(10);
  ASSERT_EQ(ms.size(), 6u);
  const gc::Motion& arc = *ms[4];
  EXPECT_EQ(arc.type, gc::MotionType::arc_ccw);
  EXPECT_NEAR(arc.arc.centre[0], 5, kEps);
  EXPECT_NEAR(arc.arc.centre[2], -15, kEps);
  EXPECT_NEAR(arc.arc.radius, 5, kEps);
  EXPECT_NEAR(arc.arc.sweep, std::numbers::pi / 2, 1e-9);
  EXPECT_NEAR(arc.end[0], 10, kEps);
  EXPECT_NEAR(arc.end[2], -15, kEps);
}

TEST(LatheCyclesLinuxcnc, G33IsAStraightMoveWithKPerRevolution) {
  // LinuxCNC docs, G33 "Spindle Synchronized Motion": G33 X- Z- K-, K = distance per revolution;
  // rs274 refuses it without K (on every G33 block, modal repeats too) and with the spindle
  // stopped. X is a diameter under G7.
  LatheRun r("G18 G21 G90 G7\nG0 X20 Z5\nM3 S300\nG33 Z-10 K1.5\nX18 Z-12 K1\nZ-14\nM2\n");
  const auto a = r.of_line(4), b = r.of_line(5);
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(a[0]->type, gc::MotionType::linear);
  EXPECT_EQ(a[0]->feed_mode, gc::FeedMode::per_rev);
  EXPECT_DOUBLE_EQ(a[0]->feed, 1.5);
  EXPECT_NEAR(a[0]->end[0], 10, kEps);
  EXPECT_NEAR(a[0]->end[2], -10, kEps);
  EXPECT_DOUBLE_EQ(b[0]->feed, 1.0);
  EXPECT_NEAR(b[0]->end[0], 9, kEps);
  EXPECT_NEAR(b[0]->end[2], -12, kEps);
  const gc::Diagnostic* d = r.find("PP-E250");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->where.line, 6u);
  LatheRun stopped("G18 G21 G90\nG0 X20 Z5\nG33 Z-10 K1.5\nM2\n");
  const gc::Diagnostic* s = stopped.find("PP-E250");
  ASSERT_NE(s, nullptr);
  EXPECT_EQ(s->where.line, 3u);
  EXPECT_TRUE(stopped.of_line(3).empty());
}

TEST(LatheCyclesLinuxcnc, G33_1RigidTapGoesToThePointAndBack) {
  // LinuxCNC G-code reference, "G33.1 Rigid Tapping": to the point at K per revolution, then back
  // (spindle reversed) to where the tap started, which is the current point after the block (rs274
  // RIGID_TAP; tests/threading/linuxcnc/rigid_tap_g33_1.ngc compares it with rs274). Without K or
  // with the spindle stopped rs274 stops: refused at the block, naming G33.1.
  LatheRun r("G17 G21 G90\nG0 X10 Y20 Z5\nM3 S300\nG33.1 Z-12 K1.25\nG0 X30\nM2\n");
  const auto tap = r.of_line(4);
  ASSERT_EQ(tap.size(), 2u) << r.all_codes();
  for (const gc::Motion* m : tap) {
    EXPECT_EQ(m->type, gc::MotionType::linear);
    EXPECT_EQ(m->feed_mode, gc::FeedMode::per_rev);
    EXPECT_DOUBLE_EQ(m->feed, 1.25);
  }
  EXPECT_NEAR(tap[0]->end[2], -12, kEps);
  EXPECT_NEAR(tap[1]->start[2], -12, kEps);
  EXPECT_NEAR(tap[1]->end[0], 10, kEps);
  EXPECT_NEAR(tap[1]->end[1], 20, kEps);
  EXPECT_NEAR(tap[1]->end[2], 5, kEps);
  const auto after = r.of_line(5);
  ASSERT_EQ(after.size(), 1u);
  EXPECT_NEAR(after[0]->start[2], 5, kEps);
  LatheRun no_k("G17 G21 G90\nG0 Z5\nM3 S300\nG33.1 Z-12\nM2\n");
  const gc::Diagnostic* k = no_k.find("PP-E250");
  ASSERT_NE(k, nullptr);
  EXPECT_EQ(k->where.line, 4u);
  EXPECT_NE(k->message.find("G33.1 needs K"), std::string::npos) << k->message;
  LatheRun with_f("G17 G21 G90\nG0 Z5\nM3 S300\nG33.1 Z-12 K1 F100\nM2\n");
  const gc::Diagnostic* f = with_f.find("PP-E250");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->where.column, 15u);
  // rs274 asks no F of G33/G33.1 in G93 (and after G93 → G94 without F): read, not refused.
  LatheRun g93("G17 G21 G90\nG0 Z5\nM3 S300\nG93\nG33.1 Z-12 K1\nG94\nG33 Z-3 K1\nM2\n");
  EXPECT_FALSE(g93.sink.has_errors()) << g93.all_codes();
  EXPECT_EQ(g93.of_line(5).size(), 2u);
  EXPECT_EQ(g93.of_line(7).size(), 1u);
  LatheRun stopped("G17 G21 G90\nG0 Z5\nG33.1 Z-12 K1\nM2\n");
  const gc::Diagnostic* s = stopped.find("PP-E250");
  ASSERT_NE(s, nullptr);
  EXPECT_NE(s->message.find("Spindle not turning in G33.1"), std::string::npos) << s->message;
}

TEST(LatheCyclesLinuxcnc, SubroutineSkippedWithoutResolvingIsReported) {
  // Read without the resolver (library use of run_program), a definition that no cycle reads is
  // skipped — not silently: PP-U212 at the block after it names the subroutine.
  const pptest::Program r(dialect("linuxcnc"), "G0 X0 Z0\nO100 sub\nG1 X5 Z-5 F100\nO100 endsub\nG0 X10\n");
  const gc::Diagnostic* d = r.find("PP-U212");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->where.line, 5u);
  EXPECT_NE(d->message.find("o100"), std::string::npos) << d->message;
  EXPECT_EQ(r.at_line(3), nullptr);
}

TEST(LatheCyclesLinuxcnc, G70ApproachRunningAwayFromTheProfileStartsLevelWithItsEnd) {
  // LinuxCNC docs, G70: "a rapid move to the start of the profile" after the move to X/Z. rs274
  // (LinuxCNC 2.9, sample program lathe_g7x_quadrants.ngc) decides whether to finish along X on
  // the profile without its approach; an approach that runs against the profile's direction
  // (here towards -Z before a profile that runs towards +Z) is cut short: rapid along Z to the
  // level of its end, then to the profile's first point (checked with rs274 -g, also in
  // tests/resolve/linuxcnc/lathe_g70_entry.ngc).
  LatheRun r(
      "G18 G21 G90 G8\nG0 X30 Z10\nF200\n"
      "O100 sub\nG0 Z-20 X18\nG1 Z-16\nG1 X8\nG1 Z-10\nG1 X-1\nG1 Z1\nO100 endsub\n"  // 4-11
      "G70 Q100 X20 Z5\n"                                                                    // 12
      "O101 sub\nG0 X-1 Z42\nG1 Z44\nX6\nZ49\nX15\nZ56\nO101 endsub\n"                        // 13-20
      "G70 Q101 X17 Z40\nM2\n");                                                            // 21
  ASSERT_EQ(r.sink.count(gc::Severity::error), 0u) << r.sink.stored().front().message;
  ASSERT_EQ(r.sink.count(gc::Severity::warning), 0u) << r.sink.stored().front().message;
  using T = gc::MotionType;
  struct Want {
    T type;
    double x, z;
  };
  const auto check = [&](std::uint64_t line, const std::vector<Want>& want) {
    const auto ms = r.of_line(line);
    ASSERT_EQ(ms.size(), want.size()) << "line " << line;
    for (std::size_t i = 0; i < want.size(); ++i) {
      EXPECT_EQ(ms[i]->type, want[i].type) << "line " << line << " move " << i;
      EXPECT_NEAR(ms[i]->end[0], want[i].x, kEps) << "line " << line << " move " << i;
      EXPECT_NEAR(ms[i]->end[2], want[i].z, kEps) << "line " << line << " move " << i;
    }
  };
  // Not a rapid straight from X20 Z5 to X18 Z-20: first along Z to Z-20, then to X18.
  check(12, {{T::rapid, 20, 5}, {T::rapid, 20, -20}, {T::rapid, 18, -20}, {T::linear, 18, -16},
             {T::linear, 8, -16}, {T::linear, 8, -10}, {T::linear, -1, -10}, {T::linear, -1, 1}});
  // An approach that runs with the profile is followed as written, and the profile is finished
  // along Z although the approach's X falls below the profile's.
  check(21, {{T::rapid, 17, 40}, {T::rapid, 17, 40}, {T::rapid, -1, 42}, {T::linear, -1, 44},
             {T::linear, 6, 44}, {T::linear, 6, 49}, {T::linear, 15, 49}, {T::linear, 15, 56}});
}

TEST(LatheCyclesLinuxcnc, CycleArcWithUnequalRadiiIsRefusedAsRs274Does) {
  // rs274 (LinuxCNC 2.9) makes each arc of the cycle as a G2/G3 with its radius check (LinuxCNC
  // docs, G2 G3 "It is an error if"): here the first roughing arc of the offset profile runs from
  // X28 Z20 about X26 Z20 (radius 2) to a point 1.8369 from it, and rs274 stops the program
  // ("Radius to end of arc differs from radius to start"): refused at the cycle's word.
  LatheRun r(
      "G18 G21 G90 G8\nF100\nG0 X50 Z50\n"
      "O100 sub\nG1 X28 Z20\nG2 X26 Z22 R2\nG1 X23 Z24\nG1 X20 Z24\nG1 X20 Z28\nG1 X17 Z30\nG1 X16 Z32\nO100 endsub\n"
      "G71 Q100 X28 Z20 D0.2 I0.7 R0.2\nM2\n");  // line 13
  const gc::Diagnostic* d = r.find("PP-E250");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->where.line, 13u);
  EXPECT_EQ(d->where.column, 1u);
  EXPECT_NE(d->message.find("Radius to end of arc differs"), std::string::npos) << d->message;
  EXPECT_TRUE(r.of_line(13).empty());
}

TEST(LatheCyclesLinuxcnc, RoughingLayerReachingAnElementOfNoWidthGoesOn) {
  // LinuxCNC docs, G72 "the facing cycle"; rs274 (LinuxCNC 2.9) moves on where a layer meets the
  // profile at the point reached (the profile runs down and up along X30 here) instead of failing
  // ("How did we get here?"): 44 moves, first layer along X at Z3 to X43, the profile followed at
  // the end (tests/resolve/linuxcnc/lathe_rough_levels.ngc compares it move for move).
  LatheRun r(
      "G18 G21 G90 G8\nF100\nG0 X50 Z50\n"
      "O100 sub\nG1 X30 Z18\nG1 X30 Z16\nG1 X30 Z12\nG1 X32 Z12\nG1 X34 Z11\nG2 X38 Z7 R4\nG1 X43 Z7\nO100 endsub\n"
      "G72 Q100 X45 Z3 I1.5\nM2\n");  // line 13
  ASSERT_EQ(r.sink.count(gc::Severity::error), 0u) << r.sink.stored().front().message;
  const auto ms = r.of_line(13);
  ASSERT_EQ(ms.size(), 44u);
  using T = gc::MotionType;
  const struct {
    T type;
    double x, z;
  } want[] = {{T::rapid, 45, 3}, {T::rapid, 30, 3}, {T::rapid, 30, 3}, {T::linear, 43, 3}, {T::rapid, 42.5, 2.5}};
  for (std::size_t i = 0; i < std::size(want); ++i) {
    EXPECT_EQ(ms[i]->type, want[i].type) << i;
    EXPECT_NEAR(ms[i]->end[0], want[i].x, kEps) << i;
    EXPECT_NEAR(ms[i]->end[2], want[i].z, kEps) << i;
  }
  EXPECT_EQ(ms[41]->type, T::arc_cw);
  EXPECT_NEAR(ms[41]->arc.centre[0], 38, kEps);
  EXPECT_NEAR(ms[41]->arc.centre[2], 11, kEps);
  EXPECT_NEAR(ms[43]->end[0], 43, kEps);
  EXPECT_NEAR(ms[43]->end[2], 3, kEps);
}

TEST(LatheCyclesLinuxcnc, RoughingPassesAnArcWhoseEndLiesBehindWithoutAMove) {
  // rs274 (LinuxCNC 2.9) passes a falling arc whose end the layer already lies beyond without
  // cutting it; the next arc then starts away from its circle and rs274 stops the program
  // ("Radius to end of arc differs from radius to start: ... r1=8.0777 r2=4.5000", rs274 -g on
  // this program; LinuxCNC docs, G2 G3 "It is an error if"): refused at the cycle's word.
  LatheRun r(
      "G18 G21 G90 G8\nF100\nG0 X50 Z50\n"
      "O100 sub\nG1 X28 Z20\nG1 X28 Z15\nG1 X25 Z15\nG3 X21 Z11 R4\nG2 X18 Z8 R3\nG2 X14 Z4 R4\nG1 X11 Z4\n"
      "O100 endsub\nG72 Q100 X20 Z35 D0.5 I1 R0.3\nM2\n");  // line 13
  const gc::Diagnostic* d = r.find("PP-E250");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->where.line, 13u);
  EXPECT_NE(d->message.find("8.0777"), std::string::npos) << d->message;
  EXPECT_NE(d->message.find("4.5000"), std::string::npos) << d->message;
  EXPECT_TRUE(r.of_line(13).empty());
}

// A program read without resolving (convert) defines all its subroutines before the cycle: the
// cycle finds its profile by Q among them, not only in the last one defined (found on LatheEasyStep
// output: o100 and o101 defined, then G71 Q100; rs274 agrees with the resolved reading).
TEST(LatheCyclesLinuxcnc, ProfileFoundAmongSeveralSubroutinesWithoutResolving) {
  const std::string text =
      "G18 G7 G21 G95\no100 sub\nG1 X10 Z0\nG1 X10 Z-10\nG1 X20 Z-10\no100 endsub\no101 sub\nG1 X22 Z0\n"
      "G1 X0 Z0\no101 endsub\nF0.2\nG0 X22 Z1\nG71 Q100 X22 Z1 D1\nM30\n";
  const pptest::Program plain(dialect("linuxcnc"), text);
  EXPECT_FALSE(plain.sink.has_errors()) << plain.all_codes();
  const LatheRun resolved(text);
  EXPECT_FALSE(resolved.sink.has_errors());
  std::size_t n_plain = 0;
  for (const auto& m : plain.motions) n_plain += m.line == 13 ? 1 : 0;
  EXPECT_GT(n_plain, 5u);
  EXPECT_EQ(n_plain, resolved.of_line(13).size());
}

}  // namespace
