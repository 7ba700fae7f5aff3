// LinuxCNC program resolution (issue 3): parameters, expressions, O-word subroutines and control
// flow resolved into the literal program, with source lines, call stacks and located refusals.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "postproc/error.hpp"
#include "postproc/gcode/resolve.hpp"

using namespace postproc::gcode;

namespace {

struct Run {
  ResolvedProgram r;
  DiagnosticSink sink;
};

Run resolve_text(const std::string& text, ResolveOptions opt = {}) {
  Run run;
  run.r = resolve(text, "t.ngc", make_dialect(DialectId::linuxcnc), opt, run.sink);
  return run;
}

std::string codes(const DiagnosticSink& s) {
  std::string c;
  for (const auto& d : s.stored()) c += d.code + "@" + std::to_string(d.where.line) + ":" + std::to_string(d.where.column) + " ";
  return c;
}

}  // namespace

TEST(ResolveLinuxcnc, NeedsResolutionOnlyForStatements) {
  const Dialect d = make_dialect(DialectId::linuxcnc);
  EXPECT_FALSE(needs_resolution("G1 X1 Y2 F100\n(comment [x])\nM2\n", d));
  EXPECT_TRUE(needs_resolution("G1 X#1\n", d));
  EXPECT_TRUE(needs_resolution("#1=2\n", d));
  EXPECT_TRUE(needs_resolution("o100 sub\n", d));
  EXPECT_EQ(first_resolution_line("G0 X0\nG1 X[1+2]\n", d), 2u);
}

TEST(ResolveLinuxcnc, ExpressionsAndAssignmentsAfterTheLine) {
  const auto run = resolve_text(
      "#1 = [2 ** 3 + 7 MOD 4 * 2 - 1]\n"
      "#2 = 1 #3 = #2 (assignments take effect after the line)\n"
      "G1 X#1 Y#3 Z[-#1 / 4] F[100 * 2]\n"
      "#<r> = 10\n"
      "G1 X[#<r> * COS[60]] Y[ATAN[1]/[1]] Z[SQRT[2] ** 2]\n"
      "G1 X[FIX[-2.5]] Y[FUP[2.1]] Z[ROUND[2.5]]\n"
      "M2\n");
  EXPECT_FALSE(run.sink.has_errors()) << codes(run.sink);
  EXPECT_EQ(run.r.text,
            " (assignments take effect after the line)\n"
            "G1 X13. Y0. Z-3.25 F200.\n"
            "G1 X5. Y45. Z2.\n"
            "G1 X-3. Y3. Z3.\n"
            "M2\n");
  EXPECT_EQ(run.r.source_line, (std::vector<std::uint64_t>{2, 3, 5, 6, 7}));
}

TEST(ResolveLinuxcnc, LoopsAndBranches) {
  const auto run = resolve_text(
      "#1 = 0\n"
      "o101 while [#1 LT 3]\n"
      "  G1 X[#1 * 10] F100\n"
      "  #1 = [#1 + 1]\n"
      "o101 endwhile\n"
      "o102 repeat [2]\n"
      "  G0 Z[5 + #1]\n"
      "o102 endrepeat\n"
      "o103 if [#1 EQ 2]\n"
      "  G1 Y1\n"
      "o103 elseif [#1 EQ 3]\n"
      "  G1 Y2\n"
      "o103 else\n"
      "  G1 Y3\n"
      "o103 endif\n"
      "#2 = 0\n"
      "o104 while [1]\n"
      "  #2 = [#2 + 1]\n"
      "  o105 if [#2 EQ 2]\n"
      "    o104 continue\n"
      "  o105 endif\n"
      "  G1 Z[#2]\n"
      "  o106 if [#2 GE 3]\n"
      "    o104 break\n"
      "  o106 endif\n"
      "o104 endwhile\n"
      "M2\n");
  EXPECT_FALSE(run.sink.has_errors()) << codes(run.sink);
  EXPECT_EQ(run.r.text,
            "  G1 X0. F100\n  G1 X10. F100\n  G1 X20. F100\n"
            "  G0 Z8.\n  G0 Z8.\n"
            "  G1 Y2\n"
            "  G1 Z1.\n  G1 Z3.\n"
            "M2\n");
  EXPECT_EQ(run.r.source_line, (std::vector<std::uint64_t>{3, 3, 3, 7, 7, 12, 22, 22, 27}));
}

