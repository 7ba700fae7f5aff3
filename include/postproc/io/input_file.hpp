#pragma once
/// @file
/// Reading a whole input file (machine files, measurement files) into memory.

#include <string>
#include <string_view>

namespace postproc::io {

/// The bytes of the file at `path` ("-": standard input). Throws postproc::Error (no_input) "PATH: cannot open the WHAT"
/// (or "cannot read") when it cannot be opened or read.
[[nodiscard]] std::string read_file(const std::string& path, std::string_view what);

}  // namespace postproc::io
