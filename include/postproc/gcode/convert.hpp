#pragma once
/// @file
/// `postproc convert`: rewrites a program block by block. With no options it is the identity
/// (byte-identical output). Blocks no option touches are copied byte for byte.

#include <array>
#include <cstdint>
#include <optional>
#include <vector>
#include <string_view>

#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/gcode/resolve.hpp"
#include "postproc/io/output_file.hpp"

namespace postproc::gcode {

enum class Units : std::uint8_t { mm, inch };

/// Per address letter (index letter - 'A'): minimum decimals, -1 where none was asked for.
using LetterDecimals = std::array<std::int8_t, 26>;
[[nodiscard]] constexpr LetterDecimals no_min_decimals() {
  LetterDecimals a{};
  a.fill(-1);
  return a;
}

struct ConvertOptions {
  bool strip_comments = false;            ///< drop ( ) and ; comments; lines left empty are dropped
  std::optional<std::uint64_t> renumber_start;  ///< renumber existing N words from here …
  std::uint64_t renumber_step = 10;       ///< … in steps of this
  /// --decimals: literal words of these letters with fewer decimals are written with this many
  /// (value unchanged); words with more are left as they are (precision is only ever raised).
  LetterDecimals min_decimals = no_min_decimals();
  /// --units: converts lengths and feeds to these units and writes the matching unit words.
  std::optional<Units> units;
  /// --linearize: replaces every arc by G1 chords deviating at most this much from it, mm,
  /// the rounding of the printed coordinates included.
  std::optional<double> linearize_tolerance_mm;
  /// If set, receives for every written line the input line it came from (1-based).
  std::vector<std::uint64_t>* line_map = nullptr;
  /// Programs with parameters, expressions, subprograms or control flow (convert_program): resolved
  /// with these options …
  ResolveOptions resolve;
  /// … and written as the resolved literal program, converted.
  bool flatten = false;

  [[nodiscard]] bool any_min_decimals() const {
    for (auto d : min_decimals)
      if (d >= 0) return true;
    return false;
  }
  [[nodiscard]] int min_decimals_for(char upper_letter) const {
    return upper_letter >= 'A' && upper_letter <= 'Z' ? min_decimals[static_cast<std::size_t>(upper_letter - 'A')] : -1;
  }
  [[nodiscard]] bool identity() const {
    return !strip_comments && !renumber_start && !any_min_decimals() && !units && !linearize_tolerance_mm;
  }
};

struct ConvertResult {
  std::uint64_t blocks = 0;
  std::uint64_t changed_blocks = 0;
  std::uint64_t removed_blocks = 0;
  std::uint64_t inserted_lines = 0;      ///< new lines: the unit word, arc segments after the first
  std::uint64_t bytes_in = 0;
  std::uint64_t decimals_raised = 0;     ///< --decimals: words written with more decimals
  std::uint64_t decimals_finer = 0;      ///< --decimals: words already finer than asked, left as written
  std::uint64_t decimals_expression = 0; ///< --decimals: words of those letters given by expressions, left
  std::uint64_t decimals_integer = 0;    ///< --decimals: Fanuc whole numbers of unknown integer input, left
  std::uint64_t unit_words = 0;          ///< --units: unit words changed or inserted
  std::uint64_t scaled_words = 0;        ///< --units: length and feed words converted
  std::uint64_t arcs_linearized = 0;     ///< --linearize: arcs replaced …
  std::uint64_t segments = 0;            ///< … by this many G1 segments
};

/// Converts the program read by `in` into `out`. Refusals are reported to `sink` (errors); the
/// caller must not commit `out` when sink.has_errors(). With --linearize and other options, the
/// other options run first and the arcs of their result are linearised (locations still name the
/// input's lines).
ConvertResult convert(LineReader& in, std::string_view file, const Dialect& dialect, const ConvertOptions& opt,
                      io::OutputFile& out, DiagnosticSink& sink);

/// convert on a program held in memory that may use parameters, expressions, subprograms or
/// control flow (resolve.hpp):
/// - opt.flatten: it is resolved and its literal program converted;
/// - --units without flatten: refused (PP-E502): lengths held in parameters and on lines the run
///   does not reach cannot be converted exactly;
/// - --linearize: the resolved program is linearised and the chords are written back into the
///   program's own lines (write_back.hpp: refused where that is not exact, PP-E711); arcs on lines
///   the run does not reach stay arcs;
/// - the other options (comments, renumbering, decimals) work on the text as written.
/// A program without such statements is converted as by convert().
ConvertResult convert_program(std::string_view text, std::string_view file, const Dialect& dialect,
                              const ConvertOptions& opt, io::OutputFile& out, DiagnosticSink& sink);

}  // namespace postproc::gcode