// rs274 2.9 (interp_o_word.cc): a continue in a do loop leaves doing_continue set; a loop that then
// ends by skipping to its endrepeat or endwhile goes back to its head instead. A repeat reads its count
// again there and runs again (forever when the do loop is in its body: rs274_control_compare seed
// 7032); a while loop left by break runs on while its condition holds. Both are refused at the line
// that would differ; where the head's second reading ends the loop anyway the program is read
// (tests/resolve/linuxcnc/reader_loop_flags.ngc, compared with rs274).
TEST(ResolveLinuxcnc, LoopsAfterAContinueInADoLoopAreRefusedWhereRs274RunsThemAgain) {
  const std::string pending_continue =
      "#1 = 0\n"
      "o1 do\n"
      "  #1 = [#1 + 1]\n"
      "  o2 if [#1 EQ 1]\n"
      "    o1 continue\n"
      "  o2 endif\n"
      "  G1 X#1 F100\n"
      "o1 while [#1 LT 2]\n";
  const auto repeat = resolve_text(pending_continue + "o3 repeat [2]\n  G1 Y1\no3 endrepeat\nM2\n");
  ASSERT_TRUE(repeat.sink.has_errors());
  EXPECT_EQ(repeat.sink.stored().front().code, "PP-E709");
  EXPECT_EQ(repeat.sink.stored().front().where.line, 9u) << codes(repeat.sink);
  const auto brk = resolve_text(pending_continue +
                                "#5 = 0\no4 while [#5 LT 3]\n  #5 = [#5 + 1]\n  G1 Y#5\n  o4 break\no4 endwhile\nM2\n");
  ASSERT_TRUE(brk.sink.has_errors());
  EXPECT_EQ(brk.sink.stored().front().code, "PP-E709");
  EXPECT_EQ(brk.sink.stored().front().where.line, 13u) << codes(brk.sink);
  // The same loops without the continue pending (a while loop ended on its condition spent it).
  const auto spent = resolve_text(pending_continue +
                                  "o5 while [#1 LT 2]\no5 endwhile\no3 repeat [2]\n  G1 Y1\no3 endrepeat\nM2\n");
  EXPECT_FALSE(spent.sink.has_errors()) << codes(spent.sink);
  EXPECT_EQ(spent.r.text, "  G1 X2. F100\n  G1 Y1\n  G1 Y1\nM2\n");
}

// o[expression] call: rs274 reads the number as a whole number (within 0.0001) naming the numbered
// subroutine; other values stop it ("Non integer value for integer"). A computed number on any other
// O-word is refused (the trap tests/resolve/linuxcnc/reader_oword_computed.ngc runs in rs274_compare).
TEST(ResolveLinuxcnc, ComputedOWordNumberNamesTheSubroutineCalled) {
  const std::string subs = "o100 sub\n  G1 X#1 F100\no100 endsub\n";
  const auto run = resolve_text(subs + "#5 = 99.99995\no[#5] call [3]\no[#5 + 0.00004] call [4]\nM2\n");
  EXPECT_FALSE(run.sink.has_errors()) << codes(run.sink);
  EXPECT_EQ(run.r.text, "  G1 X3. F100\n  G1 X4. F100\nM2\n");
  const auto frac = resolve_text(subs + "#5 = 100.4\no[#5] call [3]\nM2\n");
  ASSERT_TRUE(frac.sink.has_errors());
  EXPECT_EQ(frac.sink.stored().front().code, "PP-E207") << codes(frac.sink);
  const auto other = resolve_text("o[1] if [1]\no[1] endif\nM2\n");
  ASSERT_TRUE(other.sink.has_errors());
  EXPECT_EQ(other.sink.stored().front().code, "PP-E702") << codes(other.sink);
}

