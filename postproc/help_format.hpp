#pragma once
// `--help` that fits a screen: each option's description shortened to its first clause and cut
// to the terminal's width; `--help-all` prints the whole descriptions (as the man pages do).
#include <memory>

#include <CLI/CLI.hpp>

namespace postproc::cli {

class ScreenHelpFormatter final : public CLI::Formatter {
 public:
  explicit ScreenHelpFormatter(bool full) : full_(full) {}
  std::string make_option_desc(const CLI::Option* opt) const override;
  std::string make_footer(const CLI::App* app) const override;
  std::string make_description(const CLI::App* app) const override;
  std::string make_subcommand(const CLI::App* sub) const override;

 private:
  bool full_;
};

/// `text` wrapped at blanks to lines of fewer than `width` characters (UTF-8).
std::string wrap(std::string_view text, std::size_t width);

/// Removes "--help-all" from argv (replacing it by "--help") and says whether it was there.
bool take_help_all(int argc, char** argv);

/// The first clause of `text` (up to the first "; " outside parentheses), cut at a word to at
/// most `width` characters (UTF-8) with "…".
std::string first_clause(std::string_view text, std::size_t width);

}  // namespace postproc::cli
