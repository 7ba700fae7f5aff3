// Reading whole input files (see input_file.hpp).
#include "postproc/io/input_file.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>

#include <fmt/format.h>

#include "postproc/error.hpp"

namespace postproc::io {

std::string read_file(const std::string& path, std::string_view what) {
  if (path == "-") {  // standard input, as every command reads "-"
    std::ostringstream s;
    s << std::cin.rdbuf();
    if (std::cin.bad()) throw Error(ExitCode::no_input, fmt::format("<stdin>: cannot read the {}", what));
    return s.str();
  }
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw Error(ExitCode::no_input, fmt::format("{}: cannot open the {}{}", path, what,
                                                errno != 0 ? fmt::format(": {}", std::strerror(errno)) : std::string()));
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw Error(ExitCode::no_input, fmt::format("{}: cannot read the {}", path, what));
  return s.str();
}

}  // namespace postproc::io
