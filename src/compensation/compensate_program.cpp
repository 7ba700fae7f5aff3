// compensate_program: the --mode dispatch shared by `postproc compensate` and `postproc batch`.
#include <algorithm>
#include <filesystem>

#include "postproc/compensation/compensate.hpp"
#include "postproc/gcode/write_back.hpp"
#include "postproc/error.hpp"

namespace postproc::comp {
namespace {

/// --mode all: the figures of the geometric stage next to the contour stage's.
void merge_geometric(CompensateResult& r, const CompensateResult& g) {
  r.subdivided_blocks = g.subdivided_blocks;
  r.parallel_chunks = g.parallel_chunks;
  r.parallel_recomputed = g.parallel_recomputed;
  r.segments_added = g.segments_added;
  r.arcs_kept = g.arcs_kept;
  r.arcs_linearized = g.arcs_linearized;
  r.reference_moves = g.reference_moves;
  r.rapids_as_written = g.rapids_as_written;
  r.axis_limited_blocks = g.axis_limited_blocks;
  r.axis_limited_max_rad = g.axis_limited_max_rad;
  r.axis_limited = g.axis_limited;
  r.max_error_before_mm = g.max_error_before_mm;
  r.max_error_before_rad = g.max_error_before_rad;
  r.max_residual_mm = g.max_residual_mm;
  r.max_residual_rad = g.max_residual_rad;
  r.worst_line = g.worst_line;
  r.max_correction_mm = std::max(r.max_correction_mm, g.max_correction_mm);
  r.max_correction_deg = std::max(r.max_correction_deg, g.max_correction_deg);
  r.max_axis_correction_rad = std::max(r.max_axis_correction_rad, g.max_axis_correction_rad);
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
  if (!opt.allow_recompensation && text.find(" compensate mode=") != std::string_view::npos) {
    std::uint64_t line_no = 1;
    for (std::size_t at = 0; at < text.size(); ++line_no) {
      std::size_t end = text.find('\n', at);
      if (end == std::string_view::npos) end = text.size();
      std::string_view line = text.substr(at, end - at);
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      if (refuse_recompensation(line, line_no, file, opt, sink)) return {};
      at = end + 1;
    }
  }
  opt.allow_recompensation = true;  // checked here once (the stages below would check again)
  if (gcode::first_resolution_line(text, dialect) != 0) {
    const gcode::ResolveOptions ro = gcode::with_program_folder(opt.resolve, file);
    const std::size_t errors = sink.count(gcode::Severity::error);
    const gcode::ResolvedProgram resolved = gcode::resolve(text, file, dialect, ro, sink);
    if (sink.count(gcode::Severity::error) > errors) return {};
    gcode::DiagnosticSink mapped = gcode::source_mapped(resolved, sink);
    opt.input_bytes = resolved.text.size();
    CompensateResult r;
    if (opt.flatten && !resolved.not_flat.empty()) {  // the resolved text is not a program of its own here
      sink.report(resolved.not_flat.front());
      return {};
    }
    if (opt.flatten) {
      r = compensate_flat(resolved.text, file, dialect, m, opt, popt, out, mapped, details);
      r.flattened = true;
    } else {
      // Compensate the literal program in memory, then carry every corrected block back onto
      // its source line (write_back.hpp).
      CompensateOptions lopt = opt;
      lopt.header = false;
      std::vector<std::uint64_t> map;
      lopt.line_map = &map;
      auto mem = io::OutputFile::memory();
      r = compensate_flat(resolved.text, file, dialect, m, lopt, popt, mem, mapped, details);
      if (sink.count(gcode::Severity::error) > errors) return r;
      const std::string literal = mem.take();
      CompensateOptions hopt = opt;
      hopt.resolved_in_place = true;
      std::string written;
      const gcode::WriteBackResult wb = gcode::write_back(text, file, dialect, resolved, literal, map,
                                            opt.header ? header_comment(dialect, m, hopt) : std::string(), written, sink);
      if (!wb.ok) return r;
      out.write(written);
      r.source_lines_rewritten = wb.lines_changed;
      r.segments_added = wb.lines_added;  // lines added to the program as written
    }
    r.resolved_lines = resolved.source_line.size();
    r.used_settings = resolved.used_settings;
    r.subprogram_files.assign(resolved.files.begin() + (resolved.files.empty() ? 0 : 1), resolved.files.end());
    // The worst lines are lines of the program as written.
    for (std::uint64_t* l : {&r.worst_line, &r.contour_worst_line})
      if (*l >= 1 && *l <= resolved.source_line.size()) *l = resolved.source_line[*l - 1];
    for (ContourRunReport& c : r.contour_run_reports)
      if (c.line >= 1 && c.line <= resolved.source_line.size()) c.line = resolved.source_line[c.line - 1];
    return r;
  }
  opt.flatten = false;  // nothing to flatten: the header says nothing about it
  return compensate_flat(text, file, dialect, m, opt, popt, out, sink, details);
}

CompensateResult compensate_flat(std::string_view text, std::string_view file, const gcode::Dialect& dialect,
                                 const machine::Machine& m, const CompensateOptions& opt,
                                 const contour::PrecompensateOptions& popt, io::OutputFile& out,
                                 gcode::DiagnosticSink& sink, ContourDetails* details) {
  if (opt.mode == Mode::geometric) {
    gcode::LineReader reader{text};
    return compensate(reader, file, dialect, m, opt, out, sink);
  }
  ContourDetails local;
  ContourDetails& cd = details ? *details : local;
  if (opt.mode == Mode::contour) return compensate_contour(text, file, dialect, m, opt, popt, out, sink, &cd);
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
  std::vector<std::uint64_t> contour_lines;  // output line → intermediate line
  copt.line_map = opt.line_map != nullptr ? &contour_lines : nullptr;
  if (!sink.has_errors()) {
    const std::string intermediate = mem.take();
    if (cd.keep_geometric_stage) {
      cd.geometric_input = std::string(text);
      cd.geometric_output = intermediate;
      cd.geometric_line_map = geo_lines;
    }
    copt.input_bytes = intermediate.size();
    // The contour stage's diagnostics (PP-W611, PP-W620 …) name lines of the intermediate text:
    // carried back to the input's lines (the text shown is the line as the geometric stage wrote it).
    gcode::DiagnosticSink to_input(0);
    to_input.on_report = [&](const gcode::Diagnostic& diag) {
      gcode::Diagnostic c = diag;
      if (c.where.line >= 1 && c.where.line <= geo_lines.size() && geo_lines[c.where.line - 1] != 0)
        c.where.line = geo_lines[c.where.line - 1];
      sink.report(std::move(c));
    };
    r = compensate_contour(intermediate, file, dialect, m, copt, popt, out, to_input, &cd);
  }
  if (opt.line_map != nullptr)
    for (const std::uint64_t l : contour_lines)
      opt.line_map->push_back(l >= 1 && l <= geo_lines.size() ? geo_lines[l - 1] : 0);
  merge_geometric(r, geo);
  if (r.contour_worst_line >= 1 && r.contour_worst_line <= geo_lines.size())
    r.contour_worst_line = geo_lines[r.contour_worst_line - 1];
  for (ContourRunReport& c : r.contour_run_reports)
    if (c.line >= 1 && c.line <= geo_lines.size()) c.line = geo_lines[c.line - 1];
  return r;
}

}  // namespace postproc::comp
