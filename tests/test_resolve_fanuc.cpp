// Fanuc Macro B resolution (issue 3): golden literal programs per feature, diagnostics, the
// shared corpus, and the resolve speed of a long loop.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/resolve.hpp"

using namespace postproc::gcode;

namespace {

struct Result {
  ResolvedProgram r;
  DiagnosticSink sink;
};

Result run(std::string_view text, ResolveOptions opt = {}) {
  Result out;
  out.r = resolve(text, "t.nc", make_dialect(DialectId::fanuc), opt, out.sink);
  return out;
}

std::string diags(const DiagnosticSink& s) {
  std::string t;
  for (const Diagnostic& d : s.stored()) t += format(d, false) + "\n";
  return t;
}

/// Resolves and expects no errors; returns the literal program.
std::string literal(std::string_view text, ResolveOptions opt = {}) {
  Result x = run(text, opt);
  EXPECT_FALSE(x.sink.has_errors()) << diags(x.sink);
  return x.r.text;
}

/// The first error (fails when none).
Diagnostic first_error(const Result& x) {
  for (const Diagnostic& d : x.sink.stored())
    if (d.severity == Severity::error) return d;
  ADD_FAILURE() << "no error reported";
  return {};
}

}  // namespace

TEST(ResolveFanuc, ArithmeticAndPrecedence) {
  const std::string src =
      "%\n"
      "O1000 (ARITH)\n"
      "#1=2+3*4 (PREC)\n"
      "#2=[2+3]*4\n"
      "#3=10-4-3\n"
      "#4=-#1+1\n"
      "#5=7/2\n"
      "#6=13 MOD 5\n"
      "#7=6 AND 3\n"
      "#8=6 OR 3\n"
      "#9=6 XOR 3\n"
      "#10=1+6 AND 3\n"
      "G01 X#1 Y-#2 Z[#3+1] F#5\n"
      "G#10 X#4 Y#6 Z#7 A#8 B#9\n"
      "M30\n"
      "%\n";
  EXPECT_EQ(literal(src),
            "%\n"
            "O1000 (ARITH)\n"
            "(PREC)\n"
            "G01 X14. Y-20. Z4. F3.5\n"
            "G3 X-13. Y3. Z2. A7. B5.\n"
            "M30\n"
            "%\n");
}

TEST(ResolveFanuc, Functions) {
  const std::string src =
      "#1=SIN[30]\n"
      "#2=COS[60]\n"
      "#3=TAN[45]\n"
      "#4=ASIN[0.5]\n"
      "#5=ACOS[0.5]\n"
      "#6=ATAN[1]/[1]\n"
      "#7=ATAN[-1,-1]\n"
      "#8=SQRT[16]\n"
      "#9=ABS[-2.5]\n"
      "#10=BIN[18]\n"
      "#11=BCD[12]\n"
      "#12=ROUND[2.5]\n"
      "#13=FIX[-1.7]\n"
      "#14=FUP[1.2]\n"
      "#15=LN[1]\n"
      "#16=EXP[0]\n"
      "#17=POW[2,10]\n"
      "#18=ADP[3]\n"
      "#19=FUP[-1.2]\n"
      "#20=ROUND[-2.5]\n"
      "#21=ATAN[1]\n"
      "X#1 Y#2 Z#3 A#4 B#5 C#6\n"
      "X#7 Y#8 Z#9 A#10 B#11 C#12\n"
      "X#13 Y#14 Z#15 A#16 B#17 C#18\n"
      "X#19 Y#20 Z#21\n"
      "M30\n";
  EXPECT_EQ(literal(src),
            "X0.5 Y0.5 Z1. A30. B60. C45.\n"
            "X225. Y4. Z2.5 A12. B18. C3.\n"
            "X-1. Y2. Z0. A1. B1024. C3.\n"
            "X-2. Y-3. Z45.\n"
            "M30\n");
}

