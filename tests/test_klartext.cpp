// Heidenhain Klartext (issue 22): the lexer's block form, the interpreter's geometry per path
// function and the resolver's Q parameters, labels and repeats, asserted against values worked out
// by hand from the TNC 640 User's Manual rules named in docs/dialect-heidenhain.md. The goldens
// tests/golden/klartext_* cover the same constructs end to end through the command line.
#include <cmath>
#include <numbers>

#include "postproc/gcode/detect.hpp"
#include "src/gcode/klartext.hpp"
#include "postproc/machine/machine.hpp"
#include "support.hpp"

namespace {
using namespace pptest;
namespace kt = postproc::gcode::klartext;

gc::Dialect klartext() { return *gc::make_dialect("heidenhain"); }

gc::Block lexed(std::string_view raw) {
  gc::Block b;
  b.raw = raw;
  b.line = 1;
  gc::DiagnosticSink quiet(0);
  EXPECT_TRUE(gc::lex_block(klartext(), b, gc::LexContext{"t.h", &quiet})) << raw;
  return b;
}

TEST(KlartextLexer, BlockNumberVerbAndSignedWords) {
  const gc::Block b = lexed("15 L  IX-5,5  Y+10 R0 FMAX M3");
  EXPECT_TRUE(b.has_n);
  EXPECT_EQ(b.n_number, 15);
  EXPECT_EQ(kt::verb_of(b), kt::Verb::l);
  ASSERT_EQ(b.words.size(), 4u);  // IX, Y, R, M
  EXPECT_EQ(b.text(b.words[0].name), "IX");
  EXPECT_DOUBLE_EQ(b.words[0].number, -5.5);  // comma decimal separator
  EXPECT_EQ(b.words[0].index, 1);              // IX: 1 + the X axis, for writers (ModalTrack::axis_of)
  EXPECT_EQ(b.text(b.words[1].value), "+10");
  EXPECT_GE(kt::find_keyword(b, "FMAX"), 0);
  EXPECT_TRUE(covers_raw(b));
}

TEST(KlartextLexer, ParameterValuesAndContinuation) {
  const gc::Block f = lexed("22 L  Z-17 FQ58");
  ASSERT_EQ(f.words.size(), 2u);
  EXPECT_EQ(f.text(f.words[1].name), "F");
  EXPECT_EQ(f.words[1].kind, gc::ValueKind::parameter);
  const gc::Block q = lexed("    Q200=+2    ;SET-UP CLEARANCE ~");
  EXPECT_EQ(kt::verb_of(q), kt::Verb::q_assign);
  EXPECT_TRUE(kt::continued(q.raw));  // the '~' after the comment continues the block
  EXPECT_FALSE(kt::continued("16 CYCL DEF 32.0 TOLERANCE"));
  EXPECT_EQ(kt::verb_of(lexed("7  CYCL DEF 7.1  X+60")), kt::Verb::cycl_def);
  EXPECT_EQ(kt::verb_of(lexed("9  * - Contour")), kt::Verb::comment);
  EXPECT_EQ(kt::verb_of(lexed("5  RND R5")), kt::Verb::rnd);
}

// hyperMILL writes the block skip before the block number ("/85 M30") and FMAX as "F MAX"; a
// keyword a path block does not read is not ignored (the block is not followed, PP-U260).
TEST(KlartextLexer, SkipBeforeTheNumberAndFMaxInTwoWords) {
  const gc::Block skip = lexed("/85 M30");
  EXPECT_TRUE(skip.block_delete);
  EXPECT_TRUE(skip.has_n);
  EXPECT_EQ(skip.n_number, 85);
  EXPECT_EQ(kt::verb_of(skip), kt::Verb::m_only);
  const Program p(klartext(), "0 BEGIN PGM F MM\n1 L X+0 Y+0 Z+0 F500\n2 L X+10 R0 F MAX\n3 L X+20 FOO\n4 L Y+5\n"
                              "5 END PGM F MM\n");
  const gc::Motion* rapid = p.at_line(3);
  ASSERT_NE(rapid, nullptr);
  EXPECT_EQ(rapid->type, gc::MotionType::rapid);
  expect_diag_at(p, "PP-U260", 4, 10);
  const gc::Motion* after = p.at_line(5);
  ASSERT_NE(after, nullptr);
  EXPECT_FALSE(after->known & gc::bit(gc::Axis::x));  // the block with FOO was not followed
}

TEST(KlartextDetect, BeginPgmAfterABlockNumber) {
  const auto g = gc::guess_dialect("; header\n0  BEGIN PGM PART MM\n1  L X+0 FMAX\n");
  ASSERT_TRUE(g.has_value());
  EXPECT_EQ(g->id, gc::DialectId::heidenhain);
  const auto iso = gc::guess_dialect("%PART G71 *\nN10 G00 X0 *\n");
  EXPECT_FALSE(iso.has_value() && iso->id == gc::DialectId::heidenhain);
}

// TNC 640 User's Manual, "Circular path C around circle centre CC": DR+ counter-clockwise; the
// arc ends on the circle about CC.
TEST(KlartextPaths, ArcAboutCentreRadiusAndTangent) {
  const Program p(klartext(),
                  "0 BEGIN PGM A MM\n1 L X+0 Y+0 Z+0 FMAX\n2 L X+10 F100\n3 CC X+10 Y+5\n4 C X+10 Y+10 DR-\n"
                  "5 CR X+20 Y+10 R+5 DR+\n6 CT X+30 Y+20\n7 END PGM A MM\n");
  EXPECT_TRUE(p.sink.stored().empty()) << p.all_codes();
  const gc::Motion* c = p.at_line(5);
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->type, gc::MotionType::arc_cw);
  EXPECT_NEAR(c->arc.sweep, -std::numbers::pi, 1e-12);  // half a turn, clockwise
  const gc::Motion* cr = p.at_line(6);
  ASSERT_NE(cr, nullptr);
  EXPECT_NEAR(cr->arc.centre.x(), 15, 1e-12);  // R+5 over a 10 mm chord: the centre on the chord
  const gc::Motion* ct = p.at_line(7);
  ASSERT_NE(ct, nullptr);
  // The semicircle ends going down (-Y) at X20; the tangential arc to (30, 20) starts that way.
  const Eigen::Vector2d s(20, 10), centre(ct->arc.centre.x(), ct->arc.centre.y());
  EXPECT_NEAR((centre - s).dot(Eigen::Vector2d(0, -1)), 0, 1e-9);
  EXPECT_NEAR((centre - s).norm(), (centre - Eigen::Vector2d(30, 20)).norm(), 1e-9);
}

