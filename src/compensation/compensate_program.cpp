// compensate_program: the --mode dispatch shared by `postproc compensate` and `postproc batch`.
#include <algorithm>
#include <filesystem>

#include "postproc/compensation/compensate.hpp"
#include "postproc/contour/path.hpp"
#include "src/compensation/compensate_support.hpp"
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

CompensateResult compensate_flat(const ProgramInput& in, const CompensateOptions& opt, io::OutputFile& out,
                                 gcode::DiagnosticSink& sink, ContourDetails* details);

CompensateResult compensate_program(const ProgramInput& in, const CompensateOptions& options, io::OutputFile& out,
                                    gcode::DiagnosticSink& sink, ContourDetails* details) {
  const std::string_view text = in.text, file = in.file;
  const gcode::Dialect& dialect = in.dialect;
  const machine::Machine& m = in.machine;
  CompensateOptions opt = options;
  if (opt.input_bytes == 0) opt.input_bytes = text.size();
  if (!opt.allow_recompensation)
    if (const std::optional<CompensationHeader> h = find_compensation_header(text);
        h && refuse_recompensation(h->text, h->line, file, opt, sink))
      return {};
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
      r = compensate_flat({resolved.text, file, dialect, m}, opt, out, mapped, details);
      r.flattened = true;
    } else {
      // Compensate the literal program in memory, then carry every corrected block back onto
      // its source line (write_back.hpp).
      CompensateOptions lopt = opt;
      lopt.header = false;
      std::vector<std::uint64_t> map;
      lopt.line_map = &map;
      auto mem = io::OutputFile::memory();
      r = compensate_flat({resolved.text, file, dialect, m}, lopt, mem, mapped, details);
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
  return compensate_flat(in, opt, out, sink, details);
}

