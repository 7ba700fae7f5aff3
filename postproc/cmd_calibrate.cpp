// postproc calibrate: identify a machine's error parameters from measurement files and write
// the calibrated machine file; `calibrate plan` and `calibrate simulate` (cmd_calibrate_plan.cpp).
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include <fmt/format.h>

#include "calibrate_support.hpp"
#include "common.hpp"
#include "progress_bar.hpp"
#include "postproc/calibration/measurement_files.hpp"
#include "postproc/calibration/identify.hpp"
#include "postproc/calibration/machine_update.hpp"
#include "postproc/calibration/report.hpp"
#include "postproc/calibration/step_gauge.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/kinematics/volumetric_map.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::cli {
namespace {

struct CalibrateArgs {
  std::vector<std::string> data;
  std::vector<std::string> validate;
  std::string machine;
  std::string output;
  std::vector<std::string> reports;
  std::vector<std::string> json_reports;  ///< --json: JSON whatever the name
  std::vector<std::string> html_reports;  ///< --html: HTML whatever the name
  std::string method = "least-squares";
  double lambda = 0;
  std::vector<std::string> free;
  std::vector<std::string> fix;
  std::vector<std::string> bounds;
  std::string loss = "none";
  std::string solver = "auto";
  double loss_scale_um = 20;
  int max_iterations = 150;
  bool numeric = false;
  double angle_weight = cal::kOrientationWeight;
  std::string map_interpolation;  ///< empty: as the machine file's map, else trilinear
  std::string map_outside;        ///< empty: as the machine file's map, else refuse
  bool in_place = false;
  std::size_t max_per_code = 20;
  unsigned jobs = 0;  ///< -j: threads of the solver's evaluations (0: the usable cores)
};

/// "EX0C=-50um:50um": bounds on the deviation from nominal (error parameters) or the value.
void parse_bound(const std::string& text, const kin::Model& model, cal::IdentifyOptions& opt) {
  const auto eq = text.find('=');
  const auto colon = text.find(':', eq == std::string::npos ? 0 : eq);
  if (eq == std::string::npos || colon == std::string::npos)
    throw Error(ExitCode::usage, fmt::format("--bound '{}': write NAME=LOW:HIGH with units, e.g. EX0C=-50um:50um", text));
  const std::string name = text.substr(0, eq);
  const int k = model.parameter_index(name);
  if (k < 0) throw Error(ExitCode::usage, fmt::format("--bound '{}': the machine has no parameter '{}'", text, name));
  const kin::Parameter& p = model.parameters()[static_cast<std::size_t>(k)];
  // A scale (ratio) bound is written like a slope: "20um/m".
  const cal::Quantity q = p.unit == "mm" ? cal::Quantity::length : cal::Quantity::angle;
  auto value = [&](std::string s) {
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(s, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    const auto f = used > 0 ? cal::unit_factor(s.substr(used), q) : std::nullopt;
    if (!f)
      throw Error(ExitCode::usage, fmt::format("--bound '{}': '{}' is not a {} with a unit (e.g. {})", text, s,
                                               p.unit == "rad" ? "angle" : p.unit == "ratio" ? "scale" : "length",
                                               p.unit == "rad" ? "20arcsec" : p.unit == "ratio" ? "20um/m" : "50um"));
    return v * *f + (p.error ? p.nominal : 0.0);
  };
  const double lo = value(text.substr(eq + 1, colon - eq - 1)), hi = value(text.substr(colon + 1));
  if (!(lo < hi)) throw Error(ExitCode::usage, fmt::format("--bound '{}': LOW must be below HIGH", text));
  opt.bounds.push_back({k, {lo, hi}});
}

/// A condition number of the identification Jacobian above this is warned about on the terminal.
constexpr double kPoorCondition = 1e4;
/// A file whose normalised rms residual is beyond this factor of 1 (either way) is warned about.
constexpr double kPoorFit = 3;

void print_summary(const cal::CalibrationRun& run, const cal::Comparison& c) {
  const auto& r = run.result;
  const auto& params = run.start->parameters();
  int registration = 0;
  for (const cal::FrameEstimate& f : r.frames)
    for (int k = 0; k < 6; ++k) registration += ((f.free & ~f.held) >> k) & 1;
  const auto poorly = static_cast<std::size_t>(std::count_if(r.identified.begin(), r.identified.end(), [&](int k) {
    return cal::parameter_status(run, k) == "poorly determined";
  }));
  std::string out = fmt::format("postproc: {} measurements ({} fitted, {} held out); method {}{}; {} of {} parameters "
                                "identified{}{}, {} {} iterations, {:.3f} s\n",
                                run.data.size(), c.fit.count, c.validation.count, cal::to_string(run.options.method),
                                r.lambda > 0 ? fmt::format(" (λ = {:.3g})", r.lambda) : "", r.identified.size() - poorly,
                                r.identified.size() + r.held.size(),
                                poorly > 0 ? fmt::format(", {} estimated but poorly determined", poorly) : "",
                                registration > 0 ? fmt::format(" (and {} instrument-frame components)", registration) : "",
                                r.iterations, r.solver == cal::Solver::streamed ? "streamed LM" : "Ceres", r.seconds);
  out += fmt::format("postproc: identifiability: rank {} of {}, condition {:.4g}, O1 {:.4g}, O3 {:.4g}, O4 {:.4g}\n",
                     r.start.rank, r.start.parameters, r.start.condition, r.start.o1, r.start.o3, r.start.o4);
  for (const std::string& comb : r.start.combinations)
    out += fmt::format("postproc: not identifiable (held at the start value): {}\n", comb);
  for (const std::string& why : r.held_why) out += fmt::format("postproc: held: {}\n", why);
  if (!r.held_why.empty())
    out += fmt::format("postproc: warning: {} machine parameters keep the machine file's values because an instrument "
                       "frame's unknown placement imitates them exactly; if those values are not known, add measurements "
                       "taken in the workpiece frame (a registered instrument) so they can be identified\n",
                       r.held_why.size());
  {
    std::string weak;
    for (int k : r.identified)
      if (cal::parameter_status(run, k) == "poorly determined") {
        const kin::Parameter& p = params[static_cast<std::size_t>(k)];
        const double scale = p.unit == "rad" ? 180.0 / kin::kPi * 3600.0 : p.unit == "ratio" ? 1e6 : 1000.0;
        const char* unit = p.unit == "rad" ? "arcsec" : p.unit == "ratio" ? "µm/m" : "µm";
        const auto i = static_cast<std::size_t>(k);
        weak += fmt::format("{}{} {:.3g} ± {:.3g} {}", weak.empty() ? "" : ", ", p.name,
                            (r.values[i] - (p.error ? p.nominal : 0)) * scale, r.stddev[i] * scale, unit);
      }
    if (!weak.empty())
      out += fmt::format("postproc: warning: poorly determined (the estimate is less than 2σ from the drawing): {}; "
                         "measure poses that move these parameters' effects, or fix them (--fix)\n",
                         weak);
  }
  for (int k : r.start.unobserved)
    out += fmt::format("postproc: no measurement depends on {} (held at the start value)\n", params[static_cast<std::size_t>(k)].name);
  auto figures = [](std::string_view set, const cal::SetFigures& f) {
    std::string line = fmt::format("postproc: {} ({}):", set, f.count);
    if (f.positions > 0)
      line += fmt::format(" tool-tip (strut) error max {:.5f} → {:.5f} mm, rms {:.5f} → {:.5f} mm;", f.max_position_before_mm,
                          f.max_position_after_mm, f.rms_position_before_mm, f.rms_position_after_mm);
    if (f.angles > 0)
      line += fmt::format(" tool-axis error max {:.5f} → {:.5f} deg;", f.max_angle_before_deg, f.max_angle_after_deg);
    line.back() = '\n';
    return line;
  };
  out += figures("fitted", c.fit);
  if (c.validation.count > 0) out += figures("held out", c.validation);
  out += fmt::format("postproc: residual σ {:.5f} mm (mm-equivalent{})\n", r.sigma,
                     r.sigma_reference_mm != cal::kDefaultSigma
                         ? fmt::format(", weighted to the most accurate file's σ {:g} µm", r.sigma_reference_mm * 1000)
                         : "");
  for (const cal::FrameEstimate& f : r.frames) {
    const Eigen::Vector3d w = f.rotation();
    auto sd = [&](int k, double scale) {
      return std::isfinite(f.stddev[static_cast<std::size_t>(k)]) ? fmt::format("±{:.3g}", f.stddev[static_cast<std::size_t>(k)] * scale)
                                                                  : std::string("held");
    };
    out += fmt::format("postproc: instrument frame '{}' ({} measurements): translation ({:.4f} {}, {:.4f} {}, {:.4f} {}) µm, "
                       "rotation ({:.3f} {}, {:.3f} {}, {:.3f} {}) arcsec\n",
                       f.name, f.measurements, f.t.x() * 1000, sd(0, 1000), f.t.y() * 1000, sd(1, 1000), f.t.z() * 1000,
                       sd(2, 1000), w.x() * kArcsec, sd(3, kArcsec), w.y() * kArcsec, sd(4, kArcsec), w.z() * kArcsec,
                       sd(5, kArcsec));
    for (const std::string& why : f.held_why)
      out += fmt::format("postproc: instrument frame '{}': {}\n", f.name, why);
  }
  // Per file only when some file states its uncertainty: without it the χ² measures nothing.
  const bool per_file = std::any_of(r.files.begin(), r.files.end(), [](const cal::FileFit& f) { return f.declared; });
  for (const cal::FileFit& f : r.files) {
    if (!per_file) break;
    std::string sigma;
    if (f.lengths) sigma += fmt::format("σ {:g} µm", f.sigma_mm * 1000);
    if (f.angles) sigma += fmt::format("{}σ_angle {:.3g} arcsec", sigma.empty() ? "" : ", ", f.sigma_rad * 180.0 / kin::kPi * 3600);
    out += fmt::format("postproc: file {}: {} ({}), {} residual rows, χ² {:.4g}, normalised rms {:.3f}\n", f.file, sigma,
                       f.declared ? "declared" : "default", f.rows, f.chi2, f.normalised_rms);
    if (f.declared && f.normalised_rms > kPoorFit)
      out += fmt::format("postproc: warning: {} fits {:.1f} times worse than its declared sigma: the sigma is too "
                         "small, the file holds outliers or a misregistered frame (declare '# frame: instrument'), or "
                         "the machine model misses an error; check the file's residuals in the report\n",
                         f.file, f.normalised_rms);
    if (f.declared && f.normalised_rms < 1 / kPoorFit)
      out += fmt::format("postproc: warning: {} fits {:.1f} times better than its declared sigma: the sigma looks too "
                         "large, so this file weighs too little against the others\n",
                         f.file, 1 / f.normalised_rms);
  }
  // What the JSON report says, on the terminal too: a solve that did not converge, and
  // parameters the measurements determine poorly.
  if (r.iterations >= run.options.max_iterations)
    out += fmt::format("postproc: warning: the solver stopped at its iteration limit (--max-iterations {}) "
                       "before it converged; the parameters may not be the best fit — run again with a higher "
                       "--max-iterations\n",
                       r.iterations);
  else if (!r.converged)
    out += fmt::format("postproc: warning: the solver stopped without converging ({}); the parameters may not be the "
                       "best fit\n",
                       r.message);
  if (r.start.condition > kPoorCondition)
    out += fmt::format("postproc: warning: condition number {:.4g} (above {:g}): these measurements determine some "
                       "parameters poorly, their estimates follow the noise (the weakest combination: {}) — add poses "
                       "that move those parameters (postproc calibrate plan) or fix them (--fix)\n",
                       r.start.condition, kPoorCondition, r.start.weakest);
  std::fputs(out.c_str(), stderr);
}

void run_calibrate(const CalibrateArgs& a, int& rc) {
  const auto method = cal::parse_method(a.method);
  if (!method) throw Error(ExitCode::usage, fmt::format("--method {}: use least-squares, ridge or psi-substitution", a.method));
  if (a.data.empty()) throw Error(ExitCode::usage, "give at least one measurement file (docs/measurements.md)");
  gcode::DiagnosticSink sink;
  DiagnosticPrinter printer(sink, a.max_per_code);
  const std::string machine_text = io::read_file(a.machine, "machine file");
  const auto machine = machine::parse_machine(a.machine, machine_text, sink);
  if (!machine) {
    printer.finish();
    std::fputs(fmt::format("postproc: {}: machine file refused; nothing was written\n", a.machine).c_str(), stderr);
    rc = static_cast<int>(ExitCode::refused);
    return;
  }
  const kin::Model& start = *machine->actual;

  cal::MeasurementFiles files;
  for (const std::string& p : a.data) cal::add_measurement_file(p, false, start, files, sink);
  for (const std::string& p : a.validate) cal::add_measurement_file(p, true, start, files, sink);
  std::vector<cal::Measurement>& data = files.data;
  const cal::StepGaugeData& gauge = files.gauge;
  const bool have_gauge = files.have_gauge;
  const std::vector<cal::InputFile>& inputs = files.inputs;
  if (sink.has_errors()) {
    printer.finish();
    std::fputs("postproc: measurement files refused; nothing was written\n", stderr);
    rc = static_cast<int>(ExitCode::refused);
    return;
  }

  // Step gauge → [volumetric_map].
  cal::StepGaugeReport sgr;
  std::string map_section;
  std::vector<std::string> notes;
  if (have_gauge) {
    cal::StepGaugeOptions sg;
    if (const auto* old = dynamic_cast<const kin::VolumetricModel*>(machine->actual.get())) {
      sg.interpolation = old->map().interpolation();
      sg.outside = old->map().outside();
    }
    if (!a.map_interpolation.empty())
      sg.interpolation = a.map_interpolation == "smooth" ? kin::VolumetricMap::Interpolation::smooth
                                                         : kin::VolumetricMap::Interpolation::trilinear;
    if (!a.map_outside.empty())
      sg.outside = a.map_outside == "clamp"  ? kin::VolumetricMap::Outside::clamp
                   : a.map_outside == "zero" ? kin::VolumetricMap::Outside::zero
                                             : kin::VolumetricMap::Outside::refuse;
    const auto map = cal::build_volumetric_map(gauge, sg, sink, &sgr);
    if (!map) {
      printer.finish();
      std::fputs("postproc: step-gauge data refused; nothing was written\n", stderr);
      rc = static_cast<int>(ExitCode::refused);
      return;
    }
    map_section = cal::volumetric_map_toml(*map);
    notes.push_back(fmt::format("volumetric map from {} gauges, {} pyramids: largest |E| {:.4f} mm", gauge.gauges.size(),
                                sgr.points.size(), sgr.max_error));
    for (const auto& t : sgr.tilts)
      if (t.measured)
        notes.push_back(fmt::format("gauge {}: plate tilt θx {:.2f} arcsec, θy {:.2f} arcsec (edge-fit rms {:.2f} / {:.2f} µm)", t.gauge,
                                    t.theta.x() / kin::kDeg * 3600, t.theta.y() / kin::kDeg * 3600, t.rms.x() * 1000,
                                    t.rms.y() * 1000));
    for (const auto& n : notes) std::fputs(("postproc: " + n + "\n").c_str(), stderr);
  }

  cal::IdentifyOptions opt;
  opt.method = *method;
  opt.ridge_lambda = a.lambda;
  opt.max_iterations = a.max_iterations;
  opt.numeric_derivatives = a.numeric;
  opt.threads = static_cast<int>(a.jobs > 0 ? a.jobs : usable_cores());
  opt.orientation_weight = a.angle_weight;
  opt.loss = a.loss == "huber" ? cal::Loss::huber : a.loss == "cauchy" ? cal::Loss::cauchy : cal::Loss::none;
  opt.loss_scale = a.loss_scale_um / 1000.0;
  opt.solver = cal::parse_solver(a.solver).value_or(cal::Solver::automatic);
  if (!a.free.empty()) opt.free = match_parameters(start, a.free, "--free");
  if (!a.fix.empty()) opt.fixed = match_parameters(start, a.fix, "--fix");
  for (const std::string& b : a.bounds) parse_bound(b, start, opt);

  std::string out_text = machine_text;
  std::vector<std::string> header{fmt::format("calibrated by postproc {} calibrate from {} (sha256 {})", POSTPROC_VERSION,
                                              a.machine, machine->sha256)};
  for (const cal::InputFile& f : inputs)
    header.push_back(fmt::format("  data {} ({}, {} rows, sha256 {})", f.path, f.kind, f.measurements, f.sha256));

  cal::CalibrationRun run;
  run.tool_version = POSTPROC_VERSION;
  run.machine_file = a.machine;
  run.machine_sha256 = machine->sha256;
  run.machine_name = machine->name;
  run.output_file = a.output;
  run.inputs = inputs;
  run.options = opt;
  run.notes = notes;
  if (have_gauge) run.step_gauge = &sgr;
  kin::ModelPtr solved = machine->actual;
  if (!data.empty()) {
    {
      ProgressBar bar("postproc: calibrate:");
      if (bar.enabled())
        opt.progress = [&bar](std::string_view, double done, double total) { bar.update("solving", done, total); };
      run.result = cal::identify(start, data, opt);
      opt.progress = nullptr;
    }
    solved = start.with_values(run.result.values);
    run.start = &start;
    run.solved = solved.get();
    // Instrument-frame values in the workpiece frame (estimated registration), for every figure.
    // Copied only when a frame moves them: a million rows are 336 MB a copy.
    std::vector<cal::Measurement> as_measured;
    const bool framed =
        std::any_of(data.begin(), data.end(), [](const cal::Measurement& m) { return !m.source.frame.empty(); });
    if (framed) {
      as_measured = data;
      data = cal::registered(data, run.result);
    }
    const std::span<const cal::Measurement> original =
        framed ? std::span<const cal::Measurement>(as_measured) : std::span<const cal::Measurement>(data);
    run.data = data;
    const cal::Comparison c = cal::compare(run);
    print_summary(run, c);
    for (const cal::SignHint& h : cal::opposite_sign_hints(start, original, opt, run.result))
      std::fputs(fmt::format("postproc: warning: the data fit {:.3g} times better (residual σ {:.5f} mm) with the sign "
                             "of axis {} reversed: the measurements and the machine file use opposite rotary sign "
                             "conventions (docs/measurements.md, 'Rotary sign convention'); check the joint column or "
                             "the axis's direction in the machine file\n",
                             h.cost_ratio, h.sigma_mm, h.joint)
                     .c_str(),
                 stderr);
    if (!run.result.usable)
      throw Error(ExitCode::refused, fmt::format("the solver gave no usable solution ({}); nothing was written", run.result.message));
    cal::ErrorsTable t;
    t.model = &start;
    t.values = run.result.values;
    t.stddev = run.result.stddev;
    t.identified = run.result.identified;
    for (std::size_t i = 0; i < run.result.start.dependent.size(); ++i) {
      const int k = run.result.start.dependent[i];
      if (std::find(run.result.held.begin(), run.result.held.end(), k) == run.result.held.end()) continue;
      std::string why = std::find(run.result.start.unobserved.begin(), run.result.start.unobserved.end(), k) !=
                                run.result.start.unobserved.end()
                            ? "no measurement depends on it"
                            : "see the unidentifiable combinations in the report";
      const std::string& name = start.parameters()[static_cast<std::size_t>(k)].name;
      for (const std::string& w : run.result.held_why)
        if (w.starts_with(name + ":")) why = "the instrument frame's placement explains it";
      t.held.emplace_back(k, why);
    }
    out_text = cal::replace_toml_table(out_text, "errors", cal::errors_table_toml(t));
    if (!run.result.identified.empty()) {
      std::vector<kin::JointVector> fitted;
      for (const cal::Measurement& m : original)
        if (!m.validate) fitted.push_back(m.q);
      out_text = cal::replace_toml_table(
          out_text, "uncertainty",
          cal::uncertainty_table_toml(start, run.result.identified, run.result.covariance, fitted));
    }
    for (const cal::FrameEstimate& f : run.result.frames) {
      const Eigen::Vector3d w = f.rotation() / kin::kDeg * 3600;
      header.push_back(fmt::format("  instrument frame {}: translation ({:.4f}, {:.4f}, {:.4f}) um, rotation ({:.3f}, "
                                   "{:.3f}, {:.3f}) arcsec (estimated with the machine's parameters)",
                                   f.name, f.t.x() * 1000, f.t.y() * 1000, f.t.z() * 1000, w.x(), w.y(), w.z()));
    }
    header.push_back(fmt::format("  method {}, {} of {} parameters identified, residual sigma {:.4f} mm, fitted max error "
                                 "{:.4f} -> {:.4f} mm",
                                 cal::to_string(opt.method), run.result.identified.size(), run.result.start.parameters,
                                 run.result.sigma, c.fit.max_position_before_mm, c.fit.max_position_after_mm));
  }
  if (data.empty()) {
    // Step-gauge data only: the report names the inputs and the map figures; no parameter moves.
    run.start = run.solved = machine->actual.get();
    run.result.values = start.values();
    run.result.stddev.assign(start.values().size(), std::numeric_limits<double>::quiet_NaN());
    run.result.usable = true;
    run.result.message = "no kinematic measurements: only the volumetric map was built";
  }
  if (!map_section.empty()) {
    out_text = cal::replace_toml_table(out_text, "volumetric_map", map_section);
    header.push_back("  [volumetric_map] from the step-gauge data");
  }
  out_text = cal::add_header_comment(out_text, header);

  // The result must be a machine file every command takes as it is.
  gcode::DiagnosticSink check;
  if (!machine::parse_machine(a.output, out_text, check)) {
    std::string why;
    for (const auto& d : check.stored()) why += "\n  " + gcode::format(d, false);
    throw Error(ExitCode::internal, "the calibrated machine file does not read back:" + why);
  }
  io::OutputFile out(a.output, a.machine, a.in_place);
  out.write(out_text);
  OutputSet outputs;
  for (const std::string& rp : a.reports) {
    const bool html = rp.ends_with(".html") || rp.ends_with(".htm");
    outputs.add(rp, html ? cal::report_html(run) : cal::report_json(run));
  }
  for (const std::string& rp : a.json_reports) outputs.add(rp, cal::report_json(run));
  for (const std::string& rp : a.html_reports) outputs.add(rp, cal::report_html(run));
  outputs.commit(&out);  // the machine file and its reports together, or none of them
  note_backup_kept(out);
  printer.finish();
  std::fputs(fmt::format("postproc: wrote {}\n", a.output).c_str(), stderr);
  rc = 0;
}

}  // namespace

void setup_calibrate(CLI::App& app, int& rc) {
  auto a = std::make_shared<CalibrateArgs>();
  auto* cmd = app.add_subcommand("calibrate", "identify a machine's error parameters from measurements and write the "
                                              "calibrated machine file (docs/measurements.md)");
  cmd->add_option("data", a->data, "measurement files (CSV with '# kind: …')");
  cmd->add_option("-m,--machine", a->machine, "the machine file to calibrate (its errors are the start values)");
  cmd->add_option("-o,--output", a->output, "the calibrated machine file to write");
  cmd->add_option("--validate", a->validate, "held-out measurement files: not fitted, only checked before/after");
  cmd->add_option("--report", a->reports, "write a report: R.json, or R.html (self-contained, residual plots)");
  cmd->add_option("--json", a->json_reports, "write the JSON report here (as --report R.json)");
  cmd->add_option("--html", a->html_reports, "write the HTML report here (as --report R.html)");
  cmd->add_option("--method", a->method, "least-squares (default), ridge, psi-substitution")->capture_default_str();
  cmd->add_option("--lambda", a->lambda, "ridge weight λ (mm² per unit² of parameter); 0 = chosen by GCV")->capture_default_str();
  cmd->add_option("--free", a->free, "identify only these parameters (names, * and ? patterns, comma separated)")->delimiter(',');
  cmd->add_option("--fix", a->fix, "hold these parameters at their values in the machine file")->delimiter(',');
  cmd->add_option("--bound", a->bounds, "NAME=LOW:HIGH with units, e.g. EX0C=-50um:50um (deviation from nominal)");
  cmd->add_option("--loss", a->loss, "robust loss per measurement: none, huber, cauchy")
      ->check(CLI::IsMember({"none", "huber", "cauchy"}))
      ->capture_default_str();
  cmd->add_option("--loss-scale", a->loss_scale_um, "robust loss scale, µm (mm-equivalent)")->capture_default_str();
  cmd->add_option("--max-iterations", a->max_iterations, "solver iteration limit")->capture_default_str();
  cmd->add_option("--solver", a->solver,
                  "auto (default: streamed from 60,000 residual components), ceres, or streamed (memory "
                  "independent of the number of rows; not with --bound or psi-substitution)")
      ->check(CLI::IsMember({"auto", "ceres", "streamed"}))
      ->capture_default_str();
  cmd->add_option("--angle-weight", a->angle_weight, "mm-equivalent per rad of orientation residual (default 0.01° ≙ 0.01 mm)")
      ->capture_default_str();
  cmd->add_flag("--numeric-derivatives", a->numeric, "central differences for every parameter (checks the analytic ones)");
  cmd->add_option("--map-interpolation", a->map_interpolation,
                  "step-gauge map: trilinear or smooth (default: as the machine file's map, else trilinear)")
      ->check(CLI::IsMember({"trilinear", "smooth"}));
  cmd->add_option("--map-outside", a->map_outside,
                  "step-gauge map outside its grid: refuse, clamp or zero (default: as the machine file's map, else refuse)")
      ->check(CLI::IsMember({"refuse", "clamp", "zero"}));
  cmd->add_flag("--in-place", a->in_place, "allow -o to name the machine file (a .bak backup is kept)");
  cmd->add_option("-j,--jobs", a->jobs,
                  "threads for the solver's evaluations of serial machines (default: the cores this process may use)");
  cmd->add_option("--max-per-code", a->max_per_code, "show at most this many diagnostics per code")->capture_default_str();
  setup_calibrate_plan(*cmd, rc);
  setup_calibrate_simulate(*cmd, rc);
  cmd->require_subcommand(0, 1);
  cmd->callback([a, cmd, &rc] {
    if (!cmd->get_subcommands().empty()) return;
    if (a->machine.empty() || a->output.empty())
      throw Error(ExitCode::usage, "calibrate needs -m MACHINE.toml and -o CALIBRATED.toml (or the plan / simulate subcommand)");
    run_calibrate(*a, rc);
  });
}

}  // namespace postproc::cli
