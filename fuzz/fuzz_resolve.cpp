// libFuzzer target: the whole pipeline of one dialect over arbitrary bytes — read, resolve
// (parameters, expressions, calls, control flow) and interpret — built once per dialect with
// POSTPROC_FUZZ_DIALECT set to a DialectId enumerator (fuzz/CMakeLists.txt, fuzz/replay.cmake).
//
// Checks "no crash, no sanitizer report, no escaping exception" with limits small enough that no
// input can run long: 20,000 resolved blocks, 1 MiB of resolved text, 20,000 lines without a
// written block, calls 16 deep, 100,000 array elements. Subprogram files are looked for in a
// folder that does not exist, so the result depends on the input bytes alone. Every stored
// diagnostic is formatted too (the caret display runs under the sanitizers).

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/program.hpp"
#include "postproc/gcode/resolve.hpp"

#ifndef POSTPROC_FUZZ_DIALECT
#error "define POSTPROC_FUZZ_DIALECT (fanuc, siemens, linuxcnc or heidenhain_iso)"
#endif

namespace {

namespace gc = postproc::gcode;

struct Ignore final : gc::BlockVisitor {
  void block(const gc::Block&, std::span<const gc::Motion>, bool) override {}
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  static const gc::Dialect dialect = gc::make_dialect(gc::DialectId::POSTPROC_FUZZ_DIALECT);
  gc::ResolveOptions opt;
  opt.max_blocks = 20'000;
  opt.max_resolved_bytes = std::uint64_t{1} << 20;
  opt.max_silent_lines = 20'000;
  opt.max_call_depth = 16;
  opt.max_array_elements = 100'000;
  opt.search_dirs = {"/nonexistent-postproc-fuzz"};
  gc::DiagnosticSink sink(200);
  Ignore visitor;
  (void)gc::run_program_text(input, dialect, "/nonexistent-postproc-fuzz/input", sink, visitor, opt);
  for (const gc::Diagnostic& d : sink.stored()) (void)gc::format(d);
  return 0;
}
