// Reads an NC program with the installed postproc library and prints its number of motions and the
// end of the last one: proves the headers, the library and its dependencies are found.
#include <cstdio>
#include <span>
#include <string>
#include <vector>

#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/interpreter.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/gcode/program.hpp"

namespace gc = postproc::gcode;

struct Collect : gc::BlockVisitor {
  std::vector<gc::Motion> motions;
  void block(const gc::Block&, std::span<const gc::Motion> ms, bool) override {
    motions.insert(motions.end(), ms.begin(), ms.end());
  }
};

int main() {
  const std::string text = "G21 G90 G54\nG0 X0 Y0 Z10\nG1 X12.5 Y-3 F500\nG2 X22.5 Y-3 I5 J0\nM2\n";
  const gc::Dialect d = *gc::make_dialect("linuxcnc");
  gc::DiagnosticSink sink;
  Collect out;
  gc::LineReader reader{std::string_view(text)};
  (void)gc::run_program(reader, d, "consumer.ngc", sink, out, gc::InterpreterOptions{});
  if (sink.has_errors() || out.motions.empty()) return 1;
  const gc::Motion& last = out.motions.back();
  std::printf("%zu motions, last ends at X%.3f Y%.3f\n", out.motions.size(), last.end[0], last.end[1]);
  return 0;
}
