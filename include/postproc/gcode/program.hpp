#pragma once
/// @file
/// Drives a whole program through reader, lexer and interpreter, one block at a time (streaming).

#include <span>
#include <string_view>

#include "postproc/gcode/interpreter.hpp"
#include "postproc/gcode/line_reader.hpp"

namespace postproc::gcode {

/// Called once per block (blank lines included), after the block was interpreted.
class BlockVisitor {
 public:
  virtual ~BlockVisitor() = default;
  /// `lexed_ok` is false when the block had a lexical error (already reported).
  virtual void block(const Block& b, std::span<const Motion> motions, bool lexed_ok) = 0;
};

struct ProgramStats {
  std::uint64_t blocks = 0;  ///< lines read
  std::uint64_t bytes = 0;
};

/// Reads every line of `reader`, lexes and interprets it, and hands it to `visitor`.
ProgramStats run_program(LineReader& reader, const Dialect& dialect, std::string_view file, DiagnosticSink& sink,
                         BlockVisitor& visitor, InterpreterOptions opt = {});

}  // namespace postproc::gcode
