// Issue 17 (part): compensation never makes a part worse. The contour stage's verification gate
// (docs/compensation-verification.md): the program as written is read back, simulated in the time
// domain and compared run by run with the contour stage's input; the report's figures are the
// simulated ones. The expected answers come from postproc's own time-domain simulator
// (contour/simulate.hpp) run here independently on the written text.
#include <cstdio>
#include <random>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "contour_support.hpp"

#include "postproc/compensation/compensate.hpp"
#include "postproc/contour/path.hpp"
#include "postproc/contour/reference.hpp"
#include "postproc/contour/simulate.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/machine/machine.hpp"
#include "src/compensation/compensate_support.hpp"

namespace {

namespace ct = postproc::contour;
namespace mc = postproc::machine;
namespace gc = postproc::gcode;
namespace comp = postproc::comp;

mc::Machine machine(const std::string& name) { return pptest::sample_machine(name); }
using pptest::kSamples;

struct Outcome {
  std::string written;
  comp::CompensateResult r;
  gc::DiagnosticSink sink;
};

/// `split`: also the candidate with long moves split and arcs as chords (CompensateOptions::
/// contour_split, on by default in the tool; off here where a test is about the gate on the
/// program's own block end points).
void compensate(const std::string& program, const mc::Machine& m, const std::string& mode, Outcome& run,
                const std::string& file = "t.nc", const ct::PrecompensateOptions& popt = {}, bool split = false) {
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  comp::CompensateOptions opt;
  opt.mode = *comp::parse_mode(mode);
  opt.tool_version = "test";
  opt.contour_split = split;
  opt.contour = popt;
  auto out = postproc::io::OutputFile::memory();
  run.r = comp::compensate_program({program, file, d, m}, opt, out, run.sink);
  run.written = out.take();
}

/// `dense`: the intended contour as simulate and the verification take it (long moves densified,
/// contour::kReferenceDensifyMm), for building a reference.
ct::Path path_of(const std::string& text, const mc::Machine& m, bool dense = false) {
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  gc::DiagnosticSink sink;
  gc::LineReader in{std::string_view(text)};
  ct::PathOptions o;
  if (dense) o.densify_mm = ct::kReferenceDensifyMm;
  ct::Path p = ct::build_path(in, "t.nc", d, m, o, sink);
  EXPECT_FALSE(sink.has_errors());
  return p;
}

/// The original program and the written one simulated against the original's intended contour
/// (`postproc simulate OUT --reference IN`): an independent check of what the report says.
std::pair<ct::Simulation, ct::Simulation> simulate_both(const std::string& original, const std::string& written,
                                                         const mc::Machine& m) {
  const ct::Path po = path_of(original, m);
  const ct::Path pw = path_of(written, m);
  const ct::Reference ref(path_of(original, m, true), *m.actual);
  return {ct::simulate(po, ref, *m.actual), ct::simulate(pw, ref, *m.actual)};
}

std::size_t count(const gc::DiagnosticSink& s, const std::string& code) {
  std::size_t n = 0;
  for (const auto& d : s.stored()) n += d.code == code ? 1 : 0;
  return n;
}

/// The contour stage without the refinement on the simulation (contour/learning_control.hpp):
/// the candidates are the quasi-static iteration and the lag precompensation only.
ct::PrecompensateOptions without_refinement() {
  ct::PrecompensateOptions o;
  o.learning_iterations = 0;
  return o;
}

// The tilted 3-PRS pocket (issue 17 names it: contour mode makes it worse). The iteration
// predicts 19 → 8 µm, but the written program simulated is worse than the original (245.186 →
// 245.323 µm, 419 → 434 arcsec before this gate). The gate writes the run uncorrected, warns
// PP-W620 at the run's first move, and reports the simulated figures of what was written. (With
// the refinement on the simulation, the default, the run is refined instead: the next test.)
TEST(CompensateGate, ContourNotBetterOnTheSimulatorIsWrittenUncorrected) {
  const mc::Machine m = machine("hybrid_3prs_doc001.toml");
  const std::string prog = postproc::io::read_file(kSamples + "programs/tilted_pocket_3prs.nc", "NC program");
  Outcome c;
  compensate(prog, m, "contour", c, "t.nc", without_refinement());
  ASSERT_FALSE(c.sink.has_errors());
  ASSERT_EQ(count(c.sink, "PP-W620"), 1u);
  for (const auto& d : c.sink.stored())
    if (d.code == "PP-W620") {
      EXPECT_EQ(d.where.line, 8u);  // N60 G1 Z2. F800. : the run's first feed move
      EXPECT_EQ(d.where.column, 5u);
      EXPECT_NE(d.message.find("(24 moves)"), std::string::npos) << d.message;
    }
  EXPECT_TRUE(c.r.contour_verified);
  EXPECT_EQ(c.r.contour_runs_withheld, 1u);
  // The iteration's prediction is far better than what the simulator shows (the trap).
  EXPECT_LT(c.r.contour_predicted_after_mm, 0.5 * c.r.contour_before_mm);

  // Independent check: simulate the original and the written text against the original's contour.
  const auto [s0, s1] = simulate_both(prog, c.written, m);
  EXPECT_LE(s1.tip.max, s0.tip.max);
  EXPECT_LE(s1.axis.max, s0.axis.max);
  // The report's before / after are the simulation's, not the prediction.
  EXPECT_NEAR(c.r.contour_before_mm, s0.tip.max, 1e-9);
  EXPECT_NEAR(c.r.contour_after_mm, s1.tip.max, 1e-9);
  EXPECT_NEAR(c.r.contour_before_rad, s0.axis.max, 1e-12);
  EXPECT_NEAR(c.r.contour_after_rad, s1.axis.max, 1e-12);
  // The details behind --html: the verification's simulations, and the prediction of the
  // commands as written (the run withheld: the input's own commands, so it equals "before").
  {
    const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
    comp::CompensateOptions opt;
    opt.mode = comp::Mode::contour;
    opt.tool_version = "test";
    opt.contour_split = false;
    opt.contour = without_refinement();
    comp::ContourDetails cd;
    gc::DiagnosticSink sink;
    auto out = postproc::io::OutputFile::memory();
    comp::compensate_program({prog, "t.nc", d, m}, opt, out, sink, &cd);
    ASSERT_TRUE(cd.simulated_before.has_value());
    ASSERT_TRUE(cd.simulated_after.has_value());
    EXPECT_NEAR(cd.simulated_before->tip.max, s0.tip.max, 1e-9);
    EXPECT_NEAR(cd.simulated_after->tip.max, s1.tip.max, 1e-9);
    EXPECT_NEAR(cd.result.after.tip.max, cd.result.before.tip.max, 1e-12);
    ASSERT_EQ(cd.run_withheld.size(), 1u);
    EXPECT_EQ(cd.run_withheld[0], 1);
  }
  // Written as received: only the header line was added.
  EXPECT_EQ(c.r.changed_blocks, 0u);
  const std::size_t header_end = c.written.find('\n', c.written.find("compensate mode=contour"));
  ASSERT_NE(header_end, std::string::npos);
  const std::size_t header_start = c.written.rfind('\n', c.written.find("compensate mode=contour"));
  EXPECT_EQ(c.written.substr(0, header_start + 1) + c.written.substr(header_end + 1), prog);
}

// The same pocket with the refinement on the simulation: from the input (neither candidate
// qualified), the steps taken on the simulated samples lower every figure of the run; the run is
// written "refined", without PP-W620, and an independent simulation of the written text against
// the original's contour confirms the report: none of the four figures worse, the largest
// tool-tip error and the RMS lower (measured: 245.19 → 238.92 µm, RMS 24.95 → 23.54 µm).
TEST(CompensateGate, RefinementOnTheSimulationImprovesWhatTheCandidatesCouldNot) {
  const mc::Machine m = machine("hybrid_3prs_doc001.toml");
  const std::string prog = postproc::io::read_file(kSamples + "programs/tilted_pocket_3prs.nc", "NC program");
  Outcome c;
  compensate(prog, m, "contour", c);
  ASSERT_FALSE(c.sink.has_errors());
  EXPECT_EQ(count(c.sink, "PP-W620"), 0u);
  ASSERT_EQ(c.r.contour_run_reports.size(), 1u);
  const comp::ContourRunReport& rr = c.r.contour_run_reports[0];
  EXPECT_EQ(rr.written, "refined");
  EXPECT_GE(rr.refined_steps, 1);
  EXPECT_EQ(c.r.contour_runs_refined, 1u);
  EXPECT_EQ(c.r.contour_runs_withheld, 0u);
  EXPECT_GT(c.r.changed_blocks, 0u);
  const auto [s0, s1] = simulate_both(prog, c.written, m);
  EXPECT_LT(s1.tip.max, s0.tip.max);
  EXPECT_LE(s1.axis.max, s0.axis.max);
  EXPECT_LT(s1.run_tip_rms[0], s0.run_tip_rms[0]);
  EXPECT_LE(s1.run_axis_rms[0], s0.run_axis_rms[0]);
  EXPECT_NEAR(c.r.contour_after_mm, s1.tip.max, 1e-9);
  EXPECT_NEAR(rr.refined_mm, s1.tip.max, 1e-9);
  EXPECT_NEAR(rr.refined_rms_mm, s1.run_tip_rms[0], 1e-9);
}

// The gate's first rule covers the RMS too: on the blade (one long 5-axis run on the B/C
// trunnion) the quasi-static iteration lowers the largest error (161.92 → 160.03 µm) but cuts the
// rest of the run worse (RMS 19.42 → 25.92 µm); it does not qualify. Without the refinement the
// run is written as received, with PP-W620.
TEST(CompensateGate, ACandidateWithAGreaterRmsDoesNotQualify) {
  const mc::Machine m = machine("trunnion_bc_fanuc.toml");
  const std::string prog = postproc::io::read_file(kSamples + "programs/blade_5axis_g43_4.nc", "NC program");
  Outcome c;
  compensate(prog, m, "contour", c, "t.nc", without_refinement());
  ASSERT_FALSE(c.sink.has_errors());
  ASSERT_FALSE(c.r.contour_run_reports.empty());
  const comp::ContourRunReport& rr = c.r.contour_run_reports[0];
  EXPECT_LT(rr.iterated_mm, rr.before_mm);          // the peak is lower …
  EXPECT_GT(rr.iterated_rms_mm, rr.before_rms_mm);  // … the rest worse
  EXPECT_EQ(rr.written, "uncorrected");
  EXPECT_EQ(count(c.sink, "PP-W620"), 1u);
  EXPECT_NEAR(c.r.contour_after_mm, c.r.contour_before_mm, 1e-12);
}

// The cone on the A/C trunnion: the correction is better on the simulator, so it is written,
// without a warning, and the reported after is the simulation of the written text.
TEST(CompensateGate, ContourBetterOnTheSimulatorIsWrittenAndReportedAsSimulated) {
  const mc::Machine m = machine("trunnion_ac_fanuc.toml");
  const std::string prog = postproc::io::read_file(kSamples + "programs/cone_frustum_nas979.nc", "NC program");
  Outcome c;
  compensate(prog, m, "contour", c);
  ASSERT_FALSE(c.sink.has_errors());
  EXPECT_EQ(count(c.sink, "PP-W620") + count(c.sink, "PP-W621"), 0u);
  EXPECT_TRUE(c.r.contour_verified);
  EXPECT_EQ(c.r.contour_runs_withheld, 0u);
  EXPECT_GT(c.r.changed_blocks, 1000u);
  const auto [s0, s1] = simulate_both(prog, c.written, m);
  EXPECT_LT(s1.tip.max, 0.1 * s0.tip.max);
  EXPECT_LE(s1.axis.max, s0.axis.max);
  EXPECT_NEAR(c.r.contour_before_mm, s0.tip.max, 1e-9);
  EXPECT_NEAR(c.r.contour_after_mm, s1.tip.max, 1e-9);
  EXPECT_NEAR(c.r.contour_after_rad, s1.axis.max, 1e-12);
  // Per run, the written program is never worse than the original.
  ASSERT_EQ(s0.run_tip_max.size(), s1.run_tip_max.size());
  for (std::size_t i = 0; i < s0.run_tip_max.size(); ++i) {
    EXPECT_LE(s1.run_tip_max[i], s0.run_tip_max[i]) << "run " << i;
    EXPECT_LE(s1.run_axis_max[i], s0.run_axis_max[i]) << "run " << i;
  }
}

// --mode all on the pocket: the contour stage's input is the geometric correction; where the
// contour correction is not better on the simulator, the geometric correction alone is written.
TEST(CompensateGate, ModeAllWithheldRunKeepsTheGeometricCorrection) {
  const mc::Machine m = machine("hybrid_3prs_doc001.toml");
  const std::string prog = postproc::io::read_file(kSamples + "programs/tilted_pocket_3prs.nc", "NC program");
  Outcome all, geo;
  compensate(prog, m, "all", all);
  compensate(prog, m, "geometric", geo);
  ASSERT_FALSE(all.sink.has_errors());
  ASSERT_FALSE(geo.sink.has_errors());
  EXPECT_TRUE(all.r.contour_verified);
  // The contour stage's warnings name the input's lines (the intermediate text's are mapped back).
  for (const auto& d : all.sink.stored()) {
    if (d.code == "PP-W620") {
      EXPECT_EQ(d.where.line, 8u);
    }
  }
  // The geometric stage's output, simulated against itself on the calibrated machine, is the
  // contour stage's "before"; the written program is not worse than it.
  const ct::Path g = path_of(geo.written, m);
  const ct::Path w = path_of(all.written, m);
  const ct::Reference ref(path_of(geo.written, m, true), *m.actual);
  const ct::Simulation s0 = ct::simulate(g, ref, *m.actual);
  const ct::Simulation s1 = ct::simulate(w, ref, *m.actual);
  EXPECT_NEAR(all.r.contour_before_mm, s0.tip.max, 1e-9);
  EXPECT_NEAR(all.r.contour_after_mm, s1.tip.max, 1e-9);
  EXPECT_LE(s1.tip.max, s0.tip.max);
  EXPECT_LE(s1.axis.max, s0.axis.max);
  if (all.r.contour_runs_withheld == all.r.contour_runs) {
    // Every run withheld: the program written is the geometric one (header aside).
    const auto body = [](const std::string& t) { return t.substr(t.find('\n', t.find("compensate mode=")) + 1); };
    EXPECT_EQ(body(all.written), body(geo.written));
  }
}

}  // namespace