namespace {

/// Diagnostics held back until the candidate that reported them is chosen (at most kHeld; more,
/// and the chosen candidate is run again on the caller's sink).
constexpr std::size_t kHeld = 100000;
struct Held {
  std::vector<gcode::Diagnostic> list;
  bool overflow = false;
  gcode::DiagnosticSink sink{0};
  Held() {
    sink.on_report = [this](const gcode::Diagnostic& d) {
      if (list.size() < kHeld) list.push_back(d);
      else overflow = true;
    };
  }
  Held(const Held&) = delete;
  Held& operator=(const Held&) = delete;
};

/// The first stage of a contour mode: in --mode all the geometric remap, in --mode contour (only
/// for the split candidate) the geometric stage's writer on the controller's own model, which
/// changes nothing but the splits. Its output and line map (output line → input line).
struct FirstStage {
  CompensateResult r;
  std::string text;
  std::vector<std::uint64_t> lines;
};

FirstStage first_stage(const ProgramInput& in, const CompensateOptions& opt, gcode::DiagnosticSink& sink) {
  const machine::Machine& m = in.machine;
  FirstStage f;
  CompensateOptions gopt = opt;
  gopt.header = false;
  gopt.line_map = &f.lines;
  gopt.progress = {};
  auto mem = io::OutputFile::memory();
  gcode::LineReader reader{in.text};
  if (opt.mode == Mode::all) {
    f.r = compensate(reader, in.file, in.dialect, m, gopt, mem, sink);
  } else {
    machine::Machine nominal = m;
    nominal.actual = m.nominal;
    f.r = compensate(reader, in.file, in.dialect, nominal, gopt, mem, sink);
  }
  f.text = mem.take();
  return f;
}

/// The contour stage on `input` (the first stage's output, or the program itself when `first`
/// is null) into `out`, its diagnostics, worst lines, run lines and line map carried back to the
/// program's lines; in --mode all with the geometric figures of the first stage.
CompensateResult contour_stage(const ProgramInput& in, const FirstStage* first, const CompensateOptions& opt,
                               io::OutputFile& out, gcode::DiagnosticSink& sink, ContourDetails& cd) {
  CompensateOptions copt = opt;
  if (first == nullptr) return compensate_contour(in, copt, out, sink, &cd);
  const std::string_view input = in.text;
  const std::vector<std::uint64_t>& geo_lines = first->lines;
  std::vector<std::uint64_t> contour_lines;  // output line → intermediate line
  copt.line_map = opt.line_map != nullptr ? &contour_lines : nullptr;
  copt.input_bytes = input.size();
  // The contour stage's diagnostics (PP-W611, PP-W620 …) name lines of the intermediate text:
  // carried back to the input's lines (the text shown is the line as the first stage wrote it).
  gcode::DiagnosticSink to_input(0);
  to_input.on_report = [&](const gcode::Diagnostic& diag) {
    gcode::Diagnostic c = diag;
    if (c.where.line >= 1 && c.where.line <= geo_lines.size() && geo_lines[c.where.line - 1] != 0)
      c.where.line = geo_lines[c.where.line - 1];
    sink.report(std::move(c));
  };
  CompensateResult r = compensate_contour(in, copt, out, to_input, &cd);
  if (opt.line_map != nullptr)
    for (const std::uint64_t l : contour_lines)
      opt.line_map->push_back(l >= 1 && l <= geo_lines.size() ? geo_lines[l - 1] : 0);
  if (opt.mode == Mode::all) {
    merge_geometric(r, first->r);
  } else {
    r.arcs_linearized = first->r.arcs_linearized;
    r.segments_added = first->r.segments_added;
  }
  r.moves_split = first->r.moves_split;
  if (r.contour_worst_line >= 1 && r.contour_worst_line <= geo_lines.size())
    r.contour_worst_line = geo_lines[r.contour_worst_line - 1];
  for (ContourRunReport& c : r.contour_run_reports)
    if (c.line >= 1 && c.line <= geo_lines.size()) c.line = geo_lines[c.line - 1];
  return r;
}

/// The splits of the contour candidate, from the slowest drive: time constant τ = 1/Kv (+ the
/// velocity-loop time); pieces of 0.75 τ within 4 τ of a move's ends, where a corner's transient
/// lies. Off (step 0) when a joint has no servo data (the contour stage reports it).
CompensateOptions::SplitForContour split_settings(const machine::Machine& m) {
  CompensateOptions::SplitForContour s;
  std::string why;
  const auto drives = contour::joint_drives(m, why);
  if (!drives || drives->empty()) return s;
  double tau = 0;
  for (const contour::Drive& d : *drives)
    if (d.kv > 0) tau = std::max(tau, 1 / d.kv + d.velocity_loop_time);
  if (!(tau > 0)) return s;
  s.step_s = 0.75 * tau;
  s.span_s = 4 * tau;
  s.linearize_arcs = true;
  return s;
}

/// Largest error (tool tip + L × tool axis) and RMS of a simulation, for comparing candidates.
struct Score {
  double peak = 0, rms = 0;
};
Score score_of(const contour::Simulation& s, double length) {
  return {s.tip.max + length * s.axis.max, s.tip.rms + length * s.axis.rms};
}

/// One candidate of the contour modes, held in memory until the choice: its result, written text,
/// line map (written line → input line, 0 for the header), held diagnostics and details.
struct Candidate {
  CompensateResult r;
  std::string written;
  std::vector<std::uint64_t> lines;
  Held diags;
  ContourDetails cd;
};

/// The caller's details become a candidate's; the geometric stage's part (--mode all, kept on
/// request before the candidates ran) stays.
void take_details(ContourDetails& cd, ContourDetails&& from) {
  const bool keep = cd.keep_geometric_stage;
  std::string gi = std::move(cd.geometric_input), go = std::move(cd.geometric_output);
  std::vector<std::uint64_t> gl = std::move(cd.geometric_line_map);
  cd = std::move(from);
  cd.keep_geometric_stage = keep;
  cd.geometric_input = std::move(gi);
  cd.geometric_output = std::move(go);
  cd.geometric_line_map = std::move(gl);
}

/// a is preferred over b: the smaller largest error, and within 2 % of each other the smaller RMS.
bool prefer_score(const Score& a, const Score& b) {
  if (std::abs(a.peak - b.peak) > std::max(1e-6, 0.02 * std::min(a.peak, b.peak))) return a.peak < b.peak;
  return a.rms < b.rms;
}

/// The lines of a text, each with its end of line.
std::vector<std::string_view> lines_of(std::string_view text) {
  std::vector<std::string_view> v;
  for (std::size_t at = 0; at < text.size();) {
    std::size_t e = text.find('\n', at);
    e = e == std::string_view::npos ? text.size() : e + 1;
    v.push_back(text.substr(at, e - at));
    at = e;
  }
  return v;
}

/// A program written run by run from the two candidates.
struct Merged {
  std::string text;
  std::vector<std::uint64_t> lines;                          ///< written line → input line
  std::vector<std::pair<std::uint64_t, std::uint64_t>> ranges;  ///< input lines of the runs taken split
  contour::Simulation sim;                                   ///< against the original's contour
  [[nodiscard]] bool split_line(std::uint64_t l) const {
    for (const auto& [lo, hi] : ranges)
      if (l >= lo && l <= hi) return true;
    return false;
  }
};

/// The program with the runs marked in `split_runs` taken from `split` and everything else from
/// `plain` (by the input lines the written lines come from; `first_lines`: in --mode all, the
/// geometric stage's line map, the contour stage's lines → input lines). Kept only when every run
/// of it reads back with exactly the path of the candidate it came from (a modal arc after a run
/// written as chords would not) and it simulates; then its simulation against the original's
/// contour. nullopt otherwise.
std::optional<Merged> merge_runs(const Candidate& plain, const Candidate& split, const std::vector<char>& split_runs,
                                 const std::vector<std::uint64_t>* first_lines, std::string_view file,
                                 const gcode::Dialect& dialect, const machine::Machine& m, const ContourDetails& original) {
  const contour::Path& path = plain.cd.path;
  if (path.runs.size() != split_runs.size()) return std::nullopt;
  const auto input_line = [&](std::uint64_t l) {
    if (first_lines == nullptr) return l;
    return l >= 1 && l <= first_lines->size() ? (*first_lines)[l - 1] : 0;
  };
  Merged mg;
  for (std::size_t k = 0; k < split_runs.size(); ++k) {
    if (split_runs[k] == 0) continue;
    const contour::Run& run = path.runs[k];
    if (run.begin >= run.end) return std::nullopt;
    const std::uint64_t lo = input_line(path.points[run.begin].line), hi = input_line(path.points[run.end - 1].line);
    if (lo == 0 || hi < lo || (!mg.ranges.empty() && lo <= mg.ranges.back().second)) return std::nullopt;
    mg.ranges.emplace_back(lo, hi);
  }
  const std::vector<std::string_view> pl = lines_of(plain.written), sl = lines_of(split.written);
  if (pl.size() != plain.lines.size() || sl.size() != split.lines.size()) return std::nullopt;
  std::size_t range = 0, js = 0;
  for (std::size_t i = 0; i < pl.size(); ++i) {
    const std::uint64_t l = plain.lines[i];
    while (range < mg.ranges.size() && l > mg.ranges[range].second) ++range;
    if (range < mg.ranges.size() && l >= mg.ranges[range].first) {
      if (i > 0 && plain.lines[i - 1] >= mg.ranges[range].first && plain.lines[i - 1] <= mg.ranges[range].second)
        continue;  // the range is written already
      const auto [lo, hi] = mg.ranges[range];
      while (js < sl.size() && split.lines[js] < lo) ++js;
      for (; js < sl.size() && split.lines[js] <= hi; ++js) {
        mg.text.append(sl[js]);
        mg.lines.push_back(split.lines[js]);
      }
      continue;
    }
    mg.text.append(pl[i]);
    mg.lines.push_back(l);
  }
  // Read back: every run exactly as in the candidate it came from.
  const auto read = [&](std::string_view text) -> std::optional<contour::Path> {
    gcode::DiagnosticSink quiet(0);
    gcode::LineReader in{text};
    contour::Path p = contour::build_path(in, file, dialect, m, contour::PathOptions{}, quiet);
    if (quiet.has_errors()) return std::nullopt;
    return p;
  };
  const auto pm = read(mg.text), pp = read(plain.written), ps = read(split.written);
  if (!pm || !pp || !ps || pm->runs.size() != split_runs.size() || pp->runs.size() != split_runs.size() ||
      ps->runs.size() != split_runs.size())
    return std::nullopt;
  for (std::size_t k = 0; k < split_runs.size(); ++k) {
    const contour::Path& src = split_runs[k] != 0 ? *ps : *pp;
    const contour::Run a = pm->runs[k], b = src.runs[k];
    if (a.size() != b.size()) return std::nullopt;
    for (std::size_t i = 0; i < a.size(); ++i) {
      const contour::PathPoint &x = pm->points[a.begin + i], &y = src.points[b.begin + i];
      if ((x.q - y.q).cwiseAbs().maxCoeff() > 1e-9 || (x.command.c - y.command.c).cwiseAbs().maxCoeff() > 1e-9)
        return std::nullopt;
    }
  }
  std::string why;
  std::optional<contour::Simulation> sim = simulate_written(mg.text, file, dialect, m, original, why);
  if (!sim) return std::nullopt;
  mg.sim = std::move(*sim);
  return mg;
}

/// Writes a merged program: its text and line map, the diagnostics of each candidate on its own
/// lines, the run reports per run from the candidate written, the figures of its simulation.
CompensateResult write_merged(Merged mg, Candidate& plain, Candidate& split, const std::vector<char>& split_runs,
                              const Held& split_first_diags, io::OutputFile& out, gcode::DiagnosticSink& sink,
                              ContourDetails& cd, const CompensateOptions& opt) {
  // Each candidate's diagnostics on its own lines, in line order.
  std::vector<gcode::Diagnostic> diags;
  for (gcode::Diagnostic& d : plain.diags.list)
    if (!mg.split_line(d.where.line)) diags.push_back(std::move(d));
  for (gcode::Diagnostic& d : split.diags.list)
    if (mg.split_line(d.where.line)) diags.push_back(std::move(d));
  for (const gcode::Diagnostic& d : split_first_diags.list)
    if (d.code == "PP-W603" && mg.split_line(d.where.line)) diags.push_back(d);
  std::stable_sort(diags.begin(), diags.end(),
                   [](const gcode::Diagnostic& a, const gcode::Diagnostic& b) { return a.where.line < b.where.line; });
  for (gcode::Diagnostic& d : diags) sink.report(std::move(d));
  out.write(mg.text);
  if (opt.line_map != nullptr) opt.line_map->insert(opt.line_map->end(), mg.lines.begin(), mg.lines.end());
  CompensateResult r = plain.r;
  r.segments_added = plain.r.segments_added + (mg.lines.size() - std::min(mg.lines.size(), plain.lines.size()));
  if (r.contour_run_reports.size() == split_runs.size() && split.r.contour_run_reports.size() == split_runs.size())
    for (std::size_t k = 0; k < split_runs.size(); ++k)
      if (split_runs[k] != 0) r.contour_run_reports[k] = split.r.contour_run_reports[k];
  r.contour_runs_iterated = r.contour_runs_lag = r.contour_runs_refined = r.contour_runs_withheld = 0;
  for (auto& n : r.contour_runs_stopped) n = 0;
  r.contour_iterations = 0;
  for (std::size_t k = 0; k < r.contour_run_reports.size(); ++k) {
    const ContourRunReport& rep = r.contour_run_reports[k];
    if (rep.written == "iterated") ++r.contour_runs_iterated;
    if (rep.written == "lag") ++r.contour_runs_lag;
    if (rep.written == "refined") ++r.contour_runs_refined;
    const ContourDetails& from = split_runs[k] != 0 ? split.cd : plain.cd;
    if (k < from.run_withheld.size() && from.run_withheld[k] != 0) ++r.contour_runs_withheld;
    for (int s = 0; s < 4; ++s)
      if (rep.stop == contour::to_string(static_cast<contour::RunStop>(s))) ++r.contour_runs_stopped[s];
    r.contour_iterations = std::max(r.contour_iterations, rep.iterations);
  }
  r.contour_converged = r.contour_runs_stopped[static_cast<int>(contour::RunStop::cap)] == 0;
  r.contour_after_mm = mg.sim.tip.max;
  r.contour_after_rad = mg.sim.axis.max;
  r.max_correction_mm = std::max(plain.r.max_correction_mm, split.r.max_correction_mm);
  r.max_correction_deg = std::max(plain.r.max_correction_deg, split.r.max_correction_deg);
  take_details(cd, std::move(plain.cd));
  cd.simulated_after = std::move(mg.sim);
  return r;
}

}  // namespace

