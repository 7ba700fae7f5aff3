// The longest line a controller reads (dialect.hpp: max_line_length, line_too_long).
#include <fmt/format.h>

#include "postproc/gcode/dialect.hpp"

namespace postproc::gcode {

std::size_t max_line_length(const Dialect& d) {
  // rs274ngc reads a line into a buffer of LINELEN (255) bytes with fgets and stops with "Command
  // too long" when it is full: a line of 253 characters or more, its CR (CRLF files) counted
  // (checked against LinuxCNC 2.9's rs274, tests/rs274_line_length.py).
  return d.id == DialectId::linuxcnc ? 252 : 0;
}

std::optional<std::string> line_too_long(const Dialect& d, std::size_t chars, bool cr) {
  const std::size_t limit = max_line_length(d), length = chars + (cr ? 1 : 0);
  if (limit == 0 || length <= limit) return std::nullopt;
  return fmt::format("this line has {} characters{}; LinuxCNC reads at most {} and stops here (\"Command too long\")",
                     length, cr ? " with its CR" : "", limit);
}

}  // namespace postproc::gcode
