// Lexer: every span names exactly the bytes it should, the raw text is rebuilt byte for byte, and
// each dialect's comments, statements and addresses are told apart.
#include <gtest/gtest.h>

#include "src/gcode/number_text.hpp"
#include "support.hpp"

namespace {

using namespace pptest;
using gc::TokenKind;
using gc::ValueKind;
using Strings = std::vector<std::string>;

TEST(NumberText, ScansAndParsesEveryStyle) {
  struct Case {
    const char* text;
    double value;
  } cases[] = {{"1.", 1.0}, {".5", 0.5}, {"-0.250", -0.25}, {"+3", 3.0}, {"-.5", -0.5}, {"0101", 101.0},
               {"2.1317", 2.1317}, {"350.", 350.0}};
  for (const auto& c : cases) {
    const std::string_view t = c.text;
    EXPECT_EQ(gc::scan_number(t, 0, false), t.size()) << t;
    double v = 0;
    ASSERT_TRUE(gc::parse_number(t, v)) << t;
    EXPECT_DOUBLE_EQ(v, c.value) << t;
  }
  EXPECT_EQ(gc::scan_number(".", 0, false), 0u);
  EXPECT_EQ(gc::scan_number("-", 0, false), 0u);
  EXPECT_EQ(gc::scan_number("1.2.3", 0, false), 3u);
  EXPECT_EQ(gc::scan_number("- 1.5", 0, true), 5u);
  EXPECT_EQ(gc::scan_number("- 1.5", 0, false), 0u);
  double v = 0;
  ASSERT_TRUE(gc::parse_number("- 1.5", v));
  EXPECT_DOUBLE_EQ(v, -1.5);
}

TEST(LexerFanuc, CompactBlockSpans) {
  const Lexed L(dialect("fanuc"), "N7G0G98X2.1317Z5.6996T0101");
  ASSERT_TRUE(L.ok) << ::testing::PrintToString(L.codes());
  ASSERT_TRUE(L.block.has_n);
  EXPECT_EQ(L.of(L.block.n_span), "N7");
  EXPECT_DOUBLE_EQ(L.block.n_number, 7);
  EXPECT_EQ(L.words(), (Strings{"G0", "G98", "X2.1317", "Z5.6996", "T0101"}));
  const auto& x = L.block.words[2];
  EXPECT_EQ(x.letter, 'X');
  EXPECT_EQ(L.of(x.name), "X");
  EXPECT_EQ(L.of(x.value), "2.1317");
  EXPECT_EQ(x.kind, ValueKind::number);
  EXPECT_DOUBLE_EQ(x.number, 2.1317);
  EXPECT_DOUBLE_EQ(L.block.words[4].number, 101);
  EXPECT_TRUE(L.block.tokens.empty());
  EXPECT_TRUE(covers_raw(L.block));
}

TEST(LexerFanuc, NumberStylesAndComments) {
  // Fanuc-family comments nest: the comment ends at the matching ')'.
  const Lexed L(dialect("fanuc"), "G1 X1. Y.5 Z-0.250 A+3 (MOVE (NESTED) OK) F100  ");
  ASSERT_TRUE(L.ok) << ::testing::PrintToString(L.codes());
  EXPECT_EQ(L.words(), (Strings{"G1", "X1.", "Y.5", "Z-0.250", "A+3", "F100"}));
  EXPECT_EQ(L.tokens(), (Strings{"(MOVE (NESTED) OK)"}));
  EXPECT_EQ(L.block.tokens[0].kind, TokenKind::paren_comment);
  EXPECT_EQ(L.of(L.block.tokens[0].name), "MOVE (NESTED) OK");
  EXPECT_DOUBLE_EQ(L.block.words[1].number, 1.0);
  EXPECT_DOUBLE_EQ(L.block.words[2].number, 0.5);
  EXPECT_DOUBLE_EQ(L.block.words[3].number, -0.25);
  EXPECT_DOUBLE_EQ(L.block.words[4].number, 3.0);
  EXPECT_TRUE(covers_raw(L.block));
}

TEST(LexerFanuc, MacroAssignmentExpressionsAndControlFlow) {
  const Lexed a(dialect("fanuc"), "#501=350.(C)");
  ASSERT_TRUE(a.ok);
  EXPECT_EQ(a.tokens(), (Strings{"#501=350.", "(C)"}));
  EXPECT_EQ(a.block.tokens[0].kind, TokenKind::assignment);
  EXPECT_EQ(a.of(a.block.tokens[0].name), "#501");
  EXPECT_EQ(a.of(a.block.tokens[1].name), "C");

  const Lexed x(dialect("fanuc"), "G0X[#501+2.]Z-[#505+50.] Y#3");
  ASSERT_TRUE(x.ok);
  EXPECT_EQ(x.words(), (Strings{"G0", "X[#501+2.]", "Z-[#505+50.]", "Y#3"}));
  EXPECT_EQ(x.block.words[1].kind, ValueKind::expression);
  EXPECT_EQ(x.of(x.block.words[1].value), "[#501+2.]");
  EXPECT_EQ(x.of(x.block.words[2].value), "-[#505+50.]");
  EXPECT_EQ(x.block.words[3].kind, ValueKind::parameter);
  EXPECT_TRUE(covers_raw(x.block));

  const Lexed i(dialect("fanuc"), "N20 IF [#1 GT 2] GOTO 5 (JUMP)");
  ASSERT_TRUE(i.ok);
  EXPECT_EQ(i.of(i.block.n_span), "N20");
  EXPECT_EQ(i.tokens(), (Strings{"IF [#1 GT 2] GOTO 5", "(JUMP)"}));
  EXPECT_EQ(i.block.tokens[0].kind, TokenKind::control_flow);
  EXPECT_EQ(i.of(i.block.tokens[0].name), "IF");
  EXPECT_TRUE(i.block.words.empty());
}

TEST(LexerFanuc, ProgramNumbersPercentAndBlockDelete) {
  const Lexed colon(dialect("fanuc"), ":0100");
  ASSERT_TRUE(colon.ok);
  ASSERT_EQ(colon.block.tokens.size(), 1u);
  EXPECT_EQ(colon.block.tokens[0].kind, TokenKind::program_number);
  EXPECT_EQ(colon.tokens(), (Strings{":0100"}));
  EXPECT_EQ(colon.of(colon.block.tokens[0].name), "0100");

  const Lexed pct(dialect("fanuc"), "%O1200(TOKARKA)");
  ASSERT_TRUE(pct.ok);
  EXPECT_EQ(pct.tokens(), (Strings{"%", "O1200", "(TOKARKA)"}));
  EXPECT_EQ(pct.block.tokens[0].kind, TokenKind::percent);
  EXPECT_EQ(pct.block.tokens[1].kind, TokenKind::program_number);
  EXPECT_EQ(pct.of(pct.block.tokens[1].name), "1200");

  const Lexed bare(dialect("fanuc"), "%");
  ASSERT_TRUE(bare.ok);
  EXPECT_EQ(bare.tokens(), (Strings{"%"}));

  const Lexed del(dialect("fanuc"), "/N20 G0 Z5");
  ASSERT_TRUE(del.ok);
  EXPECT_TRUE(del.block.block_delete);
  EXPECT_EQ(del.block.block_delete_level, 0);
  EXPECT_EQ(del.of(del.block.block_delete_span), "/");
  EXPECT_EQ(del.of(del.block.n_span), "N20");
  EXPECT_EQ(del.words(), (Strings{"G0", "Z5"}));

  const Lexed del2(dialect("fanuc"), "/2 G0 Z5");
  ASSERT_TRUE(del2.ok);
  EXPECT_TRUE(del2.block.block_delete);
  EXPECT_EQ(del2.block.block_delete_level, 2);
  EXPECT_EQ(del2.of(del2.block.block_delete_span), "/2");
  EXPECT_TRUE(covers_raw(del2.block));
}

TEST(LexerFanuc, ErrorsAreLocated) {
  const Lexed open(dialect("fanuc"), "G0 X1 (unclosed", 7);
  EXPECT_FALSE(open.ok);
  ASSERT_EQ(open.sink.stored().size(), 1u);
  const auto& d = open.sink.stored()[0];
  EXPECT_EQ(d.code, "PP-E102");
  EXPECT_EQ(d.where.line, 7u);
  EXPECT_EQ(d.where.column, 7u);
  EXPECT_EQ(d.file, "t.nc");
  EXPECT_EQ(d.source_line, "G0 X1 (unclosed");
  // The unclosed comment still becomes a token to the end of the line (lossless).
  EXPECT_EQ(open.tokens(), (Strings{"(unclosed"}));

  const Lexed semi(dialect("fanuc"), "G1 X2 ; no");
  EXPECT_FALSE(semi.ok);
  ASSERT_FALSE(semi.sink.stored().empty());
  EXPECT_EQ(semi.sink.stored()[0].code, "PP-E101");
  EXPECT_EQ(semi.sink.stored()[0].where.column, 7u);

  const Lexed placeholder(dialect("fanuc"), "O ENTER OP");
  EXPECT_FALSE(placeholder.ok);
  ASSERT_FALSE(placeholder.sink.stored().empty());
  EXPECT_EQ(placeholder.sink.stored()[0].code, "PP-E103");
  EXPECT_EQ(placeholder.sink.stored()[0].where.column, 1u);
  EXPECT_EQ(placeholder.sink.stored()[1].code, "PP-E106");
  EXPECT_EQ(placeholder.sink.stored()[1].where.column, 3u);
  EXPECT_EQ(placeholder.sink.stored()[1].length, 5u);  // "ENTER"

  const Lexed star(dialect("fanuc"), "G1 X1 *");
  EXPECT_FALSE(star.ok);
  EXPECT_EQ(star.codes(), (Strings{"PP-E101"}));
}

TEST(LexerSiemens, AddressesWithEqualsAndFunctions) {
  const Lexed L(dialect("siemens"), "N10 G2 X=AC(5) Y=IC(-2) CR=5 A3=0.5 F100 ; arc (with parens)");
  ASSERT_TRUE(L.ok) << ::testing::PrintToString(L.codes());
  EXPECT_EQ(L.of(L.block.n_span), "N10");
  EXPECT_EQ(L.words(), (Strings{"G2", "X=AC(5)", "Y=IC(-2)", "CR=5", "A3=0.5", "F100"}));
  const auto& w = L.block.words;
  EXPECT_EQ(w[1].kind, ValueKind::absolute_fn);
  EXPECT_TRUE(w[1].has_equals);
  EXPECT_EQ(L.of(w[1].name), "X");
  EXPECT_EQ(L.of(w[1].value), "AC(5)");
  EXPECT_EQ(w[2].kind, ValueKind::incremental_fn);
  EXPECT_EQ(L.of(w[3].name), "CR");
  EXPECT_EQ(w[3].name_len, 2);
  EXPECT_EQ(w[3].kind, ValueKind::number);
  EXPECT_DOUBLE_EQ(w[3].number, 5);
  EXPECT_EQ(L.of(w[4].name), "A3");
  EXPECT_EQ(w[4].index, 3);
  EXPECT_DOUBLE_EQ(w[4].number, 0.5);
  EXPECT_EQ(L.tokens(), (Strings{"; arc (with parens)"}));
  EXPECT_EQ(L.block.tokens[0].kind, TokenKind::line_comment);
  EXPECT_TRUE(covers_raw(L.block));
}

TEST(LexerSiemens, KeywordsCallsAssignmentsDeclarationsLabels) {
  const auto d = dialect("siemens");
  const Lexed tra(d, "TRAORI");
  ASSERT_TRUE(tra.ok);
  ASSERT_EQ(tra.block.tokens.size(), 1u);
  EXPECT_EQ(tra.block.tokens[0].kind, TokenKind::keyword);
  EXPECT_EQ(tra.of(tra.block.tokens[0].name), "TRAORI");

  const Lexed cyc(d, "CYCLE800(1,\"TC1\",0,57,0,0,0,30,0,0,0,0,0,1) ; swivel");
  ASSERT_TRUE(cyc.ok);
  EXPECT_EQ(cyc.tokens(), (Strings{"CYCLE800(1,\"TC1\",0,57,0,0,0,30,0,0,0,0,0,1)", "; swivel"}));
  EXPECT_EQ(cyc.block.tokens[0].kind, TokenKind::call);
  EXPECT_EQ(cyc.of(cyc.block.tokens[0].name), "CYCLE800");

  const Lexed msg(d, "MSG(\"a;b)\")");
  ASSERT_TRUE(msg.ok);
  EXPECT_EQ(msg.tokens(), (Strings{"MSG(\"a;b)\")"}));

  const Lexed r(d, "R1=5 DEF REAL A=1");
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.tokens(), (Strings{"R1=5", "DEF REAL A=1"}));
  EXPECT_EQ(r.block.tokens[0].kind, TokenKind::assignment);
  EXPECT_EQ(r.of(r.block.tokens[0].name), "R1");
  EXPECT_EQ(r.block.tokens[1].kind, TokenKind::declaration);
  EXPECT_EQ(r.of(r.block.tokens[1].name), "DEF");

