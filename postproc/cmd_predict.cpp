// postproc predict / simulate: servo following and contour errors of a program on a machine
// (issue 6): the quasi-static prediction of document 004, and the time-domain simulation.
#include <cmath>
#include <memory>
#include <optional>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "common.hpp"
#include "progress_bar.hpp"
#include "postproc/compensation/compensate.hpp"
#include "postproc/contour/report.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::cli {
namespace {

constexpr double kUm = 1000.0;

/// Machine, dialect and the program's path; nullopt (diagnostics printed, rc set) when refused.
struct Loaded {
  machine::Machine machine;
  gcode::Dialect dialect;
  std::string text;
  contour::Path path;
};

/// `own_contour`: the program's own path is the contour its errors are measured against (predict;
/// simulate without --reference): a program written by compensate's contour modes is warned
/// about (PP-W622).
std::optional<Loaded> load(const std::string& program, const std::string& machine_file, std::size_t max_per_code,
                           const ResolveArgs& resolve, int& rc, std::string_view own_contour = {}) {
  machine::Machine m = load_or_refuse(machine_file, max_per_code);
  gcode::DiagnosticSink sink;
  DiagnosticPrinter printer(sink, max_per_code);
  gcode::Dialect d = *gcode::make_dialect(m.dialect_name, m.dialect_options);
  Loaded l{std::move(m), d, io::read_file(program, "NC program"), {}};
  if (!own_contour.empty()) comp::warn_servo_precompensated(l.text, program, own_contour, sink);
  l.path = contour::build_path(l.text, program, l.dialect, l.machine, contour::PathOptions{}, sink,
                               make_resolve_options(resolve));
  printer.finish();
  if (sink.has_errors()) {
    std::fputs(fmt::format("postproc: {}: refused (see the errors above)\n", program).c_str(), stderr);
    rc = static_cast<int>(ExitCode::refused);
    return std::nullopt;
  }
  return l;
}

std::string joint_unit(const kin::Model& model, std::size_t j) {
  return model.joints()[j].type == kin::JointType::rotary ? "deg" : "mm";
}

void print_following(const kin::Model& model, const std::vector<double>& f) {
  std::string s;
  for (std::size_t j = 0; j < f.size(); ++j)
    s += fmt::format("{}{} {:.4f} {}", j ? ", " : "", model.joints()[j].name, f[j], joint_unit(model, j));
  std::fputs(fmt::format("  largest following error: {}\n", s).c_str(), stderr);
}

struct PredictArgs {
  std::string input, machine, csv, json, html;
  double marker_length_mm = 100;
  std::size_t worst = 10;
  std::size_t max_per_code = 20;
  ResolveArgs resolve;
};

struct TrajectorySimulateArgs {
  std::string input, machine, reference, csv, json;
  double settle_s = 0.1;
  std::size_t every = 1;
  bool nominal = false;
  std::size_t max_per_code = 20;
  ResolveArgs resolve;
};

}  // namespace

