#pragma once
/// @file
/// Reading a whole input file (machine files, measurement files) into memory, and the checks every
/// input passes before it is read.

#include <string>
#include <string_view>

namespace postproc::io {

/// Throws postproc::Error (no_input, PP-E903) "PATH: PP-E903 the WHAT is a folder …" when `path`
/// exists but is not a regular file or a pipe (a folder, a device, a socket). "-" (standard input)
/// and paths that do not exist pass (opening them reports the error).
void check_input_kind(const std::string& path, std::string_view what);

/// check_input_kind, then notes `path` as an input of this run (io::note_input): no output of the
/// run may be written over it.
void accept_input(const std::string& path, std::string_view what);

/// The bytes of the file at `path` ("-": standard input), accepted as an input (accept_input).
/// Throws postproc::Error (no_input) "PATH: cannot open the WHAT" (or "cannot read") when it cannot
/// be opened or read.
[[nodiscard]] std::string read_file(const std::string& path, std::string_view what);

/// As read_file, for state the run itself replaces (an earlier batch manifest): not noted as an
/// input.
[[nodiscard]] std::string read_state_file(const std::string& path, std::string_view what);

}  // namespace postproc::io