  const Lexed def(d, "DEF REAL DEPTH=-2.5 ; variable");
  ASSERT_TRUE(def.ok);
  EXPECT_EQ(def.tokens(), (Strings{"DEF REAL DEPTH=-2.5", "; variable"}));

  const Lexed lbl(d, "MARK1: G0 X1");
  ASSERT_TRUE(lbl.ok);
  EXPECT_EQ(lbl.tokens(), (Strings{"MARK1:"}));
  EXPECT_EQ(lbl.block.tokens[0].kind, TokenKind::label);
  EXPECT_EQ(lbl.of(lbl.block.tokens[0].name), "MARK1");
  EXPECT_EQ(lbl.words(), (Strings{"G0", "X1"}));

  const Lexed go(d, "GOTOF MARK1");
  ASSERT_TRUE(go.ok);
  EXPECT_EQ(go.tokens(), (Strings{"GOTOF MARK1"}));
  EXPECT_EQ(go.block.tokens[0].kind, TokenKind::control_flow);

  const Lexed var(d, "Z=DEPTH+1 X=R1");
  ASSERT_TRUE(var.ok);
  EXPECT_EQ(var.words(), (Strings{"Z=DEPTH+1", "X=R1"}));
  EXPECT_EQ(var.block.words[0].kind, ValueKind::expression);