// rs274 2.9 carries out a 'break' of a loop that it passes while skipping to that loop's end (the
// skip carries the loop's name): a while loop ended by its condition with a break in its body (not
// taken) leaves doing_break set, and the next do … while runs once (rs274_control_compare seed 7469).
// Refused where the do loop would go back; a continue of a do loop that skips over a break of the
// same loop ends the loop, as rs274 does (tests/resolve/linuxcnc/reader_loop_breaks.ngc).
TEST(ResolveLinuxcnc, BreakPassedWhileSkippingIsCarriedOutAsRs274Does) {
  const std::string untaken_break =
      "#4 = 0\n"
      "o107 while [#4 LT 2]\n"
      "  #4 = [#4 + 1]\n"
      "  o108 if [#4 EQ 0]\n"
      "    o107 break\n"
      "  o108 endif\n"
      "o107 endwhile\n";
  const auto run = resolve_text(untaken_break + "#1 = 0\no102 do\n  #1 = [#1 + 1]\n  G1 X#1 F100\no102 while [#1 LT 3]\nM2\n");
  ASSERT_TRUE(run.sink.has_errors());
  EXPECT_EQ(run.sink.stored().front().code, "PP-E709") << codes(run.sink);
  EXPECT_EQ(run.sink.stored().front().where.line, 12u) << codes(run.sink);
  // Without the break line the do loop runs all its passes.
  const auto plain = resolve_text("#4 = 0\no107 while [#4 LT 2]\n  #4 = [#4 + 1]\no107 endwhile\n"
                                  "#1 = 0\no102 do\n  #1 = [#1 + 1]\n  G1 X#1 F100\no102 while [#1 LT 3]\nM2\n");
  EXPECT_FALSE(plain.sink.has_errors()) << codes(plain.sink);
  EXPECT_EQ(plain.r.text, "  G1 X1. F100\n  G1 X2. F100\n  G1 X3. F100\nM2\n");
}

// rs274 rounds a repeat count to the nearest integer, ties to even (checked with rs274 2.9).
TEST(ResolveLinuxcnc, RepeatCountIsRoundedAsRs274) {
  for (const auto& [count, passes] : std::vector<std::pair<std::string, int>>{
           {"2.6", 3}, {"2.5", 2}, {"3.5", 4}, {"1.4", 1}, {"0.5", 0}, {"-1", 0}}) {
    const auto run = resolve_text("o1 repeat [" + count + "]\n  G1 X1 F100\no1 endrepeat\nM2\n");
    EXPECT_FALSE(run.sink.has_errors()) << codes(run.sink);
    std::string want;
    for (int k = 0; k < passes; ++k) want += "  G1 X1 F100\n";
    EXPECT_EQ(run.r.text, want + "M2\n") << count;
  }
}

TEST(ResolveLinuxcnc, SubroutinesWithArgumentsLocalsRecursionAndReturnValues) {
  const auto run = resolve_text(
      "o200 sub\n"
      "  #<n> = #1\n"
      "  o201 if [#<n> GT 0]\n"
      "    G1 X[#<n>] Y[#2] F250\n"
      "    o200 call [#<n> - 1] [#2 + 1]\n"
      "  o201 endif\n"
      "  o200 return [#2 * 2]\n"
      "o200 endsub\n"
      "#2 = 7\n"
      "o200 call [2] [10]\n"
      "G1 X#<_value> Y#2\n"
      "M2\n");
  EXPECT_FALSE(run.sink.has_errors()) << codes(run.sink);
  EXPECT_EQ(run.r.text, "    G1 X2. Y10. F250\n    G1 X1. Y11. F250\nG1 X20. Y7.\nM2\n");
  ASSERT_EQ(run.r.stack.size(), 4u);
  const auto& inner = run.r.stacks[run.r.stack[1]];
  ASSERT_EQ(inner.size(), 2u);  // main → o200 (line 10) → o200 (line 5)
  EXPECT_EQ(inner[0].line, 10u);
  EXPECT_EQ(inner[1].line, 5u);
  EXPECT_EQ(inner[0].callee, "o200 call");
  EXPECT_EQ(run.r.stack[2], 0u);
}

