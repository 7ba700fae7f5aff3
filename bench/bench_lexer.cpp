// Micro benchmarks of the front end: line splitting alone, and line splitting plus lexing, over
// an in-memory copy of the benchmark program (so disk and page cache play no part).
//
// Figures: bytes_per_second (input bytes) and items_per_second (blocks, i.e. lines).

#include <cstdint>
#include <string>
#include <string_view>

#include <benchmark/benchmark.h>

#include "postproc/gcode/block.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/lexer.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "program_generator.hpp"

namespace {

namespace gc = postproc::gcode;
namespace pb = postproc::bench;

/// 100k blocks (about 5 MB): large enough to leave the caches, small enough to build quickly.
constexpr std::uint64_t kBlocks = 100000;

/// The program for a dialect, generated once per process.
std::string_view program(pb::GenDialect d) {
  static const std::string fanuc = pb::ProgramGenerator::generate({kBlocks, 1, pb::GenDialect::fanuc});
  static const std::string linuxcnc = pb::ProgramGenerator::generate({kBlocks, 1, pb::GenDialect::linuxcnc});
  return d == pb::GenDialect::fanuc ? fanuc : linuxcnc;
}

/// Splitting into lines only: the floor under every command.
void BM_LineReader(benchmark::State& state) {
  // A string_view, not the std::string: LineReader(const std::string&) would open a file by name.
  const std::string_view text = program(pb::GenDialect::fanuc);
  std::uint64_t lines = 0;
  for (auto _ : state) {
    gc::LineReader reader(text);
    std::string_view line, eol;
    while (reader.next(line, eol)) benchmark::DoNotOptimize(line.data());
    lines = reader.line_number();
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * text.size()));
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * lines));
}

/// Reading and lexing every block with one Block reused, as the streaming commands do.
void lex_program(benchmark::State& state, std::string_view dialect_name, pb::GenDialect gen) {
  const std::string_view text = program(gen);
  const gc::Dialect dialect = *gc::make_dialect(dialect_name);
  std::uint64_t lines = 0;
  std::size_t errors = 0;
  for (auto _ : state) {
    gc::DiagnosticSink sink;
    gc::LineReader reader(text);
    gc::Block b;
    std::string_view line, eol;
    while (reader.next(line, eol)) {
      b.raw = line;
      b.eol = eol;
      b.line = reader.line_number();
      gc::lex_block(dialect, b, gc::LexContext{"bench", &sink});
      benchmark::DoNotOptimize(b.words.data());
    }
    lines = reader.line_number();
    errors = sink.count(gc::Severity::error);
  }
  // A benchmark that lexes a broken program measures the error path, not the lexer.
  if (errors != 0) state.SkipWithError("the generated program has lexical errors");
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * text.size()));
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations() * lines));
}

void BM_Lex_Fanuc(benchmark::State& state) { lex_program(state, "fanuc", pb::GenDialect::fanuc); }
void BM_Lex_LinuxCNC(benchmark::State& state) { lex_program(state, "linuxcnc", pb::GenDialect::linuxcnc); }

}  // namespace

BENCHMARK(BM_LineReader)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Lex_Fanuc)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Lex_LinuxCNC)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
