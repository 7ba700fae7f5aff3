// Why a controller stops at a line longer than it reads (dialect.hpp: max_line_length, line_too_long).
#include <fmt/format.h>

#include "postproc/gcode/dialect.hpp"

namespace postproc::gcode {

std::optional<std::string> line_too_long(const Dialect& d, std::size_t chars, bool cr) {
  const std::size_t limit = max_line_length(d), length = chars + (cr ? 1 : 0);
  if (limit == 0 || length <= limit) return std::nullopt;
  return fmt::format("this line has {} characters{}; LinuxCNC reads at most {} and stops here (\"Command too long\")",
                     length, cr ? " with its CR" : "", limit);
}

}  // namespace postproc::gcode
