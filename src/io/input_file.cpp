// Reading whole input files (see input_file.hpp).
#include "postproc/io/input_file.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>

#include <fmt/format.h>

#include "postproc/error.hpp"
#include "postproc/io/input_guard.hpp"

namespace postproc::io {
namespace {

std::string read_bytes(const std::string& path, std::string_view what) {
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

}  // namespace

void check_input_kind(const std::string& path, std::string_view what) {
  struct stat st {};
  if (path.empty() || path == "-" || ::stat(path.c_str(), &st) != 0) return;
  if (S_ISREG(st.st_mode) || S_ISFIFO(st.st_mode)) return;
  const char* kind = S_ISDIR(st.st_mode)    ? "a folder"
                     : S_ISCHR(st.st_mode)  ? "a character device"
                     : S_ISBLK(st.st_mode)  ? "a block device"
                     : S_ISSOCK(st.st_mode) ? "a socket"
                                            : "not a regular file";
  throw Error(ExitCode::no_input,
              fmt::format("{}: PP-E903 the {} is {}, not a file; name a file (or '-' for standard input)", path, what,
                          kind));
}

void accept_input(const std::string& path, std::string_view what) {
  check_input_kind(path, what);
  note_input(path, what);
}

std::string read_file(const std::string& path, std::string_view what) {
  accept_input(path, what);
  return read_bytes(path, what);
}

std::string read_state_file(const std::string& path, std::string_view what) {
  check_input_kind(path, what);
  return read_bytes(path, what);
}

}  // namespace postproc::io
