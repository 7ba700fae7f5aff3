// Chamfers and corner roundings between two straight moves: Fanuc ,C ,R (B-64484EN II "Chamfering
// and corner R") and Sinumerik CHR= CHF= RND= (840D sl Fundamentals, "Chamfer, rounding: CHF, CHR,
// RND, RNDM"). Expected points come from the manuals' definitions: ,C / CHR= is the distance from
// the virtual corner to both ends of the chamfer, CHF= the length of the chamfer itself, ,R / RND=
// the radius of the arc tangent to both moves; the next move starts where the element ends, and its
// incremental words stay relative to the programmed corner.
#include <cmath>
#include <numbers>

#include "support.hpp"

namespace {

using namespace pptest;
constexpr double kTol = 1e-9;

gc::Dialect fanuc() { return dialect("fanuc"); }

std::vector<const gc::Motion*> on_line(const Program& r, std::uint64_t line) {
  std::vector<const gc::Motion*> out;
  for (const auto& m : r.motions)
    if (m.line == line) out.push_back(&m);
  return out;
}

bool diag_on_line(const Program& r, std::string_view code, std::uint64_t line) {
  for (const auto& d : r.sink.stored())
    if (d.code == code && d.where.line == line) return true;
  return false;
}

void expect_xy(const gc::AxisVector& v, double x, double y) {
  EXPECT_NEAR(v[0], x, kTol);
  EXPECT_NEAR(v[1], y, kTol);
}

TEST(Corners, FanucChamferAndRoundingBetweenLines) {
  const Program r(fanuc(), "G17 G90 G0 X0 Y0\nG1 X50. ,C5. F500\nY40. ,R10.\nX0\n");
  EXPECT_FALSE(r.sink.has_errors()) << r.all_codes();
  EXPECT_EQ(r.find("PP-U233"), nullptr) << r.all_codes();
  const auto l2 = on_line(r, 2);
  ASSERT_EQ(l2.size(), 2u);
  expect_xy(l2[0]->end, 45, 0);  // 5 mm before the corner (50, 0)
  EXPECT_EQ(l2[1]->type, gc::MotionType::linear);
  expect_xy(l2[1]->start, 45, 0);
  expect_xy(l2[1]->end, 50, 5);  // 5 mm along the next move
  EXPECT_EQ(l2[1]->programmed, 0u);
  const auto l3 = on_line(r, 3);
  ASSERT_EQ(l3.size(), 2u);
  expect_xy(l3[0]->start, 50, 5);  // starts where the chamfer ended
  expect_xy(l3[0]->end, 50, 30);   // a 90° corner: tangent length = R
  EXPECT_EQ(l3[1]->type, gc::MotionType::arc_ccw);
  expect_xy(l3[1]->end, 40, 40);
  EXPECT_NEAR(l3[1]->arc.centre[0], 40, kTol);
  EXPECT_NEAR(l3[1]->arc.centre[1], 30, kTol);
  EXPECT_NEAR(l3[1]->arc.radius, 10, kTol);
  EXPECT_NEAR(l3[1]->arc.sweep, std::numbers::pi / 2, kTol);
  const auto l4 = on_line(r, 4);
  ASSERT_EQ(l4.size(), 1u);
  expect_xy(l4[0]->start, 40, 40);
  expect_xy(l4[0]->end, 0, 40);
}

TEST(Corners, RoundingOnAnObtuseCornerTurningRight) {
  // From (0,0) to (10,0), then to (20,-10): a 45° right turn. Tangent length R·tan(22.5°).
  const Program r(fanuc(), "G17 G90 G0 X0 Y0\nG1 X10. ,R4. F100\nX20. Y-10.\n");
  const auto l2 = on_line(r, 2);
  ASSERT_EQ(l2.size(), 2u) << r.all_codes();
  const double t = 4 * std::tan(std::numbers::pi / 8);
  expect_xy(l2[0]->end, 10 - t, 0);
  EXPECT_EQ(l2[1]->type, gc::MotionType::arc_cw);
  expect_xy(l2[1]->end, 10 + t / std::sqrt(2.0), -t / std::sqrt(2.0));
  EXPECT_NEAR(l2[1]->arc.centre[0], 10 - t, kTol);
  EXPECT_NEAR(l2[1]->arc.centre[1], -4, kTol);
  EXPECT_NEAR(l2[1]->arc.sweep, -std::numbers::pi / 4, kTol);
}

// B-63944EN-1 "Optional chamfering and corner R": ,R also between a line and an arc and between two
// arcs. The rounding circle is tangent to both elements: its centre lies r from the line (or at
// R ± r from the arc's centre) on the side the path turns to, and the arcs keep their centres.
TEST(Corners, RoundingBesideArcs) {
  // Line +X into a cw half circle about (30,0) that starts upwards: a left turn.
  const Program la(fanuc(), "G17 G90 G0 X0 Y0\nG1 X20. ,R2. F100\nG2 X40. Y0 R10.\nG1 Y-20.\n");
  EXPECT_FALSE(la.sink.has_errors()) << la.all_codes();
  EXPECT_FALSE(la.has("PP-U233")) << la.all_codes();
  const auto l2 = on_line(la, 2), l3 = on_line(la, 3);
  ASSERT_EQ(l2.size(), 2u);
  const double qx = 30 - std::sqrt(12.0 * 12.0 - 4.0);  // centre at y = 2, 12 from (30, 0)
  expect_xy(l2[0]->end, qx, 0);
  EXPECT_EQ(l2[1]->type, gc::MotionType::arc_ccw);
  EXPECT_NEAR(l2[1]->arc.centre[0], qx, kTol);
  EXPECT_NEAR(l2[1]->arc.centre[1], 2, kTol);
  const double kx = 30 + 10 * (qx - 30) / 12, ky = 10 * 2.0 / 12;  // on the half circle, towards the centre
  expect_xy(l2[1]->end, kx, ky);
  ASSERT_EQ(l3.size(), 1u);
  expect_xy(l3[0]->start, kx, ky);
  EXPECT_NEAR(l3[0]->arc.centre[0], 30, kTol);
  EXPECT_NEAR(l3[0]->arc.sweep, -std::atan2(ky, kx - 30), 1e-9);  // from the tangent point to (40, 0), cw
  // An arc then a line: the cw arc about (60,20) reaches (100,20) going down; the line goes -X (right turn).
  const Program al(fanuc(), "G17 G90 G0 X60. Y60.\nG2 X100. Y20. ,R3. I0 J-40. F100\nG1 X0\n");
  EXPECT_FALSE(al.sink.has_errors()) << al.all_codes();
  const auto a2 = on_line(al, 2), a3 = on_line(al, 3);
  ASSERT_EQ(a2.size(), 2u) << al.all_codes();
  const double cx = 60 + std::sqrt(37.0 * 37.0 - 9.0);
  EXPECT_EQ(a2[1]->type, gc::MotionType::arc_cw);
  EXPECT_NEAR(a2[1]->arc.centre[0], cx, kTol);
  EXPECT_NEAR(a2[1]->arc.centre[1], 23, kTol);
  expect_xy(a2[1]->end, cx, 20);
  EXPECT_NEAR((a2[0]->end.head<2>() - Eigen::Vector2d(60, 20)).norm(), 40, kTol);  // still on the arc
  ASSERT_EQ(a3.size(), 1u);
  expect_xy(a3[0]->start, cx, 20);
  // Arc to arc: the rounding centre is R ± r from both arc centres.
  // (A ccw quarter about (0,10) ends going +Y; a cw half circle about (10,20) starts going -X.)
  const Program aa(fanuc(), "G17 G90 G0 X0 Y0\nG3 X10. Y10. R10. ,R2. F100\nG2 X10. Y30. R10.\n");
  const auto b2 = on_line(aa, 2);
  ASSERT_EQ(b2.size(), 2u) << aa.all_codes();
  EXPECT_EQ(b2[1]->type, gc::MotionType::arc_ccw);
  const Eigen::Vector2d q(b2[1]->arc.centre[0], b2[1]->arc.centre[1]);
  EXPECT_NEAR((q - Eigen::Vector2d(0, 10)).norm(), 8, kTol);    // inside the ccw arc it turns towards
  EXPECT_NEAR((q - Eigen::Vector2d(10, 20)).norm(), 12, kTol);  // outside the cw arc
  EXPECT_NEAR((b2[1]->start.head<2>() - q).norm(), 2, kTol);
  EXPECT_NEAR((b2[1]->end.head<2>() - q).norm(), 2, kTol);
  // A chamfer beside an arc stays refused.
  const Program ca(fanuc(), "G17 G90 G0 X0 Y0\nG1 X20. ,C2. F100\nG2 X40. Y0 R10.\n");
  EXPECT_TRUE(ca.has("PP-U233")) << ca.all_codes();
}

TEST(Corners, NextIncrementalMoveIsRelativeToTheProgrammedCorner) {
  const Program r(fanuc(), "G17 G90 G0 X0 Y0\nG1 X50. ,C5. F500\nG91 Y40.\n");
  const auto l3 = on_line(r, 3);
  ASSERT_EQ(l3.size(), 1u) << r.all_codes();
  expect_xy(l3[0]->start, 50, 5);
  expect_xy(l3[0]->end, 50, 40);
}

TEST(Corners, InchProgramsScaleTheCornerWord) {
  const Program r(fanuc(), "G20 G17 G90 G0 X0 Y0\nG1 X2. ,C.1 F20.\nY2.\n");
  const auto l2 = on_line(r, 2);
  ASSERT_EQ(l2.size(), 2u) << r.all_codes();
  expect_xy(l2[0]->end, 1.9 * 25.4, 0);
  expect_xy(l2[1]->end, 2 * 25.4, 0.1 * 25.4);
}

TEST(Corners, RefusedWhereThisVersionDoesNotBuildTheElement) {
  // Next move an arc: both moves refused at their words, positions after them exact.
  const Program arc(fanuc(), "G17 G90 G0 X0 Y0\nG1 X50. ,R5. F500\nG3 X60. Y10. R10.\nG1 X0\n");
  expect_diag_at(arc, "PP-U233", 2, 9);
  EXPECT_TRUE(diag_on_line(arc, "PP-U233", 3)) << arc.all_codes();
  EXPECT_TRUE(on_line(arc, 2).empty());
  EXPECT_TRUE(on_line(arc, 3).empty());
  ASSERT_EQ(on_line(arc, 4).size(), 1u);
  expect_xy(on_line(arc, 4)[0]->end, 0, 10);
  // The next line is a comment, not the move.
  const Program comment(fanuc(), "G17 G90 G0 X0 Y0\nG1 X50. ,C5. F500\n(NEXT)\nY10.\n");
  expect_diag_at(comment, "PP-U233", 2, 9);
  EXPECT_TRUE(on_line(comment, 2).empty());
  EXPECT_TRUE(on_line(comment, 4).empty());
  EXPECT_TRUE(diag_on_line(comment, "PP-U233", 4)) << comment.all_codes();
  // Collinear moves have no corner.
  const Program straight(fanuc(), "G17 G90 G0 X0 Y0\nG1 X50. ,C5. F500\nX80.\n");
  expect_diag_at(straight, "PP-U233", 2, 9);
  // Lathe direct drawing (,C on a lathe, parameter-dependent) stays refused.
  const Program lathe(dialect("fanuc", true), "G0 X20. Z2.\nG1 Z-10. ,C1. F.2\nX40.\n");
  EXPECT_TRUE(lathe.has("PP-U233")) << lathe.all_codes();
}

// B-63944EN-1 §4.5 "Chamfering and corner R" (lathe, G18): G01 along Z with I, along X with K, or
// either with R; the amount is per side (45° chamfer, quarter-circle corner) and its sign is the
// direction of the next move along the other axis. X is a diameter: Motion::end holds the radius.
TEST(Corners, FanucLatheChamferAndCornerR) {
  const Program r(dialect("fanuc", true),
                  "G18 G0 X20. Z2.\nG1 Z-10. I3. F.2\nX40. K-2.\nZ-30. R5.\nX60.\nG0 X100.\nG1 Z-10. I-3.\nX40.\n");
  EXPECT_FALSE(r.sink.has_errors()) << r.all_codes();
  EXPECT_FALSE(r.has("PP-U233")) << r.all_codes();
  const auto l2 = on_line(r, 2), l3 = on_line(r, 3), l4 = on_line(r, 4), l7 = on_line(r, 7);
  ASSERT_EQ(l2.size(), 2u);
  EXPECT_NEAR(l2[0]->end[2], -7, kTol);  // 3 mm before the corner Z-10
  EXPECT_NEAR(l2[0]->end[0], 10, kTol);
  EXPECT_NEAR(l2[1]->end[0], 13, kTol);  // 3 mm (per side) up X: radius 10 + 3
  EXPECT_NEAR(l2[1]->end[2], -10, kTol);
  ASSERT_EQ(l3.size(), 2u);
  EXPECT_NEAR(l3[0]->start[0], 13, kTol);
  EXPECT_NEAR(l3[0]->end[0], 18, kTol);  // X40 is radius 20: stops 2 mm short
  EXPECT_NEAR(l3[1]->end[0], 20, kTol);
  EXPECT_NEAR(l3[1]->end[2], -12, kTol);
  ASSERT_EQ(l4.size(), 2u);
  EXPECT_NEAR(l4[0]->end[2], -25, kTol);
  EXPECT_NEAR(l4[1]->end[0], 25, kTol);
  EXPECT_NEAR(l4[1]->end[2], -30, kTol);
  EXPECT_NEAR(l4[1]->arc.radius, 5, kTol);
  EXPECT_NEAR(l4[1]->arc.centre[0], 25, kTol);
  EXPECT_NEAR(l4[1]->arc.centre[2], -25, kTol);
  ASSERT_EQ(l7.size(), 2u);  // I-3: the next move goes down X
  EXPECT_NEAR(l7[0]->end[2], -13, kTol);
  EXPECT_NEAR(l7[1]->end[0], 47, kTol);
  // The next move against the sign, or not along the other axis: the control's alarm.
  const Program wrong(dialect("fanuc", true), "G18 G0 X20. Z2.\nG1 Z-10. I3. F.2\nX10.\n");
  expect_diag_at(wrong, "PP-E207", 2, 10);
  const Program slanted(dialect("fanuc", true), "G18 G0 X20. Z2.\nG1 Z-10. R3. F.2\nX40. Z-20.\n");
  expect_diag_at(slanted, "PP-E207", 2, 10);
  // I after an X move is not this format: refused as before.
  const Program mixed(dialect("fanuc", true), "G18 G0 X20. Z2.\nG1 X30. I3. F.2\nZ-10.\n");
  EXPECT_TRUE(mixed.has("PP-U233")) << mixed.all_codes();
}

TEST(Corners, TooLargeForTheMovesIsTheControllersAlarm) {
  // Fanuc PS0055: the chamfer does not fit on the 3 mm move.
  const Program r(fanuc(), "G17 G90 G0 X0 Y0\nG1 X50. ,C5. F500\nY3.\n");
  expect_diag_at(r, "PP-E207", 2, 9);
}

TEST(Corners, SinumerikChrChfRnd) {
  const gc::Dialect s = dialect("siemens");
  const Program r(s, "G17 G90 G0 X0 Y0\nG1 X50 CHR=5 F500\nY40 CHF=7.0710678118654755\nX0 RND=10\nY0\n");
  EXPECT_FALSE(r.sink.has_errors()) << r.all_codes();
  EXPECT_EQ(r.find("PP-U240"), nullptr) << r.all_codes();
  const auto l2 = on_line(r, 2), l3 = on_line(r, 3), l4 = on_line(r, 4), l5 = on_line(r, 5);
  ASSERT_EQ(l2.size(), 2u);
  expect_xy(l2[0]->end, 45, 0);
  expect_xy(l2[1]->end, 50, 5);
  ASSERT_EQ(l3.size(), 2u);  // a chamfer 7.07 mm long on a 90° corner: 5 mm legs
  expect_xy(l3[0]->end, 50, 35);
  expect_xy(l3[1]->end, 45, 40);
  ASSERT_EQ(l4.size(), 2u);
  expect_xy(l4[0]->start, 45, 40);
  expect_xy(l4[0]->end, 10, 40);
  EXPECT_EQ(l4[1]->type, gc::MotionType::arc_ccw);
  expect_xy(l4[1]->end, 0, 30);
  ASSERT_EQ(l5.size(), 1u);
  expect_xy(l5[0]->start, 0, 30);
  // RNDM= (modal rounding) stays refused.
  const Program m(s, "G17 G90 G0 X0 Y0\nG1 X50 RNDM=2 F500\nY40\n");
  EXPECT_TRUE(m.has("PP-U240")) << m.all_codes();
}

}  // namespace