  const Lexed pct(d, "%_N_PART1_MPF");
  ASSERT_TRUE(pct.ok);
  EXPECT_EQ(pct.tokens(), (Strings{"%_N_PART1_MPF"}));
  EXPECT_EQ(pct.block.tokens[0].kind, TokenKind::percent);

  const Lexed compact(d, "g1x10.5y-2 f200");
  ASSERT_TRUE(compact.ok);
  EXPECT_EQ(compact.words(), (Strings{"g1", "x10.5", "y-2", "f200"}));
  EXPECT_EQ(compact.block.words[1].letter, 'X');
  for (const Lexed* l : {&tra, &cyc, &msg, &r, &def, &lbl, &go, &var, &pct, &compact})
    EXPECT_TRUE(covers_raw(l->block)) << l->text;
}

TEST(LexerSiemens, ParenthesisIsNotAComment) {
  const Lexed L(dialect("siemens"), "G1 X1 (no)");
  EXPECT_FALSE(L.ok);
  ASSERT_FALSE(L.sink.stored().empty());
  EXPECT_EQ(L.sink.stored()[0].code, "PP-E101");
  EXPECT_EQ(L.sink.stored()[0].where.column, 7u);
}

TEST(LexerLinuxcnc, NamedParametersOWordsAndCase) {
  const auto d = dialect("linuxcnc");
  const Lexed a(d, "#<depth>=[#1+2] (set depth)");
  ASSERT_TRUE(a.ok);
  EXPECT_EQ(a.tokens(), (Strings{"#<depth>=[#1+2]", "(set depth)"}));
  EXPECT_EQ(a.block.tokens[0].kind, TokenKind::assignment);
  EXPECT_EQ(a.of(a.block.tokens[0].name), "#<depth>");

  const Lexed sub(d, "o100 sub");
  ASSERT_TRUE(sub.ok);
  EXPECT_EQ(sub.tokens(), (Strings{"o100 sub"}));
  EXPECT_EQ(sub.block.tokens[0].kind, TokenKind::control_flow);
  EXPECT_EQ(sub.of(sub.block.tokens[0].name), "o100");

  const Lexed call(d, "o<square> call [1] [2] ; go");
  ASSERT_TRUE(call.ok);
  EXPECT_EQ(call.tokens(), (Strings{"o<square> call [1] [2]", "; go"}));
  EXPECT_EQ(call.of(call.block.tokens[0].name), "o<square>");

  const Lexed lower(d, "g1 x1.5 y-2 f100");
  ASSERT_TRUE(lower.ok);
  EXPECT_EQ(lower.words(), (Strings{"g1", "x1.5", "y-2", "f100"}));
  EXPECT_EQ(lower.block.words[0].letter, 'G');
  EXPECT_EQ(lower.block.words[1].letter, 'X');

  const Lexed fn(d, "G1 X sin[30] Y#<r>");
  ASSERT_TRUE(fn.ok);
  EXPECT_EQ(fn.words(), (Strings{"G1", "X sin[30]", "Y#<r>"}));
  EXPECT_EQ(fn.block.words[1].kind, ValueKind::expression);
  EXPECT_EQ(fn.block.words[2].kind, ValueKind::parameter);
  for (const Lexed* l : {&a, &sub, &call, &lower, &fn}) EXPECT_TRUE(covers_raw(l->block)) << l->text;
}

