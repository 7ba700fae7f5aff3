// Reader limits (issue 21): hostile programs give a located error or a correct result, quickly —
// deep nesting, endless loops, huge numbers, overflowing arithmetic, huge arrays, long lines and
// CR-only line ends, in every dialect that has them.
#include <gtest/gtest.h>

#include <charconv>
#include <chrono>
#include <cmath>
#include <random>
#include <string>

#include "postproc/gcode/detect.hpp"
#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/lexer.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/gcode/program.hpp"
#include "postproc/gcode/resolve.hpp"
#include "src/gcode/number_text.hpp"

using namespace postproc::gcode;

namespace {

struct Outcome {
  ResolvedProgram r;
  DiagnosticSink sink;
};

Outcome resolve_text(DialectId id, const std::string& text, ResolveOptions opt = {}) {
  Outcome run;
  run.r = resolve(text, "t.nc", make_dialect(id), opt, run.sink);
  return run;
}

/// The first error's code (empty when none).
std::string first_error(const DiagnosticSink& s) {
  for (const Diagnostic& d : s.stored())
    if (d.severity == Severity::error) return d.code;
  return {};
}

const Diagnostic* find(const DiagnosticSink& s, std::string_view code) {
  for (const Diagnostic& d : s.stored())
    if (d.code == code) return &d;
  return nullptr;
}

std::string repeat(std::string_view s, int n) {
  std::string out;
  for (int i = 0; i < n; ++i) out += s;
  return out;
}

std::string fanuc(const std::string& body) { return "%\nO1000\n" + body + "M30\n%\n"; }

}  // namespace

// ---- 1. nesting depth -------------------------------------------------------------------------

TEST(ReaderLimits, DeepNestingIsRefusedAtTheLimitInEveryResolver) {
  struct Case {
    DialectId id;
    std::string text;
  } cases[] = {
      {DialectId::siemens, "R1=" + repeat("(", 10000) + "1" + repeat(")", 10000) + "\nM30\n"},
      {DialectId::siemens, "R1=" + repeat("SIN(", 10000) + "1" + repeat(")", 10000) + "\nM30\n"},
      {DialectId::siemens, "R1=" + repeat("-", 50000) + "1\nM30\n"},
      {DialectId::siemens, "R1=" + repeat("NOT ", 5000) + "1\nM30\n"},
      {DialectId::siemens, "R1=1" + repeat("+1", 50000) + "\nM30\n"},
      {DialectId::linuxcnc, "#1=" + repeat("[", 50000) + "1" + repeat("]", 50000) + "\nM2\n"},
      {DialectId::linuxcnc, "#1=[" + repeat("sin[", 10000) + "1" + repeat("]", 10000) + "]\nM2\n"},
      {DialectId::linuxcnc, "#1=" + repeat("-", 50000) + "1\nM2\n"},
      {DialectId::linuxcnc, "#1=" + repeat("#", 50000) + "1\nM2\n"},
      {DialectId::fanuc, fanuc("#1=" + repeat("[", 50000) + "1" + repeat("]", 50000) + "\n")},
      {DialectId::fanuc, fanuc("#1=" + repeat("SIN[", 10000) + "1" + repeat("]", 10000) + "\n")},
      {DialectId::fanuc, fanuc("#1=" + repeat("-", 50000) + "1\n")},
      {DialectId::fanuc, fanuc("#1=" + repeat("#", 50000) + "1\n")},
      {DialectId::fanuc, fanuc("#1=1" + repeat("+1", 50000) + "\n")},
  };
  for (const Case& c : cases) {
    const auto t0 = std::chrono::steady_clock::now();
    const Outcome run = resolve_text(c.id, c.text);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (c.id == DialectId::linuxcnc) {
      // LinuxCNC stops at any line of 253 characters or more first (rs274's "Command too long"):
      // no LinuxCNC line reaches the nesting limit.
      const Diagnostic* d = find(run.sink, "PP-E207");
      ASSERT_NE(d, nullptr) << c.text.substr(0, 40) << ": " << first_error(run.sink);
      EXPECT_NE(d->message.find("LinuxCNC reads at most 252"), std::string::npos) << d->message;
      EXPECT_LT(s, 2.0) << c.text.substr(0, 40);
      continue;
    }
    const Diagnostic* d = find(run.sink, "PP-E712");
    ASSERT_NE(d, nullptr) << c.text.substr(0, 40) << ": " << first_error(run.sink);
    EXPECT_NE(d->message.find("256"), std::string::npos) << d->message;
    EXPECT_GT(d->where.line, 0u);
    EXPECT_LT(s, 2.0) << c.text.substr(0, 40);  // generous: the point is "not quadratic, no crash"
  }
}