void setup_predict(CLI::App& app, int& rc) {
  auto o = std::make_shared<PredictArgs>();
  auto* cmd = app.add_subcommand("predict", "predict the servo following errors and the contour errors they cause "
                                            "at every block end point");
  cmd->add_option("input", o->input, "NC program")->required();
  cmd->add_option("-m,--machine", o->machine, "machine file with the servo data of every axis ([axes.X] kv …)")
      ->required();
  cmd->add_option("--csv", o->csv, "write the per-point errors here (CSV)");
  cmd->add_option("--json", o->json, "write the summary and the worst places here (JSON)");
  cmd->add_option("--html", o->html, "write a self-contained HTML report here");
  cmd->add_option("--worst", o->worst, "how many worst places to list")->capture_default_str();
  cmd->add_option("--marker-length", o->marker_length_mm, "distance of the tool-axis marker point from the tip, mm")
      ->capture_default_str();
  cmd->add_option("--max-per-code", o->max_per_code, "show at most this many diagnostics per code")->capture_default_str();
  add_resolve_options(*cmd, o->resolve);
  cmd->callback([o, &rc] {
    if (!(o->marker_length_mm > 0)) throw Error(ExitCode::usage, "--marker-length must be a positive length in mm");
    ProgressBar bar("postproc: predict:");
    bar.update("reading the path", 0, 0);
    auto l = load(o->input, o->machine, o->max_per_code, o->resolve, rc, "predict");
    if (!l) return;
    contour::ReferenceOptions ropt;
    ropt.marker_length_mm = o->marker_length_mm;
    bar.update("fitting the NURBS reference", 0, 0);
    const contour::Reference ref(l->path, *l->machine.actual, ropt);
    bar.update("predicting", 0, 0);
    const contour::Prediction p = contour::predict(l->path, *l->machine.actual, ref);
    bar.finish();
    contour::ContourReport r;
    r.title = "predict " + o->input;
    r.program = o->input;
    r.machine_file = l->machine.file;
    r.machine_sha256 = l->machine.sha256;
    r.tool_version = POSTPROC_VERSION;
    r.path = &l->path;
    r.before = &p;
    r.fit_residual_mm = ref.max_fit_residual_mm();
    r.worst = o->worst;
    OutputSet outputs;
    if (!o->csv.empty()) outputs.add(o->csv, contour::report_csv(r));
    if (!o->json.empty()) outputs.add(o->json, contour::report_json(r));
    if (!o->html.empty()) outputs.add(o->html, contour::report_html(r));
    outputs.commit();
    const auto line_of = [&](std::size_t i) { return l->path.points.empty() ? 0 : l->path.points[i].line; };
    std::fputs(fmt::format("postproc: {}: {} points on {} runs ({} feed moves, {} arcs as chords), {:.3f} s of cutting\n"
                           "  tool-tip contour error: max {:.3f} µm (line {}), RMS {:.3f} µm, p95 {:.3f} µm\n"
                           "  tool-axis contour error: max {:.2f} arcsec (line {}), RMS {:.2f} arcsec, p95 {:.2f} arcsec\n"
                           "  NURBS fit residual {:.4f} µm{}\n",
                           o->input, l->path.points.size(), l->path.runs.size(), l->path.feed_moves, l->path.arcs,
                           l->path.duration, p.tip.max * kUm, line_of(p.tip.worst), p.tip.rms * kUm, p.tip.p95 * kUm,
                           p.axis.max * kArcsec, line_of(p.axis.worst), p.axis.rms * kArcsec, p.axis.p95 * kArcsec,
                           ref.max_fit_residual_mm() * kUm,
                           ref.within_tolerance() ? "" : " (above the 0.1 µm tolerance somewhere)")
                   .c_str(),
               stderr);
    print_following(*l->machine.actual, p.max_following);
    if (p.unconverged > 0)
      std::fputs(fmt::format("postproc: warning: {} foot points did not converge (their errors are upper bounds)\n",
                             p.unconverged)
                     .c_str(),
                 stderr);
    rc = 0;
  });
}

