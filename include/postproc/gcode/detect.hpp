#pragma once
/// @file
/// Suggests a dialect from a program's text. Used only to *suggest* (check prints the evidence);
/// commands that change programs never act on a guess.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "postproc/gcode/dialect.hpp"

namespace postproc::gcode {

struct DialectGuess {
  DialectId id = DialectId::fanuc;
  std::string evidence;  ///< e.g. "TRAORI"
  std::uint64_t line = 0;
  std::uint32_t column = 0;
};

/// Looks at the first `max_lines` lines of `text` for constructs only one dialect has.
[[nodiscard]] std::optional<DialectGuess> guess_dialect(std::string_view text, std::size_t max_lines = 2000);

}  // namespace postproc::gcode
