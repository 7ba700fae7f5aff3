// postproc compensate IN -m MACHINE -o OUT: geometric remap through the calibrated machine model.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cmath>
#include <filesystem>
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "progress_bar.hpp"
#include "postproc/compensation/compensate.hpp"
#include "postproc/compensation/geometric_report.hpp"
#include "postproc/compensation/residual_bounds.hpp"
#include "postproc/compensation/result_json.hpp"
#include "postproc/contour/report.hpp"
#include "postproc/gcode/convert.hpp"
#include "postproc/gcode/detect.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::cli {
namespace {

struct CompensateArgs {
  std::string input;
  std::string output;
  std::string machine;
  std::string report;
  std::string html;
  std::string mode = "geometric";
  std::string dialect;  ///< "" = the machine file's
  bool filter_progress = false;  ///< FILTER_PROGRESS=N lines on stderr (LinuxCNC program filters)
  std::string renumber;          ///< "START[,STEP]": renumber the written program's blocks
  std::string integer_input;
  double max_deviation_um = 1.0;
  double max_angle_arcsec = 4.0;
  bool no_header = false;
  bool in_place = false;
  std::size_t max_per_code = 20;
  int iterations = 12;
  int refine_iterations = 16;
  std::string contour_split = "auto";
  bool quiet = false;
  bool flatten = false;
  bool allow_recompensation = false;
  unsigned jobs = 0;
  ResolveArgs resolve;
  std::string bounds_csv;         ///< --bounds-csv: the 95 % bound per motion
  double bound_limit_um = 0;      ///< --bound-limit: warn where the tip bound exceeds it (0: no limit)
};

/// The geometric report of `written` against `original` (comp::verify: both read back and run
/// through the calibrated model): a whole page, or with an `id_prefix` a section for another page.
std::string geometric_report(const CompensateArgs& a, const machine::Machine& m, const gcode::Dialect& d,
                             std::string_view original, std::string_view written,
                             const std::vector<std::uint64_t>& line_map, std::string title, std::string id_prefix) {
  std::vector<comp::VerifyPoint> points;
  const comp::VerifyResult v = comp::verify(original, written, line_map, d, m, &points);
  comp::GeometricReport gr;
  gr.title = std::move(title);
  gr.program = a.input;
  if (id_prefix.empty()) gr.output = a.output;
  gr.machine_file = m.file;
  gr.machine_sha256 = m.sha256;
  gr.tool_version = POSTPROC_VERSION;
  gr.verify = &v;
  gr.points = &points;
  gr.id_prefix = std::move(id_prefix);
  return gr.id_prefix.empty() ? comp::geometric_report_html(gr) : comp::geometric_report_section(gr);
}

/// The bounds of the written program (residual_bounds.hpp) and their located warnings: PP-W640
/// where a block leaves the region the calibration was measured in, PP-W641 where the tip bound
/// exceeds --bound-limit. Located at the input line each written line came from.
comp::BoundsResult bound_written(const CompensateArgs& a, std::string_view written,
                                 const std::vector<std::uint64_t>& line_map, const gcode::Dialect& d,
                                 const machine::Machine& m, gcode::DiagnosticSink& sink) {
  comp::BoundsResult b = comp::residual_bounds(written, d, m);
  // The input's lines, for the source echo of the warnings (a file; standard input is gone).
  std::string source;
  std::vector<std::size_t> starts;
  auto line_text = [&](std::uint64_t line) -> std::string_view {
    if (a.input == "-") return {};
    if (starts.empty()) {
      source = io::read_file(a.input, "NC program");
      starts.push_back(0);
      for (std::size_t i = 0; i < source.size(); ++i)
        if (source[i] == '\n') starts.push_back(i + 1);
    }
    if (line == 0 || line > starts.size()) return {};
    const std::size_t from = starts[line - 1];
    std::size_t to = line < starts.size() ? starts[line] - 1 : source.size();
    if (to > from && source[to - 1] == '\r') --to;
    return std::string_view(source).substr(from, to - from);
  };
  auto warn = [&](std::uint64_t written_line, std::string_view code, std::string message) {
    const std::uint64_t line = written_line >= 1 && written_line <= line_map.size() ? line_map[written_line - 1] : 0;
    if (line == 0) return;
    gcode::Diagnostic w;
    w.severity = gcode::Severity::warning;
    w.code = std::string(code);
    w.file = a.input;
    w.where = {line, 1};
    w.message = std::move(message);
    const std::string_view text = line_text(line);
    gcode::set_source_line(w, text);
    w.length = static_cast<std::uint32_t>(std::max<std::size_t>(1, text.size()));
    sink.report(std::move(w));
  };
  const machine::Uncertainty& u = *m.uncertainty;
  for (const comp::BlockBound& bb : b.blocks) {
    if (bb.outside_region) {
      const auto j = static_cast<std::size_t>(bb.outside_joint);
      const kin::Joint& joint = m.actual->joints()[j];
      const char* unit = joint.type == kin::JointType::rotary ? "deg" : "mm";
      warn(bb.line, "PP-W640",
           fmt::format("this block moves {} outside the range the calibration was measured in ({:g} … {:g} {}): its "
                       "correction extrapolates the calibration; measure poses that cover the program's range",
                       joint.name, u.region_min[j], u.region_max[j], unit));
    }
    if (a.bound_limit_um > 0 && bb.tip_mm * 1000 > a.bound_limit_um)
      warn(bb.line, "PP-W641",
           fmt::format("the 95 % bound of the tool-tip error left after compensation is {:.2f} µm here, above "
                       "--bound-limit {:g} µm; the calibration does not know the machine well enough at this pose "
                       "(more or better-placed measurements: postproc calibrate plan)",
                       bb.tip_mm * 1000, a.bound_limit_um));
  }
  return b;
}

nlohmann::json report_json(const CompensateArgs& a, const machine::Machine& m, const comp::CompensateResult& r,
                           const comp::ContourDetails& contour, double seconds, bool ok, const gcode::DiagnosticSink& sink) {
  nlohmann::json j;
  j["tool"] = {{"name", "postproc"}, {"version", POSTPROC_VERSION}};
  j["input"] = a.input;
  j["output"] = a.output;
  j["machine"] = {{"file", m.file}, {"sha256", m.sha256}, {"name", m.name}, {"model", m.model_kind}};
  // The controller's rule between the two solutions of a tool axis (serial machines, docs/machine-file.md).
  if (m.model_kind == "serial") j["machine"]["ik_branch"] = machine::to_string(m.ik_branch);
  j["mode"] = a.mode;
  j["status"] = ok ? "written" : "refused";
  j["limits"] = {{"max_deviation_mm", a.max_deviation_um / 1000.0}, {"max_angle_deviation_deg", a.max_angle_arcsec / 3600.0}};
  j.update(comp::result_json(r, *comp::parse_mode(a.mode), &contour));
  if (r.resolved_lines > 0) {
    nlohmann::json given = nlohmann::json::object(), used = nlohmann::json::object();
    for (const auto& [name, value] : make_resolve_options(a.resolve).set) given[name] = value;
    for (const auto& [name, value] : r.used_settings) used[name] = value;
    if (a.flatten)
      j["flattened"] = {{"resolved_lines", r.resolved_lines}, {"set_given", given}, {"set_used", used}};
    else
      j["resolved_in_place"] = {{"resolved_lines", r.resolved_lines},
                                {"source_lines_rewritten", r.source_lines_rewritten},
                                {"set_given", given},
                                {"set_used", used}};
  }
  j["seconds"] = seconds;
  j["diagnostics"] = comp::diagnostics_json(sink);
  return j;
}

}  // namespace