TEST(ResolveFanuc, VacantSemantics) {
  const std::string src =
      "#1=5\n"
      "#1=#0 (NOW VACANT)\n"
      "#2=#1*3\n"
      "IF [#1 EQ #0] THEN #3=1\n"
      "IF [#2 EQ #0] THEN #4=1\n"
      "IF [#1 NE 0] THEN #5=1\n"
      "IF [#1 LT 1] THEN #6=1\n"
      "#7=#1\n"
      "G00 X#1 Y#2 Z#3 A#4 B#5 C#6\n"
      "G00 X-#7 Y[#1+1] Z1.\n"
      "M30\n";
  // #2 = vacant*3 = 0 (not vacant); #4 stays vacant; vacant NE 0 is true; vacant LT 1 (as 0).
  // A word whose value is a vacant variable is left out, as the control does.
  EXPECT_EQ(literal(src),
            "(NOW VACANT)\n"
            "G00 Y0. Z1. B1. C1.\n"
            "G00 Y1. Z1.\n"
            "M30\n");
}

TEST(ResolveFanuc, IndirectVariables) {
  const std::string src =
      "#1=3\n"
      "#[#1+2]=7.5\n"
      "#10=5\n"
      "X#[#1+2] Y#[#10] Z##10\n"
      "M30\n";
  EXPECT_EQ(literal(src), "X7.5 Y7.5 Z7.5\nM30\n");
}

TEST(ResolveFanuc, IfGotoForwardAndBackward) {
  const std::string src =
      "#1=0\n"
      "N10 G01 X#1\n"
      "#1=#1+1\n"
      "IF [#1 LT 3] GOTO 10\n"
      "IF [#1 EQ 3] GOTO 30\n"
      "G01 Y99. (SKIPPED)\n"
      "N30 G00 Z5.\n"
      "M30\n";
  Result x = run(src);
  EXPECT_FALSE(x.sink.has_errors()) << diags(x.sink);
  EXPECT_EQ(x.r.text, "N10 G01 X0.\nN10 G01 X1.\nN10 G01 X2.\nN30 G00 Z5.\nM30\n");
  EXPECT_EQ(x.r.source_line, (std::vector<std::uint64_t>{2, 2, 2, 7, 8}));
  EXPECT_EQ(x.r.substituted, (std::vector<bool>{true, true, true, false, false}));
}

TEST(ResolveFanuc, GotoComputedAndUnconditional) {
  const std::string src =
      "#5=40\n"
      "GOTO #5\n"
      "N20 X1.\n"
      "N40 X2.\n"
      "GOTO 60\n"
      "X3.\n"
      "N60 M30\n";
  EXPECT_EQ(literal(src), "N40 X2.\nN60 M30\n");
}

TEST(ResolveFanuc, IfThen) {
  const std::string src =
      "#1=2\n"
      "IF [#1 EQ 2] THEN #2=10 (TAKEN)\n"
      "IF [#1 NE 2] THEN #2=20\n"
      "IF [[#1 GT 1] AND [#1 LT 3]] THEN #3=1\n"
      "IF [#1 GT 5 OR #1 EQ 2] THEN #4=1\n"
      "X#2 Y#3 Z#4\n"
      "M30\n";
  EXPECT_EQ(literal(src), "(TAKEN)\nX10. Y1. Z1.\nM30\n");
}

TEST(ResolveFanuc, NestedWhile) {
  const std::string src =
      "#1=0\n"
      "WHILE [#1 LT 2] DO 1\n"
      "#2=0\n"
      "WHILE [#2 LT 2] DO 2\n"
      "G01 X#1 Y#2\n"
      "#2=#2+1\n"
      "END 2\n"
      "#1=#1+1\n"
      "END 1\n"
      "WHILE [#1 GT 100] DO 1 (NEVER)\n"
      "X99.\n"
      "END 1\n"
      "M30\n";
  Result x = run(src);
  EXPECT_FALSE(x.sink.has_errors()) << diags(x.sink);
  EXPECT_EQ(x.r.text, "G01 X0. Y0.\nG01 X0. Y1.\nG01 X1. Y0.\nG01 X1. Y1.\n(NEVER)\nM30\n");
  EXPECT_EQ(x.r.source_line, (std::vector<std::uint64_t>{5, 5, 5, 5, 10, 13}));
}

TEST(ResolveFanuc, WhileMismatchedEnd) {
  Result x = run("#1=0\nWHILE [#1 LT 2] DO 1\n#1=#1+1\nEND 2\nM30\n");
  const Diagnostic d = first_error(x);
  EXPECT_EQ(d.code, "PP-E708");
  EXPECT_EQ(d.where.line, 2u);
  Result y = run("END 1\nM30\n");
  EXPECT_EQ(first_error(y).code, "PP-E708");
  EXPECT_EQ(first_error(y).where.line, 1u);
}

