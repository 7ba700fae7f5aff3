// compensate_program: the --mode dispatch shared by `postproc compensate` and `postproc batch`.
#include <algorithm>

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

CompensateResult compensate_program(std::string_view text, std::string_view file, const gcode::Dialect& dialect,
                                    const machine::Machine& m, const CompensateOptions& options,
                                    const contour::PrecompensateOptions& popt, io::OutputFile& out,
                                    gcode::DiagnosticSink& sink, ContourDetails* details) {
  CompensateOptions opt = options;
  if (opt.input_bytes == 0) opt.input_bytes = text.size();
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
  gopt.header = false;
  std::vector<std::uint64_t> geo_lines;  // intermediate line → input line
  gopt.line_map = &geo_lines;
  auto mem = io::OutputFile::memory();
  gcode::LineReader reader{text};
  const CompensateResult geo = compensate(reader, file, dialect, m, gopt, mem, sink);
  CompensateResult r;
  if (!sink.has_errors()) {
    const std::string intermediate = mem.take();
    opt.input_bytes = intermediate.size();
    r = compensate_contour(intermediate, file, dialect, m, opt, popt, out, sink, &cd);
  }
  merge_geometric(r, geo);
  if (r.contour_worst_line >= 1 && r.contour_worst_line <= geo_lines.size())
    r.contour_worst_line = geo_lines[r.contour_worst_line - 1];
  return r;
}

}  // namespace postproc::comp
