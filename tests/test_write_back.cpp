// compensate on programs with parameters, subprograms and control flow, written back into their own
// lines (write_back.hpp): the written program, resolved again, is exactly the flattened compensated
// program; what needs no change stays byte for byte; what cannot be written back exactly is
// refused at its line and word.
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <random>

#include <fmt/format.h>
#include <fstream>
#include <sstream>

#include "postproc/compensation/compensate.hpp"
#include "postproc/compensation/diff.hpp"
#include "postproc/gcode/write_back.hpp"
#include "postproc/contour/path.hpp"
#include "postproc/gcode/convert.hpp"
#include "postproc/gcode/resolve.hpp"
#include "postproc/machine/machine.hpp"
#include "sample_machine.hpp"
#include "support.hpp"

namespace {
namespace mc = postproc::machine;
namespace gc = postproc::gcode;
namespace cp = postproc::comp;
using pptest::TempDir;

mc::Machine load(const std::string& name) { return pptest::sample_machine(name); }

struct Outcome {
  std::string out;
  cp::CompensateResult result;
  gc::DiagnosticSink sink;
  [[nodiscard]] bool ok() const { return !sink.has_errors(); }
  [[nodiscard]] std::string errors() const {
    std::string s;
    for (const auto& d : sink.stored()) s += gc::format(d) + "\n";
    return s;
  }
};

void run(const mc::Machine& m, std::string_view program, Outcome& r, bool flatten, const std::string& mode = "geometric",
         const std::string& file = "in.nc", bool header = true) {
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  cp::CompensateOptions opt;
  opt.tool_version = "test";
  opt.flatten = flatten;
  opt.mode = *postproc::comp::parse_mode(mode);
  opt.header = header;
  auto mem = postproc::io::OutputFile::memory();
  r.result = cp::compensate_program({program, file, d, m}, opt, mem, r.sink);
  r.out = mem.take();
}

/// The lines of `text` without the header comment (and without "\r").
std::vector<std::string> lines_without_header(std::string_view text) {
  std::vector<std::string> out;
  std::istringstream in{std::string(text)};
  for (std::string l; std::getline(in, l);) {
    if (!l.empty() && l.back() == '\r') l.pop_back();
    if (l.find("postproc test compensate") != std::string::npos) continue;
    out.push_back(l);
  }
  return out;
}

/// Compensated in place and flattened; the in-place program, resolved again, must be the flattened
/// one line for line.
void expect_same_as_flattened(const mc::Machine& m, std::string_view program, const std::string& mode = "geometric") {
  Outcome in_place, flat;
  run(m, program, in_place, false, mode);
  ASSERT_TRUE(in_place.ok()) << in_place.errors();
  run(m, program, flat, true, mode);
  ASSERT_TRUE(flat.ok()) << flat.errors();
  EXPECT_NE(in_place.out, program);
  EXPECT_NE(in_place.out.find("resolved=parameters, calls and loops kept"), std::string::npos);
  EXPECT_NE(flat.out.find("flattened="), std::string::npos);
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  gc::DiagnosticSink sink;
  const gc::ResolvedProgram again = gc::resolve(in_place.out, "out.nc", d, {}, sink);
  ASSERT_FALSE(sink.has_errors());
  ASSERT_TRUE(again.resolved);
  EXPECT_EQ(lines_without_header(again.text), lines_without_header(flat.out));
  // The contour stage's verification gate (issue 17) may withhold the runs' corrections: then
  // nothing is rewritten in contour mode.
  if (mode != "contour" || in_place.result.changed_blocks > 0) {
    EXPECT_GT(in_place.result.source_lines_rewritten, 0u);
  }
  EXPECT_GT(in_place.result.resolved_lines, 0u);
  // Through a machine without geometric errors the program comes back byte for byte (the servo
  // modes still correct the drives' lag).
  if (mode != "geometric") return;
  mc::Machine perfect = m;
  perfect.actual = perfect.nominal;
  Outcome same;
  run(perfect, program, same, false, mode, "in.nc", false);
  ASSERT_TRUE(same.ok()) << same.errors();
  EXPECT_EQ(same.out, program);
}

/// The one error of a refused run.
const gc::Diagnostic& only_error(const Outcome& r) {
  EXPECT_EQ(r.sink.count(gc::Severity::error), 1u) << r.errors();
  static const gc::Diagnostic none;
  for (const gc::Diagnostic& d : r.sink.stored())  // warnings (e.g. PP-W620) may come first
    if (d.severity == gc::Severity::error) return d;
  return none;
}

bool has_line(std::string_view text, std::string_view line) {
  const auto lines = lines_without_header(text);
  return std::find(lines.begin(), lines.end(), std::string(line)) != lines.end();
}

const char* const kLinuxCnc = R"(%
(in place: parameters, a subroutine called once, a branch, a loop whose runs agree)
G21 G90 G94 G18 G8
G54
T1 M6
#<_cut_feed> = 300
o100 sub
  G1 X46. Z0. B-3. C20.
  #<_depth> = [#<_depth> + 1]
o100 endsub
#<_depth> = 0
G0 X60. Z10. B0. C0.
G1 X45. Z2. F#<_cut_feed>
o100 call
o200 if [#<_depth> GT 0]
  G1 X47.5 Z-5. B-4. C40. (taken)
o200 else
  G1 X48. Z-6. B-2. C50. (not taken)
o200 endif
o300 repeat [2]
  G0 X60. Z10. B0. C0.
  G1 X45. Z2. B0. C0.
o300 endrepeat
G1 X48. Z-8. B-1. C60. #<x> = 5
G0 X60.
M30
%
)";

const char* const kFanuc = R"(%
O1000
G21 G90 G94 G17
G54
G43 H1
#100=500
G0 X0. Y0. Z50. A0. C0.
G65 P9001 A10. B20.
G1 X10. Y20. Z5. A10. C30. F#100
IF [#100 GT 100] GOTO 10
G1 X99. Y99. Z5. A0. C0.
N10 G1 X15. Y25. Z5. A15. C35.
#1=0
WHILE [#1 LT 2] DO 1
G0 X0. Y0. Z20. A0. C0.
G1 X1. Y0. Z20. A0. C0.
#1=#1+1
END 1
G0 Z50.
M30
O9001
G1 X5. Y5. Z10. A0. C0. F[#2*10]
M99
%
)";

const char* const kSiemens = R"(N10 G17 G90 G54 G71
N20 DEF REAL DEPTH
N30 R1=5 DEPTH=-2
N40 G0 X0 Y0 Z50 A0 C0
N50 G1 X10 Y20 Z5 A10 C30 F=R1*100
N60 IF R1>3 GOTOF SKIP
N70 G1 X99 Y99 Z5 A0 C0
N80 SKIP: G1 X15 Y25 Z5 A15 C35
N85 G1 X100 Y0 Z5 A60 C180
N90 M30
)";

TEST(WriteBack, LinuxCncInPlaceEqualsFlattened) {
  const mc::Machine m = load("lathe_xzbc_doc004.toml");
  expect_same_as_flattened(m, kLinuxCnc);
  Outcome r;
  run(m, kLinuxCnc, r, false);
  ASSERT_TRUE(r.ok()) << r.errors();
  // Statements, the branch not taken and comments stay byte for byte; the literal words of the
  // executed moves are corrected; F#<_cut_feed> keeps its parameter.
  for (const char* kept : {"#<_cut_feed> = 300", "  #<_depth> = [#<_depth> + 1]", "o200 if [#<_depth> GT 0]",
                           "  G1 X48. Z-6. B-2. C50. (not taken)", "o300 repeat [2]", "M30"})
    EXPECT_TRUE(has_line(r.out, kept)) << kept;
  EXPECT_FALSE(has_line(r.out, "G1 X45. Z2. F#<_cut_feed>"));
  EXPECT_NE(r.out.find(" F#<_cut_feed>\n"), std::string::npos);
  EXPECT_NE(r.out.find("#<x> = 5\n"), std::string::npos);  // the assignment on a move line is kept
  EXPECT_EQ(lines_without_header(r.out).size(), lines_without_header(kLinuxCnc).size() + r.result.segments_added);
}

TEST(WriteBack, FanucInPlaceEqualsFlattened) {
  const mc::Machine m = load("trunnion_ac_fanuc.toml");
  expect_same_as_flattened(m, kFanuc);
  Outcome r;
  run(m, kFanuc, r, false);
  ASSERT_TRUE(r.ok()) << r.errors();
  for (const char* kept : {"#100=500", "G65 P9001 A10. B20.", "IF [#100 GT 100] GOTO 10", "G1 X99. Y99. Z5. A0. C0.",
                           "WHILE [#1 LT 2] DO 1", "END 1", "O9001", "M99"})
    EXPECT_TRUE(has_line(r.out, kept)) << kept;
  // The subdivided move's added points follow it as new lines.
  EXPECT_GT(r.result.segments_added, 0u);
  EXPECT_EQ(lines_without_header(r.out).size(), lines_without_header(kFanuc).size() + r.result.segments_added);
  // The header goes after '%' and the program number, as in a flat program.
  EXPECT_EQ(r.out.substr(0, 8), "%\nO1000\n");
  EXPECT_EQ(r.out.substr(8, 9), "(postproc");
}

TEST(WriteBack, SiemensInPlaceEqualsFlattened) {
  const mc::Machine m = load("trunnion_ac_siemens.toml");
  expect_same_as_flattened(m, kSiemens);
  Outcome r;
  run(m, kSiemens, r, false);
  ASSERT_TRUE(r.ok()) << r.errors();
  EXPECT_TRUE(has_line(r.out, "N70 G1 X99 Y99 Z5 A0 C0"));
  EXPECT_TRUE(has_line(r.out, "N30 R1=5 DEPTH=-2"));
  EXPECT_NE(r.out.find("F=R1*100\n"), std::string::npos);
  EXPECT_NE(r.out.find("\nN80 SKIP: G1 X15."), std::string::npos);
}

TEST(WriteBack, ContourModesInPlaceEqualFlattened) {
  // The servo correction of a move depends on the moves around it, so the loop whose runs agree
  // geometrically does not here (refused below); this program's loop runs once.
  const mc::Machine m = load("lathe_xzbc_doc004.toml");
  const std::string once = R"(%
G21 G90 G94 G18 G8
G54
T1 M6
#<_cut_feed> = 300
G0 X60. Z10. B0. C0.
G1 X45. Z2. F#<_cut_feed>
G1 X46. Z0. B-3. C20.
o100 repeat [1]
  G0 X60. Z10.
o100 endrepeat
o200 if [#<_cut_feed> GT 100]
  G1 X47.5 Z-5. B-4. C40.
o200 else
  G1 X48. Z-6. B-2. C50.
o200 endif
G1 X48. Z-8. C60.
G0 X60.
M30
%
)";
  expect_same_as_flattened(m, once, "contour");
  expect_same_as_flattened(m, once, "all");
  Outcome r;
  run(m, kLinuxCnc, r, false, "all");
  EXPECT_EQ(only_error(r).where.line, 22u);
}

TEST(WriteBack, LineEndsAreKept) {
  const mc::Machine m = load("trunnion_ac_fanuc.toml");
  std::string crlf;
  for (const char* c = kFanuc; *c != 0; ++c) {
    if (*c == '\n') crlf += '\r';
    crlf += *c;
  }
  Outcome r;
  run(m, crlf, r, false);
  ASSERT_TRUE(r.ok()) << r.errors();
  std::size_t lf = 0, crlf_ends = 0;
  for (std::size_t i = 0; i < r.out.size(); ++i)
    if (r.out[i] == '\n') {
      ++lf;
      if (i > 0 && r.out[i - 1] == '\r') ++crlf_ends;
    }
  EXPECT_EQ(lf, crlf_ends);  // the added lines of the subdivided move too
  Outcome lf_run;
  run(m, kFanuc, lf_run, false);
  std::string stripped = r.out;
  stripped.erase(std::remove(stripped.begin(), stripped.end(), '\r'), stripped.end());
  EXPECT_EQ(stripped, lf_run.out);
}

TEST(WriteBack, ExpressionThatNeedsACorrectionIsRefused) {
  const mc::Machine m = load("lathe_xzbc_doc004.toml");
  const std::string program = "G21 G90 G18 G8\nG54\n#<r> = 45\nG0 X60. Z10. B0. C0.\nG1 X[#<r> + 1] Z2. F300.\nM30\n";
  Outcome r;
  run(m, program, r, false);
  EXPECT_TRUE(r.out.empty());
  const gc::Diagnostic& d = only_error(r);
  EXPECT_EQ(d.code, "PP-E711");
  EXPECT_EQ(d.where.line, 5u);
  EXPECT_EQ(d.where.column, 4u);
  EXPECT_EQ(d.length, std::string("X[#<r> + 1]").size());
  EXPECT_NE(d.message.find("written as 'X[#<r> + 1]' here (as resolved: X46.)"), std::string::npos) << d.message;
  EXPECT_NE(d.message.find("--flatten"), std::string::npos);
  // --flatten writes it.
  Outcome flat;
  run(m, program, flat, true);
  EXPECT_TRUE(flat.ok()) << flat.errors();
}

TEST(WriteBack, LoopBodyWithDifferentCorrectionsIsRefused) {
  const mc::Machine m = load("trunnion_ac_fanuc.toml");
  const std::string program =
      "G21 G90 G17 G54 G43 H1\nG0 X0. Y0. Z50. A0. C0.\n#1=0\nWHILE [#1 LT 3] DO 1\nG91 G1 X10. F500.\n#1=#1+1\n"
      "END 1\nG90\nM30\n";
  Outcome r;
  run(m, program, r, false);
  const gc::Diagnostic& d = only_error(r);
  EXPECT_EQ(d.code, "PP-E711");
  EXPECT_EQ(d.where.line, 5u);
  EXPECT_NE(d.message.find("runs 3 times"), std::string::npos) << d.message;
  EXPECT_NE(d.message.find("differ between runs"), std::string::npos) << d.message;
}

TEST(WriteBack, MoveInASubprogramFileIsRefused) {
  const mc::Machine m = load("lathe_xzbc_doc004.toml");
  TempDir dir;
  {
    std::ofstream(dir.file("side.ngc")) << "o<side> sub\nG1 X50. Z-3. B-2. C10. F300.\no<side> endsub\nM2\n";
  }
  const std::string program = "G21 G90 G18 G8\nG54\nG0 X60. Z10. B0. C0.\no<side> call\nM30\n";
  Outcome r;
  run(m, program, r, false, "geometric", dir.file("main.ngc"));
  const gc::Diagnostic& d = only_error(r);
  EXPECT_EQ(d.code, "PP-E711");
  EXPECT_NE(d.file.find("side.ngc"), std::string::npos) << d.file;
  EXPECT_EQ(d.where.line, 2u);
  EXPECT_NE(d.message.find("subprogram file"), std::string::npos) << d.message;
}

TEST(WriteBack, SubdivisionOnALineWithAJumpIsRefused) {
  const mc::Machine m = load("trunnion_ac_siemens.toml");
  const std::string program =
      "N10 G17 G90 G54 G71\nN20 R1=5\nN30 G0 X0 Y0 Z50 A0 C0\nN40 G1 X100 Y0 Z5 A60 C180 F500 GOTOF ENDE\n"
      "N50 G1 X0\nN60 ENDE:\nN70 M30\n";
  Outcome r;
  run(m, program, r, false);
  const gc::Diagnostic& d = only_error(r);
  EXPECT_EQ(d.code, "PP-E711");
  EXPECT_EQ(d.where.line, 4u);
  EXPECT_EQ(d.where.column, std::string("N40 G1 X100 Y0 Z5 A60 C180 F500 ").size() + 1);
  EXPECT_NE(d.message.find("control flow ('GOTOF ENDE')"), std::string::npos) << d.message;
}

}  // namespace

namespace {

// The commands that read programs without writing them resolve them too: diff pairs the executed
// motions in order and names their source lines; the servo path is the flattened program's.
TEST(Resolved, DiffPairsExecutedMotionsAtTheirSourceLines) {
  const mc::Machine m = load("lathe_xzbc_doc004.toml");
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  Outcome r;
  run(m, kLinuxCnc, r, false);
  ASSERT_TRUE(r.ok()) << r.errors();
  gc::DiagnosticSink sink;
  const cp::DiffResult diff = cp::diff(kLinuxCnc, r.out, "in.ngc", "out.ngc", d, &m, sink);
  ASSERT_FALSE(sink.has_errors());
  // 10 moves executed (the loop body twice, the branch not taken never), each paired with itself.
  EXPECT_EQ(diff.motions_original, 10u);
  EXPECT_EQ(diff.motions_corrected, 10u + r.result.segments_added);
  std::vector<std::uint64_t> lines;
  for (const cp::BlockDiff& b : diff.blocks) lines.push_back(b.line_original);
  EXPECT_EQ(diff.by_block, r.result.segments_added == 0);  // else paired by path
  EXPECT_EQ(diff.unmatched, 0u);
  EXPECT_EQ(lines, (std::vector<std::uint64_t>{12, 13, 8, 16, 21, 22, 21, 22, 24, 25}));
  // The corrected program puts the tool where the original is meant to (tool-tip distance ≈ the
  // geometric error it removes, well under 0.1 mm) and moves nothing that was not executed.
  EXPECT_GT(diff.deviation.max, 1e-4);
  EXPECT_LT(diff.deviation.max, 0.1);
}

TEST(Resolved, ServoPathEqualsTheFlattenedProgramsPath) {
  const mc::Machine m = load("lathe_xzbc_doc004.toml");
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  gc::DiagnosticSink sink;
  const gc::ResolvedProgram flat = gc::resolve(kLinuxCnc, "in.ngc", d, {}, sink);
  ASSERT_FALSE(sink.has_errors());
  const postproc::contour::Path a =
      postproc::contour::build_path(kLinuxCnc, "in.ngc", d, m, postproc::contour::PathOptions{}, sink, {});
  gc::LineReader in{std::string_view(flat.text)};
  const postproc::contour::Path b =
      postproc::contour::build_path(in, "flat.ngc", d, m, postproc::contour::PathOptions{}, sink);
  ASSERT_FALSE(sink.has_errors());
  ASSERT_EQ(a.points.size(), b.points.size());
  ASSERT_GT(a.points.size(), 3u);
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    EXPECT_TRUE(a.points[i].q.isApprox(b.points[i].q, 1e-12)) << i;
    EXPECT_DOUBLE_EQ(a.points[i].t, b.points[i].t) << i;
    // Lines of the program as written, not of the resolved text.
    EXPECT_EQ(a.points[i].line, flat.source_line[b.points[i].line - 1]) << i;
  }
}

}  // namespace