// "Polar coordinates": LP about the pole CC, CP IPA with IZ is a helix.
TEST(KlartextPaths, PolarLineAndHelix) {
  const Program p(klartext(),
                  "0 BEGIN PGM P MM\n1 L X+0 Y+0 Z+0 FMAX\n2 CC X+0 Y+0\n3 LP PR+10 PA+90 F100\n"
                  "4 CP IPA+720 IZ-4 DR+\n5 END PGM P MM\n");
  const gc::Motion* lp = p.at_line(4);
  ASSERT_NE(lp, nullptr);
  EXPECT_NEAR(lp->end.x(), 0, 1e-12);
  EXPECT_NEAR(lp->end.y(), 10, 1e-12);
  const gc::Motion* cp = p.at_line(5);
  ASSERT_NE(cp, nullptr);
  EXPECT_NEAR(cp->arc.sweep, 4 * std::numbers::pi, 1e-12);
  EXPECT_EQ(cp->arc.turns, 2u);
  EXPECT_NEAR(cp->end.z(), -4, 1e-12);
  EXPECT_TRUE(cp->words_transformed);  // PA/PR words: not end points a writer may overwrite
}

// "Rounding corners RND": the arc is tangent to both lines; a 90° corner with R5 shortens each by 5.
TEST(KlartextPaths, RoundingBetweenTwoLines) {
  const Program p(klartext(),
                  "0 BEGIN PGM R MM\n1 L X+0 Y+0 Z+0 FMAX\n2 L X+50 F100\n3 RND R5\n4 L Y+40\n5 END PGM R MM\n");
  EXPECT_TRUE(p.sink.stored().empty()) << p.all_codes();
  const gc::Motion* a = p.at_line(3);
  const gc::Motion* r = p.at_line(4);
  const gc::Motion* c = p.at_line(5);
  ASSERT_TRUE(a && r && c);
  EXPECT_NEAR(a->end.x(), 45, 1e-12);
  EXPECT_NEAR(r->arc.radius, 5, 1e-12);
  EXPECT_NEAR(r->arc.sweep, std::numbers::pi / 2, 1e-12);
  EXPECT_NEAR(c->start.y(), 5, 1e-12);
  EXPECT_TRUE(a->words_transformed && c->words_transformed);
}

