#pragma once
/// @file
/// `postproc convert`: rewrites a program block by block. With no options it is the identity
/// (byte-identical output). Blocks no option touches are copied byte for byte.

#include <array>
#include <cstdint>
#include <optional>
#include <string_view>

#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/io/output_file.hpp"

namespace postproc::gcode {

struct ConvertOptions {
  bool strip_comments = false;            ///< drop ( ) and ; comments; lines left empty are dropped
  std::optional<std::uint64_t> renumber_start;  ///< renumber existing N words from here …
  std::uint64_t renumber_step = 10;       ///< … in steps of this
  [[nodiscard]] bool identity() const { return !strip_comments && !renumber_start; }
};

struct ConvertResult {
  std::uint64_t blocks = 0;
  std::uint64_t changed_blocks = 0;
  std::uint64_t removed_blocks = 0;
  std::uint64_t bytes_in = 0;
};

/// Converts the program read by `in` into `out`. Refusals are reported to `sink` (errors); the
/// caller must not commit `out` when sink.has_errors().
ConvertResult convert(LineReader& in, std::string_view file, const Dialect& dialect, const ConvertOptions& opt,
                      io::OutputFile& out, DiagnosticSink& sink);

}  // namespace postproc::gcode