TEST(ResolveFanuc, G65ArgumentsAndLocalLevels) {
  const std::string src =
      "%\n"
      "O0001\n"
      "#1=99 (MAIN LOCAL)\n"
      "#100=0\n"
      "G65 P9010 A1. B2. X3. I4. (CALL)\n"
      "G65 P9010 L2 A5.\n"
      "G00 X#1 Y#100\n"
      "M30\n"
      "O9010 (MACRO)\n"
      "#100=#100+1\n"
      "G01 X#24 Y#1 Z#2 A#4\n"
      "#1=#1+100\n"
      "M99\n"
      "%\n";
  Result x = run(src);
  EXPECT_FALSE(x.sink.has_errors()) << diags(x.sink);
  EXPECT_EQ(x.r.text,
            "%\n"
            "O0001\n"
            "(MAIN LOCAL)\n"
            "(CALL)\n"
            "(MACRO)\n"
            "G01 X3. Y1. Z2. A4.\n"
            "(MACRO)\n"
            "G01 Y5.\n"
            "(MACRO)\n"
            "G01 Y5.\n"
            "G00 X99. Y3.\n"
            "M30\n"
            "%\n");
  // Call stacks: the macro lines name the G65 call site.
  ASSERT_EQ(x.r.stack.size(), 13u);
  EXPECT_EQ(x.r.stack[0], 0u);
  const auto& frames = x.r.stacks[x.r.stack[5]];
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].callee, "G65 P9010");
  EXPECT_EQ(frames[0].line, 5u);
  EXPECT_EQ(x.r.source_line[5], 11u);
  EXPECT_EQ(x.r.stacks[x.r.stack[7]][0].line, 6u);
}

TEST(ResolveFanuc, G65ArgumentSpecificationII) {
  const std::string src =
      "G65 P100 A1. I2. J3. K4. I5. J6.\n"
      "M30\n"
      "O100\n"
      "X#1 Y#4 Z#5 A#6 B#7 C#8\n"
      "M99\n";
  EXPECT_EQ(literal(src), "X1. Y2. Z3. A4. B5. C6.\nM30\n");
}

TEST(ResolveFanuc, M98RepeatsAndSameLocals) {
  const std::string src =
      "#1=0\n"
      "G00 X0. M98 P1000 L3\n"
      "M98 P00021000\n"
      "G00 X#1\n"
      "M30\n"
      ":1000\n"
      "#1=#1+1\n"
      "G91 G01 Z-1.\n"
      "M99\n";
  Result x = run(src);
  EXPECT_FALSE(x.sink.has_errors()) << diags(x.sink);
  EXPECT_EQ(x.r.text,
            "G00 X0.\n"
            "G91 G01 Z-1.\nG91 G01 Z-1.\nG91 G01 Z-1.\n"
            "G91 G01 Z-1.\nG91 G01 Z-1.\n"
            "G00 X5.\n"
            "M30\n");
  EXPECT_EQ(x.r.stacks[x.r.stack[1]][0].callee, "M98 P1000");
  EXPECT_EQ(x.r.stacks[x.r.stack[4]][0].line, 3u);
}

TEST(ResolveFanuc, SubprogramFileInSearchFolder) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() /
                       ("postproc_fanuc_" + std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
  fs::create_directories(dir);
  {
    std::ofstream(dir / "O2000.nc") << "%\nO2000 (POCKET)\nG01 X#24 Y#25\nG01 Z-1.\nM99\n%\n";
  }
  ResolveOptions opt;
  opt.search_dirs = {dir.string()};
  Result x = run("G65 P2000 X1. Y2.\nM98 P2000\nM30\n", opt);
  EXPECT_FALSE(x.sink.has_errors()) << diags(x.sink);
  // M98 keeps the caller's locals: #24/#25 are vacant there, so X and Y are left out (G01 stays).
  EXPECT_EQ(x.r.text, "(POCKET)\nG01 X1. Y2.\nG01 Z-1.\n(POCKET)\nG01\nG01 Z-1.\nM30\n");
  ASSERT_EQ(x.r.files.size(), 2u);
  EXPECT_EQ(x.r.source_file[1], 1u);
  EXPECT_EQ(x.r.source_line[1], 3u);
  fs::remove_all(dir);
}

