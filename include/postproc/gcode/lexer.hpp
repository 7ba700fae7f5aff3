#pragma once
/// @file
/// Lexes one block losslessly per dialect. Never throws on bad input: problems become located
/// diagnostics and the rest of the block is still lexed where possible.

#include <string_view>

#include "postproc/gcode/block.hpp"
#include "postproc/gcode/dialect.hpp"

namespace postproc::gcode {

/// Context for located diagnostics.
/// Words and statements in one block at most (more: PP-E110, the rest of the line is not lexed).
inline constexpr std::size_t kMaxBlockItems = 10'000;

struct LexContext {
  std::string_view file;   ///< name shown in diagnostics
  DiagnosticSink* sink = nullptr;
};

/// Lexes `block.raw` (already set, with `block.line`) into words and tokens. Returns false when
/// the block has a lexical error (reported to ctx.sink); the block keeps what could be lexed.
bool lex_block(const Dialect& dialect, Block& block, const LexContext& ctx);

/// Reports a diagnostic at `span` of `block`.
void report_at(const LexContext& ctx, const Block& block, Span span, Severity sev, std::string_view code,
               std::string message);

}  // namespace postproc::gcode