// "Rounding corners RND" next to an arc: the rounding arc is tangent to the line and to the arc about
// CC; worked by hand: line X50 Y-30 → Y0, then the arc about (50, 20) r 20 counter-clockwise to
// (70, 20); the path turns right, so the R5 centre lies where the line offset 5 to the right (x = 55)
// meets the circle of radius 25 about CC: (55, 20 − √600); tangent points (50, 20 − √600) and
// CC + 20/25 · (5, −√600).
TEST(KlartextPaths, RoundingBetweenALineAndAnArc) {
  const Program p(klartext(),
                  "0 BEGIN PGM R MM\n1 L X+50 Y-30 Z+0 FMAX\n2 CC X+50 Y+20\n3 L Y+0 F100\n4 RND R5\n"
                  "5 C X+70 Y+20 DR+\n6 END PGM R MM\n");
  EXPECT_TRUE(p.sink.stored().empty()) << p.all_codes();
  const gc::Motion* a = p.at_line(4);
  const gc::Motion* r = p.at_line(5);
  const gc::Motion* c = p.at_line(6);
  ASSERT_TRUE(a && r && c) << p.all_codes();
  const double h = std::sqrt(600.0);
  EXPECT_NEAR(a->end.x(), 50, 1e-9);
  EXPECT_NEAR(a->end.y(), 20 - h, 1e-9);
  EXPECT_EQ(r->type, gc::MotionType::arc_cw);
  EXPECT_NEAR(r->arc.centre.x(), 55, 1e-9);
  EXPECT_NEAR(r->arc.centre.y(), 20 - h, 1e-9);
  EXPECT_NEAR(r->end.x(), 50 + 20.0 / 25 * 5, 1e-9);
  EXPECT_NEAR(r->end.y(), 20 - 20.0 / 25 * h, 1e-9);
  EXPECT_NEAR(c->start.x(), r->end.x(), 1e-12);
  EXPECT_NEAR(c->start.y(), r->end.y(), 1e-12);
  EXPECT_NEAR(c->end.x(), 70, 1e-12);  // the arc still ends where programmed, about the same centre
  EXPECT_NEAR(c->arc.centre.y(), 20, 1e-12);
  const double start_angle = std::atan2(c->start.y() - 20, c->start.x() - 50);
  EXPECT_NEAR(c->arc.sweep, 0 - start_angle, 1e-9);  // to the end at angle 0, counter-clockwise
  // The same with the CC between the corner and the arc, as TNC programs usually give it.
  const Program cc_between(klartext(), "0 BEGIN PGM R MM\n1 L X+50 Y-30 Z+0 FMAX\n2 L Y+0 F100\n3 RND R5\n"
                                       "4 CC X+50 Y+20\n5 C X+70 Y+20 DR+\n6 END PGM R MM\n");
  EXPECT_TRUE(cc_between.sink.stored().empty()) << cc_between.all_codes();
  const gc::Motion* r2 = cc_between.at_line(4);
  ASSERT_NE(r2, nullptr) << cc_between.all_codes();
  EXPECT_NEAR(r2->arc.centre.x(), 55, 1e-9);
  EXPECT_NEAR(r2->arc.centre.y(), 20 - h, 1e-9);
  // A chamfer next to an arc stays refused (TNC: CHF joins two straight lines).
  const Program chf(klartext(), "0 BEGIN PGM R MM\n1 L X+50 Y-30 Z+0 FMAX\n2 CC X+50 Y+20\n3 L Y+0 F100\n"
                                "4 CHF 2\n5 C X+70 Y+20 DR+\n6 END PGM R MM\n");
  EXPECT_NE(chf.find("PP-U260"), nullptr) << chf.all_codes();
}

// "Cycle 7 DATUM SHIFT": the shift moves the current point's coordinates; IX adds to the shift.
TEST(KlartextFrames, DatumShiftAbsoluteAndIncremental) {
  const Program p(klartext(),
                  "0 BEGIN PGM D MM\n1 L X+0 Y+0 Z+0 FMAX\n2 CYCL DEF 7.0 DATUM SHIFT\n3 CYCL DEF 7.1 X+10\n"
                  "4 CYCL DEF 7.2 IY+5\n5 L IX+1 FMAX\n6 END PGM D MM\n");
  const gc::Motion* m = p.at_line(6);
  ASSERT_NE(m, nullptr);
  EXPECT_NEAR(m->end.x(), -9, 1e-12);  // 0 - 10 + 1 in the shifted frame
  EXPECT_NEAR(m->end.y(), -5, 1e-12);
  EXPECT_NEAR(m->local_offset.x(), 10, 1e-12);
  EXPECT_NEAR(m->local_offset.y(), 5, 1e-12);
}