TEST(ResolveFanuc, M99ReturnsToSequenceNumber) {
  const std::string src =
      "M98 P10\n"
      "X1. (SKIPPED)\n"
      "N50 X2.\n"
      "M30\n"
      "O10\n"
      "Z1.\n"
      "M99 P50\n";
  EXPECT_EQ(literal(src), "Z1.\nN50 X2.\nM30\n");
}

TEST(ResolveFanuc, M99InMainWarns) {
  Result x = run("G00 X1.\nM99\nX2.\n");
  EXPECT_FALSE(x.sink.has_errors()) << diags(x.sink);
  EXPECT_EQ(x.r.text, "G00 X1.\n");
  ASSERT_EQ(x.sink.stored().size(), 1u);
  EXPECT_EQ(x.sink.stored()[0].code, "PP-W701");
  EXPECT_EQ(x.sink.stored()[0].where.line, 2u);
}

TEST(ResolveFanuc, SystemVariableRefusedThenSet) {
  const std::string src = "G31 Z-10. F100.\n#1=#5063 (PROBED)\nG00 Z[#1+5.]\nM30\n";
  Result x = run(src);
  const Diagnostic d = first_error(x);
  EXPECT_EQ(d.code, "PP-E701");
  EXPECT_EQ(d.where.line, 2u);
  EXPECT_EQ(d.where.column, 4u);
  EXPECT_NE(d.message.find("#5063"), std::string::npos) << d.message;
  EXPECT_NE(d.message.find("skip position"), std::string::npos) << d.message;
  EXPECT_NE(d.message.find("--set '#5063="), std::string::npos) << d.message;

  ResolveOptions opt;
  opt.set["#5063"] = -7.25;
  Result y = run(src, opt);
  EXPECT_FALSE(y.sink.has_errors()) << diags(y.sink);
  EXPECT_EQ(y.r.text, "G31 Z-10. F100.\n(PROBED)\nG00 Z-2.25\nM30\n");
  EXPECT_EQ(y.r.used_settings.at("#5063"), -7.25);
}

TEST(ResolveFanuc, SystemVariableWrite) {
  Result x = run("#2001=0.5\nM30\n");
  EXPECT_EQ(first_error(x).code, "PP-E709");
  // Part count and clocks: harmless, stored.
  EXPECT_EQ(literal("#3901=4\nX#3901\nM30\n"), "X4.\nM30\n");
}

TEST(ResolveFanuc, RetainedCommonNeedsSet) {
  Result x = run("X#510\nM30\n");
  EXPECT_EQ(first_error(x).code, "PP-E701");
  EXPECT_EQ(literal("#510=2\nX#510 Y#100\nM30\n"), "X2.\nM30\n");
  ResolveOptions opt;
  opt.set["#510"] = 3;
  EXPECT_EQ(literal("X#510\nM30\n", opt), "X3.\nM30\n");
}

TEST(ResolveFanuc, AlarmRaised) {
  Result x = run("#1=1\nIF [#1 EQ 1] THEN #3000=15 (TOOL LIFE EXPIRED)\nM30\n");
  const Diagnostic d = first_error(x);
  EXPECT_EQ(d.code, "PP-E710");
  EXPECT_EQ(d.where.line, 2u);
  EXPECT_NE(d.message.find("alarm 15"), std::string::npos) << d.message;
  EXPECT_NE(d.message.find("TOOL LIFE EXPIRED"), std::string::npos) << d.message;
}

TEST(ResolveFanuc, DivisionByZeroAndDomainErrors) {
  Result x = run("#1=0\n#2=5/#1\nM30\n");
  const Diagnostic d = first_error(x);
  EXPECT_EQ(d.code, "PP-E707");
  EXPECT_EQ(d.where.line, 2u);
  EXPECT_EQ(d.where.column, 5u);
  EXPECT_EQ(first_error(run("#1=SQRT[-1]\n")).code, "PP-E707");
  EXPECT_EQ(first_error(run("#1=ASIN[2]\n")).code, "PP-E707");
  EXPECT_EQ(first_error(run("#1=LN[0]\n")).code, "PP-E707");
}

TEST(ResolveFanuc, SyntaxErrors) {
  EXPECT_EQ(first_error(run("#1=2+*3\n")).code, "PP-E702");
  EXPECT_EQ(first_error(run("#1=FOO[3]\n")).code, "PP-E702");
  EXPECT_EQ(first_error(run("IF [#1 EQ 0] X1.\n")).code, "PP-E702");
  EXPECT_EQ(first_error(run("X#40\n")).code, "PP-E703");
}

