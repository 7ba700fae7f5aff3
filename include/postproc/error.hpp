#pragma once
/// @file
/// The one exception type of postproc, carrying a documented process exit code.

#include <stdexcept>
#include <string>

namespace postproc {

/// Exit codes of the `postproc` command (documented in README.md).
enum class ExitCode : int {
  ok = 0,             ///< accepted, fully resolved
  unresolved = 1,     ///< accepted, but contains constructs later compensation refuses (warnings)
  refused = 2,        ///< the input has errors; nothing was written
  usage = 64,         ///< bad command line
  no_input = 66,      ///< an input file cannot be opened or read
  cannot_write = 73,  ///< an output cannot be created or renamed into place
  internal = 70,      ///< a bug: please report it with the input
};

class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& what) : std::runtime_error(what), code_(code) {}
  [[nodiscard]] ExitCode code() const { return code_; }

 private:
  ExitCode code_;
};

}  // namespace postproc
