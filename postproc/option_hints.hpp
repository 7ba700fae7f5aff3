#pragma once
// "Did you mean" for a mistyped command or option: the command line is checked against the
// definitions of the command it names (only after CLI11 refused it, so valid lines are untouched).
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

namespace postproc::cli {

/// The first word of argv that names no command or option of `app` (walking into the commands it
/// names), as a message with the nearest names ("did you mean …") and where the list is; nullopt
/// when every command and option word is known.
[[nodiscard]] std::optional<std::string> unknown_word_hint(CLI::App& app, int argc, const char* const* argv);

}  // namespace postproc::cli
