#include "postproc/gcode/program.hpp"

#include <string>
#include <vector>

#include "postproc/gcode/lexer.hpp"

namespace postproc::gcode {
namespace {
class Collect final : public MotionSink {
 public:
  std::vector<Motion> motions;
  void motion(const Motion& m, const Block&) override { motions.push_back(m); }
};
}  // namespace

ProgramStats run_program(LineReader& reader, const Dialect& dialect, std::string_view file, DiagnosticSink& sink,
                         BlockVisitor& visitor, InterpreterOptions opt) {
  Interpreter interp(dialect, std::string(file), sink, opt);
  const LexContext ctx{file, &sink};
  Block b;
  Collect collect;
  std::string_view line, eol;
  ProgramStats st;
  while (reader.next(line, eol)) {
    b.raw = line;
    b.eol = eol;
    b.line = reader.line_number();
    const bool ok = lex_block(dialect, b, ctx);
    collect.motions.clear();
    interp.execute(b, collect);
    visitor.block(b, collect.motions, ok);
    ++st.blocks;
  }
  st.bytes = reader.bytes_read();
  return st;
}

}  // namespace postproc::gcode