namespace {

// Issue 17: "a program compensated twice is compensated twice". compensate writes a header
// naming the machine file and its hash (header_comment); an input carrying it is refused
// (PP-E620, at the header) unless --allow-recompensation.
TEST(CompensateGate, HeaderIsRecognisedOnlyAsPostprocWritesIt) {
  EXPECT_EQ(comp::compensation_header_offset(
                "(postproc 0.1.0 compensate mode=geometric machine=m.toml sha256=0123abcd)"),
            1u);
  EXPECT_EQ(comp::compensation_header_offset("; postproc 0.1.0 compensate mode=contour machine=m.toml sha256=ab"), 2u);
  // Not in a comment, no hash, another wording: not the header.
  EXPECT_EQ(comp::compensation_header_offset("postproc 0.1.0 compensate mode=geometric machine=m sha256=ab"),
            std::string_view::npos);
  EXPECT_EQ(comp::compensation_header_offset("(postproc 0.1.0 compensate mode=geometric machine=m)"),
            std::string_view::npos);
  EXPECT_EQ(comp::compensation_header_offset("(compensated with postproc, see report)"), std::string_view::npos);
}

TEST(CompensateGate, CompensatedProgramIsRefusedUnlessAllowed) {
  const mc::Machine m = machine("trunnion_ac_fanuc.toml");
  const std::string prog = postproc::io::read_file(kSamples + "programs/cone_frustum_nas979.nc", "NC program");
  for (const std::string mode : {"geometric", "contour", "all"}) {
    SCOPED_TRACE(mode);
    Outcome first;
    compensate(prog, m, mode, first);
    ASSERT_FALSE(first.sink.has_errors());
    // The header is the third line (after % and the O line).
    Outcome again;
    compensate(first.written, m, mode, again);
    ASSERT_TRUE(again.sink.has_errors());
    ASSERT_EQ(again.sink.count(gc::Severity::error), 1u);
    const gc::Diagnostic& d = again.sink.stored().front();
    EXPECT_EQ(d.code, "PP-E620");
    EXPECT_EQ(d.where.line, 3u);
    EXPECT_EQ(d.where.column, 2u);
    EXPECT_NE(d.message.find("trunnion_ac_fanuc.toml"), std::string::npos) << d.message;
    EXPECT_TRUE(again.written.empty());
  }
  // With allow_recompensation it is compensated (one header line more, the rest corrected again).
  Outcome first, again;
  compensate(prog, m, "geometric", first);
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  comp::CompensateOptions opt;
  opt.tool_version = "test";
  opt.allow_recompensation = true;
  auto out = postproc::io::OutputFile::memory();
  comp::compensate_program({first.written, "t.nc", d, m}, opt, out, again.sink);
  EXPECT_FALSE(again.sink.has_errors());
  EXPECT_FALSE(out.take().empty());
}

// The streaming path of `compensate` (a flat program read from a file, geometric mode) checks too.
TEST(CompensateGate, StreamingCompensateRefusesACompensatedProgram) {
  const mc::Machine m = machine("trunnion_ac_fanuc.toml");
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  const std::string prog = "%\nO1\n(postproc 0.1.0 compensate mode=geometric machine=x.toml sha256=00ff)\n"
                           "G90 G54 G0 X0. Y0. Z50. A0. C0.\nG1 X10. F1000.\nM30\n%\n";
  comp::CompensateOptions opt;
  opt.tool_version = "test";
  gc::DiagnosticSink sink;
  auto out = postproc::io::OutputFile::memory();
  gc::LineReader in{std::string_view(prog)};
  comp::compensate(in, "t.nc", d, m, opt, out, sink);
  ASSERT_EQ(sink.count(gc::Severity::error), 1u);
  EXPECT_EQ(sink.stored().front().code, "PP-E620");
  EXPECT_EQ(sink.stored().front().where.line, 3u);
  EXPECT_EQ(sink.stored().front().where.column, 2u);
}

}  // namespace

