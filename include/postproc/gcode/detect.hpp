#pragma once
/// @file
/// Suggests a dialect from a program's text. Used only to *suggest* (check prints the evidence);
/// commands that change programs never act on a guess.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/line_reader.hpp"

namespace postproc::gcode {

struct DialectGuess {
  DialectId id = DialectId::fanuc;
  std::string evidence;  ///< e.g. "TRAORI"
  std::uint64_t line = 0;
  std::uint32_t column = 0;
};

/// Looks at the first `max_lines` lines of `text` for constructs only one dialect has.
[[nodiscard]] std::optional<DialectGuess> guess_dialect(std::string_view text, std::size_t max_lines = 2000);

/// For commands that take their dialect from elsewhere (the machine file, --dialect): when the
/// first lines of `text` hold a construct only another dialect writes (guess_dialect), reports
/// warning PP-W005 at it — the program is read as `used` (`source` says who chose it, e.g. "the
/// machine file m.toml"), and how to read it otherwise. Returns whether it warned.
bool warn_other_dialect(std::string_view text, std::string_view file, const Dialect& used, std::string_view source,
                        DiagnosticSink& sink);

/// A block that only one Fanuc lathe G-code system reads without contradiction.
struct GCodeSystemEvidence {
  char system = 0;          ///< 'A' or 'B' (B stands for B and C: both use G90/G91 and G94/G95)
  std::uint64_t line = 0;
  std::uint32_t column = 0;
  std::string text;         ///< the G word(s), e.g. "G90"
  std::string why;          ///< what it means in the system it points to
  std::string source;       ///< the block as written
};

/// First evidence for each system in a whole program (B-64604EN / B-64484EN "G code system":
/// system A has no G90/G91 absolute/incremental codes and feeds by G98/G99; systems B and C
/// use G90/G91 and G94/G95, and G98/G99 there only choose a canned cycle's return level).
struct GCodeSystemScan {
  std::optional<GCodeSystemEvidence> a, b;
};
[[nodiscard]] GCodeSystemScan scan_lathe_gcode_system(LineReader& in, const Dialect& d);

/// For a Fanuc lathe dialect whose G-code system is not stated (`gcode_system == '?'`): scans `in`
/// (then rewinds it), reports the evidence as note PP-N004 at its line, or error PP-E209 when the
/// program holds evidence for both systems or cannot be read twice, and returns the dialect with
/// the system settled ('A', the factory setting, when nothing in the program decides). Any other
/// dialect is returned as it is.
[[nodiscard]] Dialect settle_gcode_system(const Dialect& d, LineReader& in, std::string_view file,
                                          DiagnosticSink& sink);

}  // namespace postproc::gcode