TEST(ReaderLimits, NestingJustBelowTheLimitIsEvaluated) {
  const Outcome l = resolve_text(DialectId::linuxcnc, "#1=" + repeat("[", 100) + "2" + repeat("]", 100) + "\nG1 X#1 F100\nM2\n");
  EXPECT_FALSE(l.sink.has_errors()) << first_error(l.sink);
  EXPECT_NE(l.r.text.find("X2."), std::string::npos) << l.r.text;
  const Outcome f = resolve_text(DialectId::fanuc, fanuc("#1=" + repeat("[", 100) + "2" + repeat("]", 100) + "\nG1 X#1 F100\n"));
  EXPECT_FALSE(f.sink.has_errors()) << first_error(f.sink);
  EXPECT_NE(f.r.text.find("X2."), std::string::npos) << f.r.text;
  const Outcome s = resolve_text(DialectId::siemens, "R1=" + repeat("(", 100) + "2" + repeat(")", 100) + "\nG1 X=R1 F100\nM30\n");
  EXPECT_FALSE(s.sink.has_errors()) << first_error(s.sink);
  EXPECT_NE(s.r.text.find("X=2."), std::string::npos) << s.r.text;
}

// ---- 2. endless loops -------------------------------------------------------------------------

TEST(ReaderLimits, LoopsWithoutProgressAreRefusedAtOnceAndLocated) {
  struct Case {
    DialectId id;
    std::string text;
    std::uint64_t line;  // where the loop jumps back
  } cases[] = {
      {DialectId::linuxcnc, "o1 while [1]\no1 endwhile\nM2\n", 2},
      {DialectId::linuxcnc, "o1 while [1]\nG1 X1 F100\no1 endwhile\nM2\n", 3},
      {DialectId::linuxcnc, "#1=0\no1 do\n#1=1\no1 while [#1 GT 0]\nM2\n", 4},
      // Each pass changes variables and puts them back (rs274_control_compare seed 7151: #<_i4>
      // goes 0 → 1 → 0 and the moves repeat): the same state at the head, so endless. Before, the
      // change counted as progress and the loop ran until 1 GiB of resolved text.
      {DialectId::linuxcnc, "#<_i>=0\no1 while [#<_i> LT 1]\n#<_i>=[#<_i>+1]\n#<_i>=0\nG1 Z0 F100\nG1 X3\no1 endwhile\nM2\n", 7},
      {DialectId::linuxcnc, "#1=0\n#<l>=5\no1 while [#1 LT 1]\n#1=2\n#<l>=6\n#1=0\n#<l>=5\nG1 X1 F100\no1 endwhile\nM2\n", 9},
      {DialectId::fanuc, fanuc("WHILE [1] DO1\nEND1\n"), 4},
      {DialectId::fanuc, fanuc("N10 #1=1\nG1 X1 F100\nGOTO10\n"), 5},
      {DialectId::fanuc, fanuc("#1=0\nN10 IF [#1 LT 5] GOTO10\n"), 4},
      {DialectId::siemens, "LOOP\nENDLOOP\nM30\n", 2},
      {DialectId::siemens, "R1=0\nREPEAT\nR2=1\nUNTIL R1>0\nM30\n", 4},
      {DialectId::siemens, "R1=0\nWHILE R1<1\nG1 X1 F100\nENDWHILE\nM30\n", 4},
      {DialectId::siemens, "MA: R1=1\nGOTOB MA\nM30\n", 2},
  };
  for (const Case& c : cases) {
    const Outcome run = resolve_text(c.id, c.text);
    const Diagnostic* d = find(run.sink, "PP-E705");
    ASSERT_NE(d, nullptr) << c.text << first_error(run.sink);
    EXPECT_EQ(d->where.line, c.line) << c.text;
    EXPECT_NE(d->message.find("endless loop"), std::string::npos) << d->message;
    // At once: the loop ran twice, not until a block limit.
    EXPECT_LT(run.r.source_line.size(), 10u) << c.text;
  }
}

