// postproc command line: wires subcommands to the library. Exit codes are documented in docs/exit-codes.md.
#include <cstdio>
#include <exception>
#include <string_view>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "common.hpp"
#include "help_format.hpp"
#include "docgen.hpp"
#include "option_hints.hpp"
#include "postproc/io/input_guard.hpp"
#include "postproc/io/signal_cleanup.hpp"

int main(int argc, char** argv) {
  postproc::io::install_signal_cleanup();
  const postproc::io::RunInputs run;  // no output of this run over any of its inputs
  CLI::App app{"postproc: read, check, rewrite and compensate NC programs through calibrated machine models"};
  app.set_version_flag("--version", std::string("postproc ") + POSTPROC_VERSION);
  // Before the commands are added: they inherit it. --help fits a screen, --help-all is whole.
  app.formatter(std::make_shared<postproc::cli::ScreenHelpFormatter>(postproc::cli::take_help_all(argc, argv)));
  app.require_subcommand(1);
  int rc = 0;
  postproc::cli::setup_check(app, rc);
  postproc::cli::setup_dump(app, rc);
  postproc::cli::setup_convert(app, rc);
  postproc::cli::setup_compensate(app, rc);
  postproc::cli::setup_calibrate(app, rc);
  postproc::cli::setup_predict(app, rc);
  postproc::cli::setup_simulate(app, rc);
  postproc::cli::setup_diff(app, rc);
  postproc::cli::setup_batch(app, rc);
  // Hidden, for the build: man pages and shell completions from the definitions above.
  if (argc == 3 && std::string_view(argv[1]) == "--generate-docs") {
    try {
      postproc::cli::generate_docs(app, argv[2], POSTPROC_VERSION);
      return 0;
    } catch (const std::exception& e) {
      std::fputs(fmt::format("postproc: error: {}\n", e.what()).c_str(), stderr);
      return static_cast<int>(postproc::ExitCode::cannot_write);
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // A mistyped command or option: name it, with the nearest names, before CLI11's own message
    // (which may only say that a required option is missing).
    if (e.get_exit_code() != 0)
      if (const auto hint = postproc::cli::unknown_word_hint(app, argc, argv)) {
        std::fputs(fmt::format("postproc: error: {}\n", *hint).c_str(), stderr);
        return static_cast<int>(postproc::ExitCode::usage);
      }
    const int code = app.exit(e);
    return code == 0 ? 0 : static_cast<int>(postproc::ExitCode::usage);
  } catch (const postproc::Error& e) {
    std::fputs(fmt::format("postproc: error: {}\n", e.what()).c_str(), stderr);
    return static_cast<int>(e.code());
  } catch (const std::exception& e) {
    std::fputs(fmt::format("postproc: internal error: {} (please report with the input)\n", e.what()).c_str(), stderr);
    return static_cast<int>(postproc::ExitCode::internal);
  }
  return rc;
}