TEST(ResolveLinuxcnc, SubroutineFileNextToTheProgram) {
  const auto dir = std::filesystem::temp_directory_path() / "postproc_resolve_lcnc";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "square.ngc") << "o<square> sub\n  G1 X#1 F100\n  G1 Y#1\no<square> endsub\n";
  ResolveOptions opt;
  opt.search_dirs.push_back(dir.string());
  const auto run = resolve_text("o<square> call [4]\nM2\n", opt);
  EXPECT_FALSE(run.sink.has_errors()) << codes(run.sink);
  EXPECT_EQ(run.r.text, "  G1 X4. F100\n  G1 Y4.\nM2\n");
  EXPECT_EQ(run.r.files.size(), 2u);
  EXPECT_EQ(run.r.source_file[0], 1u);
  const auto missing = resolve_text("o<nothere> call\nM2\n", opt);
  EXPECT_EQ(codes(missing.sink), "PP-E704@1:1 ");
  std::filesystem::remove_all(dir);
}

TEST(ResolveLinuxcnc, RuntimeParametersAreRefusedUnlessSet) {
  const auto refused = resolve_text("G38.2 Z-10 F100\nG1 Z#5063\nM2\n");
  ASSERT_TRUE(refused.sink.has_errors());
  EXPECT_EQ(refused.sink.stored()[0].code, "PP-E701");
  EXPECT_NE(refused.sink.stored()[0].message.find("#5063"), std::string::npos);
  EXPECT_EQ(refused.sink.stored()[0].where.line, 2u);
  ResolveOptions opt;
  opt.set["#5063"] = -4.5;
  const auto given = resolve_text("G38.2 Z-10 F100\nG1 Z[#5063 + 1]\nM2\n", opt);
  EXPECT_FALSE(given.sink.has_errors()) << codes(given.sink);
  EXPECT_EQ(given.r.text, "G38.2 Z-10 F100\nG1 Z-3.5\nM2\n");
  EXPECT_EQ(given.r.used_settings.at("#5063"), -4.5);
  EXPECT_EQ(codes(resolve_text("G1 X#<_x>\n").sink), "PP-E701@1:5 ");
}

// LinuxCNC G-code "G38.x Straight Probe": the probe writes #5061–#5070 when it runs (modal group 1:
// axis words after G38.2 probe again). A value the program set before a probe is gone: a loop on
// #5070 (smartprobe.ngc in LinuxCNC's samples) is refused at the read, not run to the block limit.
TEST(ResolveLinuxcnc, ProbingForgetsTheProbeResultsTheProgramSet) {
  const auto loop = resolve_text("#5070=1\no4 while [#5070 NE 0]\n  G38.5 Z1 F20\n  G38.3 X2\no4 endwhile\nM2\n");
  EXPECT_EQ(codes(loop.sink), "PP-E701@2:1 ");
  // Set and read before any probe: the program's value.
  const auto before = resolve_text("#5070=1\nG1 X#5070 F10\nM2\n");
  EXPECT_FALSE(before.sink.has_errors()) << codes(before.sink);
  EXPECT_EQ(before.r.text, "G1 X1. F10\nM2\n");  // the assignment line is consumed
  // Modal: a line of axis words after G38.2 probes again; after G1 it does not.
  const auto modal = resolve_text("G38.2 Z-1 F10\n#5063=2\nZ-2\nG1 X#5063\nM2\n");
  EXPECT_EQ(codes(modal.sink), "PP-E701@4:5 ");
  const auto ended = resolve_text("G38.2 Z-1 F10\nG1 X0\n#5063=2\nZ-2\nG1 X#5063\nM2\n");
  EXPECT_FALSE(ended.sink.has_errors()) << codes(ended.sink);
}