TEST(ReaderLimits, LoopsThatChangeStateRunToTheirEnd) {
  // Counters, repeat counts and calls are progress: these loops end and are resolved completely.
  const Outcome l = resolve_text(DialectId::linuxcnc,
                             "#1=0\no1 while [#1 LT 3]\n#1=[#1+1]\no1 endwhile\no2 repeat [3]\no2 endrepeat\nG1 X#1 F100\nM2\n");
  EXPECT_FALSE(l.sink.has_errors()) << first_error(l.sink);
  EXPECT_NE(l.r.text.find("G1 X3."), std::string::npos) << l.r.text;
  // A pass that returns a variable to a value it had earlier, but not to the state of the pass
  // before (the state cycles with period 2, the loop ends on its counter): not refused.
  const Outcome c = resolve_text(DialectId::linuxcnc, "#1=0\n#2=0\no1 while [#1 LT 6]\n#1=[#1+1]\n#2=[1-#2]\n"
                                                      "G1 X#2 F100\no1 endwhile\nG1 X#1\nM2\n");
  EXPECT_FALSE(c.sink.has_errors()) << first_error(c.sink);
  EXPECT_NE(c.r.text.find("G1 X6."), std::string::npos) << c.r.text;
  const Outcome f = resolve_text(DialectId::fanuc, fanuc("#1=0\nWHILE [#1 LT 3] DO1\n#1=#1+1\nEND1\nG1 X#1 F100\n"));
  EXPECT_FALSE(f.sink.has_errors()) << first_error(f.sink);
  EXPECT_NE(f.r.text.find("G1 X3."), std::string::npos) << f.r.text;
  const Outcome s = resolve_text(DialectId::siemens, "R1=0\nWHILE R1<3\nR1=R1+1\nENDWHILE\nG1 X=R1 F100\nM30\n");
  EXPECT_FALSE(s.sink.has_errors()) << first_error(s.sink);
  EXPECT_NE(s.r.text.find("X=3."), std::string::npos) << s.r.text;
}

TEST(ReaderLimits, SilentLoopsStopAtTheLineLimitWhichAnOptionRaises) {
  // The counter changes every pass (no repeated state), but nothing is ever written.
  const std::string lcnc = "#1=0\no1 while [1]\n#1=[#1+1]\no1 endwhile\nM2\n";
  const std::string fan = fanuc("#1=0\nWHILE [1] DO1\n#1=#1+1\nEND1\n");
  const std::string sie = "R1=0\nLOOP\nR1=R1+1\nENDLOOP\nM30\n";
  ResolveOptions opt;
  opt.max_silent_lines = 10'000;
  for (const auto& [id, text] : {std::pair{DialectId::linuxcnc, lcnc}, std::pair{DialectId::fanuc, fan},
                                 std::pair{DialectId::siemens, sie}}) {
    const Outcome run = resolve_text(id, text, opt);
    const Diagnostic* d = find(run.sink, "PP-E705");
    ASSERT_NE(d, nullptr) << text;
    EXPECT_NE(d->message.find("10000 lines"), std::string::npos) << d->message;
    EXPECT_GT(d->where.line, 0u);
  }
  // A loop computing 20,000 lines before its first block passes with the limit raised.
  const std::string counted = "#1=0\no1 while [#1 LT 10000]\n#1=[#1+1]\no1 endwhile\nG1 X#1 F100\nM2\n";
  EXPECT_EQ(first_error(resolve_text(DialectId::linuxcnc, counted, opt).sink), "PP-E705");
  opt.max_silent_lines = 100'000;
  const Outcome ok = resolve_text(DialectId::linuxcnc, counted, opt);
  EXPECT_FALSE(ok.sink.has_errors()) << first_error(ok.sink);
  EXPECT_NE(ok.r.text.find("X10000."), std::string::npos);
}

