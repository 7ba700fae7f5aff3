#pragma once
// Man pages and shell completions generated from the command definitions (docgen.cpp).
#include <string>

#include <CLI/CLI.hpp>

namespace postproc::cli {

/// Writes DIR/man1/postproc*.1 (one page per command), DIR/bash-completion/postproc,
/// DIR/zsh/_postproc and DIR/fish/postproc.fish from `app`'s subcommands and options.
void generate_docs(const CLI::App& app, const std::string& dir, const std::string& version);

}  // namespace postproc::cli
