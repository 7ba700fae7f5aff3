// Fanuc lathe turning cycles (issue 16, area "Fanuc turning cycles"): G71/G72 type I, G73, G70,
// G74/G75, G90/G94 expanded into the moves the control makes; what is not followed is refused at
// its line (docs/fanuc-turning-cycles.md). Expected paths follow the Fanuc Series 0i/30i lathe
// operator's manual (B-64484EN-1 / B-64604EN), "Multiple repetitive cycle (G70-G76)" and "Canned
// cycle (G90, G92, G94)": the cutting-path figures and the manual's example programs.
// Motion::end holds X as a radius (diameter programming).
#include <cmath>
#include <string>
#include <vector>

#include "support.hpp"

namespace {

namespace gc = postproc::gcode;
using pptest::dialect;
using pptest::expect_diag_at;

constexpr double kEps = 1e-6;

gc::Dialect lathe(char system, gc::Dialect::IntegerInput input, bool final_cut) {
  gc::DialectOptions o;
  o.lathe = true;
  o.gcode_system = system;
  o.integer_input = input;
  gc::Dialect d = *gc::make_dialect("fanuc", o);
  d.fanuc_rough_final_cut = final_cut;
  return d;
}

struct LatheRun : pptest::Program {
  explicit LatheRun(std::string program, char system = 'A',
                    gc::Dialect::IntegerInput input = gc::Dialect::IntegerInput::calculator, bool final_cut = true)
      : Program(lathe(system, input, final_cut), std::move(program)) {}
  [[nodiscard]] std::vector<const gc::Motion*> of_line(std::uint64_t line) const {
    std::vector<const gc::Motion*> out;
    for (const auto& m : motions)
      if (m.line == line) out.push_back(&m);
    return out;
  }
};

/// Expects motion `m` to end at radius x, z with the given type.
void expect_at(const gc::Motion* m, gc::MotionType type, double x, double z, const char* what) {
  ASSERT_NE(m, nullptr) << what;
  EXPECT_EQ(m->type, type) << what;
  EXPECT_NEAR(m->end[0], x, kEps) << what;
  EXPECT_NEAR(m->end[2], z, kEps) << what;
}

using T = gc::MotionType;

// B-64484EN-1 "Stock removal in turning (G71)", example program (diameter, metric).
const char* kG71Example =
    "N010 G50 X220.0 Z190.0\n"                  // 1
    "N011 G00 X176.0 Z132.0\n"                  // 2
    "N012 G71 U7.0 R1.0\n"                      // 3
    "N013 G71 P014 Q020 U4.0 W2.0 F0.3 S550\n"  // 4
    "N014 G00 X40.0 F0.15 S700\n"               // 5
    "N015 G01 W-40.0\n"                         // 6
    "N016 X60.0 W-30.0\n"                       // 7
    "N017 W-10.0\n"                             // 8
    "N018 X100.0 W-10.0\n"                      // 9
    "N019 W-20.0\n"                             // 10
    "N020 X140.0 W-20.0\n"                      // 11
    "N021 G70 P014 Q020\n"                      // 12
    "N022 G00 X220.0 Z190.0\n"                  // 13
    "N023 M30\n";                               // 14

TEST(FanucTurningCycles, G71TypeICutsLayersOfDepthDeltaDAndReturnsToTheStart) {
  // B-64484EN-1 §"Stock removal in turning (G71)", Fig. "Cutting path in stock removal in turning
  // (type I)": from A (X176 Z132, radius 88) layers Δd = 7 (radius) deep are cut parallel to Z up
  // to the shape shifted by Δu/2 = 2 and Δw = 2, each left by e = 1 at 45° and returned at rapid;
  // where a layer lies above the shape's end B, it ends on the line B–C. The infeed is G00 as the
  // ns block (N014) is G00. The profile blocks N014–N020 are not executed by G71.
  const LatheRun r(kG71Example);
  ASSERT_EQ(r.sink.count(gc::Severity::error), 0u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const auto ms = r.of_line(4);
  // Shifted shape: (Z134 r22) (Z94 r22) (Z64 r32) (Z54 r32) (Z44 r52) (Z24 r52) (Z4 r72).
  const double levels[9] = {81, 74, 67, 60, 53, 46, 39, 32, 25};
  const double ends[9] = {4, 4, 9, 16, 23, 47, 50.5, 64, 85};
  ASSERT_EQ(ms.size(), 9u * 4u + 1u + 6u + 1u);
  for (std::size_t k = 0; k < 9; ++k) {
    expect_at(ms[4 * k], T::rapid, levels[k], 132, "infeed");
    expect_at(ms[4 * k + 1], T::linear, levels[k], ends[k], "cut");
    expect_at(ms[4 * k + 2], T::rapid, levels[k] + 1, ends[k] + 1, "45° escape by e");
    expect_at(ms[4 * k + 3], T::rapid, levels[k] + 1, 132, "return");
    EXPECT_NEAR(ms[4 * k + 1]->feed, 0.3, kEps);  // F of the G71 block, not the shape's F0.15
  }
  // Last: to A' with the allowance, then the shifted shape (parameter 5105#1 RF1 = 0), back to A.
  expect_at(ms[36], T::rapid, 22, 134, "A' + allowance");
  expect_at(ms[37], T::linear, 22, 94, "shape");
  expect_at(ms[42], T::linear, 72, 4, "B + allowance");
  expect_at(ms[43], T::rapid, 88, 132, "back to A");
  EXPECT_EQ(ms[0]->column, 6u);
  // Nothing is cut on the profile lines themselves.
  for (std::uint64_t line = 5; line <= 11; ++line) EXPECT_TRUE(r.of_line(line).empty()) << line;
}

TEST(FanucTurningCycles, G70RunsTheShapeWithItsFeedAndReturnsToTheStartAtRapid) {
  // B-64484EN-1 "Finishing cycle (G70)": the blocks ns…nf run as programmed with their F (0.15),
  // then the tool returns to the start point at rapid; the program continues after G70.
  const LatheRun r(kG71Example);
  const auto ms = r.of_line(12);
  ASSERT_EQ(ms.size(), 8u);
  expect_at(ms[0], T::rapid, 20, 132, "N014");
  expect_at(ms[1], T::linear, 20, 92, "N015");
  EXPECT_NEAR(ms[1]->feed, 0.15, kEps);
  expect_at(ms[6], T::linear, 70, 2, "N020");
  expect_at(ms[7], T::rapid, 88, 132, "return to the start");
  for (const auto* m : ms) EXPECT_EQ(m->word_index[0], -1);
  expect_at(r.at_line(13), T::rapid, 110, 190, "N022");
}

TEST(FanucTurningCycles, G72FacesInLayersAlongZ) {
  // B-64484EN-1 "Stock removal in facing (G72)", example program: the same path as G71 with X
  // and Z exchanged (layers of Δd = 7 along Z, cut parallel to X).
  const LatheRun r(
      "N010 G50 X220.0 Z190.0\n"
      "N011 G00 X176.0 Z132.0\n"
      "N012 G72 W7.0 R1.0\n"
      "N013 G72 P014 Q019 U4.0 W2.0 F0.3 S550\n"
      "N014 G00 Z58.0 F0.15 S700\n"
      "N015 G01 X120.0 W12.0\n"
      "N016 W10.0\n"
      "N017 X80.0 W10.0\n"
      "N018 W20.0\n"
      "N019 X36.0 W22.0\n"
      "N020 G70 P014 Q019\n"
      "M30\n");
  ASSERT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const auto ms = r.of_line(4);
  const double levels[10] = {125, 118, 111, 104, 97, 90, 83, 76, 69, 62};
  const double ends[10] = {29, 36, 42, 42, 42, 46, 60, 62, 69, 90 - 28.0 * 2 / 12};
  ASSERT_EQ(ms.size(), 10u * 4u + 1u + 5u + 1u);
  for (std::size_t k = 0; k < 10; ++k) {
    expect_at(ms[4 * k], T::rapid, 88, levels[k], "infeed along Z");
    expect_at(ms[4 * k + 1], T::linear, ends[k], levels[k], "cut along X");
    expect_at(ms[4 * k + 2], T::rapid, ends[k] + 1, levels[k] + 1, "escape");
    expect_at(ms[4 * k + 3], T::rapid, 88, levels[k] + 1, "return");
  }
  expect_at(ms[40], T::rapid, 90, 60, "A' + allowance");
  expect_at(ms[45], T::linear, 20, 134, "B + allowance");
  expect_at(ms[46], T::rapid, 88, 132, "back to A");
  EXPECT_EQ(r.of_line(11).size(), 7u);
}

TEST(FanucTurningCycles, G73RepeatsTheShapeShiftedTowardsItself) {
  // B-64484EN-1 "Pattern repeating (G73)", example program: d = 3 passes, the first shifted by
  // Δi + Δu/2 = 14 + 2 in X (radius) and Δk + Δw = 14 + 2 in Z, the last by the allowance alone;
  // each pass starts with the ns block's G00 from A and returns to A at rapid.
  const LatheRun r(
      "N010 G50 X260.0 Z220.0\n"
      "N011 G00 X220.0 Z160.0\n"
      "N012 G73 U14.0 W14.0 R3\n"
      "N013 G73 P014 Q019 U4.0 W2.0 F0.3 S0180\n"
      "N014 G00 X80.0 W-40.0\n"
      "N015 G01 W-20.0 F0.15 S0600\n"
      "N016 X120.0 W-10.0\n"
      "N017 W-20.0 S0400\n"
      "N018 G02 X160.0 W-20.0 R20.0\n"
      "N019 G01 X180.0 W-10.0 S0280\n"
      "N020 G70 P014 Q019\n"
      "M30\n");
  ASSERT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const auto ms = r.of_line(4);
  ASSERT_EQ(ms.size(), 3u * 7u);
  const double shift[3] = {16, 9, 2};
  for (std::size_t k = 0; k < 3; ++k) {
    const double s = shift[k];
    expect_at(ms[7 * k], T::rapid, 40 + s, 120 + s, "A' shifted");
    expect_at(ms[7 * k + 1], T::linear, 40 + s, 100 + s, "N015");
    expect_at(ms[7 * k + 4], T::arc_cw, 80 + s, 50 + s, "N018 arc");
    EXPECT_NEAR(ms[7 * k + 4]->arc.radius, 20, kEps);
    expect_at(ms[7 * k + 5], T::linear, 90 + s, 40 + s, "N019");
    expect_at(ms[7 * k + 6], T::rapid, 110, 160, "back to A");
  }
}

TEST(FanucTurningCycles, G90StraightAndTaperRepeatModally) {
  // B-64484EN-1 "Outer diameter/internal diameter cutting cycle (G90)": (1) rapid in X to the cut's
  // start, (2) cut to X Z, (3) cut in X back to the start's diameter, (4) rapid in Z to the start.
  // With R (radius, start minus end of the taper) the first move ends at X + 2R on the diameter.
  // X(U) Z(W) R are modal while the cycle repeats in blocks of axis words.
  const LatheRun r(
      "G00 X60.0 Z2.0\n"           // 1
      "G90 X50.0 Z-30.0 F0.2\n"    // 2
      "X45.0\n"                    // 3
      "U-20.0 R-2.0\n"             // 4: X40, taper
      "G00 X100.0 Z100.0\n"        // 5
      "M30\n");
  ASSERT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const auto a = r.of_line(2);
  ASSERT_EQ(a.size(), 4u);
  expect_at(a[0], T::rapid, 25, 2, "(1)");
  expect_at(a[1], T::linear, 25, -30, "(2)");
  expect_at(a[2], T::linear, 30, -30, "(3)");
  expect_at(a[3], T::rapid, 30, 2, "(4)");
  EXPECT_NEAR(a[1]->feed, 0.2, kEps);
  const auto b = r.of_line(3);
  ASSERT_EQ(b.size(), 4u);
  expect_at(b[1], T::linear, 22.5, -30, "repeat keeps Z");
  const auto c = r.of_line(4);
  ASSERT_EQ(c.size(), 4u);
  expect_at(c[0], T::rapid, 18, 2, "taper start X + R");
  expect_at(c[1], T::linear, 20, -30, "taper end");
  expect_at(r.at_line(5), T::rapid, 50, 100, "G00 ends the cycle");
}

TEST(FanucTurningCycles, G94FacesWithTaperR) {
  // B-64484EN-1 "End face turning cycle (G94)": (1) rapid in Z to the face (Z + R for a taper),
  // (2) cut to X Z, (3) cut in Z back to the start's Z, (4) rapid in X to the start.
  const LatheRun r(
      "G00 X60.0 Z2.0\n"
      "G94 X20.0 Z-2.0 R-3.0 F0.2\n"
      "W-4.0\n"
      "G00 X100.0\n");
  ASSERT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const auto a = r.of_line(2);
  ASSERT_EQ(a.size(), 4u);
  expect_at(a[0], T::rapid, 30, -5, "(1) Z + R");
  expect_at(a[1], T::linear, 10, -2, "(2)");
  expect_at(a[2], T::linear, 10, 2, "(3)");
  expect_at(a[3], T::rapid, 30, 2, "(4)");
  const auto b = r.of_line(3);
  ASSERT_EQ(b.size(), 4u);
  expect_at(b[1], T::linear, 10, -2, "W from the start point, R kept");
  expect_at(b[0], T::rapid, 30, -5, "R kept");
}

TEST(FanucTurningCycles, SystemBG77AndG79AreTheSingleCycles) {
  // B-64484EN-1 "G code system": G77 / G79 of system B are G90 / G94 of system A.
  const LatheRun r(
      "G90 G00 X60.0 Z2.0\n"
      "G77 X50.0 Z-30.0 F0.2\n"
      "G79 X20.0 Z-2.0\n",
      'B');
  ASSERT_TRUE(r.sink.stored().empty()) << r.all_codes();
  ASSERT_EQ(r.of_line(2).size(), 4u);
  expect_at(r.of_line(2)[1], T::linear, 25, -30, "G77 cut");
  ASSERT_EQ(r.of_line(3).size(), 4u);
  expect_at(r.of_line(3)[1], T::linear, 10, -2, "G79 cut");
}

TEST(FanucTurningCycles, G74PecksWithReturnAmountAndStepsInX) {
  // B-64484EN-1 "End face peck drilling cycle (G74)": cut Δk (Q, 0.001 mm units), return e (first
  // block R), cut again Δk + e …, down to Z; at the bottom relief Δd (R) against the X steps, back
  // to the start's Z at rapid; then step Δi (P) in X, last step to X; finally back to the start.
  const LatheRun r(
      "G00 X20.0 Z1.0\n"
      "G74 R0.5\n"
      "G74 X30.0 Z-4.0 P4000 Q2000 R0.2 F0.1\n");
  ASSERT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const auto ms = r.of_line(3);
  // Column at r10: -1, (-0.5), -3, (-2.5), -4; relief to r9.8; up to Z1. Column at r14 (10 + 4),
  // column at r15 (X30): each the same.
  ASSERT_EQ(ms.size(), 7u + 8u + 8u + 1u);
  expect_at(ms[0], T::linear, 10, -1, "first peck");
  expect_at(ms[1], T::rapid, 10, -0.5, "return e");
  expect_at(ms[2], T::linear, 10, -3, "second peck");
  expect_at(ms[4], T::linear, 10, -4, "bottom");
  expect_at(ms[5], T::rapid, 9.8, -4, "relief");
  expect_at(ms[6], T::rapid, 9.8, 1, "back to the start's Z");
  expect_at(ms[7], T::rapid, 14, 1, "step P");
  expect_at(ms[15], T::rapid, 15, 1, "last step to X");
  expect_at(ms.back(), T::rapid, 10, 1, "back to the start");
}

TEST(FanucTurningCycles, G75GroovesAlongX) {
  // B-64484EN-1 "Outer diameter/internal diameter drilling cycle (G75)": G74 with X and Z exchanged;
  // P (Δi) is the depth of each cut in X (radius), no steps along Z here.
  const LatheRun r(
      "G00 X42.0 Z-10.0\n"
      "G75 R0.5\n"
      "G75 X30.0 P2000 F0.05\n");
  ASSERT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const auto ms = r.of_line(3);
  ASSERT_EQ(ms.size(), 6u);
  expect_at(ms[0], T::linear, 19, -10, "first cut");
  expect_at(ms[1], T::rapid, 19.5, -10, "return");
  expect_at(ms[2], T::linear, 17, -10, "second cut");
  expect_at(ms[4], T::linear, 15, -10, "bottom");
  expect_at(ms[5], T::rapid, 21, -10, "back to the start");
}

TEST(FanucTurningCycles, G71InfeedFollowsTheNsBlockModeAndParameterRF1) {
  // B-64484EN-1 G71: "when A–A' is programmed by G01, the infeed is at cutting feed"; parameter
  // 5105#1 RF1 = 1 leaves out the last cut along the allowance shape (the last layer is cut like
  // the others, escape and return included), then the tool returns to A.
  const std::string prog =
      "G00 X50.0 Z2.0\n"
      "G71 U2.0 R0.5\n"
      "G71 P10 Q20 U1.0 W0 F0.2\n"
      "N10 G01 X40.0\n"
      "Z-20.0\n"
      "N20 X52.0\n";
  const LatheRun r(prog, 'A', gc::Dialect::IntegerInput::calculator, false);
  ASSERT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const auto ms = r.of_line(3);
  // Levels r23, r21 and the last on A' + allowance, r20.5; each ends on the shifted step at Z-20.
  ASSERT_EQ(ms.size(), 3u * 4u + 1u);
  expect_at(ms[0], T::linear, 23, 2, "G01 infeed");
  expect_at(ms[1], T::linear, 23, -20, "cut");
  expect_at(ms[4], T::linear, 21, 2, "second layer");
  expect_at(ms[8], T::linear, 20.5, 2, "last layer's infeed");
  expect_at(ms[9], T::linear, 20.5, -20, "last layer");
  expect_at(ms[10], T::rapid, 21, -19.5, "escape");
  expect_at(ms[12], T::rapid, 25, 2, "back to A");
  const LatheRun f(prog);
  const auto fs = f.of_line(3);
  ASSERT_EQ(fs.size(), 2u * 4u + 1u + 2u + 1u);
  expect_at(fs[8], T::linear, 20.5, 2, "to A' + allowance at feed");
  expect_at(fs[10], T::linear, 26.5, -20, "shape end + allowance");
}

TEST(FanucTurningCycles, G73DivisionCountIsNotALength) {
  // B-64484EN-1 G73: R(d) is the number of divisions; with standard input (whole numbers in least
  // increments) it stays 3, and no integer-input warning is due for it.
  const LatheRun r(
      "G00 X60.0 Z2.0\n"
      "G73 U2.0 W0.0 R3\n"
      "G73 P10 Q20 U0.0 W0.0 F0.2\n"
      "N10 G00 X40.0 Z0.0\n"
      "N20 G01 X60.0 Z-20.0\n",
      'A', gc::Dialect::IntegerInput::unknown);
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  EXPECT_EQ(r.of_line(3).size(), 3u * 3u);
  expect_at(r.of_line(3)[0], T::rapid, 22, 0, "first pass shifted by Δi");
}

TEST(FanucTurningCycles, SystemBReadsUAndWAsCycleValuesAndInchUnits) {
  // B-64484EN-1 "G code system": in system B the cycle words U W keep their meaning (depth,
  // allowance); inch input (G20) scales every length by 25.4.
  const LatheRun r(
      "G20 G90 G00 X2.0 Z0.1\n"
      "G71 U0.1 R0.02\n"
      "G71 P10 Q20 U0.0 W0.0 F0.01\n"
      "N10 G00 X1.8\n"
      "G01 Z-1.0\n"
      "N20 X2.2\n",
      'B');
  ASSERT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const auto ms = r.of_line(3);
  ASSERT_FALSE(ms.empty());
  expect_at(ms[0], T::rapid, 0.9 * 25.4, 0.1 * 25.4, "first layer");
  expect_at(ms[1], T::linear, 0.9 * 25.4, -25.4, "cut");
  expect_at(ms.back(), T::rapid, 25.4, 0.1 * 25.4, "back to A");
}

// ---- Refusals ----------------------------------------------------------------------------------

TEST(FanucTurningCycles, TypeIIIsRefusedAtTheCycle) {
  // 0i-F (B-64604EN) G71: X and Z in the first block of the shape select type II (pockets).
  const LatheRun r(
      "G00 X50.0 Z2.0\n"
      "G71 U1.0 R0.5\n"
      "G71 P10 Q20 U0.4 W0.1 F0.2\n"
      "N10 G00 X10.0 Z1.0\n"
      "G01 Z-20.0\n"
      "N20 X52.0\n"
      "G00 X60.0 Z10.0\n");
  expect_diag_at(r, "PP-U252", 3, 1);
  EXPECT_TRUE(r.of_line(3).empty());
  EXPECT_TRUE(r.of_line(5).empty());  // the shape is still not executed
  expect_at(r.at_line(7), T::rapid, 30, 10, "after the shape");
}

TEST(FanucTurningCycles, FirstBlockOfTheShapeMustBeG00OrG01) {
  // B-64484EN-1 G71: the ns block must give G00 or G01 (alarm otherwise).
  const LatheRun r(
      "G00 X50.0 Z2.0\n"
      "G71 U1.0 R0.5\n"
      "G71 P10 Q20 U0.4 W0.1 F0.2\n"
      "N10 X10.0\n"
      "G01 Z-20.0\n"
      "N20 X52.0\n");
  expect_diag_at(r, "PP-E252", 4, 1);
}

TEST(FanucTurningCycles, UnstatedParametersAndFormsAreRefused) {
  // Δd and e left to parameters 5132/5133; the Series 10/11 one-block format (D); a G70 whose
  // shape no cycle read; a shape whose last block never comes.
  const LatheRun p("G00 X50.0 Z2.0\nG71 P10 Q20 U0.4 W0.1 F0.2\nN10 G00 X10.0\nN20 G01 Z-10.0\n");
  expect_diag_at(p, "PP-U252", 2, 1);
  EXPECT_NE(p.find("PP-U252")->message.find("5132"), std::string::npos);
  const LatheRun d("G00 X50.0 Z2.0\nG71 P10 Q20 U0.4 W0.1 D1500 F0.2\nN10 G00 X10.0\nN20 G01 Z-10.0\n");
  expect_diag_at(d, "PP-U252", 2, 1);
  EXPECT_NE(d.find("PP-U252")->message.find("10/11"), std::string::npos);
  // A refused cycle still does not execute its shape (the control reads on after N(nf)).
  EXPECT_TRUE(p.of_line(3).empty());
  EXPECT_TRUE(d.of_line(4).empty());
  const LatheRun g70("G00 X50.0 Z2.0\nN5 G70 P10 Q20\n");
  expect_diag_at(g70, "PP-U252", 2, 4);
  const LatheRun open("G00 X50.0 Z2.0\nG71 U1.0 R0.5\nG71 P10 Q20 U0.4 F0.2\nN10 G00 X10.0\nG01 Z-10.0\n");
  expect_diag_at(open, "PP-E252", 3, 1);
}

TEST(FanucTurningCycles, ModalMotionAfterTheCycleIsRefused) {
  // G70–G73 are one-shot; the manual does not state the group-01 mode after them.
  const LatheRun r(std::string(kG71Example).replace(std::string(kG71Example).find("N022 G00 X220.0"), 15, "N022 X220.0"));
  expect_diag_at(r, "PP-U253", 13, 6);
  EXPECT_EQ(r.at_line(13), nullptr);
}

TEST(FanucTurningCycles, AddressesOutsideTheFormatAreRefused) {
  // B-64484EN-1 "Outer diameter/internal diameter cutting cycle (G90)": X(U) Z(W) R F; an I (the
  // taper word of other controls) is not guessed at.
  const LatheRun r("G00 X60.0 Z2.0\nG90 X50.0 Z-30.0 I-2.0 F0.2\n");
  expect_diag_at(r, "PP-U252", 2, 1);
  EXPECT_TRUE(r.of_line(2).empty());
  const LatheRun g70("G00 X60.0 Z2.0\nG70 P10 Q20 F0.1\n");
  expect_diag_at(g70, "PP-U252", 2, 1);
}

TEST(FanucTurningCycles, PeckAmountsTakeNoDecimalPoint) {
  // B-64484EN-1 G74: P and Q in the least input increment, without a decimal point.
  const LatheRun r("G00 X0 Z1.0\nG74 R0.5\nG74 Z-10.0 Q2.5 F0.1\n");
  expect_diag_at(r, "PP-E252", 3, 1);
}

}  // namespace
