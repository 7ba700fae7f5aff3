// Reading whole input files (see input_file.hpp).
#include "postproc/io/input_file.hpp"

#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "postproc/error.hpp"

namespace postproc::io {

std::string read_file(const std::string& path, std::string_view what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ExitCode::no_input, fmt::format("{}: cannot open the {}", path, what));
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw Error(ExitCode::no_input, fmt::format("{}: cannot read the {}", path, what));
  return s.str();
}

}  // namespace postproc::io
