// postproc diff ORIGINAL CORRECTED: per-block axis deltas and (with a machine file) tool-tip
// distances between the two programs, a summary and the largest changes with their lines.
#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <utility>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "postproc/compensation/diff.hpp"
#include "postproc/compensation/diff_report.hpp"
#include "postproc/contour/reference.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::cli {
namespace {


struct DiffArgs {
  std::string original, corrected, machine, csv, json, html;
  DialectArgs dialect;
  bool predict = false;
  double fail_above_um = -1;
  std::size_t worst = 10;
  std::size_t max_per_code = 20;
  ResolveArgs resolve;
};

std::string csv_of(const comp::DiffResult& r, bool machine) {
  std::string s = "original_line,corrected_line";
  for (char L : gcode::kAxisLetters) s += fmt::format(",d{}_{}", L, gcode::is_rotary(gcode::axis_index(L)) ? "deg" : "mm");
  s += machine ? ",tip_um,axis_arcsec\n" : ",linear_um\n";
  for (const comp::BlockDiff& b : r.blocks) {
    s += fmt::format("{},{}", b.line_original, b.line_corrected);
    for (int k = 0; k < gcode::kAxisCount; ++k)
      s += ((b.axes >> k) & 1u) ? fmt::format(",{:.9g}", b.delta[k]) : std::string(",");
    if (machine)
      s += std::isnan(b.tip_mm) ? std::string(",,\n") : fmt::format(",{:.6g},{:.6g}\n", b.tip_mm * 1000, b.axis_rad * kArcsec);
    else
      s += fmt::format(",{:.6g}\n", b.linear_mm * 1000);
  }
  return s;
}

/// The servo contour errors of both programs against the original's intended contour
/// (`--predict`): the corrected program's path must have the original's structure (points and
/// runs), since its points are measured against the original's at the same index.
struct Predictions {
  contour::Path original, corrected;
  contour::Prediction before, after;
  double fit_residual_mm = 0;
};

/// nullopt (diagnostics printed, rc set) when a path cannot be built.
std::optional<Predictions> predict_both(const DiffArgs& o, const machine::Machine& m, const gcode::Dialect& d,
                                        std::string_view a, std::string_view b, int& rc) {
  gcode::DiagnosticSink sink;
  DiagnosticPrinter printer(sink, o.max_per_code);
  Predictions p;
  const gcode::ResolveOptions ro = make_resolve_options(o.resolve);
  p.original = contour::build_path(a, o.original, d, m, contour::PathOptions{}, sink, ro);
  p.corrected = contour::build_path(b, o.corrected, d, m, contour::PathOptions{}, sink, ro);
  printer.finish();
  if (sink.has_errors()) {
    std::fputs("postproc: diff: --predict refused (see the errors above)\n", stderr);
    rc = static_cast<int>(ExitCode::refused);
    return std::nullopt;
  }
  const auto same_runs = [&] {
    if (p.original.runs.size() != p.corrected.runs.size()) return false;
    for (std::size_t k = 0; k < p.original.runs.size(); ++k)
      if (p.original.runs[k].begin != p.corrected.runs[k].begin || p.original.runs[k].end != p.corrected.runs[k].end)
        return false;
    return true;
  };
  if (p.original.points.size() != p.corrected.points.size() || !same_runs())
    throw Error(ExitCode::usage,
                fmt::format("--predict: {} has {} path points in {} runs but {} has {} in {}; predict needs a corrected "
                            "program with the original's structure (compensate --mode contour --contour-split off); "
                            "for a program with split moves, run postproc simulate CORRECTED --reference ORIGINAL",
                            o.corrected, p.corrected.points.size(), p.corrected.runs.size(), o.original,
                            p.original.points.size(), p.original.runs.size()));
  const contour::Reference ref(p.original, *m.actual);
  p.fit_residual_mm = ref.max_fit_residual_mm();
  p.before = contour::predict(p.original, *m.actual, ref);
  p.after = contour::predict(p.corrected, *m.actual, ref);
  return p;
}

nlohmann::json prediction_json(const contour::Prediction& p) {
  return {{"tip_um", {{"max", p.tip.max * 1000}, {"rms", p.tip.rms * 1000}, {"p95", p.tip.p95 * 1000}}},
          {"axis_arcsec", {{"max", p.axis.max * kArcsec}, {"rms", p.axis.rms * kArcsec}, {"p95", p.axis.p95 * kArcsec}}}};
}

}  // namespace

