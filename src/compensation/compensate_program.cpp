// compensate_program: the --mode dispatch shared by `postproc compensate` and `postproc batch`.
#include <algorithm>
#include <filesystem>

#include "postproc/compensation/compensate.hpp"
#include "postproc/error.hpp"

namespace postproc::comp {
namespace {

/// --mode all: the figures of the geometric stage next to the contour stage's.
void merge_geometric(CompensateResult& r, const CompensateResult& g) {
  r.subdivided_blocks = g.subdivided_blocks;
  r.segments_added = g.segments_added;
  r.arcs_kept = g.arcs_kept;
  r.arcs_linearized = g.arcs_linearized;
  r.reference_moves = g.reference_moves;
  r.rapids_as_written = g.rapids_as_written;
  r.singular_fallbacks = g.singular_fallbacks;
  r.max_error_before_mm = g.max_error_before_mm;
  r.max_error_before_rad = g.max_error_before_rad;
  r.max_residual_mm = g.max_residual_mm;
  r.max_residual_rad = g.max_residual_rad;
  r.worst_line = g.worst_line;
  r.max_correction_mm = std::max(r.max_correction_mm, g.max_correction_mm);
  r.max_correction_deg = std::max(r.max_correction_deg, g.max_correction_deg);
}

}  // namespace

CompensateResult compensate_flat(std::string_view text, std::string_view file, const gcode::Dialect& dialect,
                                 const machine::Machine& m, const CompensateOptions& opt,
                                 const contour::PrecompensateOptions& popt, io::OutputFile& out,
                                 gcode::DiagnosticSink& sink, ContourDetails* details);

CompensateResult compensate_program(std::string_view text, std::string_view file, const gcode::Dialect& dialect,
                                    const machine::Machine& m, const CompensateOptions& options,
                                    const contour::PrecompensateOptions& popt, io::OutputFile& out,
                                    gcode::DiagnosticSink& sink, ContourDetails* details) {
  CompensateOptions opt = options;
  if (opt.input_bytes == 0) opt.input_bytes = text.size();
  if (const std::uint64_t line = gcode::first_resolution_line(text, dialect); line != 0) {
    if (!opt.flatten) {
      gcode::Diagnostic d;
      d.severity = gcode::Severity::error;
      d.code = "PP-E711";
      d.file = std::string(file);
      d.where = {line, 1};
      std::size_t pos = 0;
      for (std::uint64_t k = 1; k < line && pos != std::string_view::npos; ++k) {
        pos = text.find('\n', pos);
        if (pos != std::string_view::npos) ++pos;
      }
      if (pos != std::string_view::npos) {
        std::string_view l = text.substr(pos, text.find('\n', pos) - pos);
        if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
        d.source_line = std::string(l);
        d.length = static_cast<std::uint32_t>(std::max<std::size_t>(1, l.size()));
      }
      d.message =
          "the program uses parameters, expressions, subprogram calls or control flow (first here); a corrected value "
          "cannot be written back into an expression or into a loop body or subprogram that runs with different "
          "values: give --flatten to write the resolved program as literal moves";
      sink.report(std::move(d));
      return {};
    }
    gcode::ResolveOptions ro = opt.resolve;
    if (ro.search_dirs.empty()) {
      const std::filesystem::path dir = file == "-" ? std::filesystem::path(".") : std::filesystem::path(file).parent_path();
      ro.search_dirs.push_back(dir.empty() ? std::string(".") : dir.string());
    }
    const std::size_t errors = sink.count(gcode::Severity::error);
    const gcode::ResolvedProgram resolved = gcode::resolve(text, file, dialect, ro, sink);
    if (sink.count(gcode::Severity::error) > errors) return {};
    gcode::DiagnosticSink mapped(0);
    mapped.on_report = [&](const gcode::Diagnostic& diag) {
      gcode::Diagnostic m2 = diag;
      gcode::map_to_source(resolved, m2);
      sink.report(std::move(m2));
    };
    opt.input_bytes = resolved.text.size();
    CompensateResult r = compensate_flat(resolved.text, file, dialect, m, opt, popt, out, mapped, details);
    r.resolved_lines = resolved.source_line.size();
    r.used_settings = resolved.used_settings;
    return r;
  }
  opt.flatten = false;  // nothing to flatten: the header says nothing about it
  return compensate_flat(text, file, dialect, m, opt, popt, out, sink, details);
}

CompensateResult compensate_flat(std::string_view text, std::string_view file, const gcode::Dialect& dialect,
                                 const machine::Machine& m, const CompensateOptions& opt,
                                 const contour::PrecompensateOptions& popt, io::OutputFile& out,
                                 gcode::DiagnosticSink& sink, ContourDetails* details) {
  if (opt.mode == "geometric") {
    gcode::LineReader reader{text};
    return compensate(reader, file, dialect, m, opt, out, sink);
  }
  if (opt.mode != "contour" && opt.mode != "all")
    throw Error(ExitCode::usage, "unknown compensation mode '" + opt.mode + "' (geometric, contour or all)");
  ContourDetails local;
  ContourDetails& cd = details ? *details : local;
  if (opt.mode == "contour") return compensate_contour(text, file, dialect, m, opt, popt, out, sink, &cd);
  // all: the geometric stage into memory, then the contour stage on its output.
  CompensateOptions gopt = opt;
  CompensateOptions copt = opt;
  gopt.header = false;
  std::vector<std::uint64_t> geo_lines;  // intermediate line → input line
  gopt.line_map = &geo_lines;
  auto mem = io::OutputFile::memory();
  gcode::LineReader reader{text};
  const CompensateResult geo = compensate(reader, file, dialect, m, gopt, mem, sink);
  CompensateResult r;
  if (!sink.has_errors()) {
    const std::string intermediate = mem.take();
    copt.input_bytes = intermediate.size();
    r = compensate_contour(intermediate, file, dialect, m, copt, popt, out, sink, &cd);
  }
  merge_geometric(r, geo);
  if (r.contour_worst_line >= 1 && r.contour_worst_line <= geo_lines.size())
    r.contour_worst_line = geo_lines[r.contour_worst_line - 1];
  return r;
}

}  // namespace postproc::comp