TEST(ResolveFanuc, MissingTargets) {
  Result x = run("G00 X1.\nGOTO 99\nM30\n");
  const Diagnostic d = first_error(x);
  EXPECT_EQ(d.code, "PP-E704");
  EXPECT_EQ(d.where.line, 2u);
  EXPECT_NE(d.message.find("N99"), std::string::npos) << d.message;
  EXPECT_EQ(first_error(run("M98 P4711\nM30\n")).code, "PP-E704");
  EXPECT_EQ(first_error(run("G66.1 P9010 A1.\nM30\n")).code, "PP-E709");
  EXPECT_EQ(first_error(run("G66 P9011 A1.\nG0 X1.\nM30\n")).code, "PP-E704");  // when the move calls it
}

TEST(ResolveFanuc, EndlessLoop) {
  ResolveOptions opt;
  opt.max_blocks = 100;
  Result x = run("N10 G91 X1.\nGOTO 10\n", opt);
  const Diagnostic d = first_error(x);
  EXPECT_EQ(d.code, "PP-E705");
  EXPECT_GE(d.where.line, 1u);
  EXPECT_LE(x.r.source_line.size(), 100u);
}

TEST(ResolveFanuc, CallDepth) {
  ResolveOptions opt;
  opt.max_call_depth = 5;
  Result x = run("M98 P1\nM30\nO1\nG00 X1.\nM98 P1\nM99\n", opt);
  const Diagnostic d = first_error(x);
  EXPECT_EQ(d.code, "PP-E706");
  EXPECT_EQ(d.where.line, 5u);
  EXPECT_NE(d.message.find("reached through"), std::string::npos) << d.message;
}

TEST(ResolveFanuc, ErrorInsideCallNamesTheStack) {
  Result x = run("G65 P9000 A0.\nM30\nO9000\n#2=1/#1\nM99\n");
  const Diagnostic d = first_error(x);
  EXPECT_EQ(d.code, "PP-E707");
  EXPECT_EQ(d.where.line, 4u);
  EXPECT_NE(d.message.find("G65 P9000"), std::string::npos) << d.message;
}

TEST(ResolveFanuc, LeaderAndPercentPassThrough) {
  const std::string src = "CAM LISTING #1\n%\nO0100\n#1=1\nX#1\nM30\n%\n";
  EXPECT_EQ(literal(src), "CAM LISTING #1\n%\nO0100\nX1.\nM30\n%\n");
}

// ---------------------------------------------------------------------------------------------
// Shared corpus: every Fanuc program using macro B (found with
// grep -lE '#[0-9]|M98|G65|WHILE|GOTO' on the corpus; nx_haas_vf2_trunnion_5t.ptp has '#' only
// inside comments and no macro statements, so it is not a macro program).

namespace {
std::string corpus_dir() {
  for (const char* c : {"/work/shared/corpus", "../shared/corpus"})
    if (std::filesystem::exists(std::string(c) + "/MANIFEST.tsv")) return c;
  return {};
}
std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
}  // namespace

TEST(ResolveFanucCorpus, FlangeMacroResolves) {
  // Lathe program with #501–#509 assigned at its top and bracketed expressions: fully determined,
  // so it resolves without errors.
  const std::string dir = corpus_dir();
  if (dir.empty()) GTEST_SKIP() << "shared corpus not found";
  const std::string text = slurp(dir + "/lathe/gcw_0100_flange_macro.nc");
  DiagnosticSink sink;
  ResolvedProgram r = resolve(text, "gcw_0100_flange_macro.nc", make_dialect(DialectId::fanuc), {}, sink);
  EXPECT_FALSE(sink.has_errors()) << diags(sink);
  EXPECT_NE(r.text.find("G0G96X350.Z50.S250M3M8(ROUGH SPIGOT)"), std::string::npos) << r.text;
  EXPECT_EQ(r.text.find('#'), std::string::npos) << r.text;
  EXPECT_EQ(r.text.find('['), std::string::npos) << r.text;
  EXPECT_NE(r.text.rfind("M30"), std::string::npos);
  EXPECT_EQ(r.text.back(), '\n');
}