TEST(LexerLinuxcnc, SpacesInsideWords) {
  const Lexed L(dialect("linuxcnc"), "G 1 X 1.5 Y - 2 Z-3");
  ASSERT_TRUE(L.ok) << ::testing::PrintToString(L.codes());
  EXPECT_EQ(L.words(), (Strings{"G 1", "X 1.5", "Y - 2", "Z-3"}));
  EXPECT_DOUBLE_EQ(L.block.words[0].number, 1);
  EXPECT_DOUBLE_EQ(L.block.words[1].number, 1.5);
  EXPECT_EQ(L.of(L.block.words[1].value), "1.5");
  EXPECT_DOUBLE_EQ(L.block.words[2].number, -2);
  EXPECT_TRUE(covers_raw(L.block));
  // Fanuc disregards spaces anywhere in a number (B-64484EN "Tape code"): "G 1 X 1 0" is G1 X10
  // (more in test_reader_fanuc.cpp); a letter without any digits is still an error.
  const Lexed F(dialect("fanuc"), "G 1 X 1 0");
  ASSERT_TRUE(F.ok);
  EXPECT_EQ(F.words(), (Strings{"G 1", "X 1 0"}));
  EXPECT_DOUBLE_EQ(F.block.words[1].number, 10);
  EXPECT_TRUE(covers_raw(F.block));
  const Lexed bad(dialect("fanuc"), "G X1");
  EXPECT_FALSE(bad.ok);
  EXPECT_EQ(bad.sink.stored().at(0).code, "PP-E106");
}