// TNC 640 cycles manual, cycle 247 DATUM SETTING: row Q339 of the preset table becomes the datum at
// the definition. The moves after it are in that frame (work offset PRESET<Q339>, like an ISO G55),
// their coordinates unknown until programmed; without a literal Q339 the frame is not known (the
// motions say so: compensate refuses them, PP-E602). Before it: the datum active at the start (G54).
// A comment wrapped with '~' continues on an indented line (Fusion's Heidenhain post writes so).
TEST(KlartextFrames, DatumSettingSelectsThePreset) {
  const Program p(klartext(),
                  "0 BEGIN PGM P MM\n1 ;  description: a long comment on the~\n Head\n2 L X+0 Y+0 Z+10 FMAX\n"
                  "3 CYCL DEF 247 DATUM SETTING ~\n    Q339=+2    ;DATUM NUMBER\n4 L X+5 FMAX\n5 L Y+5 Z+1 FMAX\n"
                  "6 CYCL DEF 247 DATUM SETTING ~\n    Q339=+Q9 ;DATUM NUMBER\n7 L X+1 Y+1 Z+1 FMAX\n8 END PGM P MM\n");
  EXPECT_EQ(p.find("PP-E101"), nullptr) << p.all_codes();
  const gc::Motion* before = p.at_line(4);
  const gc::Motion* x_only = p.at_line(7);
  const gc::Motion* stated = p.at_line(8);
  const gc::Motion* unknown = p.at_line(11);
  ASSERT_TRUE(before && x_only && stated && unknown) << p.all_codes();
  EXPECT_EQ(postproc::machine::work_offset_name(before->work_offset), "G54");
  EXPECT_FALSE(before->work_offset_rewritten);
  EXPECT_EQ(postproc::machine::work_offset_name(stated->work_offset), "PRESET2");
  EXPECT_FALSE(stated->work_offset_rewritten);
  EXPECT_FALSE(x_only->known & gc::bit(gc::Axis::y));  // Y in the new frame is not known yet
  EXPECT_TRUE((stated->known & 7u) == 7u);
  EXPECT_TRUE(unknown->work_offset_rewritten);  // Q339 not a number: the preset is not known
  // An indented line that continues no block is refused at the line, as any unknown block.
  const Program bad(klartext(), "0 BEGIN PGM B MM\n1 L X+0 Y+0 Z+0 FMAX\n   Head\n2 END PGM B MM\n");
  expect_diag_at(bad, "PP-E101", 3, 4);
}

// "Program section repeats": CALL LBL 1 REP 2 runs the section two more times.
TEST(KlartextResolve, SectionRepeatAndFormula) {
  const ResolvedProgram p(klartext(),
                          "0 BEGIN PGM Q MM\n1 Q1 = 2 * 3 + SQ 2\n2 L X+0 Y+0 Z+0 FMAX\n3 LBL 1\n4 L IX+Q1 F100\n"
                          "5 CALL LBL 1 REP 2\n6 END PGM Q MM\n");
  EXPECT_TRUE(p.sink.stored().empty()) << p.all_codes();
  ASSERT_EQ(p.motions.size(), 4u);
  EXPECT_NEAR(p.motions.back().end.x(), 30, 1e-12);  // three times IX+10
}

// A Q parameter the program reads before it sets it holds a run-time value (Q100–Q199: the control's;
// Q120–Q122 after PLANE … STAY: the rotary angles from the kinematics). A coordinate word reading it
// leaves that block not followed and its axes unknown (PP-U213 at the word; compensate refuses a
// correction that depends on them, PP-E601); a formula or condition reading it is refused (PP-E701).
TEST(KlartextResolve, ParameterReadBeforeItIsSetIsRefusedAtTheRead) {
  const ResolvedProgram p(klartext(), "0 BEGIN PGM Q MM\n1 L X+0 Y+0 FMAX\n2 L X+Q108 FMAX\n3 L Y+5 FMAX\n4 END PGM Q MM\n");
  expect_diag_at(p, "PP-U213", 3, 5);
  EXPECT_EQ(p.find("PP-E701"), nullptr) << p.all_codes();
  ASSERT_EQ(p.motions.size(), 2u) << p.all_codes();
  EXPECT_FALSE(p.motions[1].known & gc::bit(gc::Axis::x));  // X after the block reading Q108 is not known
  EXPECT_TRUE(p.motions[1].known & gc::bit(gc::Axis::y));
  const ResolvedProgram formula(klartext(), "0 BEGIN PGM Q MM\n1 Q1 = Q108 * 2\n2 L X+Q1 FMAX\n3 END PGM Q MM\n");
  expect_diag_at(formula, "PP-E701", 2, 8);
  gc::ResolveOptions set;
  set.set["Q108"] = 4;
  const ResolvedProgram given(klartext(), "0 BEGIN PGM Q MM\n1 L X+Q108 FMAX\n2 END PGM Q MM\n", set);
  ASSERT_EQ(given.motions.size(), 1u);
  EXPECT_NEAR(given.motions[0].end.x(), 4, 1e-12);
}

}  // namespace