// Found by fuzzing: an O-word statement after other words ("Z2 o1 endwhile") is rs274's "Bad character
// 'o' used"; it used to end in an internal error (the loop structure did not know the line).
TEST(ResolveLinuxcnc, OWordAfterOtherWordsIsRefusedLocated) {
  const auto r = resolve_text("o1 while [1 LT 0]\nG0 X1\nZ2.0 o1 endwhile\nM2\n");
  EXPECT_EQ(codes(r.sink), "PP-E708@3:6 ");
}

// rs274 (LinuxCNC 2.9), checked with rs274 -g: a number names one O-word block within the main
// program or one subroutine ("duplicate O-word label", also after the first block closed), and
// nothing but comments may follow a keyword that takes no argument ("Unexpected character after
// O-word"). tests/resolve/linuxcnc/reader_oword_spacing.ngc has the forms it accepts.
TEST(ResolveLinuxcnc, OWordLabelsAndTrailingTextAsRs274) {
  EXPECT_EQ(codes(resolve_text("o100 if [1]\nG0 X1\no100 endif\no100 if [1]\nG0 X2\no100 endif\nM2\n").sink),
            "PP-E708@4:1 ");
  EXPECT_EQ(codes(resolve_text("o100 while [#1 LT 3]\n#1=[#1+1]\no100 if [#1 GT 1]\no100 break\no100 endif\n"
                               "o100 endwhile\nM2\n").sink),
            "PP-E708@3:1 ");
  EXPECT_EQ(codes(resolve_text("o100 repeat [2]\nG0 X1\no100 endrepeat\no100 repeat [2]\no100 endrepeat\nM2\n").sink),
            "PP-E708@4:1 ");
  // only blocks that run count: the same number in the two branches of an if (LinuxCNC's own
  // qt_auto_probe_tool.ngc), or in a branch not taken, passes
  EXPECT_FALSE(resolve_text("o150 if [1]\no175 if [0]\nG0 X1\no175 endif\no150 else\no175 if [1]\nG0 X2\n"
                            "o175 endif\no150 endif\nM2\n").sink.has_errors());
  EXPECT_FALSE(resolve_text("o1 if [0]\no100 if [1]\no100 endif\no1 endif\no100 if [1]\nG0 X1\no100 endif\nM2\n")
                   .sink.has_errors());
  // a subroutine's numbers are its own; a do closed by its while is one block
  EXPECT_FALSE(resolve_text("o<a> sub\no100 if [1]\nG0 X1\no100 endif\no<a> endsub\no100 if [1]\nG0 X2\n"
                            "o100 endif\no<a> call\no<a> call\nM2\n").sink.has_errors());
  EXPECT_FALSE(resolve_text("o1 do\n#1=[#1+1]\no1 while [#1 LT 3]\nM2\n").sink.has_errors());
  EXPECT_EQ(codes(resolve_text("o100 if [1]\nG0 Z1\no100 endif G0 Z9\nM2\n").sink).substr(0, 10), "PP-E702@3:");
  EXPECT_EQ(codes(resolve_text("o100 if [0]\nG0 Z1\no100 else [3]\nG0 Z2\no100 endif\nM2\n").sink), "PP-E702@3:1 ");
  EXPECT_EQ(codes(resolve_text("o100 sub [1]\nG0 Z1\no100 endsub\no100 call\nM2\n").sink).substr(0, 12), "PP-E702@1:1 ");
  // "else if" is elseif, not else followed by text
  const auto r = resolve_text("o100 if [0]\nG0 X1\no100 else if [0]\nG0 X2\no100 e lse\nG0 X3\no100 end if\nM2\n");
  EXPECT_FALSE(r.sink.has_errors()) << codes(r.sink);
  EXPECT_EQ(r.r.text, "G0 X3\nM2\n");
}

// A file of subroutine definitions only: rs274 runs it without a move (checked with rs274 -g on
// LinuxCNC's twp square.ngc); read so, with a warning that its moves are read where it is called.
TEST(ResolveLinuxcnc, FileOfSubroutinesOnlyRunsWithoutAMove) {
  const auto r = resolve_text("o<square> sub\nG1 X#1 F100\no<square> endsub\n");
  EXPECT_FALSE(r.sink.has_errors()) << codes(r.sink);
  EXPECT_EQ(codes(r.sink), "PP-U223@1:1 ");
}

