// guess_dialect(): suggests a dialect from constructs only one dialect writes, with their location.
#include <gtest/gtest.h>

#include "postproc/gcode/detect.hpp"
#include "support.hpp"

namespace {

using namespace pptest;
using gc::DialectId;

struct Case {
  const char* text;
  DialectId id;
  const char* evidence;
  std::uint64_t line;
  std::uint32_t column;
};

TEST(Detect, MarkersWithLocation) {
  const Case cases[] = {
      {"N10 G0 X0\nN20 TRAORI\n", DialectId::siemens, "TRAORI", 2, 5},
      {"G0 X0\r\nCYCLE800(1)\r\n", DialectId::siemens, "CYCLE8", 2, 1},
      {"%_N_PART_MPF\n", DialectId::siemens, "%_N_", 1, 1},
      {"G0 X0\n#<depth>=2\n", DialectId::linuxcnc, "#<", 2, 1},
      {"o100 sub\n", DialectId::linuxcnc, " SUB", 1, 5},
      {"G0 X0\nG43.4 H1 Z5\n", DialectId::fanuc, "G43.4", 2, 1},
      {"G54.1 P1\n", DialectId::fanuc, "G54.1", 1, 1},
      {"N1 G0 X0\nN2 M128\n", DialectId::heidenhain_iso, "M128", 2, 4},
      {"g0 x0\nm428\n", DialectId::linuxcnc, "M428", 2, 1},  // case-insensitive
      {"G0 X0\nG1 X1\ntraori\n", DialectId::siemens, "TRAORI", 3, 1},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.text);
    const auto g = gc::guess_dialect(c.text);
    ASSERT_TRUE(g.has_value());
    EXPECT_EQ(g->id, c.id);
    EXPECT_EQ(g->evidence, c.evidence);
    EXPECT_EQ(g->line, c.line);
    EXPECT_EQ(g->column, c.column);
  }
}

TEST(Detect, NothingToGo) {
  EXPECT_FALSE(gc::guess_dialect("").has_value());
  EXPECT_FALSE(gc::guess_dialect("G0 X0 Y0\nG1 X1 F100\nM30\n").has_value());
  // "%_N_" and "DEF REAL" count only at the start of a line.
  EXPECT_FALSE(gc::guess_dialect("(%_N_ in a comment)\n").has_value());
}

TEST(Detect, MaxLinesIsRespected) {
  std::string text;
  for (int i = 0; i < 10; ++i) text += "G1 X1\n";
  text += "TRAORI\n";
  EXPECT_FALSE(gc::guess_dialect(text, 10).has_value());
  const auto g = gc::guess_dialect(text, 11);
  ASSERT_TRUE(g.has_value());
  EXPECT_EQ(g->line, 11u);
}

TEST(Detect, FirstMarkingLineWins) {
  const auto g = gc::guess_dialect("G0 X0\nG43.4 H1\nTRAORI\n");
  ASSERT_TRUE(g.has_value());
  EXPECT_EQ(g->id, DialectId::fanuc);
}

TEST(Detect, LinuxcncOWordLoopIsNotFanucWhile) {
  // "o1 while [...]" is a LinuxCNC o-word loop; Fanuc writes "WHILE [...] DO1" without an o-word.
  const auto g = gc::guess_dialect("G20\nO1 while [#9 lt #6]\nO1 endwhile\nM2\n");
  ASSERT_TRUE(g.has_value());
  EXPECT_EQ(g->id, DialectId::linuxcnc);
  EXPECT_EQ(g->line, 3u);
  const auto f = gc::guess_dialect("O0001\nWHILE [#1 LT 10] DO1\nEND1\nM30\n");
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->id, DialectId::fanuc);
}

TEST(Detect, CommentTextIsNotEvidence) {
  // A Fanuc comment such as "(ROUGH SUB-PROGRAM)" says nothing about the dialect.
  const auto g = gc::guess_dialect("O1000 (ROUGH SUB-PROGRAM)\nG0 X0\n");
  EXPECT_FALSE(g.has_value());
}

}  // namespace