namespace {

// Issue 17: [errors] "tool.length" (the calibrated length of the tool of [tool] length, as
// `calibrate` writes it, docs/machine-file.md) is used by `calibrate simulate` through m.actual
// but was overwritten by compensate's per-block tool length (nothing changed, exit 0). Now the
// tool of [tool] length runs through m.actual itself; a block with another tool length is refused
// (PP-E621): the file does not give that tool's length error.
std::string trunnion_with_tool_length(const std::string& value) {
  const std::string text = postproc::io::read_file(kSamples + "machines/trunnion_ac_fanuc.toml", "machine file");
  std::string out;
  bool skip = false;
  std::size_t at = 0;
  while (at < text.size()) {
    std::size_t end = text.find('\n', at);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(at, end - at);
    if (!line.empty() && line[0] == '[')
      skip = line.rfind("[errors]", 0) == 0 || line.rfind("[error_motions", 0) == 0;
    if (!skip) out += line + "\n";
    at = end + 1;
  }
  return out + "[errors]\n\"tool.length\" = \"" + value + "\"\n";
}

mc::Machine parse(const std::string& text) {
  gc::DiagnosticSink sink;
  auto m = mc::parse_machine("tl.toml", text, sink);
  for (const auto& d : sink.stored()) ADD_FAILURE() << d.message;
  EXPECT_TRUE(m.has_value());
  return *m;
}

TEST(CompensateGate, ToolLengthErrorIsCompensated) {
  const mc::Machine m = parse(trunnion_with_tool_length("100.02 mm"));
  ASSERT_DOUBLE_EQ(m.tool_length, 100.0);
  // The model compensate uses for the [tool] length is calibrate simulate's (m.actual itself).
  postproc::machine::ToolLengthModels models(m);
  EXPECT_EQ(models.with_tool_length(100.0).second.get(), m.actual.get());
  EXPECT_TRUE(models.length_error_known(100.0));
  EXPECT_FALSE(models.length_error_known(85.25));
  // A tool 0.02 mm longer cuts 0.02 mm deeper at A0 C0: Z is raised by 0.02 (3 decimals).
  const std::string prog = "%\nO1\nG90 G54 G0 X0. Y0. Z50. A0. C0.\nG1 Z10. F1000.\nX10.\nM30\n%\n";
  for (const std::string mode : {"geometric", "all"}) {
    SCOPED_TRACE(mode);
    Outcome c;
    // (--mode all: without the refinement on the simulation, which would also move the corner
    // at the bottom of the plunge against the servo lag.)
    compensate(prog, m, mode, c, "t.nc", without_refinement());
    ASSERT_FALSE(c.sink.has_errors());
    EXPECT_NE(c.written.find("\nG90 G54 G0 X0. Y0. Z50.02 A0. C0.\n"), std::string::npos) << c.written;
    EXPECT_NE(c.written.find("\nG1 Z10.02 F1000.\n"), std::string::npos) << c.written;
  }
  // Without the error nothing changes (the same file, tool.length = [tool] length).
  const mc::Machine same = parse(trunnion_with_tool_length("100 mm"));
  Outcome c;
  compensate(prog, same, "geometric", c);
  ASSERT_FALSE(c.sink.has_errors());
  EXPECT_NE(c.written.find("\nG1 Z10. F1000.\n"), std::string::npos) << c.written;
}

TEST(CompensateGate, ToolLengthErrorWithAnotherToolIsRefusedLocated) {
  const mc::Machine m = parse(trunnion_with_tool_length("100.02 mm"));
  // H1 is 85.25 mm ([tool.lengths] 1): its length error is not in the file.
  const std::string prog = "%\nO1\nG90 G54 G0 X0. Y0. Z50. A0. C0.\nG1 Z10. F1000.\nG43 H1 Z20.\nM30\n%\n";
  for (const std::string mode : {"geometric", "contour"}) {
    SCOPED_TRACE(mode);
    Outcome c;
    compensate(prog, m, mode, c);
    ASSERT_TRUE(c.sink.has_errors());
    const gc::Diagnostic* e = nullptr;
    for (const auto& d : c.sink.stored())
      if (d.severity == gc::Severity::error && e == nullptr) e = &d;
    ASSERT_NE(e, nullptr);
    EXPECT_EQ(e->code, "PP-E621");
    EXPECT_EQ(e->where.line, 5u);
    EXPECT_NE(e->message.find("85.25 mm (H1)"), std::string::npos) << e->message;
  }
}

}  // namespace