void setup_simulate(CLI::App& app, int& rc) {
  auto o = std::make_shared<TrajectorySimulateArgs>();
  auto* cmd = app.add_subcommand("simulate", "time-domain simulation: the controller's interpolator and every axis's "
                                             "closed-loop drive, with the contour errors of the actual path");
  cmd->add_option("input", o->input, "NC program that runs (e.g. a compensated program)")->required();
  cmd->add_option("-m,--machine", o->machine, "machine file with the servo data of every axis")->required();
  cmd->add_option("--reference", o->reference,
                  "the program whose path is intended (default: the input itself); give the original program when "
                  "simulating its compensated version");
  cmd->add_option("--csv", o->csv, "write the samples here (CSV: time, line, command and actual joints, errors)");
  cmd->add_option("--json", o->json, "write the summary here (JSON)");
  cmd->add_option("--every", o->every, "keep every k-th interpolation period in the CSV")->capture_default_str();
  cmd->add_option("--settle", o->settle_s, "time simulated at rest after each run, s")->capture_default_str();
  cmd->add_flag("--nominal-reference", o->nominal,
                "measure against the path of the nominal machine (the drawing: geometric and servo errors "
                "together, e.g. after compensate --mode all); default: the calibrated machine's path without lag");
  cmd->add_option("--max-per-code", o->max_per_code, "show at most this many diagnostics per code")->capture_default_str();
  add_resolve_options(*cmd, o->resolve);
  cmd->callback([o, &rc] {
    if (o->every == 0) throw Error(ExitCode::usage, "--every must be at least 1");
    if (!(o->settle_s >= 0)) throw Error(ExitCode::usage, "--settle must be a time ≥ 0 in s");
    ProgressBar bar("postproc: simulate:");
    bar.update("reading the path", 0, 0);
    auto l = load(o->input, o->machine, o->max_per_code, o->resolve, rc,
                  o->reference.empty() ? std::string_view("simulate without --reference") : std::string_view());
    if (!l) return;
    std::optional<Loaded> ref_prog;
    if (!o->reference.empty()) {
      ref_prog = load(o->reference, o->machine, o->max_per_code, o->resolve, rc);
      if (!ref_prog) return;
      if (ref_prog->path.runs.size() != l->path.runs.size())
        throw Error(ExitCode::usage,
                    fmt::format("{} has {} cutting runs but the reference {} has {}; simulate a program against its "
                                "own original",
                                o->input, l->path.runs.size(), o->reference, ref_prog->path.runs.size()));
    }
    // The intended contour: the reference program's path with its long moves densified as the
    // controller interpolates them (PathOptions::densify_mm; compensate's verification does the same).
    const Loaded& intended_prog = ref_prog ? *ref_prog : *l;
    contour::PathOptions dense;
    dense.densify_mm = contour::kReferenceDensifyMm;
    gcode::DiagnosticSink quiet(0);
    const contour::Path intended =
        contour::build_path(intended_prog.text, ref_prog ? o->reference : o->input, intended_prog.dialect,
                            intended_prog.machine, dense, quiet, make_resolve_options(o->resolve));
    contour::ReferenceOptions ropt;
    ropt.nominal = o->nominal;
    bar.update("fitting the NURBS reference", 0, 0);
    const contour::Reference ref(intended, *l->machine.actual, ropt);
    contour::SimulateOptions so;
    so.settle_s = o->settle_s;
    so.keep_every = o->csv.empty() ? 0 : o->every;
    bar.update("simulating", 0, 0);
    const contour::Simulation s = contour::simulate(l->path, ref, *l->machine.actual, so);
    bar.finish();
    const kin::Model& model = *l->machine.actual;
    OutputSet outputs;
    if (!o->csv.empty()) {
      std::string csv = "t_s,run,line";
      for (const kin::Joint& j : model.joints()) csv += fmt::format(",{0}_command_{1},{0}_actual_{1}", j.name,
                                                                    j.type == kin::JointType::rotary ? "deg" : "mm");
      csv += ",tip_x_mm,tip_y_mm,tip_z_mm,tip_contour_um,axis_contour_arcsec\n";
      for (const contour::SimSample& x : s.kept) {
        csv += fmt::format("{:.6f},{},{}", x.t, x.run, x.line);
        for (int j = 0; j < x.command.size(); ++j) csv += fmt::format(",{:.9g},{:.9g}", x.command[j], x.actual[j]);
        csv += fmt::format(",{:.9g},{:.9g},{:.9g},{:.6g},{:.6g}\n", x.tip.x(), x.tip.y(), x.tip.z(), x.tip_mm * kUm,
                           x.axis_rad * kArcsec);
      }
      outputs.add(o->csv, csv);
    }
    if (!o->json.empty()) {
      nlohmann::json j;
      j["tool"] = {{"name", "postproc"}, {"version", POSTPROC_VERSION}};
      j["program"] = o->input;
      j["reference"] = o->reference.empty() ? o->input : o->reference;
      j["machine"] = {{"file", l->machine.file}, {"sha256", l->machine.sha256}};
      j["interpolation_period_s"] = l->path.period;
      j["samples"] = s.samples;
      j["tip_um"] = {{"max", s.tip.max * kUm}, {"rms", s.tip.rms * kUm}, {"p95", s.tip.p95 * kUm}};
      j["axis_arcsec"] = {{"max", s.axis.max * kArcsec}, {"rms", s.axis.rms * kArcsec}, {"p95", s.axis.p95 * kArcsec}};
      j["worst_tip_line"] = s.worst_tip_line;
      j["worst_axis_line"] = s.worst_axis_line;
      nlohmann::json f = nlohmann::json::object();
      for (std::size_t k = 0; k < s.max_following.size(); ++k)
        f[model.joints()[k].name] = {{"value", s.max_following[k]}, {"unit", joint_unit(model, k)}};
      j["max_following"] = f;
      j["fit_residual_um"] = ref.max_fit_residual_mm() * kUm;
      outputs.add(o->json, j.dump(2) + "\n");
    }
    outputs.commit();
    std::fputs(fmt::format("postproc: {}: simulated {} periods of {} ms\n"
                           "  tool-tip contour error: max {:.3f} µm (line {}), RMS {:.3f} µm, p95 {:.3f} µm\n"
                           "  tool-axis contour error: max {:.2f} arcsec (line {}), RMS {:.2f} arcsec, p95 {:.2f} arcsec\n",
                           o->input, s.samples, l->path.period * 1000, s.tip.max * kUm, s.worst_tip_line,
                           s.tip.rms * kUm, s.tip.p95 * kUm, s.axis.max * kArcsec, s.worst_axis_line,
                           s.axis.rms * kArcsec, s.axis.p95 * kArcsec)
                   .c_str(),
               stderr);
    print_following(model, s.max_following);
    rc = 0;
  });
}

}  // namespace postproc::cli