TEST(ReaderLimits, HugeRepeatCountsDoNotOverflow) {
  // 1e300 passes of an empty body: no undefined conversion; the empty passes change the count, so
  // the silent-line limit ends it.
  ResolveOptions opt;
  opt.max_silent_lines = 10'000;
  const Outcome run = resolve_text(DialectId::linuxcnc, "o1 repeat [1e300]\no1 endrepeat\nM2\n", opt);
  EXPECT_TRUE(run.sink.has_errors());
  const Outcome r2 = resolve_text(DialectId::linuxcnc, "o1 repeat [10**300]\no1 endrepeat\nM2\n", opt);
  EXPECT_EQ(first_error(r2.sink), "PP-E705");
}

// ---- 3. numbers -------------------------------------------------------------------------------

TEST(ReaderLimits, NumberReaderMatchesFromCharsOnRandomDigitStrings) {
  std::mt19937_64 rng(21);
  std::uniform_int_distribution<int> len(1, 60), digit(0, 9), coin(0, 3);
  for (int n = 0; n < 20000; ++n) {
    std::string t;
    const int a = len(rng) - (coin(rng) == 0 ? 0 : 1);
    for (int i = 0; i < a; ++i) t += static_cast<char>('0' + digit(rng));
    if (coin(rng) != 0) {
      t += '.';
      const int b = len(rng) % (coin(rng) == 0 ? 40 : 8);
      for (int i = 0; i < b; ++i) t += static_cast<char>('0' + digit(rng));
    }
    if (t.find_first_of("0123456789") == std::string::npos) t += '7';
    double mine = 0, ref = 0;
    ASSERT_TRUE(parse_number(t, mine)) << t;
    std::string_view digits = t;
    if (digits.back() == '.') digits.remove_suffix(1);
    const auto r = std::from_chars(digits.data(), digits.data() + digits.size(), ref);
    ASSERT_EQ(r.ec, std::errc()) << t;
    EXPECT_EQ(mine, ref) << t;  // exactly: correctly rounded both
  }
}

TEST(ReaderLimits, NumbersBeyondTheDoubleRangeReadAsInfinityOrZero) {
  double v = 0;
  ASSERT_TRUE(parse_number(std::string(400, '9'), v));
  EXPECT_TRUE(std::isinf(v) && v > 0);
  ASSERT_TRUE(parse_number("-" + std::string(400, '9') + ".5", v));
  EXPECT_TRUE(std::isinf(v) && v < 0);
  ASSERT_TRUE(parse_number("0." + std::string(400, '0') + "1", v));
  EXPECT_EQ(v, 0.0);
  ASSERT_TRUE(parse_number("12345678901234567890", v));  // 20 digits: exact to double precision
  EXPECT_EQ(v, 12345678901234567890.0);
  ASSERT_TRUE(parse_number("0.12345678901234567890123", v));
  EXPECT_EQ(v, 0.12345678901234567890123);
}