namespace {

const char* const kArcs = R"(G21 G90 G17
#<r> = 0.5
G0 X0 Y0
G1 X10. Y0 F100.
o100 if [#<r> GT 0.1]
  G2 X20. Y0 I5. J0 (taken)
o100 else
  G3 X20. Y0 I5. J0 (not taken)
o100 endif
o200 repeat [2]
  G1 X30. Y0
  G3 X30. Y10. I0 J5.
  G0 X30. Y0
o200 endrepeat
G1 X[#<r>*2] Y1.
M2
)";

std::string convert_text(std::string_view text, const gc::ConvertOptions& opt, gc::DiagnosticSink& sink) {
  const gc::Dialect d = pptest::dialect("linuxcnc");
  auto mem = postproc::io::OutputFile::memory();
  (void)gc::convert_program(text, "in.ngc", d, opt, mem, sink);
  return mem.take();
}

TEST(ConvertResolved, LinearizeWritesChordsIntoTheProgramsOwnLines) {
  gc::ConvertOptions opt;
  opt.linearize_tolerance_mm = 0.01;
  gc::DiagnosticSink sink;
  const std::string in_place = convert_text(kArcs, opt, sink);
  ASSERT_FALSE(sink.has_errors());
  opt.flatten = true;
  const std::string flat = convert_text(kArcs, opt, sink);
  ASSERT_FALSE(sink.has_errors());
  // Resolved again, the program written in place is the flattened one.
  const gc::ResolvedProgram again = gc::resolve(in_place, "out.ngc", pptest::dialect("linuxcnc"), {}, sink);
  ASSERT_FALSE(sink.has_errors());
  EXPECT_EQ(lines_without_header(again.text), lines_without_header(flat));
  // The arc not taken stays an arc; the statements stay; the loop's arc (the same each run) is
  // replaced once.
  for (const char* kept : {"  G3 X20. Y0 I5. J0 (not taken)", "o100 if [#<r> GT 0.1]", "o200 repeat [2]",
                           "G1 X[#<r>*2] Y1."})
    EXPECT_TRUE(has_line(in_place, kept)) << kept;
  EXPECT_FALSE(has_line(in_place, "  G2 X20. Y0 I5. J0 (taken)"));
  EXPECT_FALSE(has_line(in_place, "  G3 X30. Y10. I0 J5."));
  // Only the two executed arcs grew into chords: every other line is there once, as written.
  EXPECT_GT(std::count(in_place.begin(), in_place.end(), '\n'), std::count(kArcs, kArcs + std::strlen(kArcs), '\n'));
}

TEST(ConvertResolved, UnitsNeedFlatten) {
  gc::ConvertOptions opt;
  opt.units = gc::Units::inch;
  gc::DiagnosticSink sink;
  EXPECT_TRUE(convert_text(kArcs, opt, sink).empty());
  ASSERT_EQ(sink.count(gc::Severity::error), 1u);
  EXPECT_EQ(sink.stored().front().code, "PP-E502");
  EXPECT_EQ(sink.stored().front().where.line, 2u);
  EXPECT_NE(sink.stored().front().message.find("--flatten"), std::string::npos);
  opt.flatten = true;
  gc::DiagnosticSink ok;
  const std::string flat = convert_text(kArcs, opt, ok);
  ASSERT_FALSE(ok.has_errors());
  EXPECT_EQ(flat.find('#'), std::string::npos);
  EXPECT_TRUE(has_line(flat, "G1 X0.0394 Y0.0394"));  // X[#<r>*2] = 1 mm
}

TEST(ConvertResolved, TextOptionsKeepStatementsWithoutWarnings) {
  gc::ConvertOptions opt;
  opt.strip_comments = true;
  gc::DiagnosticSink sink;
  const std::string out = convert_text(kArcs, opt, sink);
  EXPECT_EQ(sink.stored().size(), 0u) << (sink.stored().empty() ? "" : gc::format(sink.stored().front()));
  EXPECT_TRUE(has_line(out, "  G3 X20. Y0 I5. J0"));  // the comment of a line not executed goes too
  EXPECT_TRUE(has_line(out, "o100 else"));
}

}  // namespace

namespace {

// Property: over random LinuxCNC programs (literal moves, parameters in feeds, assignments on move
// lines, branches, subroutines called once or twice, now and then an axis expression), compensate
// either writes the program back so that, resolved again, it is exactly the flattened program, or
// refuses with PP-E711 only, in which case --flatten writes it.
TEST(WriteBackProperty, RandomProgramsResolveToTheFlattenedProgramOrAreRefused) {
  const mc::Machine m = load("lathe_xzbc_doc004.toml");
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  std::mt19937 rng(20261122);
  std::uniform_real_distribution<double> x(30, 60), z(-20, 5), b(-10, 10), c(-90, 90);
  const auto move = [&](const char* g = "G1", bool expression = false) {
    return fmt::format("{} X{}{:.3f}{} Z{:.3f} B{:.3f} C{:.3f}", g, expression ? "[" : "", x(rng), expression ? " + 0]" : "",
                       z(rng), b(rng), c(rng));
  };
  int written = 0, refused = 0;
  for (int trial = 0; trial < 60; ++trial) {
    std::string p = "G21 G90 G94 G18 G8 F300\nG54\n#<_f> = 300\n#<_t> = 1\n";
    std::string subs;
    std::vector<std::string> calls;
    const int items = 4 + static_cast<int>(rng() % 8);
    for (int k = 0; k < items; ++k) {
      switch (rng() % 6) {
        case 0: p += move() + " F#<_f>\n"; break;
        case 1: p += move() + fmt::format(" #<_t> = [#<_t> + {}]\n", k); break;
        case 2:
          p += fmt::format("o{0} if [#<_t> GT {1}]\n  {2}\no{0} else\n  {3}\no{0} endif\n", 100 + k, rng() % 4, move(),
                           move("G0"));
          break;
        case 3: {
          subs += fmt::format("o{0} sub\n  {1} F[#<_f> * 2]\no{0} endsub\n", 200 + k, move());
          const int times = 1 + static_cast<int>(rng() % 2);
          for (int t = 0; t < times; ++t) calls.push_back(fmt::format("o{} call\n", 200 + k));
          break;
        }
        case 4: p += move("G0") + "\n"; break;
        default:
          if (rng() % 4 == 0) p += move("G1", true) + " F300\n";
          else p += move() + " F300\n";
      }
    }
    for (const std::string& call : calls) p += call;
    p = subs + p + "M2\n";
    Outcome in_place, flat;
    run(m, p, in_place, false);
    run(m, p, flat, true);
    ASSERT_TRUE(flat.ok()) << flat.errors() << p;
    if (in_place.ok()) {
      ++written;
      gc::DiagnosticSink sink;
      const gc::ResolvedProgram again = gc::resolve(in_place.out, "out.ngc", d, {}, sink);
      ASSERT_FALSE(sink.has_errors()) << p;
      EXPECT_EQ(lines_without_header(again.text), lines_without_header(flat.out)) << p << "\n---\n" << in_place.out;
    } else {
      ++refused;
      for (const gc::Diagnostic& diag : in_place.sink.stored()) EXPECT_EQ(diag.code, "PP-E711") << gc::format(diag);
      EXPECT_TRUE(in_place.out.empty());
    }
  }
  std::printf("[ property ] %d random programs written back in place, %d refused\n", written, refused);
  // Both outcomes occur (the test exercises each).
  EXPECT_GT(written, 10);
  EXPECT_GT(refused, 5);
}

}  // namespace
