// postproc check FILE…: diagnostics and a summary per program.
#include <cerrno>
#include <cstring>
#include <fstream>
#include <memory>

#include <fmt/format.h>

#include "common.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/gcode/detect.hpp"
#include "postproc/gcode/program.hpp"
#include "postproc/gcode/summary.hpp"

namespace postproc::cli {
namespace {

struct CheckOptions {
  std::vector<std::string> files;
  DialectArgs dialect;
  ResolveArgs resolve;
  std::size_t max_per_code = 20;
  bool quiet = false;
};

class Summarise final : public gcode::BlockVisitor {
 public:
  gcode::ProgramSummary summary;
  void block(const gcode::Block&, std::span<const gcode::Motion> motions, bool) override {
    ++summary.blocks;
    for (const auto& m : motions) summary.add(m);
  }
};

std::string unit_of(int axis) { return gcode::is_rotary(axis) ? "deg" : "mm"; }

/// Four decimals without a "-0.0000" for values that round to zero.
std::string fixed4(double v) {
  std::string s = fmt::format("{:.4f}", v);
  return s == "-0.0000" ? s.substr(1) : s;
}

void print_summary(const std::string& file, const gcode::Dialect& d, const std::string& how,
                   const gcode::ProgramSummary& s, const gcode::DiagnosticSink& sink) {
  using gcode::MotionType;
  std::string out = fmt::format("{}: dialect {}{}{}\n", file, d.name, d.lathe ? " (lathe)" : "", how);
  if (d.id == gcode::DialectId::siemens)
    out += fmt::format("  machine settings: basic system {} (MD10240), reset motion {} (MD20150); see --basic-system, "
                       "--reset-motion\n",
                       d.basic_inch ? "inch" : "metric", d.reset_motion == gcode::GMeaning::rapid ? "G0" : "G1");
  out += fmt::format("  blocks: {}\n", s.blocks);
  out += fmt::format("  motions: {} (rapid {}, linear {}, cw {}, ccw {}, drill {}{})\n", s.motions(),
                     s.motions_by_type[0], s.motions_by_type[1], s.motions_by_type[2], s.motions_by_type[3],
                     s.motions_by_type[4],
                     s.machine_frame_moves ? fmt::format("; {} in machine coordinates", s.machine_frame_moves) : "");
  std::string axes;
  for (int a = 0; a < gcode::kAxisCount; ++a)
    if ((s.axes_used >> a) & 1u) axes += fmt::format("{}{}", axes.empty() ? "" : " ", gcode::kAxisLetters[a]);
  out += fmt::format("  axes: {}\n", axes.empty() ? "none" : axes);
  for (int a = 0; a < gcode::kAxisCount; ++a)
    if (s.min[a] <= s.max[a])
      out += fmt::format("  extent {}: {} .. {} {}\n", gcode::kAxisLetters[a], fixed4(s.min[a]), fixed4(s.max[a]), unit_of(a));
  constexpr const char* kFeedUnit[] = {"mm/min", "mm/rev", "1/min (inverse time)"};
  constexpr const char* kFeedName[] = {"per minute", "per revolution", "inverse time"};
  for (std::size_t k = 0; k < 3; ++k)
    if (s.feeds[k].count > 0)
      out += fmt::format("  feed {}: {:.4g} .. {:.4g} {} ({} move{})\n", kFeedName[k], s.feeds[k].min, s.feeds[k].max,
                         kFeedUnit[k], s.feeds[k].count, s.feeds[k].count == 1 ? "" : "s");
  std::string unresolved;
  for (const auto& [code, n] : sink.per_code())
    if (code.rfind("PP-U", 0) == 0) unresolved += fmt::format("{}{} ×{}", unresolved.empty() ? "" : ", ", code, n);
  out += fmt::format("  unresolved constructs: {}\n", unresolved.empty() ? "none" : unresolved);
  const auto errors = sink.count(gcode::Severity::error);
  out += fmt::format("  result: {}\n", errors > 0 ? fmt::format("refused ({} errors)", errors)
                                       : unresolved.empty() ? std::string("accepted")
                                                            : std::string("accepted with unresolved constructs"));
  std::fputs(out.c_str(), stdout);
}

int check_one(const std::string& file, const CheckOptions& o) {
  gcode::DiagnosticSink sink;
  DiagnosticPrinter printer(sink, o.max_per_code);
  std::string how;
  DialectArgs args = o.dialect;
  const auto guess = gcode::guess_dialect(head_of(file));
  if (args.dialect.empty()) {
    if (!guess)
      throw Error(ExitCode::usage, fmt::format("{}: no --dialect given and nothing in the program identifies one; "
                                               "pass --dialect {}",
                                               file, gcode::dialect_names()));
    args.dialect = gcode::make_dialect(guess->id).name;
    how = fmt::format(" (guessed from '{}' at {}:{}; pass --dialect to confirm)", guess->evidence, guess->line,
                      guess->column);
  } else if (guess && gcode::make_dialect(guess->id).name != args.dialect) {
    std::fputs(fmt::format("{}:{}:{}: note: PP-N002: '{}' suggests dialect {}, but --dialect {} was given\n", file,
                           guess->line, guess->column, guess->evidence, gcode::make_dialect(guess->id).name,
                           args.dialect)
                   .c_str(),
               stderr);
  }
  const gcode::Dialect d = make_dialect(args);
  Summarise v;
  gcode::run_program_file(file, d, file, sink, v, make_resolve_options(o.resolve));
  printer.finish();
  if (!o.quiet) print_summary(file, d, how, v.summary, sink);
  return static_cast<int>(exit_code_for(sink));
}

}  // namespace

void setup_check(CLI::App& app, int& rc) {
  auto o = std::make_shared<CheckOptions>();
  auto* cmd = app.add_subcommand("check", "read programs, report located diagnostics and a summary");
  cmd->add_option("files", o->files, "NC programs ('-' = stdin)")->required();
  add_dialect_options(*cmd, o->dialect, false);
  add_resolve_options(*cmd, o->resolve);
  cmd->add_option("--max-per-code", o->max_per_code, "show at most this many diagnostics per code")
      ->capture_default_str();
  cmd->add_flag("-q,--quiet", o->quiet, "diagnostics only, no summary");
  cmd->callback([o, &rc] {
    int worst = 0;
    for (const auto& f : o->files) {
      int r = 0;
      try {
        r = check_one(f, *o);
      } catch (const Error& e) {
        // One unreadable file does not stop the others.
        std::fputs(fmt::format("postproc: error: {}\n", e.what()).c_str(), stderr);
        r = static_cast<int>(e.code());
      }
      worst = std::max(worst, r);
    }
    rc = worst;
  });
}

}  // namespace postproc::cli