TEST(ReaderLimits, OutOfRangeLiteralsAreRefusedAtTheWordInEveryDialect) {
  for (DialectId id : {DialectId::fanuc, DialectId::siemens, DialectId::linuxcnc, DialectId::heidenhain_iso}) {
    const Dialect d = make_dialect(id);
    DiagnosticSink sink;
    Block b;
    const std::string raw = "G1 X" + std::string(400, '9') + " Y1";
    b.raw = raw;
    b.line = 7;
    EXPECT_FALSE(lex_block(d, b, LexContext{"t", &sink})) << d.name;
    const Diagnostic* e = find(sink, "PP-E205");
    ASSERT_NE(e, nullptr) << d.name;
    EXPECT_EQ(e->where.line, 7u);
    EXPECT_EQ(e->where.column, 5u);
    EXPECT_NE(e->message.find("out of range"), std::string::npos);
    EXPECT_EQ(find(sink, "PP-E106"), nullptr) << d.name;
    for (const Word& w : b.words) EXPECT_TRUE(std::isfinite(w.number)) << d.name;
  }
}

TEST(ReaderLimits, OutOfRangeLiteralsInExpressionsAreRefused) {
  const std::string big(400, '9');
  // LinuxCNC: a line that long is refused for its length (rs274's "Command too long"); within 252
  // characters no literal leaves the range of a double.
  EXPECT_EQ(first_error(resolve_text(DialectId::linuxcnc, "#1=[" + big + "]\nM2\n").sink), "PP-E207");
  EXPECT_EQ(first_error(resolve_text(DialectId::fanuc, fanuc("#1=" + big + "\n")).sink), "PP-E205");
  EXPECT_EQ(first_error(resolve_text(DialectId::siemens, "R1=" + big + "\nM30\n").sink), "PP-E205");
}

// ---- 4. arithmetic ----------------------------------------------------------------------------

TEST(ReaderLimits, OverflowAndDomainErrorsAreLocatedAndNamed) {
  struct Case {
    DialectId id;
    std::string text;
    std::string names;
  } cases[] = {
      {DialectId::linuxcnc, "#1=[EXP[1000]]\nG1 X#1 F100\nM2\n", "EXP"},
      {DialectId::linuxcnc, "#1=[10**400]\nM2\n", "**"},
      {DialectId::linuxcnc, "#1=[1E200]\n", ""},  // a word letter, not an exponent: a syntax error
      {DialectId::linuxcnc, "#1=[SQRT[-1]]\nM2\n", "SQRT"},
      {DialectId::linuxcnc, "#1=[LN[0]]\nM2\n", "LN"},
      {DialectId::linuxcnc, "#1=[ASIN[2]]\nM2\n", "ASIN"},
      {DialectId::linuxcnc, "#1=[10000000000*10000000000]\n#2=[#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1]\nM2\n", "product"},
      {DialectId::fanuc, fanuc("#1=EXP[1000]\nG1 X#1 F100\n"), "EXP"},
      {DialectId::fanuc, fanuc("#1=POW[10,400]\n"), "POW"},
      {DialectId::fanuc, fanuc("#1=SQRT[-1]\n"), "SQRT"},
      {DialectId::fanuc, fanuc("#1=LN[0]\n"), "LN"},
      {DialectId::fanuc, fanuc("#1=ASIN[2]\n"), "ASIN"},
      {DialectId::fanuc, fanuc("#1=10000000000\n#2=#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1*#1\n"), "product"},
      {DialectId::fanuc, fanuc("#1=1E300\n"), ""},
      {DialectId::fanuc, fanuc("#1=10000000000\n#2=#1*#1\n#3=#2 MOD 7\n"), "integer"},
      {DialectId::siemens, "R1=EXP(1000)\nG1 X=R1 F100\nM30\n", "EXP"},
      {DialectId::siemens, "R1=1EX300*1EX300\nM30\n", "product"},
      {DialectId::siemens, "R1=SQRT(-1)\nM30\n", "square root"},
      {DialectId::siemens, "R1=LN(0)\nM30\n", "logarithm"},
      {DialectId::siemens, "R1=ASIN(2)\nM30\n", "ASIN"},
      {DialectId::siemens, "R1=1EX300 B_AND 1\nM30\n", "integer"},
  };
  for (const Case& c : cases) {
    const Outcome run = resolve_text(c.id, c.text);
    ASSERT_TRUE(run.sink.has_errors()) << c.text;
    const Diagnostic& d = run.sink.stored().front();
    EXPECT_GT(d.where.line, 0u) << c.text;
    if (!c.names.empty()) {
      EXPECT_EQ(d.code, "PP-E707") << c.text << d.message;
      EXPECT_NE(d.message.find(c.names), std::string::npos) << c.text << ": " << d.message;
    }
    // Never an infinite word handed on.
    EXPECT_EQ(run.r.text.find("inf"), std::string::npos) << run.r.text;
    EXPECT_EQ(run.r.text.find("nan"), std::string::npos) << run.r.text;
  }
}