TEST(ResolveLinuxcnc, ErrorsAreLocated) {
  EXPECT_EQ(codes(resolve_text("G1 X#<undefined>\n").sink), "PP-E703@1:5 ");
  EXPECT_EQ(codes(resolve_text("G1 X[1/0]\n").sink), "PP-E707@1:5 ");
  EXPECT_EQ(codes(resolve_text("G1 X[SQRT[-1]]\n").sink), "PP-E707@1:5 ");
  EXPECT_EQ(codes(resolve_text("G1 X[1 +]\n").sink).substr(0, 7), "PP-E702");
  EXPECT_EQ(codes(resolve_text("o100 while [1]\nG1 X1\n").sink).substr(0, 7), "PP-E708");
  EXPECT_EQ(codes(resolve_text("o100 endwhile\n").sink).substr(0, 7), "PP-E708");
  EXPECT_EQ(codes(resolve_text("o100 call\n").sink), "PP-E704@1:1 ");
  EXPECT_EQ(codes(resolve_text("(abort, tool broken)\n").sink), "PP-E710@1:1 ");
  ResolveOptions small;
  small.max_blocks = 100;
  EXPECT_EQ(codes(resolve_text("o1 while [1]\nG1 X1\no1 endwhile\n", small).sink).substr(0, 7), "PP-E705");
  ResolveOptions shallow;
  shallow.max_call_depth = 5;
  EXPECT_EQ(codes(resolve_text("o1 sub\no1 call\no1 endsub\no1 call\n", shallow).sink).substr(0, 7), "PP-E706");
}

TEST(ResolveLinuxcnc, DiagnosticsMapBackToTheSource) {
  const auto run = resolve_text("o1 sub\n  G1 X#1\no1 endsub\no1 call [5]\nM2\n");
  ASSERT_FALSE(run.sink.has_errors());
  Diagnostic d;
  d.code = "PP-U999";
  d.file = "t.ngc";
  d.where = {1, 4};
  d.source_line = "  G1 X5.";
  map_to_source(run.r, d);
  EXPECT_EQ(d.where.line, 2u);
  EXPECT_NE(d.message.find("reached through o1 call at t.ngc:4"), std::string::npos) << d.message;
}

TEST(ResolveLinuxcnc, ParseSetting) {
  EXPECT_EQ(parse_setting("#5061=1.25").first, "#5061");
  EXPECT_EQ(parse_setting("#<_probe>= -2").second, -2);
  EXPECT_EQ(parse_setting("#<_probe>=-2").first, "#<_PROBE>");
  EXPECT_THROW((void)parse_setting("#5061"), postproc::Error);
  EXPECT_THROW((void)parse_setting("#5061=abc"), postproc::Error);
}

// A program that opens with '%' keeps its closing '%' when M2 ends the run before it (without it,
// rs274 reports "percent sign missing from end of file"); without the opening one, nothing after
// M2 is written.
TEST(ResolveLinuxcnc, ClosingPercentAfterTheProgramEnd) {
  auto run = resolve_text("%\n#1 = 2\nG0 X#1\nM2\no100 sub\nG0 X9\no100 endsub\n%\n\n");
  EXPECT_FALSE(run.sink.has_errors()) << codes(run.sink);
  EXPECT_EQ(run.r.text, "%\nG0 X2.\nM2\n%\n");
  EXPECT_EQ(run.r.source_line.back(), 8u);
  run = resolve_text("#1 = 2\nG0 X#1\nM2\n%\n");
  EXPECT_EQ(run.r.text, "G0 X2.\nM2\n");
  run = resolve_text("%\n#1 = 2\nG0 X#1\n%\n");  // no M2: the closing '%' ends it
  EXPECT_EQ(run.r.text, "%\nG0 X2.\n%\n");
}
