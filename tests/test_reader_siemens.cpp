// Reader round 2, Siemens (Sinumerik 840D sl): units and feeds, the motion addresses of the arc
// forms (CR= AR= TURN= CIP CT) and corner words, the reset state, declarations, T/D. Each expected
// answer names the Sinumerik manual section it follows ("Fundamentals" = SINUMERIK 840D sl
// Programming Manual Fundamentals; "Job planning" = Programming Manual Job Planning).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "postproc/compensation/compensate.hpp"
#include "postproc/gcode/resolve.hpp"
#include "postproc/io/output_file.hpp"
#include "sample_machine.hpp"
#include "support.hpp"

namespace {

using namespace pptest;
using gc::MotionType;
constexpr double kTol = 1e-9;
constexpr double kPi = std::numbers::pi;

#define EXPECT_VEC(v, x, y, z)       \
  do {                               \
    EXPECT_NEAR((v)[0], (x), kTol);  \
    EXPECT_NEAR((v)[1], (y), kTol);  \
    EXPECT_NEAR((v)[2], (z), kTol);  \
  } while (0)

gc::Dialect siemens(gc::DialectOptions o = {}) { return gc::make_dialect(gc::DialectId::siemens, o); }

/// A Sinumerik program run as `postproc check` runs it (resolver, then interpreter).
struct Resolved : ResolvedProgram {
  explicit Resolved(std::string program, gc::ResolveOptions opt = {})
      : ResolvedProgram(siemens(), std::move(program), std::move(opt)) {}
};

// ---- 1. units -----------------------------------------------------------------------------------

TEST(ReaderSiemens, G70ChangesLengthsButNotTheFeed) {
  // Fundamentals, "Inch or metric dimensions: G70/G700, G71/G710": G70/G71 convert geometric data
  // only; F stays in the basic system (metric here: mm/min). G700/G710 convert F as well.
  const Program r(siemens(), "G70 G1 X1 F100\nG700 X2 F10\nG70 X3 F100\nG710 X50 F300\nG71 X40\n");
  ASSERT_EQ(r.motions.size(), 5u) << r.all_codes();
  EXPECT_NEAR(r.motions[0].end[0], 25.4, kTol);
  EXPECT_NEAR(r.motions[0].feed, 100, kTol);       // G70: mm/min (basic system)
  EXPECT_NEAR(r.motions[1].end[0], 50.8, kTol);
  EXPECT_NEAR(r.motions[1].feed, 254, kTol);       // G700: inch/min
  EXPECT_NEAR(r.motions[2].feed, 100, kTol);       // back to G70: the basic system again
  EXPECT_NEAR(r.motions[3].end[0], 50, kTol);
  EXPECT_NEAR(r.motions[3].feed, 300, kTol);
  EXPECT_NEAR(r.motions[4].feed, 300, kTol);       // F is modal, not re-read by G71
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
}

TEST(ReaderSiemens, InchBasicSystemIsAnOption) {
  // Fundamentals, same section: the basic system is machine data (MD10240
  // $MN_SCALING_SYSTEM_IS_METRIC); on an inch machine F under G70/G71 is inch/min and the program
  // starts in inches.
  gc::DialectOptions o;
  o.basic_inch = true;
  const Program r(siemens(o), "G1 X1 F10\nG71 X10 F10\nG710 X20 F10\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  EXPECT_NEAR(r.motions[0].end[0], 25.4, kTol);
  EXPECT_NEAR(r.motions[0].feed, 254, kTol);
  EXPECT_NEAR(r.motions[1].end[0], 10, kTol);
  EXPECT_NEAR(r.motions[1].feed, 254, kTol);  // G71: lengths metric, F in the (inch) basic system
  EXPECT_NEAR(r.motions[2].feed, 10, kTol);   // G710: mm/min
}

// ---- 2. arc forms and motion addresses ------------------------------------------------------------

TEST(ReaderSiemens, MotionAddressesLexAsWords) {
  // Fundamentals, "Helical interpolation (G2/G3, TURN)" and "Chamfer, rounding (CHF, CHR, RND,
  // RNDM)": TURN= CHF= CHR= RND= RNDM= are addresses of the block, not variable assignments.
  const Lexed l(siemens(), "G3 X10 Y0 I-5 TURN=2 CHF=1 RND=2 RNDM=0.5 CHR=1");
  ASSERT_TRUE(l.ok);
  EXPECT_EQ(l.words(), (std::vector<std::string>{"G3", "X10", "Y0", "I-5", "TURN=2", "CHF=1", "RND=2", "RNDM=0.5", "CHR=1"}));
  EXPECT_TRUE(l.tokens().empty());
}

TEST(ReaderSiemens, TurnAddsFullTurnsToAHelix) {
  // Fundamentals, "Helical interpolation (G2/G3, TURN)": TURN=n adds n full circles before the end.
  const Program r(siemens(), "G17 G0 X10 Y0 Z0\nG3 X10 Y0 Z-6 I-10 J0 TURN=2 F100\nG2 X0 Y10 Z-8 I-10 TURN=1\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const gc::Motion& h = r.motions[1];
  EXPECT_EQ(h.arc.turns, 3u);
  EXPECT_NEAR(h.arc.sweep, 3 * 2 * kPi, 1e-9);  // end on start: one full circle plus TURN=2
  EXPECT_VEC(h.arc.centre, 0, 0, 0);
  EXPECT_VEC(h.end, 10, 0, -6);
  const gc::Motion& q = r.motions[2];
  EXPECT_EQ(q.arc.turns, 2u);
  EXPECT_NEAR(q.arc.sweep, -(1.5 * kPi + 2 * kPi), 1e-9);  // cw 270° to (0,10), plus one turn
}

TEST(ReaderSiemens, TurnMustBeAWholeNumber) {
  // Fundamentals, "Helical interpolation": TURN= 0…999 further full turns. Beyond the range: refused
  // (PP-E240); a fraction (NX posts write TURN=.5) has no documented reading: not resolved (PP-U243).
  const Program r(siemens(), "G0 X10 Y0\nG3 X10 Y0 I-10 TURN=1000\n");
  expect_diag_at(r, "PP-E240", 2, 16);
  EXPECT_EQ(r.motions.size(), 1u);
  const Program f(siemens(), "G0 X10 Y0 Z0\nG3 X-10 Y0 Z-1 I-10 TURN=.5\nG1 X0 Y0\n");
  expect_diag_at(f, "PP-U243", 2, 21);
  EXPECT_EQ(f.find("PP-U243")->severity, gc::Severity::warning);
  ASSERT_EQ(f.motions.size(), 2u);
  // The end point is the programmed one whatever the turns: the next block starts there.
  EXPECT_VEC(f.motions[1].start, -10, 0, -1);
  EXPECT_EQ(f.motions[1].known & gc::bit(gc::Axis::x), gc::bit(gc::Axis::x));
}

TEST(ReaderSiemens, RadiusCR) {
  // Fundamentals, "Circular interpolation with radius and end point (CR)": CR=+ the arc up to 180°,
  // CR=- the one beyond.
  const Program r(siemens(), "G0 X0 Y0\nG2 X10 Y0 CR=5\nG0 X0 Y0\nG2 X10 Y0 CR=-10\n");
  ASSERT_EQ(r.motions.size(), 4u) << r.all_codes();
  EXPECT_VEC(r.motions[1].arc.centre, 5, 0, 0);
  EXPECT_NEAR(r.motions[1].arc.sweep, -kPi, 1e-9);
  EXPECT_GT(std::abs(r.motions[3].arc.sweep), kPi);
  EXPECT_NEAR(r.motions[3].arc.radius, 10, kTol);
}

TEST(ReaderSiemens, OpeningAngleWithEndPoint) {
  // Fundamentals, "Circular interpolation with opening angle and end point (AR, X, Y)": the centre
  // lies on the chord's bisector so that the arc turns by AR (G3 counter-clockwise).
  const Program r(siemens(), "G0 X0 Y0\nG3 X10 Y0 AR=90\nG0 X0 Y0\nG2 X10 Y0 AR=90\nG0 X0 Y0\nG3 X10 Y0 AR=270\n");
  ASSERT_EQ(r.motions.size(), 6u) << r.all_codes();
  EXPECT_VEC(r.motions[1].arc.centre, 5, 5, 0);
  EXPECT_NEAR(r.motions[1].arc.sweep, kPi / 2, 1e-9);
  EXPECT_NEAR(r.motions[1].arc.radius, std::sqrt(50.0), 1e-9);
  EXPECT_VEC(r.motions[3].arc.centre, 5, -5, 0);
  EXPECT_NEAR(r.motions[3].arc.sweep, -kPi / 2, 1e-9);
  EXPECT_VEC(r.motions[5].arc.centre, 5, -5, 0);
  EXPECT_NEAR(r.motions[5].arc.sweep, 1.5 * kPi, 1e-9);
}

TEST(ReaderSiemens, OpeningAngleWithCentre) {
  // Fundamentals, "Circular interpolation with opening angle and centre point (AR, I, J)": the end
  // point is the start turned by AR about the centre.
  const Program r(siemens(), "G0 X10 Y0 Z0\nG3 I-10 J0 AR=90 F100\nG2 I=AC(0) J=AC(0) AR=45\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  EXPECT_VEC(r.motions[1].end, 0, 10, 0);
  EXPECT_NEAR(r.motions[1].arc.sweep, kPi / 2, 1e-9);
  const double c = std::sqrt(50.0);
  EXPECT_VEC(r.motions[2].end, c, c, 0);
  EXPECT_NEAR(r.motions[2].arc.sweep, -kPi / 4, 1e-9);
  // A following incremental move starts from the computed end point.
  const Program g(siemens(), "G0 X10 Y0\nG3 I-10 AR=180\nG91 G1 X5\n");
  ASSERT_EQ(g.motions.size(), 3u) << g.all_codes();
  EXPECT_VEC(g.motions[2].end, -5, 0, 0);
}

TEST(ReaderSiemens, OpeningAngleMisuseIsRefused) {
  // Fundamentals, circular interpolation programming forms: AR= goes with the centre or with the end
  // point, never with both or with CR=; 0 < AR < 360.
  const Program both(siemens(), "G0 X0 Y0\nG3 X10 Y0 I5 AR=90\n");
  expect_diag_at(both, "PP-E240", 2, 14);
  const Program cr(siemens(), "G0 X0 Y0\nG3 X10 Y0 CR=5 AR=90\n");
  expect_diag_at(cr, "PP-E240", 2, 16);
  const Program range(siemens(), "G0 X0 Y0\nG3 X10 Y0 AR=360\n");
  expect_diag_at(range, "PP-E240", 2, 11);
  const Program linear(siemens(), "G0 X0 Y0\nG1 X10 AR=90 F100\n");
  expect_diag_at(linear, "PP-E240", 2, 8);
  for (const Program* p : {&both, &cr, &range, &linear}) EXPECT_EQ(p->motions.size(), 1u);
}

TEST(ReaderSiemens, CircleThroughIntermediatePoint) {
  // Fundamentals, "Circular interpolation with intermediate and end points (CIP)", the manual's
  // example N5 G90 X30 Y40 / N10 CIP X50 Y40 I1=40 J1=45: the direction follows start →
  // intermediate → end (here clockwise); CIP is modal.
  const Program r(siemens(), "G0 X30 Y40 Z0\nCIP X50 Y40 I1=40 J1=45 F100\nX30 Y40 I1=40 J1=20\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  const gc::Motion& m = r.motions[1];
  EXPECT_EQ(m.type, MotionType::arc_cw);
  EXPECT_EQ(m.column, 1u);
  EXPECT_VEC(m.arc.centre, 40, 32.5, 0);
  EXPECT_NEAR(m.arc.radius, 12.5, 1e-9);
  EXPECT_NEAR(m.arc.sweep, -2 * std::atan2(10.0, 7.5), 1e-9);
  const gc::Motion& back = r.motions[2];  // modal CIP, back below the centre: clockwise again
  EXPECT_EQ(back.type, MotionType::arc_cw);
  EXPECT_VEC(back.arc.centre, 40, 32.5, 0);
  EXPECT_NEAR(back.arc.sweep, -(2 * kPi - 2 * std::atan2(10.0, 7.5)), 1e-9);
}

TEST(ReaderSiemens, CipIncrementalFromTheStart) {
  // Fundamentals, CIP: with G91 (or =IC) the intermediate and end points are measured from the
  // circle's start point.
  const Program r(siemens(), "G0 X30 Y40 Z0\nG91 CIP X20 Y0 I1=10 J1=5 F100\n");
  ASSERT_EQ(r.motions.size(), 2u) << r.all_codes();
  EXPECT_VEC(r.motions[1].end, 50, 40, 0);
  EXPECT_VEC(r.motions[1].arc.centre, 40, 32.5, 0);
}

TEST(ReaderSiemens, CipInOtherPlaneAndInSpace) {
  // Fundamentals, CIP: the arc may lie in any plane ("inclined in space"). One parallel to ZX is
  // read in that plane; an inclined one is refused at its CIP, and so is an omitted K1 that (as 0)
  // takes the arc out of the plane.
  const Program zx(siemens(), "G17 G0 X0 Y5 Z0\nCIP X10 Z0 I1=5 J1=5 K1=5 F100\n");
  ASSERT_EQ(zx.motions.size(), 2u) << zx.all_codes();
  EXPECT_EQ(zx.motions[1].plane, gc::Plane::zx);
  EXPECT_VEC(zx.motions[1].arc.centre, 5, 5, 0);
  EXPECT_NEAR(zx.motions[1].arc.radius, 5, 1e-9);
  const Program space(siemens(), "G0 X30 Y40 Z-5\nCIP X50 Y40 I1=40 J1=45 F100\nG1 X0\n");
  expect_diag_at(space, "PP-U241", 2, 1);
  ASSERT_EQ(space.motions.size(), 2u);
  EXPECT_EQ(space.motions[1].known & gc::bit(gc::Axis::y), 0);  // Y unknown after the refused arc
  const Program line(siemens(), "G0 X0 Y0 Z0\nCIP X20 Y0 I1=10 J1=0\n");
  expect_diag_at(line, "PP-E301", 2, 1);
}

TEST(ReaderSiemens, TangentialArc) {
  // Fundamentals, "Circular interpolation with tangential transition (CT)": the arc leaves the
  // previous element (line or arc) tangentially and ends at the programmed point; CT is modal.
  const Program r(siemens(), "G0 X0 Y0 Z0\nG1 X10 Y0 F100\nCT X20 Y10\nX30 Y20\n");
  ASSERT_EQ(r.motions.size(), 4u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  EXPECT_EQ(r.motions[2].type, MotionType::arc_ccw);
  EXPECT_VEC(r.motions[2].arc.centre, 10, 10, 0);
  EXPECT_NEAR(r.motions[2].arc.sweep, kPi / 2, 1e-9);
  EXPECT_EQ(r.motions[3].type, MotionType::arc_cw);  // tangent +Y at (20,10), end to the right
  EXPECT_VEC(r.motions[3].arc.centre, 30, 10, 0);
  EXPECT_NEAR(r.motions[3].arc.sweep, -kPi / 2, 1e-9);
}

TEST(ReaderSiemens, TangentialArcWithoutKnownDirectionIsRefused) {
  // CT needs the previous path element's direction in the plane: after a plunge along Z there is
  // none; at program start even the start point is unknown.
  const Program r(siemens(), "G0 X0 Y0 Z5\nG1 Z0 F100\nCT X20 Y10\nG1 X0 Y0\n");
  expect_diag_at(r, "PP-U241", 3, 1);
  ASSERT_EQ(r.motions.size(), 3u);
  const Program start(siemens(), "CT X20 Y10\n");
  expect_diag_at(start, "PP-U209", 1, 1);
  const Program straight(siemens(), "G0 X0 Y0\nG1 X10\nCT X20 Y0\n");
  expect_diag_at(straight, "PP-E301", 3, 1);
}

TEST(ReaderSiemens, ChamferAndRoundingBuiltOrRefusedAtTheirWord) {
  // Fundamentals, "Chamfer, rounding: CHF, CHR, RND, RNDM": a chamfer or rounding is inserted
  // between two blocks and shortens both. Between two straight moves it is built (tests/test_corners.cpp);
  // RNDM= (modal) and a corner without a next move are refused (PP-U240) at the word; RNDM=0
  // switches modal rounding off and is not refused.
  const Program chf(siemens(), "G0 X0 Y0\nG1 X10 Y0 CHF=2 F100\nY10\n");
  EXPECT_TRUE(chf.sink.stored().empty()) << chf.all_codes();
  ASSERT_EQ(chf.motions.size(), 4u);
  const double leg = 2 / (2 * std::cos(std::numbers::pi / 4));  // CHF is the chamfer's own length
  EXPECT_VEC(chf.motions[1].end, 10 - leg, 0, 0);
  EXPECT_VEC(chf.motions[2].end, 10, leg, 0);
  EXPECT_VEC(chf.motions[3].end, 10, 10, 0);
  const Program rndm(siemens(), "G0 X0 Y0\nRNDM=2\nG1 X10 F100\nRNDM=0\nY10\n");
  expect_diag_at(rndm, "PP-U240", 2, 1);
  EXPECT_EQ(rndm.sink.stored().size(), 1u) << rndm.all_codes();
  const Program off(siemens(), "G0 X0 Y0\nRNDM=0\nG1 X10 F100\n");
  EXPECT_TRUE(off.sink.stored().empty()) << off.all_codes();
  const Program rnd(siemens(), "G0 X0 Y0\nG1 X10 RND=1 F100\n");
  expect_diag_at(rnd, "PP-U240", 2, 8);
}

// ---- 3. reset state -------------------------------------------------------------------------------

TEST(ReaderSiemens, MovesBeforeAnyMotionCodeUseTheResetState) {
  // Fundamentals, "List of G functions", group 1: G1 is the Siemens default setting
  // (MD20150 $MC_GCODE_RESET_VALUES); group 6 G17, group 14 G90, group 13 G71 (metric basic system).
  const Program r(siemens(), "X10 Y5 F100\nZ-1\nG0 X0\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  EXPECT_EQ(r.motions[0].type, MotionType::linear);
  EXPECT_EQ(r.motions[0].plane, gc::Plane::xy);
  EXPECT_VEC(r.motions[0].end, 10, 5, 0);
  EXPECT_FALSE(r.motions[0].inch_source);
  EXPECT_EQ(r.motions[1].type, MotionType::linear);
  // A machine whose MD20150[0] says G0: the option.
  gc::DialectOptions o;
  o.reset_motion = '0';
  const Program g0(siemens(o), "X10 Y5\n");
  ASSERT_EQ(g0.motions.size(), 1u);
  EXPECT_EQ(g0.motions[0].type, MotionType::rapid);
  // LinuxCNC powers on with no motion mode (G80): axis words before a G0–G3 stay refused there.
  const Program lcnc(dialect("linuxcnc"), "X10 Y5\n");
  EXPECT_TRUE(lcnc.has("PP-E204"));
}

// ---- 5. T and D -----------------------------------------------------------------------------------

TEST(ReaderSiemens, DSelectsTheToolLengthOffset) {
  // Fundamentals, "Tool offset call (D)": T selects the tool, D1…D9 its cutting edge with the length
  // offset, D0 deselects the offset. A change of D is a change of the active tool length.
  const Program r(siemens(), "T1 D1\nM6\nG0 X0 Y0 Z10\nD0\nG0 Z5\nT2 D2\nG1 Z0 F100\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  EXPECT_TRUE(r.motions[0].tool_length_active);
  EXPECT_EQ(r.motions[0].tool_length_h, 1u);
  EXPECT_FALSE(r.motions[1].tool_length_active);
  EXPECT_TRUE(r.motions[2].tool_length_active);
  EXPECT_EQ(r.motions[2].tool_length_h, 2u);
  const Program bad(siemens(), "D1.5\n");
  expect_diag_at(bad, "PP-E205", 1, 1);
}

// ---- 6. other constructs ----------------------------------------------------------------------------

TEST(ReaderSiemens, DwellFIsSecondsNotAFeed) {
  // Fundamentals, "Dwell time (G4)": G4 F… gives the dwell in seconds; the programmed feed stays.
  const Program r(siemens(), "G0 X0 Y0 Z0\nG1 X10 F200\nG4 F3\nG1 X20\n");
  ASSERT_EQ(r.motions.size(), 3u) << r.all_codes();
  EXPECT_NEAR(r.motions[2].feed, 200, kTol);
}

TEST(ReaderSiemens, PolarMovesAboutThePole) {
  // Fundamentals, "Polar coordinates: G110, G111, G112" and "Travel commands with polar coordinates
  // (G0, G1, G2, G3, AP, RP)": G111 pole in work coordinates, G110 relative to the last position,
  // G112 relative to the last pole; AP= angle from the plane's first axis, RP= radius, both modal;
  // G2/G3 turn about the pole; without any pole the work origin is the pole.
  const Program r(siemens(), "G17 G0 X0 Y0 Z0\nG111 X10 Y10\nG1 RP=5 AP=90 F100\nAP=180\nG3 AP=270\n"
                             "G112 X5\nG1 RP=2 AP=0\nG110 X1 Y1\nG0 AP=90 RP=1\nG111 AP=90 RP=10\nG1 AP=0 RP=3\n");
  ASSERT_EQ(r.motions.size(), 7u) << r.all_codes();
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  EXPECT_VEC(r.motions[1].end, 10, 15, 0);
  EXPECT_VEC(r.motions[2].end, 5, 10, 0);
  EXPECT_EQ(r.motions[3].type, MotionType::arc_ccw);
  EXPECT_VEC(r.motions[3].end, 10, 5, 0);
  EXPECT_VEC(r.motions[3].arc.centre, 10, 10, 0);
  EXPECT_NEAR(r.motions[3].arc.sweep, kPi / 2, 1e-9);
  EXPECT_VEC(r.motions[4].end, 17, 10, 0);  // pole (15,10)
  EXPECT_VEC(r.motions[5].end, 18, 12, 0);  // pole (18,11) = last position + (1,1)
  EXPECT_VEC(r.motions[6].end, 3, 10, 0);   // pole (0,10) given by AP/RP from the origin
  const Program origin(siemens(), "G0 X0 Y0 Z0\nG1 RP=10 AP=30 F100\n");
  ASSERT_EQ(origin.motions.size(), 2u);
  EXPECT_VEC(origin.motions[1].end, 10 * std::cos(kPi / 6), 5, 0);
}

TEST(ReaderSiemens, PolarMovesThatCannotBeReadAreRefused) {
  // A new pole asks for RP= again (Fundamentals, same section); polar moves in G91 are not read.
  const Program pole(siemens(), "G0 X0 Y0 Z0\nG111 X0 Y0\nG1 RP=5 AP=0 F100\nG111 X10 Y0\nG1 AP=90\nG1 X0 Y0\n");
  expect_diag_at(pole, "PP-U204", 5, 1);
  EXPECT_EQ(pole.motions.size(), 3u);
  const Program inc(siemens(), "G0 X0 Y0 Z0\nG91 G1 RP=5 AP=0 F100\n");
  expect_diag_at(inc, "PP-U204", 2, 5);
}

/// Compensates `program` for the sample TRAORI machine (trunnion_ac_siemens.toml); returns the
/// diagnostics.
gc::DiagnosticSink compensate_siemens(const std::string& program) {
  const auto m = sample_machine("trunnion_ac_siemens.toml");
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  TempDir dir;
  gc::DiagnosticSink sink;
  gc::LineReader reader{std::string_view(program)};
  postproc::io::OutputFile out(dir.file("out.mpf"));
  postproc::comp::CompensateOptions opt;
  opt.tool_version = "test";
  (void)postproc::comp::compensate(reader, "in.mpf", d, m, opt, out, sink);
  return sink;
}

TEST(ReaderSiemens, CompensateRefusesMovesWhoseWordsItCannotRewrite) {
  // A polar end point (AP= RP=) or a CIP intermediate point would go stale when only X Y Z are
  // rewritten: compensate refuses those blocks at their line instead of writing a wrong program.
  const std::string head = "G17 G90 G54 G71\nT=\"BALL_8\" M6\nD1\nTRAORI\nG0 X0 Y0 Z50 A0 C0\n";
  for (const auto& [block, word] : std::vector<std::pair<std::string, std::string>>{
           {"G1 RP=10 AP=0 F100\n", "RP=10"}, {"CIP X10 Y10 I1=7 J1=3 K1=50 F100\n", "CIP / CT"}}) {
    const gc::DiagnosticSink sink = compensate_siemens(head + block + "M30\n");
    bool found = false;
    for (const auto& diag : sink.stored())
      found = found || (diag.severity == gc::Severity::error && diag.where.line == 6 &&
                        diag.message.find(word) != std::string::npos);
    EXPECT_TRUE(found) << block;
  }
}

// ---- 4. declarations and global user data ----------------------------------------------------------

TEST(ReaderSiemens, GlobalUserVariableRefusesOnlyTheWordThatReadsIt) {
  // Job planning, "Global user data (GUD)": variables defined on the controller (GUD blocks), used in
  // programs without DEF. Their value is the controller's: the block reading one is refused
  // (PP-U242, naming the variable and --set), the rest of the program is read.
  const Resolved r("G0 X0 Y0 Z0\nG1 X=_DEPTH F100\nG1 Y5\nG1 X2\nM30\n");
  const gc::Diagnostic* d = r.find("PP-U242");
  ASSERT_NE(d, nullptr) << r.all_codes();
  EXPECT_EQ(d->severity, gc::Severity::warning);
  EXPECT_EQ(d->where.line, 2u);
  EXPECT_EQ(d->where.column, 6u);
  EXPECT_NE(d->message.find("_DEPTH"), std::string::npos);
  EXPECT_NE(d->message.find("--set _DEPTH="), std::string::npos);
  EXPECT_EQ(r.sink.count(gc::Severity::error), 0u) << r.all_codes();
  ASSERT_EQ(r.motions.size(), 4u) << r.all_codes();
  EXPECT_EQ(r.motions[1].known & gc::bit(gc::Axis::x), 0);  // X of the refused block: unknown
  EXPECT_EQ(r.motions[2].known & gc::bit(gc::Axis::x), 0);
  EXPECT_VEC(r.motions[3].end, 2, 5, 0);                    // known again after an absolute X
  // Given with --set, it is read.
  gc::ResolveOptions o;
  o.set["_DEPTH"] = 7.5;
  const Resolved s("G0 X0 Y0 Z0\nG1 X=_DEPTH F100\nM30\n", o);
  EXPECT_TRUE(s.sink.stored().empty()) << s.all_codes();
  ASSERT_EQ(s.motions.size(), 2u);
  EXPECT_VEC(s.motions[1].end, 7.5, 0, 0);
  // Written by the program first, it is known from there on.
  const Resolved w("_OFS=3\nG0 X=_OFS+1 Y0 Z0\nM30\n");
  EXPECT_TRUE(w.sink.stored().empty()) << w.all_codes();
  ASSERT_EQ(w.motions.size(), 1u);
  EXPECT_VEC(w.motions[0].end, 4, 0, 0);
}

TEST(ReaderSiemens, GlobalUserVariableAsLoopCounter) {
  // A GUD the program assigns (here as FOR counter) is known from there on.
  const Resolved r("G0 X0 Y0 Z0\nFOR _I=1 TO 3\nG1 X=_I*10 F100\nENDFOR\nM30\n");
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  ASSERT_EQ(r.motions.size(), 4u);
  EXPECT_VEC(r.motions[3].end, 30, 0, 0);
}

TEST(ReaderSiemens, GlobalUserVariableDecidingControlFlowRefusesTheProgram) {
  // The branch taken depends on the controller's value: nothing after it can be followed (PP-E241).
  const Resolved r("G0 X0 Y0 Z0\nIF _MODE==1 GOTOF SKIP\nG1 X5 F100\nSKIP:\nM30\n");
  const gc::Diagnostic* d = r.find("PP-E241");
  ASSERT_NE(d, nullptr) << r.all_codes();
  EXPECT_EQ(d->where.line, 2u);
  EXPECT_EQ(d->where.column, 4u);
  EXPECT_NE(d->message.find("--set _MODE="), std::string::npos);
}

TEST(ReaderSiemens, DeclarationsOfEveryTypeAreNotMotion) {
  // Job planning, "Variable definition (DEF)": INT REAL BOOL CHAR STRING[n] AXIS FRAME; a STRING
  // used in MSG only does not refuse the program.
  const Resolved r("DEF INT CNT=2\nDEF REAL DEPTH=-1.5\nDEF BOOL FLAG=1\nDEF CHAR CH=\"A\"\n"
                   "DEF STRING[20] TXT=\"ROUGH\"\nDEF AXIS AX1\nDEF FRAME FR1\n"
                   "MSG(\"OP \"<<TXT)\nG0 X=CNT Y0 Z=DEPTH\nMSG()\nM30\n");
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  ASSERT_EQ(r.motions.size(), 1u);
  EXPECT_VEC(r.motions[0].end, 2, 0, -1.5);
}

TEST(ReaderSiemens, BlanksAroundOperatorsLexAsOneValue) {
  // Job planning, "Arithmetic operations": blanks may separate operands and operators (R1 = 2 * 4).
  // The block lexer reads the value as the resolver does, so convert reads what check reads.
  const Lexed l(siemens(), "R1 = 2 * 4 G0 X=R1 + 1 Y=7 DIV 2");
  ASSERT_TRUE(l.ok) << ::testing::PrintToString(l.codes());
  EXPECT_EQ(l.tokens(), (std::vector<std::string>{"R1 = 2 * 4"}));
  EXPECT_EQ(l.words(), (std::vector<std::string>{"G0", "X=R1 + 1", "Y=7 DIV 2"}));
  const Resolved r("R1 = 2 * 4\nG0 X=R1 + 1 Y=7 DIV 2 Z0\nM30\n");
  EXPECT_TRUE(r.sink.stored().empty()) << r.all_codes();
  ASSERT_EQ(r.motions.size(), 1u);
  EXPECT_VEC(r.motions[0].end, 9, 3, 0);
}

}  // namespace
