// postproc convert IN -o OUT [options]: with no options the output is byte-identical to the input.
#include <memory>

#include <fmt/format.h>

#include "common.hpp"
#include "postproc/gcode/convert.hpp"

namespace postproc::cli {
namespace {

struct ConvertArgs {
  std::string input;
  std::string output;
  DialectArgs dialect;
  bool in_place = false;
  std::size_t max_per_code = 20;
  std::string renumber;  ///< "START[,STEP]"
  gcode::ConvertOptions opt;
};

void parse_renumber(const std::string& s, gcode::ConvertOptions& opt) {
  const auto comma = s.find(',');
  try {
    opt.renumber_start = std::stoull(s.substr(0, comma));
    if (comma != std::string::npos) opt.renumber_step = std::stoull(s.substr(comma + 1));
  } catch (const std::exception&) {
    throw Error(ExitCode::usage, fmt::format("--renumber '{}': expected START[,STEP], e.g. 10,10", s));
  }
  if (opt.renumber_step == 0) throw Error(ExitCode::usage, "--renumber: STEP must be at least 1");
}

}  // namespace

void setup_convert(CLI::App& app, int& rc) {
  auto o = std::make_shared<ConvertArgs>();
  auto* cmd = app.add_subcommand("convert", "rewrite a program; with no options the output equals the input");
  cmd->add_option("input", o->input, "NC program ('-' = stdin)")->required();
  cmd->add_option("-o,--output", o->output, "output file ('-' = stdout)")->required();
  add_dialect_options(*cmd, o->dialect, true);
  cmd->add_flag("--in-place", o->in_place, "allow -o to name the input (a .bak backup is kept)");
  cmd->add_flag("--strip-comments", o->opt.strip_comments, "remove ( ) and ; comments; comment-only lines go");
  cmd->add_option("--renumber", o->renumber, "renumber existing N words: START[,STEP] (refused if the program "
                                             "jumps to sequence numbers)");
  cmd->add_option("--max-per-code", o->max_per_code, "show at most this many diagnostics per code")
      ->capture_default_str();
  cmd->callback([o, &rc] {
    if (!o->renumber.empty()) parse_renumber(o->renumber, o->opt);
    const gcode::Dialect d = make_dialect(o->dialect);
    gcode::DiagnosticSink sink;
    DiagnosticPrinter printer(sink, o->max_per_code);
    gcode::LineReader reader(o->input);
    io::OutputFile out(o->output, o->input, o->in_place);
    gcode::convert(reader, o->input, d, o->opt, out, sink);
    printer.finish();
    if (sink.has_errors()) {
      std::fputs(fmt::format("postproc: {}: refused; nothing was written\n", o->input).c_str(), stderr);
      rc = static_cast<int>(ExitCode::refused);
      return;
    }
    out.commit();
    rc = 0;  // written; warnings (unresolved constructs) were printed but change nothing here
  });
}

}  // namespace postproc::cli