void setup_diff(CLI::App& app, int& rc) {
  auto o = std::make_shared<DiffArgs>();
  auto* cmd = app.add_subcommand("diff", "compare a program with its corrected version block by block (axis deltas; "
                                         "with a machine file, tool-tip distances)");
  cmd->add_option("original", o->original, "the original program")->required();
  cmd->add_option("corrected", o->corrected, "the corrected program")->required();
  cmd->add_option("-m,--machine", o->machine, "machine file: tool-tip distance and tool-axis angle in the workpiece frame");
  cmd->add_option("--csv", o->csv, "write the per-block deltas here (CSV)");
  cmd->add_option("--json", o->json, "write the summary and the largest changes here (JSON)");
  cmd->add_option("--html", o->html, "write a self-contained HTML report here (no network resources)");
  cmd->add_flag("--predict", o->predict,
                "also predict the servo contour errors of both programs against the original's intended contour "
                "(needs -m with servo data, as predict)");
  cmd->add_option("--fail-above", o->fail_above_um,
                  "exit with code 1 when any deviation (tool tip with -m, else linear axes) exceeds this, µm");
  cmd->add_option("--worst", o->worst, "how many of the largest changes to list")->capture_default_str();
  cmd->add_option("--max-per-code", o->max_per_code, "show at most this many diagnostics per code")->capture_default_str();
  add_dialect_options(*cmd, o->dialect, false);
  add_resolve_options(*cmd, o->resolve);
  cmd->callback([o, &rc] {
    gcode::DiagnosticSink sink;
    DiagnosticPrinter printer(sink, o->max_per_code);
    std::optional<machine::Machine> m;
    if (!o->machine.empty()) m = load_or_refuse(o->machine, o->max_per_code);
    if (o->predict && !m) throw Error(ExitCode::usage, "diff --predict needs -m MACHINE.toml with the servo data");
    if (!m && o->dialect.dialect.empty())
      throw Error(ExitCode::usage, "diff needs the dialect: give -m MACHINE.toml or --dialect");
    const gcode::Dialect d = m && o->dialect.dialect.empty() ? *gcode::make_dialect(m->dialect_name, m->dialect_options)
                                                              : make_dialect(o->dialect);
    const std::string a = io::read_file(o->original, "NC program");
    const std::string b = io::read_file(o->corrected, "NC program");
    const comp::DiffResult r = comp::diff(a, b, o->original, o->corrected, d, m ? &*m : nullptr, sink,
                                               make_resolve_options(o->resolve));
    printer.finish();
    if (sink.has_errors()) {
      std::fputs("postproc: diff: the programs have errors (see above); nothing compared\n", stderr);
      rc = static_cast<int>(ExitCode::refused);
      return;
    }
    std::optional<Predictions> pred;
    if (o->predict) {
      pred = predict_both(*o, *m, d, a, b, rc);
      if (!pred) return;
    }
    const bool with_machine = m.has_value();
    const auto worst = comp::worst_blocks(r, o->worst);
    OutputSet outputs;
    if (!o->csv.empty()) {
      outputs.add(o->csv, csv_of(r, with_machine));
    }
    const char* what = with_machine ? "tool-tip distance" : "linear-axis change";
    if (!o->json.empty()) {
      nlohmann::json j;
      j["tool"] = {{"name", "postproc"}, {"version", POSTPROC_VERSION}};
      j["original"] = o->original;
      j["corrected"] = o->corrected;
      if (with_machine) j["machine"] = {{"file", m->file}, {"sha256", m->sha256}};
      j["aligned"] = r.by_block ? "by block" : "by path";
      j["motions"] = {{"original", r.motions_original}, {"corrected", r.motions_corrected}};
      j["pairs"] = r.blocks.size();
      j["changed"] = r.changed;
      j["unmatched"] = r.unmatched;
      j["deviation"] = {{"measure", what},
                        {"max_um", r.deviation.max * 1000},
                        {"rms_um", r.deviation.rms * 1000},
                        {"p95_um", r.deviation.p95 * 1000}};
      if (with_machine)
        j["axis_angle"] = {{"max_arcsec", r.angle.max * kArcsec},
                           {"rms_arcsec", r.angle.rms * kArcsec},
                           {"p95_arcsec", r.angle.p95 * kArcsec}};
      nlohmann::json w = nlohmann::json::array();
      for (std::size_t k : worst) {
        const comp::BlockDiff& bd = r.blocks[k];
        w.push_back({{"original_line", bd.line_original},
                     {"corrected_line", bd.line_corrected},
                     {"deviation_um", bd.deviation_mm * 1000},
                     {"rotary_deg", bd.rotary_deg}});
      }
      j["largest"] = w;
      if (o->fail_above_um >= 0) j["fail_above_um"] = o->fail_above_um;
      if (pred)
        j["predicted"] = {{"original", prediction_json(pred->before)},
                          {"corrected", prediction_json(pred->after)},
                          {"fit_residual_um", pred->fit_residual_mm * 1000}};
      outputs.add(o->json, j.dump(2) + "\n");
    }
    if (!o->html.empty()) {
      comp::DiffReport rep;
      rep.result = &r;
      rep.original_file = o->original;
      rep.corrected_file = o->corrected;
      if (with_machine) {
        rep.machine_file = m->file;
        rep.machine_sha256 = m->sha256;
      }
      rep.tool_version = POSTPROC_VERSION;
      rep.original_text = a;
      rep.corrected_text = b;
      rep.worst = o->worst;
      if (pred) {
        rep.path = &pred->original;
        rep.predicted_before = &pred->before;
        rep.predicted_after = &pred->after;
      }
      outputs.add(o->html, comp::diff_report_html(rep));
    }
    outputs.commit();
    std::string s = fmt::format(
        "postproc: diff {} → {}: {} / {} motions, aligned {}, {} pairs ({} changed, {} unmatched)\n"
        "  {}: max {:.3f} µm, RMS {:.3f} µm, p95 {:.3f} µm\n",
        o->original, o->corrected, r.motions_original, r.motions_corrected, r.by_block ? "by block" : "by path",
        r.blocks.size(), r.changed, r.unmatched, what, r.deviation.max * 1000, r.deviation.rms * 1000,
        r.deviation.p95 * 1000);
    if (with_machine)
      s += fmt::format("  tool-axis angle: max {:.2f} arcsec, RMS {:.2f} arcsec\n", r.angle.max * kArcsec,
                       r.angle.rms * kArcsec);
    if (pred)
      for (const auto& [name, p] : {std::pair{"original", &pred->before}, std::pair{"corrected", &pred->after}})
        s += fmt::format("  predicted contour error, {}: tool tip max {:.3f} µm, RMS {:.3f} µm; tool axis max {:.2f} "
                         "arcsec, RMS {:.2f} arcsec\n",
                         name, p->tip.max * 1000, p->tip.rms * 1000, p->axis.max * kArcsec, p->axis.rms * kArcsec);
    for (std::size_t k : worst) {
      const comp::BlockDiff& bd = r.blocks[k];
      if (bd.deviation_mm <= 0 && bd.rotary_deg <= 0) break;
      s += fmt::format("  line {} → {}: {:.3f} µm, rotary {:.5f} deg\n", bd.line_original, bd.line_corrected,
                       bd.deviation_mm * 1000, bd.rotary_deg);
    }
    std::fputs(s.c_str(), stderr);
    rc = 0;
    if (o->fail_above_um >= 0 && r.deviation.max * 1000 > o->fail_above_um) {
      std::fputs(fmt::format("postproc: diff: {} {:.3f} µm exceeds --fail-above {} µm\n", what, r.deviation.max * 1000,
                             o->fail_above_um)
                     .c_str(),
                 stderr);
      rc = 1;
    }
  });
}

}  // namespace postproc::cli
