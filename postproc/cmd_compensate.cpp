// postproc compensate IN -m MACHINE -o OUT: geometric remap through the calibrated machine model.
#include <chrono>
#include <cmath>
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "postproc/compensation/compensate.hpp"
#include "postproc/contour/report.hpp"
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
  std::string integer_input;
  double max_deviation_um = 1.0;
  double max_angle_arcsec = 4.0;
  bool no_header = false;
  bool in_place = false;
  std::size_t max_per_code = 20;
  int iterations = 12;
};

/// --mode all: the figures of the geometric stage next to the contour stage's.
void merge_geometric(comp::CompensateResult& r, const comp::CompensateResult& g) {
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

nlohmann::json report_json(const CompensateArgs& a, const machine::Machine& m, const comp::CompensateResult& r,
                           const comp::ContourDetails& contour, double seconds, bool ok, const gcode::DiagnosticSink& sink) {
  nlohmann::json j;
  j["tool"] = {{"name", "postproc"}, {"version", POSTPROC_VERSION}};
  j["input"] = a.input;
  j["output"] = a.output;
  j["machine"] = {{"file", m.file}, {"sha256", m.sha256}, {"name", m.name}, {"model", m.model_kind}};
  j["mode"] = a.mode;
  j["status"] = ok ? "written" : "refused";
  j["limits"] = {{"max_deviation_mm", a.max_deviation_um / 1000.0}, {"max_angle_deviation_deg", a.max_angle_arcsec / 3600.0}};
  j["counts"] = {{"blocks", r.blocks},
                 {"motions", r.motions},
                 {"changed_blocks", r.changed_blocks},
                 {"words_changed", r.words_changed},
                 {"words_inserted", r.words_inserted},
                 {"subdivided_blocks", r.subdivided_blocks},
                 {"segments_added", r.segments_added},
                 {"arcs_kept", r.arcs_kept},
                 {"arcs_linearized", r.arcs_linearized},
                 {"reference_moves", r.reference_moves},
                 {"rapids_as_written", r.rapids_as_written},
                 {"singular_points_tip_only", r.singular_fallbacks}};
  j["figures"] = {{"max_correction_mm", r.max_correction_mm},
                  {"max_correction_deg", r.max_correction_deg},
                  {"max_error_before_mm", r.max_error_before_mm},
                  {"max_error_before_deg", r.max_error_before_rad * 180.0 / 3.14159265358979323846},
                  {"worst_line_before", r.worst_line},
                  {"max_residual_after_mm", r.max_residual_mm},
                  {"max_residual_after_deg", r.max_residual_rad * 180.0 / 3.14159265358979323846}};
  if (a.mode != "geometric") {
    constexpr double kArcsec = 180.0 / 3.14159265358979323846 * 3600.0;
    j["contour"] = {{"before_tip_um", r.contour_before_mm * 1000},
                    {"before_axis_arcsec", r.contour_before_rad * kArcsec},
                    {"after_tip_um", r.contour_after_mm * 1000},
                    {"after_axis_arcsec", r.contour_after_rad * kArcsec},
                    {"worst_line_before", r.contour_worst_line},
                    {"iterations", r.contour_iterations},
                    {"converged", r.contour_converged},
                    {"fit_residual_um", r.fit_residual_mm * 1000}};
    nlohmann::json hu = nlohmann::json::array(), ha = nlohmann::json::array();
    for (double v : contour.result.history_mm) hu.push_back(v * 1000);
    for (double v : contour.result.history_rad) ha.push_back(v * kArcsec);
    j["contour"]["history_tip_um"] = hu;
    j["contour"]["history_axis_arcsec"] = ha;
  }
  j["seconds"] = seconds;
  nlohmann::json diags = nlohmann::json::array();
  for (const auto& d : sink.stored())
    diags.push_back({{"severity", std::string(gcode::to_string(d.severity))},
                     {"code", d.code},
                     {"file", d.file},
                     {"line", d.where.line},
                     {"column", d.where.column},
                     {"message", d.message}});
  j["diagnostics"] = diags;
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
  cmd->add_option("--report", o->report, "write a JSON report of the run here");
  cmd->add_option("--html", o->html,
                  "contour modes: write a self-contained HTML report of the predicted contour errors before and "
                  "after compensation here");
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
  cmd->add_option("--iterations", o->iterations,
                  "contour modes: most prediction / correction rounds (stops earlier when the predicted contour error "
                  "stops improving)")
      ->capture_default_str();
  cmd->add_flag("--no-header", o->no_header, "do not write the header comment naming tool, machine file and hash");
  cmd->add_flag("--in-place", o->in_place, "allow -o to name the input (a .bak backup is kept)");
  cmd->add_option("--max-per-code", o->max_per_code, "show at most this many diagnostics per code")->capture_default_str();
  cmd->callback([o, &rc] {
    if (!o->html.empty() && o->mode == "geometric")
      throw Error(ExitCode::usage, "--html shows contour errors: use it with --mode contour or --mode all");
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
    const gcode::Dialect d = *gcode::make_dialect(machine->dialect_name, dopt);
    comp::CompensateOptions opt;
    opt.max_deviation_mm = o->max_deviation_um / 1000.0;
    opt.max_angle_rad = o->max_angle_arcsec / 3600.0 * 3.14159265358979323846 / 180.0;
    opt.header = !o->no_header;
    opt.tool_version = POSTPROC_VERSION;
    opt.mode = o->mode;
    io::OutputFile out(o->output, o->input, o->in_place);
    comp::CompensateResult r;
    comp::ContourDetails contour;
    const bool servo = o->mode != "geometric";
    if (!servo) {
      gcode::LineReader reader(o->input);
      r = comp::compensate(reader, o->input, d, *machine, opt, out, sink);
    } else {
      // The contour stage reads the program twice (path, then writing): it is held in memory.
      std::string text = io::read_file(o->input, "NC program");
      comp::CompensateResult geo;
      std::vector<std::uint64_t> geo_lines;  // intermediate line → input line
      if (o->mode == "all") {
        comp::CompensateOptions gopt = opt;
        gopt.header = false;
        gopt.line_map = &geo_lines;
        auto mem = io::OutputFile::memory();
        gcode::LineReader reader{std::string_view(text)};
        geo = comp::compensate(reader, o->input, d, *machine, gopt, mem, sink);
        text = mem.take();
      }
      if (!sink.has_errors()) {
        contour::PrecompensateOptions popt;
        popt.max_iterations = o->iterations;
        r = comp::compensate_contour(text, o->input, d, *machine, opt, popt, out, sink, &contour);
      }
      if (o->mode == "all") {
        merge_geometric(r, geo);
        if (r.contour_worst_line >= 1 && r.contour_worst_line <= geo_lines.size())
          r.contour_worst_line = geo_lines[r.contour_worst_line - 1];
      }
    }
    printer.finish();
    const bool ok = !sink.has_errors();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!o->report.empty()) {
      write_text(o->report, o->input, report_json(*o, *machine, r, contour, seconds, ok, sink).dump(2) + "\n");
    }
    if (!o->html.empty() && ok) {
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
      cr.fit_residual_mm = r.fit_residual_mm;
      write_text(o->html, o->input, contour::report_html(cr));
    }
    if (!ok) {
      std::fputs(fmt::format("postproc: {}: refused; nothing was written\n", o->input).c_str(), stderr);
      rc = static_cast<int>(ExitCode::refused);
      return;
    }
    out.commit();
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
                             "deg; error before {:.4f} mm (line {}), predicted residual after {:.5f} mm\n",
                             r.blocks, r.motions, r.changed_blocks, r.words_changed, r.words_inserted,
                             r.subdivided_blocks, r.arcs_kept, r.arcs_linearized, r.segments_added, r.max_correction_mm,
                             r.max_correction_deg, r.max_error_before_mm, r.worst_line, r.max_residual_mm)
                     .c_str(),
                 stderr);
    if (servo)
      std::fputs(fmt::format("postproc: contour: predicted tool-tip contour error {:.3f} → {:.3f} µm (worst before: line "
                             "{}), tool-axis {:.2f} → {:.2f} arcsec, {} iterations{}; NURBS fit residual {:.4f} µm\n",
                             r.contour_before_mm * 1000, r.contour_after_mm * 1000, r.contour_worst_line,
                             r.contour_before_rad * 206264.80624709636, r.contour_after_rad * 206264.80624709636,
                             r.contour_iterations, r.contour_converged ? "" : " (not converged)", r.fit_residual_mm * 1000)
                     .c_str(),
                 stderr);
    rc = 0;
  });
}

}  // namespace postproc::cli
