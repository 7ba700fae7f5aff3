// compensate with several threads (CompensateOptions::jobs, compensate_parallel.cpp): the written
// program, the line map, the diagnostics in their order and the report's figures are those of the
// one-thread run, for any number of threads, any chunk size and any warm-up — whether the chunks'
// guessed start states hold (warm-up long enough) or have to be corrected again (no warm-up).
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "bench/program_generator.hpp"
#include "postproc/compensation/compensate.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/io/output_file.hpp"
#include "sample_machine.hpp"

namespace {
namespace cp = postproc::comp;
namespace gc = postproc::gcode;
namespace mc = postproc::machine;

struct Outcome {
  std::string out;
  std::vector<std::uint64_t> line_map;
  std::vector<std::string> diagnostics;
  cp::CompensateResult result;
};

Outcome run(const mc::Machine& m, const std::string& program, unsigned jobs, std::size_t chunk, std::size_t warmup) {
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  Outcome r;
  cp::CompensateOptions opt;
  opt.tool_version = "test";
  opt.line_map = &r.line_map;
  opt.jobs = jobs;
  opt.chunk_blocks = chunk;
  opt.warmup_blocks = warmup;
  gc::DiagnosticSink sink(100000);
  gc::LineReader reader{std::string_view(program)};
  auto out = postproc::io::OutputFile::memory();
  r.result = cp::compensate(reader, "in.nc", d, m, opt, out, sink);
  r.out = out.take();
  for (const gc::Diagnostic& diag : sink.stored()) r.diagnostics.push_back(gc::format(diag));
  return r;
}

std::string read(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

void expect_same(const Outcome& a, const Outcome& b, const std::string& what) {
  SCOPED_TRACE(what);
  EXPECT_EQ(a.out, b.out);
  EXPECT_EQ(a.line_map, b.line_map);
  EXPECT_EQ(a.diagnostics, b.diagnostics);
  const cp::CompensateResult& x = a.result;
  const cp::CompensateResult& y = b.result;
  EXPECT_EQ(x.blocks, y.blocks);
  EXPECT_EQ(x.motions, y.motions);
  EXPECT_EQ(x.changed_blocks, y.changed_blocks);
  EXPECT_EQ(x.words_changed, y.words_changed);
  EXPECT_EQ(x.words_inserted, y.words_inserted);
  EXPECT_EQ(x.subdivided_blocks, y.subdivided_blocks);
  EXPECT_EQ(x.segments_added, y.segments_added);
  EXPECT_EQ(x.arcs_kept, y.arcs_kept);
  EXPECT_EQ(x.arcs_linearized, y.arcs_linearized);
  EXPECT_EQ(x.reference_moves, y.reference_moves);
  EXPECT_EQ(x.rapids_as_written, y.rapids_as_written);
  EXPECT_EQ(x.axis_limited_blocks, y.axis_limited_blocks);
  EXPECT_EQ(x.axis_limited.size(), y.axis_limited.size());
  EXPECT_EQ(x.bytes_in, y.bytes_in);
  EXPECT_EQ(x.max_correction_mm, y.max_correction_mm);
  EXPECT_EQ(x.max_correction_deg, y.max_correction_deg);
  EXPECT_EQ(x.max_axis_correction_rad, y.max_axis_correction_rad);
  EXPECT_EQ(x.max_error_before_mm, y.max_error_before_mm);
  EXPECT_EQ(x.max_error_before_rad, y.max_error_before_rad);
  EXPECT_EQ(x.max_residual_mm, y.max_residual_mm);
  EXPECT_EQ(x.max_residual_rad, y.max_residual_rad);
  EXPECT_EQ(x.worst_line, y.worst_line);
}

/// Every thread count × chunk size × warm-up against one thread. Returns the chunks corrected
/// again over the runs with the long warm-up and without one.
std::pair<std::uint64_t, std::uint64_t> check_all(const mc::Machine& m, const std::string& program) {
  const Outcome one = run(m, program, 1, 4096, 32);
  EXPECT_EQ(one.result.parallel_chunks, 0u);
  std::uint64_t with_warmup = 0, without = 0;
  for (unsigned jobs : {2u, 3u})
    for (std::size_t chunk : {1u, 5u, 64u})
      for (std::size_t warm : {0u, 2u, 32u}) {
        const Outcome p = run(m, program, jobs, chunk, warm);
        expect_same(one, p, "jobs " + std::to_string(jobs) + " chunk " + std::to_string(chunk) + " warm-up " +
                                std::to_string(warm));
        EXPECT_GE(p.result.parallel_chunks, 1u);
        if (warm == 32) with_warmup += p.result.parallel_recomputed;
        if (warm == 0) without += p.result.parallel_recomputed;
      }
  return {with_warmup, without};
}

struct Sample {
  const char* program;
  const char* machine;
};

class ParallelSample : public ::testing::TestWithParam<Sample> {};

TEST_P(ParallelSample, SameAsOneThread) {
  const mc::Machine m = pptest::sample_machine(GetParam().machine);
  const std::string program = read(std::string(POSTPROC_SOURCE_DIR) + "/samples/programs/" + GetParam().program);
  ASSERT_FALSE(program.empty());
  const auto [with_warmup, without] = check_all(m, program);
  // Without a warm-up the guesses start at the program's start state: wrong after a motion.
  EXPECT_GT(without, 0u);
  (void)with_warmup;
}

INSTANTIATE_TEST_SUITE_P(
    Samples, ParallelSample,
    ::testing::Values(Sample{"impeller_axes_bc.nc", "trunnion_bc_fanuc.toml"},
                      Sample{"impeller_axes_bc.h", "trunnion_bc_heidenhain.toml"},
                      Sample{"blade_5axis_g43_4.nc", "trunnion_bc_fanuc.toml"},
                      Sample{"cone_frustum_nas979.nc", "trunnion_ac_fanuc.toml"},
                      Sample{"housing_traori.mpf", "trunnion_ac_siemens.toml"},
                      Sample{"freeform_hexapod_g43_5.nc", "hexapod_doc003.toml"},
                      Sample{"tilted_pocket_3prs.nc", "hybrid_3prs_doc001.toml"},
                      Sample{"pocket_3axis_map.nc", "mill3_stepgauge_map.toml"},
                      Sample{"freeform_lathe_xzbc.ngc", "lathe_xzbc_doc004.toml"}),
    [](const ::testing::TestParamInfo<Sample>& i) {
      std::string n = i.param.program;
      for (char& c : n)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return n;
    });

TEST(Parallel, GeneratedAxisProgramKeepsItsGuesses) {
  // Axis programs: after one corrected motion the state no longer depends on the blocks before,
  // so with the default warm-up no chunk is corrected twice (the speed of -j rests on this).
  const mc::Machine m = pptest::sample_machine("trunnion_ac_fanuc.toml");
  postproc::bench::GeneratorOptions g;
  g.blocks = 3000;
  const std::string program = postproc::bench::ProgramGenerator::generate(g);
  const Outcome one = run(m, program, 1, 4096, 32);
  const Outcome two = run(m, program, 2, 256, 32);
  expect_same(one, two, "jobs 2 chunk 256");
  EXPECT_GE(two.result.parallel_chunks, 11u);
  EXPECT_EQ(two.result.parallel_recomputed, 0u);
  EXPECT_GT(one.result.arcs_linearized, 0u);  // the chunks cut through linearised arcs too
}

TEST(Parallel, StateFromTheTextAcrossChunks) {
  // What a chunk takes from the text before it, not from corrections: incremental mode, a work
  // offset change (the held position becomes unknown), a modal arc after a linearised one (its G
  // word comes back in the program's spelling), a reference return, the header, CRLF line ends,
  // warnings (positions not known yet) and a refusal (an axis the machine does not have) — all in
  // the one-thread order.
  const mc::Machine m = pptest::sample_machine("trunnion_ac_fanuc.toml");
  std::string p = "%\r\nO1 (T)\r\nG21 G90 G94 G17\r\nG54\r\nG0 X10 Y0\r\nG0 Z5 A0 C0\r\n";
  for (int k = 0; k < 6; ++k) {
    p += "G1 X10 Y0 Z-10 A5 C10 F500\r\nG02 X30 Y0 I10 J0 A6\r\nX50 Y0 I10 J0\r\nG91 G1 X1 Y1\r\nX1\r\nG90\r\n";
    p += k % 2 == 0 ? "G55\r\nG0 X0 Y0 Z20\r\n" : "G54\r\nG28 G91 Z0\r\nG90\r\nG0 X5 Y5 Z10 A0 C0\r\n";
  }
  p += "M30\r\n%\r\n";
  const Outcome base = run(m, p, 1, 4096, 32);
  ASSERT_FALSE(base.out.empty());
  for (std::size_t chunk : {1u, 2u, 3u, 7u})
    for (std::size_t warm : {0u, 1u, 4u}) expect_same(base, run(m, p, 2, chunk, warm), "chunk " + std::to_string(chunk));
  const std::string refused = p.substr(0, p.size() - 8) + "G1 V5\r\nG1 X20\r\n" + p.substr(p.size() - 8);
  const Outcome bad = run(m, refused, 1, 4096, 32);
  ASSERT_FALSE(bad.diagnostics.empty());
  for (std::size_t chunk : {1u, 4u}) expect_same(bad, run(m, refused, 3, chunk, 2), "refused, chunk " + std::to_string(chunk));
}

}  // namespace