void setup_compensate(CLI::App& app, int& rc) {
  auto o = std::make_shared<CompensateArgs>();
  auto* cmd = app.add_subcommand("compensate", "rewrite a program so the calibrated machine cuts what the nominal "
                                               "machine would have");
  cmd->add_option("input", o->input, "NC program ('-' = stdin)")->required();
  cmd->add_option("-m,--machine", o->machine, "machine file (TOML, docs/machine-file.md)")->required();
  cmd->add_option("-o,--output", o->output, "output file ('-' = stdout)")->required();
  cmd->add_option("--report,--json", o->report, "write a JSON report of the run here (--json: the same)");
  cmd->add_option("--html", o->html,
                  "write a self-contained HTML report here: geometric mode, the error the original program leaves "
                  "on the calibrated machine beside the residual of the written one; contour modes, the contour "
                  "errors before and after");
  cmd->add_option("--dialect", o->dialect,
                  fmt::format("read the program as this dialect ({}) instead of the machine file's (which names its "
                              "controller's); a program whose first lines hold another dialect's construct gets "
                              "warning PP-W005 either way",
                              gcode::dialect_names()));
  cmd->add_option("--renumber", o->renumber,
                  "renumber the written program's blocks START[,STEP] as convert --renumber does (Klartext: every "
                  "block, the inserted ones included, which the TNC needs; ISO: the existing N words)");
  cmd->add_flag("--filter-progress", o->filter_progress,
                "print the progress as 'FILTER_PROGRESS=N' lines (percent) on stderr, as LinuxCNC's GUIs read them "
                "from a [FILTER] program (on by itself when AXIS_PROGRESS_BAR=1, which AXIS sets; docs/linuxcnc-filter.md)");
  cmd->add_option("--mode", o->mode,
                  "geometric: the calibrated machine's errors; contour: the servo contour errors (precompensation "
                  "from the drives in the machine file); all: geometric, then contour")
      ->check(CLI::IsMember({"geometric", "contour", "all"}))
      ->capture_default_str();
  cmd->add_option("--max-deviation", o->max_deviation_um,
                  "largest tool-tip deviation from the intended path between corrected points, µm; longer moves are "
                  "subdivided")
      ->capture_default_str();
  cmd->add_option("--max-angle-deviation", o->max_angle_arcsec, "largest tool-axis deviation, arcsec")->capture_default_str();
  cmd->add_option("--integer-input", o->integer_input,
                  "Fanuc: whole numbers without a point are 'increment' (X100 = 0.1 mm) or 'calculator' (100 mm); "
                  "overrides the machine file")
      ->check(CLI::IsMember({"increment", "calculator"}));
  cmd->add_option("--iterations,--max-iterations", o->iterations,
                  "contour modes: most prediction / correction rounds (stops earlier when the predicted contour error "
                  "stops improving)")
      ->capture_default_str();
  cmd->add_option("--refine-iterations", o->refine_iterations,
                  "contour modes: most accepted steps per run of the refinement on the time-domain simulation of the "
                  "written program (0: none)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--contour-split", o->contour_split,
                  "contour modes: 'auto' also tries the program with long moves split near their ends and feed arcs "
                  "as chords, and writes it when its simulation is better; 'off' corrects block end points only")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "off"}));
  cmd->add_option("--bounds-csv", o->bounds_csv,
                  "write the 95 % bound of the tool-tip (mm) and tool-axis (rad) error left after compensation, one "
                  "row per motion of the written program (needs the machine file's [uncertainty] from calibrate)");
  cmd->add_option("--bound-limit", o->bound_limit_um,
                  "warn (PP-W641, located) where the tool-tip bound exceeds this many µm (implies the bounds)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("-q,--quiet", o->quiet, "diagnostics only, no summary lines");
  cmd->add_flag("--flatten", o->flatten,
                "programs with parameters, expressions, subprograms or loops: write the resolved program as literal "
                "moves (loops unrolled, calls expanded; comments and other blocks kept); without it the corrections "
                "are written into the program's own lines where that is exact, and refused (PP-E711) where not");
  add_resolve_options(*cmd, o->resolve);
  cmd->add_flag("--no-header", o->no_header, "do not write the header comment naming tool, machine file and hash");
  cmd->add_flag("--allow-recompensation", o->allow_recompensation,
                "compensate a program that already carries postproc's compensation header (refused otherwise, "
                "PP-E620: the corrections would be applied twice)");
  cmd->add_flag("--in-place", o->in_place, "allow -o to name the input (a .bak backup is kept)");
  cmd->add_option("-j,--jobs", o->jobs,
                  "threads for the geometric stage (default: the cores this process may use, from its CPU "
                  "affinity); the output is the same for any number");
  cmd->add_option("--max-per-code", o->max_per_code, "show at most this many diagnostics per code")->capture_default_str();
  cmd->callback([o, &rc] {
    if (!(o->max_deviation_um > 0) || !std::isfinite(o->max_deviation_um))
      throw Error(ExitCode::usage, "--max-deviation must be a positive number of µm, e.g. 1");
    if (!(o->max_angle_arcsec > 0) || !std::isfinite(o->max_angle_arcsec))
      throw Error(ExitCode::usage, "--max-angle-deviation must be a positive number of arcsec, e.g. 4");
    const auto t0 = std::chrono::steady_clock::now();
    gcode::DiagnosticSink sink;
    DiagnosticPrinter printer(sink, o->max_per_code);
    const auto machine = machine::load_machine(o->machine, sink);
    if (!machine) {
      printer.finish();
      std::fputs(fmt::format("postproc: {}: machine file refused; nothing was written\n", o->machine).c_str(), stderr);
      rc = static_cast<int>(ExitCode::refused);
      return;
    }
    gcode::DialectOptions dopt = machine->dialect_options;
    if (!o->integer_input.empty())
      dopt.integer_input = o->integer_input == "increment" ? gcode::Dialect::IntegerInput::increment
                                                            : gcode::Dialect::IntegerInput::calculator;
    std::string dialect_source = fmt::format("the dialect of the machine file {}", o->machine);
    std::string dialect_name = machine->dialect_name;
    if (!o->dialect.empty()) {
      if (!gcode::make_dialect(o->dialect, dopt))
        throw Error(ExitCode::usage,
                    fmt::format("unknown dialect '{}' for --dialect; use {}", o->dialect, gcode::dialect_names()));
      if (o->dialect != machine->dialect_name && !o->quiet)
        std::fputs(fmt::format("postproc: note: {} is read as {} (--dialect); the machine file {} names {}\n",
                               o->input, o->dialect, o->machine, machine->dialect_name)
                       .c_str(),
                   stderr);
      dialect_name = o->dialect;
      dialect_source = "--dialect";
    }
    gcode::Dialect d = *gcode::make_dialect(dialect_name, dopt);
    {
      // Only a regular file is looked at twice (standard input and pipes are read once, by the run).
      std::error_code kind;
      if (o->input != "-" && std::filesystem::is_regular_file(o->input, kind))
        gcode::warn_other_dialect(head_of(o->input), o->input, d, dialect_source, sink);
    }
    if (d.gcode_system == '?' && o->input != "-") {
      // Settled once here; every pass over the program (compensate, contour, verification) then
      // reads it in the same system without scanning it again.
      gcode::LineReader scan(o->input);
      d = gcode::settle_gcode_system(d, scan, o->input, sink);
    }
    comp::CompensateOptions opt;
    opt.max_deviation_mm = o->max_deviation_um / 1000.0;
    opt.max_angle_rad = o->max_angle_arcsec / 3600.0 * 3.14159265358979323846 / 180.0;
    opt.header = !o->no_header;
    opt.tool_version = POSTPROC_VERSION;
    opt.mode = *comp::parse_mode(o->mode);  // checked by --mode
    opt.flatten = o->flatten;
    opt.allow_recompensation = o->allow_recompensation;
    opt.jobs = o->jobs > 0 ? o->jobs : usable_cores();
    opt.resolve = make_resolve_options(o->resolve);
    io::OutputFile out(o->output, o->input, o->in_place);
    ProgressBar bar("postproc:");
    const char* axis_bar = std::getenv("AXIS_PROGRESS_BAR");
    auto filter_percent = std::make_shared<std::atomic<int>>(-1);
    const bool filter_mode = o->filter_progress || (axis_bar != nullptr && std::string_view(axis_bar) == "1");
    if (filter_mode) {
      // LinuxCNC's filter protocol: one "FILTER_PROGRESS=N" line per whole percent reached.
      opt.progress = [filter_percent](std::string_view, double done, double total) {
        if (!(total > 0)) return;
        const int n = static_cast<int>(std::clamp(100.0 * done / total, 0.0, 100.0));
        int was = filter_percent->load();
        while (n > was && !filter_percent->compare_exchange_weak(was, n)) {
        }
        if (n > was) std::fputs(fmt::format("FILTER_PROGRESS={}\n", n).c_str(), stderr);
      };
    } else if (bar.enabled()) {
      opt.progress = [&bar](std::string_view stage, double done, double total) { bar.update(stage, done, total); };
    }
    if (opt.progress && o->input != "-") {
      std::error_code ec;
      opt.input_bytes = std::filesystem::file_size(o->input, ec);
    }
    const bool bounds = !o->bounds_csv.empty() || o->bound_limit_um > 0;
    if (bounds && !machine->uncertainty)
      throw Error(ExitCode::usage,
                  fmt::format("--bounds-csv/--bound-limit: {} has no [uncertainty] table, so nothing says how well its "
                              "errors are known; write it with postproc calibrate",
                              o->machine));
    // With bounds, and for the geometric HTML report, the written program is read back: it is
    // held in memory first.
    const bool geometric_html = !o->html.empty() && o->mode == "geometric";
    gcode::ConvertOptions renumber;
    if (!o->renumber.empty()) {
      parse_renumber(o->renumber, renumber);
      opt.renumbered_after = true;
    }
    const bool hold = bounds || geometric_html || renumber.renumber_start.has_value();
    io::OutputFile held = io::OutputFile::memory();
    io::OutputFile& target = hold ? held : out;
    std::vector<std::uint64_t> line_map;
    if (hold) opt.line_map = &line_map;
    comp::CompensateResult r;
    comp::ContourDetails contour;
    contour.keep_geometric_stage = o->mode == "all" && !o->html.empty();  // its part of the report
    const bool servo = o->mode != "geometric";
    // Flat programs stream from the file; programs with parameters or control flow are resolved
    // in memory (compensate_program).
    std::error_code ec;
    bool streaming = !servo && !geometric_html && o->input != "-" && std::filesystem::is_regular_file(o->input, ec);
    std::string text;  // the program, when it is held in memory
    if (streaming) {
      gcode::LineReader scan(o->input);
      streaming = !gcode::needs_resolution(scan, d);
    }
    if (streaming) {
      gcode::LineReader reader(o->input);
      r = comp::compensate(reader, o->input, d, *machine, opt, target, sink);
    } else {
      // The contour stage reads the program twice (path, then writing): it is held in memory.
      // So is a program to resolve.
      text = io::read_file(o->input, "NC program");
      opt.contour.max_iterations = o->iterations;
      opt.contour.learning_iterations = o->refine_iterations;
      opt.contour_split = o->contour_split == "auto";
      r = comp::compensate_program({text, o->input, d, *machine}, opt, target, sink, &contour);
    }
    bar.finish();
    if (filter_mode && filter_percent->exchange(100) < 100) std::fputs("FILTER_PROGRESS=100\n", stderr);
    std::optional<comp::BoundsResult> bound;
    std::string geometric_page;
    if (hold && !sink.has_errors()) {
      std::string written = held.take();
      if (renumber.renumber_start) {
        // Block numbers only: the lines stay where they are, so the line map still holds.
        auto numbered = io::OutputFile::memory();
        (void)gcode::convert_program(written, o->output, d, renumber, numbered, sink);
        if (!sink.has_errors()) written = numbered.take();
      }
      if (bounds) bound = bound_written(*o, written, line_map, d, *machine, sink);
      if (geometric_html) {
        // The report's figures are those of the written program read back (comp::verify).
        geometric_page = geometric_report(*o, *machine, d, text, written, line_map,
                                          fmt::format("compensate {}", o->input), {});
      }
      out.write(written);
    }
    printer.finish();
    const bool ok = !sink.has_errors();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    OutputSet outputs;
    if (!o->report.empty()) {
      nlohmann::json j = report_json(*o, *machine, r, contour, seconds, ok, sink);
      if (bound)
        j["uncertainty"] = {{"confidence", 0.95},
                            {"parameters", bound->parameters},
                            {"k", bound->k},
                            {"blocks", bound->blocks.size()},
                            {"max_bound_tip_mm", bound->max_tip_mm},
                            {"max_bound_axis_rad", bound->max_axis_rad},
                            {"blocks_outside_calibrated_region", bound->outside_region},
                            {"skipped", bound->skipped}};
      outputs.add(o->report, j.dump(2) + "\n");
    }
    if (bound && ok && !o->bounds_csv.empty()) outputs.add(o->bounds_csv, comp::bounds_csv(*bound));
    if (geometric_html && ok) outputs.add(o->html, geometric_page);
    if (!o->html.empty() && !geometric_html && ok) {
      contour::ContourReport cr;
      cr.title = fmt::format("compensate --mode {} {}", o->mode, o->input);
      cr.program = o->input;
      cr.machine_file = machine->file;
      cr.machine_sha256 = machine->sha256;
      cr.tool_version = POSTPROC_VERSION;
      cr.path = &contour.path;
      cr.before = &contour.result.before;
      cr.after = &contour.result.after;
      cr.compensation = &contour.result;
      // The verification's simulation of the input and of the program as written.
      if (contour.simulated_before) cr.simulated_before = &*contour.simulated_before;
      if (contour.simulated_after) cr.simulated_after = &*contour.simulated_after;
      cr.fit_residual_mm = r.fit_residual_mm;
      if (contour.keep_geometric_stage && !contour.geometric_output.empty()) {
        // --mode all: the geometric stage's part, checked on its own output (comp::verify), after
        // the contour part.
        cr.appendix = geometric_report(*o, *machine, d, contour.geometric_input, contour.geometric_output,
                                       contour.geometric_line_map,
                                       "Geometric part: the calibrated machine's errors, before the contour stage",
                                       "geometric-");
      }
      outputs.add(o->html, contour::report_html(cr));
    }
    if (!ok) {
      outputs.commit();  // the report of the refusal; the program is not written
      std::fputs(fmt::format("postproc: {}: refused; nothing was written\n", o->input).c_str(), stderr);
      rc = static_cast<int>(ExitCode::refused);
      return;
    }
    outputs.commit(&out);  // the program and its reports together, or none of them
    note_backup_kept(out);
    if (o->quiet) {
      rc = 0;
      return;
    }
    if (bound)
      std::fputs(fmt::format("postproc: 95 % bound of the error left after compensation (calibration covariance of {} "
                             "parameters, k = {:.3f}, plus rounding): tool tip ≤ {:.3f} µm, tool axis ≤ {:.2f} arcsec over "
                             "{} motions{}\n",
                             bound->parameters, bound->k, bound->max_tip_mm * 1000,
                             bound->max_axis_rad * 180 / 3.14159265358979323846 * 3600, bound->blocks.size(),
                             bound->outside_region > 0
                                 ? fmt::format("; {} outside the calibrated region (PP-W640)", bound->outside_region)
                                 : "")
                     .c_str(),
                 stderr);
    if (o->mode == "contour")
      std::fputs(fmt::format("postproc: {} blocks, {} moves, {} blocks changed ({} words changed, {} inserted); largest "
                             "correction {:.4f} mm / {:.5f} deg\n",
                             r.blocks, r.motions, r.changed_blocks, r.words_changed, r.words_inserted,
                             r.max_correction_mm, r.max_correction_deg)
                     .c_str(),
                 stderr);
    else
      std::fputs(fmt::format("postproc: {} blocks, {} moves, {} blocks changed ({} words changed, {} inserted), {} moves "
                             "subdivided, {} arcs kept, {} linearised (+{} lines); largest correction {:.4f} mm / {:.5f} "
                             "deg, tool axis {:.4f} mrad; error before {:.4f} mm / {:.4f} mrad (line {}), predicted "
                             "residual after {:.5f} mm / {:.5f} mrad\n",
                             r.blocks, r.motions, r.changed_blocks, r.words_changed, r.words_inserted,
                             r.subdivided_blocks, r.arcs_kept, r.arcs_linearized, r.segments_added, r.max_correction_mm,
                             r.max_correction_deg, r.max_axis_correction_rad * 1e3, r.max_error_before_mm,
                             r.max_error_before_rad * 1e3, r.worst_line, r.max_residual_mm, r.max_residual_rad * 1e3)
                     .c_str(),
                 stderr);
    if (servo)
      std::fputs(fmt::format("postproc: contour: {} tool-tip contour error {:.3f} → {:.3f} µm (worst before: line {}), "
                             "tool-axis {:.2f} → {:.2f} arcsec{}; the iteration predicted {:.3f} µm / {:.2f} arcsec after "
                             "at most {} iterations per run{}; runs: {} ({} iterated, {} lag precompensation, {} refined on the "
                             "simulation, {} uncorrected; "
                             "stopped: {} converged, {} no improvement, {} iteration limit, {} nothing to correct); "
                             "NURBS fit residual {:.4f} µm\n",
                             r.contour_verified ? "simulated (the program as written)" : "NOT simulated, predicted",
                             r.contour_before_mm * 1000, r.contour_after_mm * 1000, r.contour_worst_line,
                             r.contour_before_rad * 206264.80624709636, r.contour_after_rad * 206264.80624709636,
                             r.contour_runs_withheld > 0
                                 ? fmt::format("; {} of {} runs written without the contour correction (PP-W620/W621)",
                                               r.contour_runs_withheld, r.contour_runs)
                                 : std::string(),
                             r.contour_predicted_after_mm * 1000, r.contour_predicted_after_rad * 206264.80624709636,
                             r.contour_iterations, r.contour_converged ? "" : " (not converged)", r.contour_runs,
                             r.contour_runs_iterated, r.contour_runs_lag, r.contour_runs_refined,
                             r.contour_runs - std::min(r.contour_runs, r.contour_runs_iterated + r.contour_runs_lag +
                                                                           r.contour_runs_refined),
                             r.contour_runs_stopped[1], r.contour_runs_stopped[2], r.contour_runs_stopped[3],
                             r.contour_runs_stopped[0], r.fit_residual_mm * 1000)
                     .c_str(),
                 stderr);
    if (servo && r.contour_split_tried)
      std::fputs(fmt::format("postproc: contour: split candidate ({} long moves split near their ends, {} arcs as chords): "
                             "simulated {:.3f} µm / {:.2f} arcsec against {:.3f} µm / {:.2f} arcsec with the block end "
                             "points only; written {}\n",
                             r.moves_split, r.contour_split_arcs, r.contour_split_after_mm * 1000,
                             r.contour_split_after_rad * 206264.80624709636, r.contour_unsplit_after_mm * 1000,
                             r.contour_unsplit_after_rad * 206264.80624709636,
                             !r.contour_split_written ? std::string("with the block end points only")
                             : r.contour_split_runs < r.contour_runs
                                 ? fmt::format("split in {} of {} runs, the others on their block end points",
                                               r.contour_split_runs, r.contour_runs)
                                 : std::string("split"))
                     .c_str(),
                 stderr);
    rc = 0;
  });
}

}  // namespace postproc::cli
