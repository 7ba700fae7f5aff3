// Running the interpreter on a program that may need resolution (resolve.hpp).
#include <algorithm>
#include <filesystem>

#include "postproc/gcode/resolve.hpp"
#include "postproc/io/input_file.hpp"

namespace postproc::gcode {
namespace {

/// Hands blocks and motions to `inner` with their source line numbers.
class SourceLines final : public BlockVisitor {
 public:
  SourceLines(const ResolvedProgram& r, BlockVisitor& inner) : r_(r), inner_(inner) {}
  void block(const Block& b, std::span<const Motion> motions, bool lexed_ok) override {
    const std::uint64_t line = b.line >= 1 && b.line <= r_.source_line.size() ? r_.source_line[b.line - 1] : b.line;
    copy_ = b;
    copy_.line = line;
    motions_.assign(motions.begin(), motions.end());
    for (Motion& m : motions_) m.line = line;
    inner_.block(copy_, motions_, lexed_ok);
  }

 private:
  const ResolvedProgram& r_;
  BlockVisitor& inner_;
  Block copy_;
  std::vector<Motion> motions_;
};

}  // namespace

DiagnosticSink source_mapped(const ResolvedProgram& r, DiagnosticSink& to) {
  DiagnosticSink mapped(0);
  mapped.on_report = [&r, &to](const Diagnostic& diag) {
    Diagnostic m = diag;
    map_to_source(r, m);
    to.report(std::move(m));
  };
  return mapped;
}

ProgramStats run_resolved(const ResolvedProgram& r, const Dialect& d, std::string_view file, DiagnosticSink& sink,
                          BlockVisitor& visitor) {
  DiagnosticSink mapped = source_mapped(r, sink);
  SourceLines lines(r, visitor);
  LineReader reader{std::string_view(r.text)};
  InterpreterOptions opt;
  opt.source_text = false;  // the resolver checked the source lines
  return run_program(reader, d, file, mapped, lines, opt);
}

ResolveOptions with_program_folder(ResolveOptions opt, std::string_view file) {
  const std::filesystem::path dir =
      file == "-" ? std::filesystem::current_path() : std::filesystem::path(file).parent_path();
  const std::string own = dir.empty() ? std::string(".") : dir.string();
  if (std::find(opt.search_dirs.begin(), opt.search_dirs.end(), own) == opt.search_dirs.end())
    opt.search_dirs.insert(opt.search_dirs.begin(), own);
  return opt;
}

namespace {

/// Resolves `text` and runs the interpreter on the result (the text needs resolution).
ProgramStats resolve_and_run(std::string_view text, const Dialect& d, std::string_view file, DiagnosticSink& sink,
                             BlockVisitor& visitor, const ResolveOptions& opt, ResolvedProgram* resolved) {
  const std::size_t errors = sink.count(Severity::error);
  ResolvedProgram local;
  ResolvedProgram& r = resolved ? *resolved : local;
  r = resolve(text, file, d, with_program_folder(opt, file), sink);
  ProgramStats st;
  st.bytes = text.size();
  if (sink.count(Severity::error) > errors) return st;
  const ProgramStats rs = run_resolved(r, d, file, sink, visitor);
  st.blocks = rs.blocks;
  return st;
}

}  // namespace

ProgramStats run_program_text(std::string_view text, const Dialect& d, std::string_view file, DiagnosticSink& sink,
                              BlockVisitor& visitor, const ResolveOptions& opt, ResolvedProgram* resolved) {
  if (!needs_resolution(text, d)) {
    LineReader reader{text};
    return run_program(reader, d, file, sink, visitor);
  }
  return resolve_and_run(text, d, file, sink, visitor, opt, resolved);
}

ProgramStats run_program_file(const std::string& path, const Dialect& d, std::string_view file, DiagnosticSink& sink,
                              BlockVisitor& visitor, const ResolveOptions& opt, ResolvedProgram* resolved) {
  std::error_code ec;
  // Standard input, pipes and other streams can be read once only: held in memory.
  if (path == "-" || !std::filesystem::is_regular_file(path, ec)) {
    const std::string text = io::read_file(path, "NC program");
    return run_program_text(text, d, file, sink, visitor, opt, resolved);
  }
  bool needed = false;
  {
    LineReader scan(path);
    needed = needs_resolution(scan, d);
  }
  if (!needed) {
    LineReader reader(path);
    return run_program(reader, d, file, sink, visitor);
  }
  const std::string text = io::read_file(path, "NC program");
  // Subprogram files are next to the program's path (which `file` may only name for display).
  return resolve_and_run(text, d, file, sink, visitor, with_program_folder(opt, path), resolved);
}

}  // namespace postproc::gcode