TEST(ResolveFanucCorpus, HaasToolLifeRefusedWithoutTimers) {
  // Haas program testing tool-life timers (#5405, #5403) and raising #3000 alarms: the timers are
  // run-time state, so without --set it is refused with a located PP-E701 at line 7; with the
  // timers given it resolves, and with an expired timer the alarm is reported (PP-E710).
  const std::string dir = corpus_dir();
  if (dir.empty()) GTEST_SKIP() << "shared corpus not found";
  const std::string text = slurp(dir + "/three_axis/gcw_haas_macro_toollife.nc");
  {
    DiagnosticSink sink;
    (void)resolve(text, "gcw_haas_macro_toollife.nc", make_dialect(DialectId::fanuc), {}, sink);
    ASSERT_TRUE(sink.has_errors());
    const Diagnostic& d = sink.stored().front();
    EXPECT_EQ(d.code, "PP-E701");
    EXPECT_EQ(d.file, "gcw_haas_macro_toollife.nc");
    EXPECT_EQ(d.where.line, 7u);
    EXPECT_GE(d.where.column, 1u);
    EXPECT_NE(d.message.find("#5405"), std::string::npos) << d.message;
  }
  {
    ResolveOptions opt;
    opt.set["#5405"] = 100;
    opt.set["#5403"] = 200;
    DiagnosticSink sink;
    ResolvedProgram r = resolve(text, "gcw_haas_macro_toollife.nc", make_dialect(DialectId::fanuc), opt, sink);
    EXPECT_FALSE(sink.has_errors()) << diags(sink);
    EXPECT_NE(r.text.find("N40 ( TOOL LIFE EXPIRED )"), std::string::npos) << r.text;
    EXPECT_EQ(r.used_settings.size(), 2u);
  }
  {
    ResolveOptions opt;
    opt.set["#5405"] = 7000;
    DiagnosticSink sink;
    (void)resolve(text, "gcw_haas_macro_toollife.nc", make_dialect(DialectId::fanuc), opt, sink);
    ASSERT_TRUE(sink.has_errors());
    EXPECT_EQ(sink.stored().front().code, "PP-E710");
    EXPECT_EQ(sink.stored().front().where.line, 7u);
  }
}

TEST(ResolveFanucCorpus, EveryFanucMacroProgramResolvesOrIsRefusedAtALine) {
  const std::string dir = corpus_dir();
  if (dir.empty()) GTEST_SKIP() << "shared corpus not found";
  const Dialect fanuc = make_dialect(DialectId::fanuc);
  int checked = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const std::string name = e.path().filename().string();
    if (name == "MANIFEST.tsv" || name == "README.md") continue;
    const std::string text = slurp(e.path().string());
    // Fanuc-style programs of the corpus: the MANIFEST's dialect column says fanuc for these.
    const std::string rel = std::filesystem::relative(e.path(), dir).string();
    const std::string manifest = slurp(dir + "/MANIFEST.tsv");
    const auto at = manifest.find(rel + "\t");
    if (at == std::string::npos) continue;
    const auto line_end = manifest.find('\n', at);
    if (manifest.substr(at, line_end - at).find("\tfanuc\t") == std::string::npos) continue;
    if (!needs_resolution(text, fanuc)) continue;
    ++checked;
    DiagnosticSink sink;
    (void)resolve(text, rel, fanuc, {}, sink);
    for (const Diagnostic& d : sink.stored()) {
      if (d.severity != Severity::error) continue;
      EXPECT_EQ(d.file, rel);
      EXPECT_GE(d.where.line, 1u) << rel;
      EXPECT_GE(d.where.column, 1u) << rel;
      EXPECT_EQ(d.code.rfind("PP-E7", 0), 0u) << rel << ": " << format(d, false);
    }
  }
  EXPECT_GE(checked, 2);
}

// ---------------------------------------------------------------------------------------------