TEST(LexerLinuxcnc, CommentsDoNotNest) {
  // LinuxCNC ends a comment at the first ')': the rest " OK)" is not a comment.
  const Lexed L(dialect("linuxcnc"), "G1 (MOVE (A) OK)");
  EXPECT_FALSE(L.ok);
  EXPECT_EQ(L.tokens().at(0), "(MOVE (A)");
  ASSERT_FALSE(L.sink.stored().empty());
  EXPECT_EQ(L.sink.stored()[0].where.column, 14u);
}

TEST(LexerLinuxcnc, BothCommentStyles) {
  const Lexed L(dialect("linuxcnc"), "G0 X1 (first) ; rest (of) line");
  ASSERT_TRUE(L.ok);
  EXPECT_EQ(L.tokens(), (Strings{"(first)", "; rest (of) line"}));
  EXPECT_EQ(L.block.tokens[1].kind, TokenKind::line_comment);
}

TEST(LexerHeidenhain, StarEndsBlock) {
  const Lexed L(dialect("heidenhain-iso"), "N10 G01 X+10 Y-5 F200 * ; tail");
  ASSERT_TRUE(L.ok) << ::testing::PrintToString(L.codes());
  EXPECT_EQ(L.of(L.block.n_span), "N10");
  EXPECT_EQ(L.words(), (Strings{"G01", "X+10", "Y-5", "F200"}));
  EXPECT_EQ(L.tokens(), (Strings{"*", "; tail"}));
  EXPECT_EQ(L.block.tokens[0].kind, TokenKind::block_end);
  EXPECT_TRUE(covers_raw(L.block));
  const Lexed hash(dialect("heidenhain-iso"), "#1=2");
  EXPECT_FALSE(hash.ok);  // no # parameters in Heidenhain ISO
}