// ---- 5. arrays --------------------------------------------------------------------------------

TEST(ReaderLimits, HugeSiemensArraysAreRefusedBeforeAllocating) {
  for (const std::string decl : {"DEF REAL A[100000000]", "DEF REAL A[1000000,1000000]", "DEF INT A[1000,1000,1000]"}) {
    const Outcome run = resolve_text(DialectId::siemens, decl + "\nM30\n");
    const Diagnostic* d = find(run.sink, "PP-E714");
    ASSERT_NE(d, nullptr) << decl << first_error(run.sink);
    EXPECT_EQ(d->where.line, 1u);
    EXPECT_NE(d->message.find("10000000"), std::string::npos) << d->message;
  }
  // Arrays alive at once count together; the option raises the limit.
  ResolveOptions opt;
  opt.max_array_elements = 1000;
  const std::string two = "DEF REAL A[600]\nDEF REAL B[600]\nA[599]=1\nB[599]=2\nG1 X=A[599]+B[599] F100\nM30\n";
  EXPECT_EQ(first_error(resolve_text(DialectId::siemens, two, opt).sink), "PP-E714");
  opt.max_array_elements = 2000;
  const Outcome ok = resolve_text(DialectId::siemens, two, opt);
  EXPECT_FALSE(ok.sink.has_errors()) << first_error(ok.sink);
  EXPECT_NE(ok.r.text.find("X=3."), std::string::npos) << ok.r.text;
}

// ---- 6. long lines ----------------------------------------------------------------------------

TEST(ReaderLimits, LongLinesAreEchoedAsAWindowAroundTheColumn) {
  const std::string line = std::string(100000, ' ') + "G1 X1 ?" + std::string(100000, ' ') + "Y2";
  Block b;
  b.raw = line;
  b.line = 3;
  DiagnosticSink sink;
  (void)lex_block(make_dialect(DialectId::fanuc), b, LexContext{"t", &sink});
  const Diagnostic* d = find(sink, "PP-E101");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->where.column, 100007u);
  EXPECT_LE(d->source_line.size(), kMaxSourceEcho);
  const std::string text = format(*d);
  EXPECT_LT(text.size(), 1200u);
  // The caret is under the '?'.
  const auto src = text.find("\n  ") + 3;
  const auto car = text.find('\n', src) + 3;
  const auto q = text.find('?', src);
  const auto caret = text.find('^', car);
  ASSERT_NE(q, std::string::npos);
  ASSERT_NE(caret, std::string::npos);
  EXPECT_EQ(caret - car, q - src - std::string("…").size() + 1);
  // Both sides left out are marked.
  EXPECT_EQ(text.substr(src, std::string("…").size()), "…") << text.substr(0, 400);
  EXPECT_NE(text.find("…\n", src), std::string::npos) << text.substr(0, 400);

  // Short lines are kept whole.
  Diagnostic s;
  s.where = {1, 3};
  set_source_line(s, "G1 X1");
  EXPECT_EQ(s.source_line, "G1 X1");
  EXPECT_EQ(format(s), ":1:3: error: : \n  G1 X1\n    ^\n");
}