CompensateResult compensate_flat(const ProgramInput& in, const CompensateOptions& opt, io::OutputFile& out,
                                 gcode::DiagnosticSink& sink, ContourDetails* details) {
  const std::string_view text = in.text, file = in.file;
  const gcode::Dialect& dialect = in.dialect;
  const machine::Machine& m = in.machine;
  if (opt.mode == Mode::geometric) {
    gcode::LineReader reader{text};
    return compensate(reader, file, dialect, m, opt, out, sink);
  }
  ContourDetails local;
  ContourDetails& cd = details ? *details : local;
  const bool all = opt.mode == Mode::all;
  // The plain candidate's first stage (--mode all: the geometric remap; --mode contour: none).
  std::optional<FirstStage> plain_first;
  if (all) {
    plain_first = first_stage(in, opt, sink);
    if (sink.has_errors()) return plain_first->r;
    if (cd.keep_geometric_stage) {
      cd.geometric_input = std::string(text);
      cd.geometric_output = plain_first->text;
      cd.geometric_line_map = plain_first->lines;
    }
  }
  const std::string_view plain_input = all ? std::string_view(plain_first->text) : text;
  // The split candidate (CompensateOptions::contour_split): its first stage, kept only when it
  // runs without errors and changes something.
  std::optional<FirstStage> split_first;
  Held split_first_diags;
  if (opt.contour_split) {
    CompensateOptions sopt = opt;
    sopt.split = split_settings(m);
    if (sopt.split.step_s > 0) {
      split_first = first_stage(in, sopt, split_first_diags.sink);
      if (split_first_diags.sink.has_errors() || split_first_diags.overflow || split_first->text == plain_input ||
          split_first->r.moves_split + split_first->r.arcs_linearized == 0)
        split_first.reset();
    }
  }
  if (!split_first)
    return contour_stage({plain_input, file, dialect, m}, all ? &*plain_first : nullptr, opt, out, sink, cd);

  // Both candidates, into memory with their diagnostics held back; the one whose written program
  // simulates better against the split candidate's reference (the denser description of the same
  // path) is written.
  const auto run = [&](Candidate& c, std::string_view input, const FirstStage* first) {
    c.cd.keep_geometric_stage = false;
    CompensateOptions copt = opt;
    copt.line_map = &c.lines;  // always: the merge per run needs it
    auto mem = io::OutputFile::memory();
    c.r = contour_stage({input, file, dialect, m}, first, copt, mem, c.diags.sink, c.cd);
    c.written = mem.take();
  };
  Candidate plain, split;
  run(plain, plain_input, all ? &*plain_first : nullptr);
  const auto replay = [&](Candidate& c, std::string_view input, const FirstStage* first) -> CompensateResult {
    if (c.diags.overflow) {  // run again on the caller's sink
      c.cd = ContourDetails{};
      auto mem = io::OutputFile::memory();
      c.lines.clear();
      CompensateOptions copt = opt;
      copt.line_map = &c.lines;
      c.r = contour_stage({input, file, dialect, m}, first, copt, mem, sink, c.cd);
      c.written = mem.take();
    } else {
      for (gcode::Diagnostic& d : c.diags.list) sink.report(std::move(d));
    }
    if (sink.has_errors()) return c.r;
    out.write(c.written);
    if (opt.line_map != nullptr) opt.line_map->insert(opt.line_map->end(), c.lines.begin(), c.lines.end());
    take_details(cd, std::move(c.cd));
    return c.r;
  };
  if (plain.diags.sink.has_errors() || !plain.cd.reference || !plain.cd.simulated_after) {
    return replay(plain, plain_input, all ? &*plain_first : nullptr);
  }
  run(split, split_first->text, &*split_first);
  // Both written programs simulated against the original's intended contour (what `postproc
  // simulate WRITTEN --reference ORIGINAL` shows, and what the report gives).
  std::string why;
  const std::optional<contour::Simulation>& plain_sim = plain.cd.simulated_after;
  std::optional<contour::Simulation> split_sim;
  if (!split.diags.sink.has_errors() && plain_sim && plain.cd.simulated_before)
    split_sim = simulate_written(split.written, file, dialect, m, plain.cd, why);
  // Both candidates' figures for the report, copied before either candidate's details move out.
  struct Figures {
    double unsplit_mm, unsplit_rad, split_mm, split_rad;
  };
  std::optional<Figures> figures;
  if (plain_sim && split_sim)
    figures = Figures{plain_sim->tip.max, plain_sim->axis.max, split_sim->tip.max, split_sim->axis.max};
  bool take_split = false;
  std::vector<char> split_runs;  // per run: the split candidate's run is better
  const double L = opt.contour.orientation_length_mm;
  if (plain_sim && split_sim) {
    const Score a = score_of(*plain_sim, L), b = score_of(*split_sim, L);
    const contour::Simulation& before = *plain.cd.simulated_before;
    // Never worse than the input at its largest errors; then the smaller largest error (ties
    // within 2 % decided by the RMS).
    const bool sound = split_sim->tip.max <= before.tip.max + 1e-7 && split_sim->axis.max <= before.axis.max + 1e-9;
    take_split = sound && prefer_score(b, a);
    // The same rule per run.
    const std::size_t runs = before.run_tip_max.size();
    if (plain_sim->run_tip_max.size() == runs && split_sim->run_tip_max.size() == runs) {
      split_runs.assign(runs, 0);
      for (std::size_t k = 0; k < runs; ++k) {
        const Score pa{plain_sim->run_tip_max[k] + L * plain_sim->run_axis_max[k],
                       plain_sim->run_tip_rms[k] + L * plain_sim->run_axis_rms[k]};
        const Score pb{split_sim->run_tip_max[k] + L * split_sim->run_axis_max[k],
                       split_sim->run_tip_rms[k] + L * split_sim->run_axis_rms[k]};
        const bool run_sound = split_sim->run_tip_max[k] <= before.run_tip_max[k] + 1e-7 &&
                               split_sim->run_axis_max[k] <= before.run_axis_max[k] + 1e-9;
        split_runs[k] = run_sound && pb.peak < pa.peak - 1e-7 && prefer_score(pb, pa) ? 1 : 0;
      }
    }
  }
  const std::size_t split_count = static_cast<std::size_t>(std::count(split_runs.begin(), split_runs.end(), 1));
  std::optional<Merged> merged;
  if (split_count > 0 && split_count < split_runs.size() && !plain.diags.overflow && !split.diags.overflow) {
    // Some runs better split, others on their end points: the program written per run, kept only
    // when every run reads back as the candidate it came from and the whole is not worse.
    merged = merge_runs(plain, split, split_runs, all ? &plain_first->lines : nullptr, file,
                                              dialect, m, plain.cd);
    if (merged) {
      const Score mb = score_of(merged->sim, L);
      const Score best = take_split ? score_of(*split_sim, L) : score_of(*plain_sim, L);
      const contour::Simulation& before = *plain.cd.simulated_before;
      if (!(merged->sim.tip.max <= before.tip.max + 1e-7 && merged->sim.axis.max <= before.axis.max + 1e-9) ||
          prefer_score(best, mb))
        merged.reset();
    }
  }
  CompensateResult r;
  if (merged) {
    r = write_merged(std::move(*merged), plain, split, split_runs, split_first_diags, out, sink, cd, opt);
    r.contour_split_runs = split_count;
  } else if (take_split) {
    std::optional<contour::Simulation> before = std::move(plain.cd.simulated_before);
    r = replay(split, split_first->text, &*split_first);
    // The split stage's own notes (PP-W603: Klartext blocks inserted without numbers).
    for (const gcode::Diagnostic& d : split_first_diags.list)
      if (d.code == "PP-W603") sink.report(d);
    if (all && cd.keep_geometric_stage) {
      cd.geometric_output = split_first->text;
      cd.geometric_line_map = split_first->lines;
    }
    // The figures against the original's contour (the runs' own figures stay those of the split
    // program's contour).
    r.contour_worst_line = plain.r.contour_worst_line;
    r.contour_before_mm = before->tip.max;
    r.contour_before_rad = before->axis.max;
    r.contour_after_mm = split_sim->tip.max;
    r.contour_after_rad = split_sim->axis.max;
    cd.simulated_before = std::move(before);
    cd.simulated_after = split_sim;
  } else {
    r = replay(plain, plain_input, all ? &*plain_first : nullptr);
  }
  r.contour_split_tried = true;
  r.contour_split_written = take_split || r.contour_split_runs > 0;
  if (take_split && r.contour_split_runs == 0) r.contour_split_runs = split_runs.empty() ? r.contour_runs : split_runs.size();
  if (figures) {
    r.contour_unsplit_after_mm = figures->unsplit_mm;
    r.contour_unsplit_after_rad = figures->unsplit_rad;
    r.contour_split_after_mm = figures->split_mm;
    r.contour_split_after_rad = figures->split_rad;
  }
  r.moves_split = split_first->r.moves_split;
  r.contour_split_arcs = split_first->r.arcs_linearized;
  return r;
}

}  // namespace postproc::comp