TEST(Lexer, EmptyAndBlankBlocks) {
  for (const char* name : {"fanuc", "siemens", "linuxcnc", "heidenhain-iso"}) {
    const Lexed e(dialect(name), "");
    EXPECT_TRUE(e.ok);
    EXPECT_TRUE(e.block.empty());
    const Lexed b(dialect(name), " \t ");
    EXPECT_TRUE(b.ok);
    EXPECT_TRUE(b.block.empty());
  }
}

TEST(Lexer, ReusedBlockKeepsNoStaleState) {
  const auto d = dialect("fanuc");
  gc::Block b;
  gc::DiagnosticSink sink;
  const gc::LexContext ctx{"t.nc", &sink};
  const std::string first = "/2 N10 G1 X1 (c)";
  b.raw = first;
  ASSERT_TRUE(gc::lex_block(d, b, ctx));
  const std::string second = "G0 Y2";
  b.raw = second;
  ASSERT_TRUE(gc::lex_block(d, b, ctx));
  EXPECT_FALSE(b.block_delete);
  EXPECT_FALSE(b.has_n);
  EXPECT_EQ(b.words.size(), 2u);
  EXPECT_TRUE(b.tokens.empty());
}

TEST(Diagnostics, FormatShowsCaretUnderTheSpan) {
  gc::Diagnostic d;
  d.severity = gc::Severity::error;
  d.code = "PP-E201";
  d.file = "p.nc";
  d.where = {3, 4};
  d.message = "bad";
  d.source_line = "G1\tG7 X1";
  d.length = 2;
  EXPECT_EQ(gc::format(d), "p.nc:3:4: error: PP-E201: bad\n  G1\tG7 X1\n    \t^~\n");
  EXPECT_EQ(gc::format(d, false), "p.nc:3:4: error: PP-E201: bad\n");
  gc::DiagnosticSink sink(1);
  sink.report(d);
  sink.report(d);
  EXPECT_EQ(sink.stored().size(), 1u);
  EXPECT_EQ(sink.dropped(), 1u);
  EXPECT_EQ(sink.count(gc::Severity::error), 2u);
  EXPECT_EQ(sink.per_code().at("PP-E201"), 2u);
}

}  // namespace

// Statements the Sinumerik writes with brackets, strings or '$' are one token each, so a line that
// holds them lexes (convert reads the program as written) and the pre-scan sees them.
TEST(LexerSiemens, IndexedAssignmentsCallByNameAndSystemVariableWrites) {
  const auto d = dialect("siemens");
  const Lexed arr(d, "AR[1, R2]=5*R3 G1 X=AR[1] ; set");
  ASSERT_TRUE(arr.ok);
  EXPECT_EQ(arr.tokens(), (Strings{"AR[1, R2]=5*R3", "; set"}));
  EXPECT_EQ(arr.block.tokens[0].kind, TokenKind::assignment);
  EXPECT_EQ(arr.of(arr.block.tokens[0].name), "AR");
  EXPECT_EQ(arr.words(), (Strings{"G1", "X=AR[1]"}));

  const Lexed r(d, "R[R1+1] = 2");
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.tokens(), (Strings{"R[R1+1] = 2"}));
  EXPECT_EQ(r.block.tokens[0].kind, TokenKind::assignment);

  const Lexed call(d, "N20 CALL \"PART2\" ; sub");
  ASSERT_TRUE(call.ok);
  EXPECT_EQ(call.tokens(), (Strings{"CALL \"PART2\"", "; sub"}));
  EXPECT_EQ(call.block.tokens[0].kind, TokenKind::call);
  EXPECT_EQ(call.of(call.block.tokens[0].name), "CALL");

  const Lexed sys(d, "$P_UIFR[1,X,TR]=10");
  ASSERT_TRUE(sys.ok);
  EXPECT_EQ(sys.block.tokens[0].kind, TokenKind::assignment);
  EXPECT_EQ(sys.of(sys.block.tokens[0].name), "$P_UIFR");

  // Still refused: a read of a system variable where a statement should be, an open string.
  EXPECT_FALSE(Lexed(d, "$AA_IM[X]").ok);
  EXPECT_FALSE(Lexed(d, "CALL \"PART2").ok);
  EXPECT_FALSE(Lexed(d, "AR[1]=").ok);
}
