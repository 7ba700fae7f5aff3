#pragma once
/// @file
/// Writing a rewritten program with parameters, expressions, subprograms or control flow back into
/// the program itself (issue 3), instead of flattening it: `compensate` and `convert --linearize`.
///
/// The program is resolved (resolve.hpp) and its literal program rewritten (compensated,
/// linearised); then every block of the rewritten literal program is carried back onto the source
/// line it was executed from. A source line is rewritten only where that is exact:
/// - every execution of the line (a loop body, a subprogram called several times) must come out
///   the same, so that the one rewritten line is right each time it runs;
/// - a word that needs a correction must be a literal in the source (X12.5, X=IC(2)): a corrected
///   value cannot be written into an expression or a parameter (X[#1+2], X#5, X=R1);
/// - the line must be in the program itself, not in a subprogram file found next to it;
/// - a move that needs subdivision gets its added moves as new lines after its own, which is
///   refused when that line also holds control flow (a jump would skip them).
/// Anything else is refused with PP-E711 at the source line, with the reason; `--flatten` writes
/// the resolved program as literal moves instead. Lines that need no change (statements, lines
/// never executed, moves whose correction rounds away) are copied byte for byte.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/gcode/block.hpp"
#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/resolve.hpp"

namespace postproc::gcode {

struct WriteBackResult {
  bool ok = false;                  ///< false: refusals were reported, `out` is incomplete
  std::uint64_t lines_changed = 0;  ///< source lines rewritten
  std::uint64_t lines_added = 0;    ///< lines added after them (subdivided moves)
};

/// True while a header comment must wait: it goes after a leading '%' line and the program number
/// / name line (what compensate writes in a flat program, too).
[[nodiscard]] bool header_waits(const Block& b);

/// Carries `compensated` — the rewritten text of `r.text`, without a header, where
/// `line_map[k]` is the resolved line (1-based) that output line k + 1 came from — back onto
/// `source` (the program `r` resolved, named `file` in diagnostics) into `out`. `header` (no end
/// of line; empty for none) is written where compensate writes it in a flat program: before the
/// first line that is not a leading '%' / program-number / empty line. Refusals go to `sink`
/// (PP-E711, located at the source line and word).
WriteBackResult write_back(std::string_view source, std::string_view file, const Dialect& d,
                           const ResolvedProgram& r, std::string_view compensated,
                           const std::vector<std::uint64_t>& line_map, std::string_view header, std::string& out,
                           DiagnosticSink& sink);

}  // namespace postproc::gcode