TEST(ResolveFanucSpeed, ThousandPassesOverThousandMoves) {
  std::string src = "#1=0\nWHILE [#1 LT 1000] DO 1\n";
  for (int i = 0; i < 1000; ++i) src += i % 2 ? "G01 X" + std::to_string(i) + ". Y[#1*0.5] F500.\n" : "G01 X1. Y2.\n";
  src += "#1=#1+1\nEND 1\nM30\n";
  // Wall time and process CPU time (the shared build machine is often loaded; the CPU time is
  // what the resolver itself costs).
  const auto t0 = std::chrono::steady_clock::now();
  const std::clock_t c0 = std::clock();
  Result x = run(src);
  const double cpu = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_FALSE(x.sink.has_errors()) << diags(x.sink);
  EXPECT_EQ(x.r.source_line.size(), 1'000'001u);
  const auto blocks = static_cast<double>(x.r.executed_blocks);
  const double rate = blocks / cpu;
  std::printf("resolved %llu blocks: wall %.3f s (%.2f M blocks/s), cpu %.3f s (%.2f M blocks/s)\n",
              static_cast<unsigned long long>(x.r.executed_blocks), s, blocks / s / 1e6, cpu, rate / 1e6);
  RecordProperty("blocks_per_cpu_second", std::to_string(rate));
#ifdef NDEBUG
  EXPECT_GE(rate, 1e6);
#endif
}

// G66 modal call: every block with an axis word calls the macro after its move, with G66's
// arguments, until G67; moves inside the macro do not call it again; L repeats each call.
TEST(ResolveFanuc, G66ModalCall) {
  const std::string program =
      "%\nO1000\nG21 G90 G17 G54\n#100=2.\nG0 X0. Y0. Z10.\nG66 P9010 R2. Z-5. F100.\nG0 X10. Y10.\nX20.\nM05\n"
      "G67\nG0 X30.\nM30\nO9010\nG0 Z#18\nG1 Z#26 F#9\nG0 Z#18\nM99\n%\n";
  Result x = run(program);
  ASSERT_FALSE(x.sink.has_errors()) << diags(x.sink);
  EXPECT_EQ(x.r.text,
            "%\nO1000\nG21 G90 G17 G54\nG0 X0. Y0. Z10.\nG0 X10. Y10.\nG0 Z2.\nG1 Z-5. F100.\nG0 Z2.\nX20.\n"
            "G0 Z2.\nG1 Z-5. F100.\nG0 Z2.\nM05\nG0 X30.\nM30\n%\n");
  // The macro's lines are reached through the G66 call at the move's line.
  ASSERT_GE(x.r.stack.size(), 6u);
  const auto& frames = x.r.stacks[x.r.stack[5]];
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].callee, "G66 P9010");
  EXPECT_EQ(frames[0].line, 7u);
  // L2: two calls after each move.
  const std::string twice = literal("G66 P9010 L2 R1. Z-1.\nG0 X5.\nG67\nM30\nO9010\nG1 Z#26\nM99\n");
  EXPECT_EQ(twice, "G0 X5.\nG1 Z-1.\nG1 Z-1.\nM30\n");
}

namespace {
// Found by fuzzing: a subprogram that runs off the end of its file is reported at the file's last
// line (it used to read past the end of the file's lines and crash).
TEST(ResolveFanuc, SubprogramRunningOffTheFileIsLocatedAtItsLastLine) {
  const Result x = run("O0001\nM98 P100\nM30\nO0100\nG0 X1.\n");
  const Diagnostic d = first_error(x);
  EXPECT_EQ(d.code, "PP-E708");
  EXPECT_EQ(d.where.line, 5u);
}
}  // namespace

namespace {
// Found by fuzzing: an endless M99 Pn loop of long blocks used 10 GB before the block limit; the
// resolved text is capped too (PP-E705 names both limits).
TEST(ResolveFanuc, EndlessLoopIsStoppedByTheTextLimitToo) {
  ResolveOptions opt;
  opt.max_resolved_bytes = 4096;
  // The fuzzer's loop changes nothing between passes: refused at once, on its second pass (issue 21).
  Result x = run("O0001\nN10 G1 X1.2345 Y2.3456 Z3.4567 A4.5678 B5.6789 F100.\nM99 P10\n", opt);
  EXPECT_EQ(first_error(x).code, "PP-E705");
  EXPECT_LE(x.r.source_line.size(), 3u);
  // A counter that changes every pass defeats that check: the text limit stops it.
  Result y = run("O0001\n#1=0\nN10 G1 X1.2345 Y2.3456 Z3.4567 A4.5678 B5.6789 F100.\n#1=#1+1\nM99 P10\n", opt);
  const Diagnostic d = first_error(y);
  EXPECT_EQ(d.code, "PP-E705");
  EXPECT_NE(d.message.find("MiB of resolved program"), std::string::npos) << d.message;
  EXPECT_LE(y.r.text.size(), 4096u);
}
}  // namespace
