// BlockEditor: edits of one block keep everything else byte for byte.
#include <gtest/gtest.h>

#include "postproc/error.hpp"
#include "postproc/gcode/block_writer.hpp"
#include "support.hpp"

namespace {

using namespace pptest;

/// Index of the first word with letter `L` (the test's blocks have one).
std::size_t word(const gc::Block& b, char L) {
  for (std::size_t i = 0; i < b.words.size(); ++i)
    if (b.words[i].letter == L) return i;
  ADD_FAILURE() << "no word " << L;
  return 0;
}

std::string render(gc::BlockEditor& ed) {
  std::string out;
  ed.render(out);
  return out;
}

TEST(BlockWriter, NoEditsRendersTheRawText) {
  const gc::Dialect d = dialect("fanuc");
  for (const char* line : {"N10 G1 X-49.650 Y.5 F100. (cut)", "  G0X1Y2  ", "", "/2 M30", "%"}) {
    Lexed l(d, line);
    gc::BlockEditor ed(l.block);
    EXPECT_TRUE(ed.empty());
    EXPECT_EQ(render(ed), line);
  }
}

TEST(BlockWriter, ReplacesValuesKeepingLetterPlaceAndStyle) {
  const gc::Dialect d = dialect("linuxcnc");
  Lexed l(d, "N10 G1 X-49.650  Y.5\tF100. (keep)");
  gc::BlockEditor ed(l.block);
  EXPECT_FALSE(ed.replace_word_value(word(l.block, 'X'), 12.3, 0));
  EXPECT_FALSE(ed.replace_word_value(word(l.block, 'Y'), -0.25, 2));  // ".5" shows 1 decimal; ask for 2
  EXPECT_FALSE(ed.replace_word_value(word(l.block, 'F'), 80, 0));
  EXPECT_EQ(render(ed), "N10 G1 X12.300  Y-.25\tF80. (keep)");
}

TEST(BlockWriter, WritesAPointOnWholeNumbersWhereTheDialectNeedsOne) {
  const gc::Dialect d = dialect("fanuc");
  Lexed l(d, "G1 X10 Y2.5");
  gc::BlockEditor fanuc(l.block, d.decimal_point_required);
  EXPECT_FALSE(fanuc.replace_word_value(word(l.block, 'X'), 12, 0));
  EXPECT_FALSE(fanuc.replace_word_value(word(l.block, 'Y'), 3, 0));
  EXPECT_EQ(render(fanuc), "G1 X12. Y3.");
  gc::BlockEditor plain(l.block, false);
  EXPECT_FALSE(plain.replace_word_value(word(l.block, 'X'), 12, 0));
  EXPECT_EQ(render(plain), "G1 X12 Y2.5");
}

TEST(BlockWriter, SiemensEqualsFormKeepsItsAddress) {
  const gc::Dialect d = dialect("siemens");
  Lexed l(d, "N5 G1 X=10.50 CR=5 ; c");
  gc::BlockEditor ed(l.block);
  EXPECT_FALSE(ed.replace_word_value(word(l.block, 'X'), 11.25, 0));
  EXPECT_EQ(render(ed), "N5 G1 X=11.25 CR=5 ; c");
}

TEST(BlockWriter, RefusesExpressionsAndMissingWords) {
  const gc::Dialect d = dialect("fanuc");
  Lexed l(d, "G1 X[#1+2] Y#2 Z3.");
  gc::BlockEditor ed(l.block);
  EXPECT_EQ(ed.replace_word_value(word(l.block, 'X'), 1, 0), gc::EditRefusal::not_a_literal);
  EXPECT_EQ(ed.replace_word_value(word(l.block, 'Y'), 1, 0), gc::EditRefusal::not_a_literal);
  EXPECT_EQ(ed.replace_word_value(99, 1, 0), gc::EditRefusal::no_such_word);
  EXPECT_TRUE(ed.empty());
  EXPECT_FALSE(gc::to_string(gc::EditRefusal::not_a_literal).empty());
}

TEST(BlockWriter, RemovesWordsWithTheirSeparator) {
  const gc::Dialect d = dialect("fanuc");
  Lexed l(d, "G2 X1. Y2. I3. J4. F100.");
  gc::BlockEditor ed(l.block);
  ed.remove_word(word(l.block, 'I'));
  ed.remove_word(word(l.block, 'J'));
  EXPECT_EQ(render(ed), "G2 X1. Y2. F100.");
  Lexed first(d, "I3. J4. X1.");
  gc::BlockEditor ed2(first.block);
  ed2.remove_word(0);
  ed2.remove_word(1);
  EXPECT_EQ(render(ed2), " X1.");  // the first item goes alone; no overlapping edits
}

TEST(BlockWriter, InsertsKeepingCallOrder) {
  const gc::Dialect d = dialect("fanuc");
  Lexed l(d, "N1 G1 X1. Y2. F100.");
  gc::BlockEditor ed(l.block);
  const gc::Span y = l.block.words[word(l.block, 'Y')].span;
  ed.insert_after(y, " Z3.");
  ed.insert_after(y, " A4.");
  ed.insert_before(l.block.words[0].span, "G90 ");
  ed.replace(y, "Y5.");  // a replacement of the span the insertions follow
  EXPECT_EQ(render(ed), "N1 G90 G1 X1. Y5. Z3. A4. F100.");
}

TEST(BlockWriter, OverlappingEditsAreAnInternalError) {
  const gc::Dialect d = dialect("fanuc");
  Lexed l(d, "G1 X1. Y2.");
  gc::BlockEditor ed(l.block);
  ed.replace({3, 6}, "X9.");
  ed.replace({5, 8}, "oops");
  try {
    (void)render(ed);
    FAIL() << "overlap not detected";
  } catch (const postproc::Error& e) {
    EXPECT_EQ(e.code(), postproc::ExitCode::internal);
  }
  std::vector<gc::Edit> outside{{{8, 20}, "x"}};
  std::string out;
  EXPECT_THROW(gc::render_edits("G1 X1.", outside, out), postproc::Error);
}

TEST(BlockWriter, RoundTripOfEveryWordKeepsTheLine) {
  // Rewriting each literal with its own value in its own style reproduces the line exactly.
  const gc::Dialect d = dialect("linuxcnc");
  for (const char* line : {"N0010 G01 X-49.650 Y.5 Z+3 F100. (c)", "g1 x1.25 y-0.5000 ; end", "G0 X10. Y-.125"}) {
    Lexed l(d, line);
    gc::BlockEditor ed(l.block);
    for (std::size_t i = 0; i < l.block.words.size(); ++i) {
      if (l.block.words[i].letter != 'G') {
        EXPECT_FALSE(ed.replace_word_value(i, l.block.words[i].number, 0));
      }
    }
    EXPECT_EQ(render(ed), line);
  }
}

}  // namespace