TEST(ReaderLimits, StoredDiagnosticsAreBoundedInCountAndMemory) {
  DiagnosticSink sink(100000, 1 << 20);
  Diagnostic d;
  d.where = {1, 1};
  d.message = std::string(100000, 'm');
  for (int i = 0; i < 1000; ++i) sink.report(d);
  EXPECT_EQ(sink.count(Severity::error), 1000u);
  EXPECT_LT(sink.stored().size(), 1000u);
  EXPECT_GT(sink.dropped(), 0u);
  EXPECT_EQ(sink.stored().size() + sink.dropped(), 1000u);
  EXPECT_LE(sink.stored().front().message.size(), kMaxMessage + 4);
}

// ---- 7. CR-only line ends ---------------------------------------------------------------------

TEST(ReaderLimits, CrOnlyLineEndsReadAsLinesInEveryDialect) {
  struct Case {
    DialectId id;
    std::string text;
  } cases[] = {
      {DialectId::fanuc, "%\rO1000\rG1 X1 F100\rG1 X2\rM30\r%\r"},
      {DialectId::linuxcnc, "G1 X1 F100\rG1 X2\rM2\r"},
      {DialectId::siemens, "G1 X1 F100\rG1 X2\rM30\r"},
      {DialectId::heidenhain_iso, "%P G71 *\rN10 G1 X1 F100 *\rN20 G1 X2 *\rN30 M30 *\rN99999 %P G71 *\r"},
  };
  struct Count final : BlockVisitor {
    int motions = 0;
    void block(const Block&, std::span<const Motion> m, bool) override { motions += static_cast<int>(m.size()); }
  };
  for (const Case& c : cases) {
    DiagnosticSink sink;
    Count v;
    const ProgramStats st = run_program_text(c.text, make_dialect(c.id), "t.nc", sink, v, ResolveOptions{});
    EXPECT_FALSE(sink.has_errors()) << c.text << first_error(sink);
    EXPECT_EQ(v.motions, 2) << c.text;
    EXPECT_GE(st.blocks, 3u) << c.text;
  }
  // Resolved programs too.
  const Outcome l = resolve_text(DialectId::linuxcnc, "#1=2\rG1 X#1 F100\rM2\r");
  EXPECT_FALSE(l.sink.has_errors()) << first_error(l.sink);
  EXPECT_NE(l.r.text.find("G1 X2."), std::string::npos) << l.r.text;
}

TEST(ReaderLimits, DialectIsGuessedFromProgramsWithCrOnlyLineEnds) {
  for (const std::string eol : {"\n", "\r\n", "\r"}) {
    const std::string text = "G1 X1 F100" + eol + "G1 X2" + eol + "DEF REAL A" + eol + "M30" + eol;
    const auto g = guess_dialect(text);
    ASSERT_TRUE(g.has_value()) << eol.size();
    EXPECT_EQ(g->id, DialectId::siemens);
    EXPECT_EQ(g->line, 3u);
    EXPECT_EQ(g->column, 1u);
  }
}

TEST(ReaderLimits, AHugeBlockIsRefusedOnceNotLexedIntoMillionsOfWords) {
  std::string line;
  for (int i = 0; i < 200000; ++i) line += "G1 X1 Y2 ";
  Block b;
  b.raw = line;
  b.line = 1;
  DiagnosticSink sink;
  EXPECT_FALSE(lex_block(make_dialect(DialectId::fanuc), b, LexContext{"t", &sink}));
  EXPECT_LE(b.words.size() + b.tokens.size(), kMaxBlockItems);
  ASSERT_NE(find(sink, "PP-E110"), nullptr);
  EXPECT_EQ(sink.count(Severity::error), 1u);
  EXPECT_NE(find(sink, "PP-E110")->message.find("10000"), std::string::npos);
}
