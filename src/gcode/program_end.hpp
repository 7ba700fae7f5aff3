#pragma once
// The program's end as the controls read it (M2/M30, the '%' closing an opening one): what the
// reader (program.cpp) and the Fanuc resolver (resolve/fanuc.cpp) share about the lines after it.
#include <algorithm>
#include <cstdint>
#include <string>
#include <string_view>

#include <fmt/format.h>

#include "postproc/gcode/block.hpp"
#include "postproc/gcode/dialect.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode::program_end {

/// A line with something the control would execute: words, or tokens other than comments and '%'.
[[nodiscard]] inline bool holds_nc_words(const Block& b) {
  return !b.words.empty() || std::any_of(b.tokens.begin(), b.tokens.end(), [](const Token& t) {
           return t.kind != TokenKind::paren_comment && t.kind != TokenKind::line_comment &&
                  t.kind != TokenKind::percent;
         });
}

/// An M2 or M30 word: it ends the program (every ISO dialect).
[[nodiscard]] inline bool ends_program(const Word& w) {
  return w.letter == 'M' && w.name_len == 1 && w.kind == ValueKind::number && (w.number == 2 || w.number == 30);
}

/// A line that starts another program of the file (a Fanuc O line; a Sinumerik archive's
/// '%_N_…' header): it runs only where it is called, so the lines after it are not warned about.
[[nodiscard]] inline bool starts_program(const Block& b, DialectId d) {
  return std::any_of(b.tokens.begin(), b.tokens.end(), [&](const Token& t) {
    return t.kind == TokenKind::program_number ||
           (t.kind == TokenKind::percent && d != DialectId::linuxcnc && text::trim(b.raw).size() > 1);
  });
}

/// PP-W210's text: `what` ended the program at `line`.
[[nodiscard]] inline std::string after_end_message(std::string_view what, std::uint64_t line) {
  return fmt::format("this line and those after it come after the program's end ({} at line {}): the control never "
                     "runs them; they are copied unchanged. Move them before the end if they are meant to run",
                     what, line);
}

}  // namespace postproc::gcode::program_end