namespace {

// Property (issue 17, "never worse"): random zigzag programs (sharp corners, feeds 1–8 m/min,
// several runs) on the 3-axis test mill, --mode contour: the written program, read back and
// simulated independently against the original's contour, is never worse than the original in
// any run (max tool-tip error), and the report's after is that simulation.
TEST(CompensateGate, RandomProgramsAreNeverWorseOnTheSimulator) {
  const mc::Machine& m = pptest::mill();
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> step(-25.0, 25.0), feed(1000.0, 8000.0);
  std::uniform_int_distribution<int> moves(3, 14), runs(1, 3);
  std::size_t withheld = 0, total_runs = 0;
  for (int k = 0; k < 12; ++k) {
    SCOPED_TRACE(k);
    std::string prog = "%\nO1\nG90 G54 G0 X0. Y0. Z5.\n";
    double x = 0, y = 0;
    const int nr = runs(rng);
    for (int r = 0; r < nr; ++r) {
      prog += fmt::format("G1 Z0. F{:.0f}\n", feed(rng));
      const int n = moves(rng);
      for (int i = 0; i < n; ++i) {
        x += step(rng);
        y += step(rng);
        prog += fmt::format("G1 X{:.3f} Y{:.3f} F{:.0f}\n", x, y, feed(rng));
      }
      prog += "G0 Z5.\n";
    }
    prog += "M30\n%\n";
    Outcome c;
    compensate(prog, m, "contour", c, "t.nc", {}, true);
    ASSERT_FALSE(c.sink.has_errors());
    ASSERT_TRUE(c.r.contour_verified);
    withheld += c.r.contour_runs_withheld;
    total_runs += c.r.contour_runs;
    const ct::Path original = path_of(prog, m);
    const ct::Path written = path_of(c.written, m);
    const ct::Reference ref(path_of(prog, m, true), *m.actual);
    const ct::Simulation s0 = ct::simulate(original, ref, *m.actual);
    const ct::Simulation s1 = ct::simulate(written, ref, *m.actual);
    ASSERT_EQ(s0.run_tip_max.size(), s1.run_tip_max.size());
    // A run written as received may differ from the original's simulation by rounding noise
    // (1e-13 mm): the runs before it, corrected, change the simulation clock it starts at.
    for (std::size_t i = 0; i < s0.run_tip_max.size(); ++i)
      EXPECT_LE(s1.run_tip_max[i], s0.run_tip_max[i] + 1e-9) << "run " << i;
    EXPECT_NEAR(c.r.contour_after_mm, s1.tip.max, 1e-9);
    EXPECT_NEAR(c.r.contour_before_mm, s0.tip.max, 1e-9);
  }
  std::printf("random programs: %zu of %zu runs written without the contour correction\n", withheld, total_runs);
}

}  // namespace
