// Calibration reports, JSON and self-contained HTML (see report.hpp).
#include "postproc/calibration/report.hpp"
#include "src/io/html.hpp"
#include "src/io/html_plot.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace postproc::cal {
namespace {

using nlohmann::json;

/// NaN (the kind has no such error) counts as 0; infinity (the model cannot evaluate) stays.
double finite_or(double v, double alt) { return std::isnan(v) ? alt : v; }

json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

void accumulate(SetFigures& f, const MeasurementError& b, const MeasurementError& a, double& sum_b, double& sum_a) {
  ++f.count;
  if (!std::isnan(b.angle_deg)) ++f.angles;
  if (!std::isnan(b.position_mm)) {
    ++f.positions;
    f.max_position_before_mm = std::max(f.max_position_before_mm, finite_or(b.position_mm, 0));
    f.max_position_after_mm = std::max(f.max_position_after_mm, finite_or(a.position_mm, 0));
    sum_b += finite_or(b.position_mm, 0) * finite_or(b.position_mm, 0);
    sum_a += finite_or(a.position_mm, 0) * finite_or(a.position_mm, 0);
  }
  f.max_angle_before_deg = std::max(f.max_angle_before_deg, finite_or(b.angle_deg, 0));
  f.max_angle_after_deg = std::max(f.max_angle_after_deg, finite_or(a.angle_deg, 0));
}

json figures(const SetFigures& f) {
  return {{"measurements", f.count},
          {"with_position", f.positions},
          {"with_angle", f.angles},
          {"max_position_before_mm", f.max_position_before_mm},
          {"max_position_after_mm", f.max_position_after_mm},
          {"rms_position_before_mm", f.rms_position_before_mm},
          {"rms_position_after_mm", f.rms_position_after_mm},
          {"max_angle_before_deg", f.max_angle_before_deg},
          {"max_angle_after_deg", f.max_angle_after_deg}};
}

json identifiability(const Identifiability& a) {
  json sv = json::array();
  for (Eigen::Index i = 0; i < a.singular_values.size(); ++i) sv.push_back(a.singular_values[i]);
  return {{"rows", a.rows},       {"parameters", a.parameters}, {"rank", a.rank},
          {"condition", a.condition}, {"O1", a.o1},             {"O3", a.o3},
          {"O4", a.o4},            {"singular_values_scaled", sv}, {"unidentifiable_combinations", a.combinations},
          {"weakest_combination", a.weakest}};
}

/// An estimated parameter counts as identified when its ±1σ is small against its value (the
/// estimate lies at least 2σ from the drawing) or small in itself (≤ 1 µm, 1 arcsec or 1 µm/m: a
/// parameter that really is at its nominal value is then known to be there); otherwise it is
/// "poorly determined" — estimated, used, but the data do not pin it down.
bool well_determined(const kin::Parameter& p, double change_from_nominal, double sigma) {
  if (!std::isfinite(sigma)) return false;
  const double floor = p.unit == "rad" ? 1.0 / 3600.0 * kin::kPi / 180.0 : p.unit == "ratio" ? 1e-6 : 1e-3;
  return sigma <= floor || std::abs(change_from_nominal) >= 2 * sigma;
}

std::string status_of_parameter(const CalibrationRun& run, int k) {
  const auto& r = run.result;
  if (std::find(r.identified.begin(), r.identified.end(), k) != r.identified.end()) {
    const auto i = static_cast<std::size_t>(k);
    const kin::Parameter& p = run.start->parameters()[i];
    const double sigma = i < r.stddev.size() ? r.stddev[i] : std::numeric_limits<double>::quiet_NaN();
    return well_determined(p, r.values[i] - (p.error ? p.nominal : 0), sigma) ? "identified" : "poorly determined";
  }
  if (std::find(r.held.begin(), r.held.end(), k) != r.held.end()) return "unidentifiable";
  return "fixed";
}

using io::html_escape;

/// The volumetric map from the step gauge: the error vector of every pyramid on the grid (three
/// projections coloured by |E|), |E| and its components along each gauge, how well each value is
/// determined (the noise gain 1/σmin(T): a reading error of 1 µm moves E by at most that many µm;
/// the plate tilt's edge-fit residual), and the largest errors.
std::string step_gauge_html(const StepGaugeReport& g) {
  std::string s = "<h2>Volumetric map from the step gauge</h2>\n";
  double gain = 0;
  std::size_t worst = 0;
  for (std::size_t i = 0; i < g.points.size(); ++i) {
    gain = std::max(gain, g.points[i].noise_gain);
    if (g.points[i].error.norm() > g.points[worst].error.norm()) worst = i;
  }
  s += fmt::format(
      "<p id=\"step-gauge-summary\">{} pyramids on {} gauges; largest |E| {:.3f} µm{}. How well the map is "
      "determined: each pyramid's error solves its readings through the gauge's geometry, and a reading error of "
      "1 µm moves E by at most the noise gain (largest {:.3f}); the plate tilt comes from the edge readings (fit "
      "residual below).</p>\n",
      g.points.size(), g.tilts.size(), g.max_error * 1000,
      g.points.empty() ? std::string()
                       : fmt::format(" (gauge {}, pyramid {})", html_escape(g.points[worst].gauge),
                                     html_escape(g.points[worst].pyramid)),
      gain);
  s += "<table id=\"step-gauge-tilts\"><tr><th class=l>gauge</th><th>pyramids</th><th>max |E| (µm)</th>"
       "<th>max noise gain</th><th>tilt θx (arcsec)</th><th>tilt θy (arcsec)</th><th>edge-fit rms x / y (µm)</th></tr>\n";
  for (const StepGaugeReport::Tilt& t : g.tilts) {
    std::size_t n = 0;
    double emax = 0, gmax = 0;
    for (const StepGaugeReport::Point& p : g.points)
      if (p.gauge == t.gauge) {
        ++n;
        emax = std::max(emax, p.error.norm());
        gmax = std::max(gmax, p.noise_gain);
      }
    constexpr double arcsec = 180.0 / kin::kPi * 3600.0;
    s += fmt::format("<tr><td class=l>{}</td><td>{}</td><td>{:.3f}</td><td>{:.3f}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                     html_escape(t.gauge), n, emax * 1000, gmax,
                     t.measured ? fmt::format("{:.2f}", t.theta.x() * arcsec) : std::string("not measured"),
                     t.measured ? fmt::format("{:.2f}", t.theta.y() * arcsec) : std::string("not measured"),
                     t.measured ? fmt::format("{:.3f} / {:.3f}", t.rms.x() * 1000, t.rms.y() * 1000) : std::string("–"));
  }
  s += "</table>\n";
  // The grid coloured by |E|: every pyramid a dot.
  io::PlotPath map;
  for (std::size_t i = 0; i < g.points.size(); ++i) {
    map.points.push_back(g.points[i].position);
    map.values.push_back(g.points[i].error.norm() * 1000);
    map.runs.emplace_back(i, i + 1);
  }
  s += "<h3>|E| on the grid (machine frame, mm)</h3>\n<div class=views>";
  for (const auto& [u, v] : {std::pair{0, 1}, std::pair{0, 2}, std::pair{1, 2}})
    s += io::projection(map, u, v, g.max_error * 1000, 4000);
  s += "</div>\n" + io::colour_bar(g.max_error * 1000, "|E| (µm)") + "\n";
  // Per gauge: the components of E and the noise gain (× 1 µm), pyramid by pyramid.
  for (const StepGaugeReport::Tilt& t : g.tilts) {
    std::vector<io::Series> plot{{"Ex", "#d7191c", {}}, {"Ey", "#1a9641", {}}, {"Ez", "#2c7bb6", {}},
                                 {"noise gain × 1 µm", "#999999", {}}};
    double along = 0;  // the pyramid's number on its gauge (the file's order)
    for (const StepGaugeReport::Point& p : g.points) {
      if (p.gauge != t.gauge) continue;
      along += 1;
      plot[0].xy.emplace_back(along, p.error.x() * 1000);
      plot[1].xy.emplace_back(along, p.error.y() * 1000);
      plot[2].xy.emplace_back(along, p.error.z() * 1000);
      plot[3].xy.emplace_back(along, p.noise_gain);
    }
    s += fmt::format("<h3>Gauge {}</h3>\n", html_escape(t.gauge));
    s += io::line_plot(plot, "pyramid (in the gauge file's order)", "error (µm)",
                       "step-gauge-" + t.gauge) +
         "\n";
  }
  return s;
}

/// Value in the unit people read: µm for mm parameters, arcsec for rad ones.
std::string human(const kin::Parameter& p, double v) {
  if (!std::isfinite(v)) return "–";
  if (p.unit == "ratio") return fmt::format("{:.3f} µm/m", v * 1e6);
  return p.unit == "rad" ? fmt::format("{:.3f} arcsec", v * 180.0 / kin::kPi * 3600.0) : fmt::format("{:.3f} µm", v * 1000.0);
}

/// Log-scale scatter of the per-measurement error before (grey) and after (blue: fitted,
/// orange: held out), inline SVG.
std::string residual_plot(const CalibrationRun& run, const Comparison& c, bool angle) {
  const std::size_t n = run.data.size();
  auto value = [&](const MeasurementError& e) { return angle ? e.angle_deg : e.position_mm; };
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  for (std::size_t i = 0; i < n; ++i)
    for (double v : {value(c.before[i]), value(c.after[i])})
      if (std::isfinite(v) && v > 0) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
  if (!(hi > 0)) return {};
  const double d0 = std::floor(std::log10(lo)), d1 = std::max(d0 + 1, std::ceil(std::log10(hi)));
  const double w = 760, h = 260, left = 70, right = 10, top = 10, bottom = 40;
  auto x = [&](std::size_t i) { return left + (w - left - right) * (static_cast<double>(i) + 0.5) / static_cast<double>(n); };
  auto y = [&](double v) { return top + (h - top - bottom) * (d1 - std::log10(v)) / (d1 - d0); };
  std::string s = fmt::format(R"(<svg class="plot" xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" viewBox="0 0 {} {}">)",
                              w, h, w, h);
  for (double d = d0; d <= d1; d += 1) {
    s += fmt::format(R"(<line x1="{}" x2="{}" y1="{:.1f}" y2="{:.1f}" stroke="#ddd"/>)", left, w - right, y(std::pow(10, d)),
                     y(std::pow(10, d)));
    s += fmt::format(R"(<text x="{}" y="{:.1f}" font-size="11" text-anchor="end">{:g} {}</text>)", left - 4,
                     y(std::pow(10, d)) + 4, std::pow(10, d), angle ? "°" : "mm");
  }
  for (std::size_t i = 0; i < n; ++i) {
    const double b = value(c.before[i]), a = value(c.after[i]);
    const std::string label = html_escape(run.data[i].label);
    if (std::isfinite(b) && b > 0)
      s += fmt::format(R"(<circle cx="{:.1f}" cy="{:.1f}" r="3" fill="#999"><title>{} before: {:.5g}</title></circle>)", x(i),
                       y(b), label, b);
    if (std::isfinite(a) && a > 0)
      s += fmt::format(R"(<circle cx="{:.1f}" cy="{:.1f}" r="3" fill="{}"><title>{} after: {:.5g}</title></circle>)", x(i),
                       y(a), run.data[i].validate ? "#e67e22" : "#1f6fb4", label, a);
  }
  s += fmt::format(R"(<text x="{}" y="{}" font-size="12">measurement (grey: before, blue: after on fitted data, orange: after on held-out data)</text>)",
                   left, h - 10);
  s += "</svg>";
  return s;
}

}  // namespace

Comparison compare(const CalibrationRun& run) {
  Comparison c;
  double fb = 0, fa = 0, vb = 0, va = 0;
  for (const Measurement& m : run.data) {
    c.before.push_back(measurement_error(*run.start, m));
    c.after.push_back(measurement_error(*run.solved, m));
    if (m.validate) accumulate(c.validation, c.before.back(), c.after.back(), vb, va);
    else accumulate(c.fit, c.before.back(), c.after.back(), fb, fa);
  }
  if (c.fit.positions > 0) {
    c.fit.rms_position_before_mm = std::sqrt(fb / static_cast<double>(c.fit.positions));
    c.fit.rms_position_after_mm = std::sqrt(fa / static_cast<double>(c.fit.positions));
  }
  if (c.validation.positions > 0) {
    c.validation.rms_position_before_mm = std::sqrt(vb / static_cast<double>(c.validation.positions));
    c.validation.rms_position_after_mm = std::sqrt(va / static_cast<double>(c.validation.positions));
  }
  return c;
}

std::string report_json(const CalibrationRun& run) {
  const Comparison c = compare(run);
  const IdentifyResult& r = run.result;
  json j;
  j["tool"] = {{"name", "postproc"}, {"version", run.tool_version}};
  j["machine"] = {{"file", run.machine_file}, {"sha256", run.machine_sha256}, {"name", run.machine_name}};
  j["output"] = run.output_file;
  json inputs = json::array();
  for (const InputFile& f : run.inputs)
    inputs.push_back({{"file", f.path}, {"sha256", f.sha256}, {"kind", f.kind}, {"measurements", f.measurements}});
  j["inputs"] = inputs;
  j["method"] = std::string(to_string(run.options.method));
  j["ridge_lambda"] = r.lambda;
  j["orientation_weight_mm_per_rad"] = run.options.orientation_weight;
  j["solver"] = {{"name", std::string(to_string(r.solver))},
                 {"iterations", r.iterations},
                 {"seconds", r.seconds},
                 {"usable", r.usable},
                 {"message", r.message},
                 {"initial_cost_mm2", r.initial_cost},
                 {"final_cost_mm2", r.final_cost},
                 {"residual_sigma_mm", number(r.sigma)}};
  j["solver"]["converged"] = r.converged;
  j["sigma_reference_mm"] = r.sigma_reference_mm;
  json frames = json::array();
  for (const FrameEstimate& f : r.frames) {
    json free = json::array(), held = json::array(), sd = json::object();
    for (int k = 0; k < 6; ++k) {
      const std::string name(registration_name(k));
      if ((f.free & (1u << k)) != 0) free.push_back(name);
      if ((f.held & (1u << k)) != 0) held.push_back(name);
      sd[name + (k < 3 ? "_mm" : "_rad")] = number(f.stddev[static_cast<std::size_t>(k)]);
    }
    const Eigen::Vector3d w = f.rotation();
    const Eigen::AngleAxisd start(f.start_r);
    const Eigen::Vector3d w0 = start.angle() * start.axis();
    frames.push_back({{"name", f.name},
                      {"measurements", f.measurements},
                      {"free", free},
                      {"held", held},
                      {"held_why", f.held_why},
                      {"translation_mm", {f.t.x(), f.t.y(), f.t.z()}},
                      {"rotation_vector_rad", {w.x(), w.y(), w.z()}},
                      {"stddev", sd},
                      {"start_translation_mm", {f.start_t.x(), f.start_t.y(), f.start_t.z()}},
                      {"start_rotation_vector_rad", {w0.x(), w0.y(), w0.z()}}});
  }
  j["frames"] = frames;
  j["held_by_registration"] = r.held_why;
  json files = json::array();
  for (const FileFit& f : r.files)
    files.push_back({{"file", f.file},
                     {"rows", f.rows},
                     {"sigma_mm", f.sigma_mm},
                     {"sigma_angle_rad", f.sigma_rad},
                     {"declared", f.declared},
                     {"has_length_rows", f.lengths},
                     {"has_angle_rows", f.angles},
                     {"chi2", f.chi2},
                     {"normalised_rms", f.normalised_rms}});
  j["files"] = files;
  j["identifiability"] = {{"start", identifiability(r.start)}, {"solution", identifiability(r.solution)}};
  json params = json::array();
  for (std::size_t k = 0; k < run.start->parameters().size(); ++k) {
    const kin::Parameter& p = run.start->parameters()[k];
    const std::string st = parameter_status(run, static_cast<int>(k));
    if (!p.error && st == "fixed") continue;
    params.push_back({{"name", p.name},
                      {"unit", p.unit},
                      {"status", st},
                      {"start", run.start->values()[k]},
                      // An unidentifiable parameter has no estimate: it keeps its start value.
                      {"value", st == "unidentifiable" ? json(nullptr) : json(r.values[k])},
                      {"change", st == "unidentifiable" ? json(nullptr) : json(r.values[k] - run.start->values()[k])},
                      {"stddev", number(r.stddev[k])}});
  }
  j["parameters"] = params;
  if (run.step_gauge != nullptr) {
    const StepGaugeReport& g = *run.step_gauge;
    json pts = json::array(), tilts = json::array();
    double gain = 0;
    for (const StepGaugeReport::Point& p : g.points) {
      gain = std::max(gain, p.noise_gain);
      pts.push_back({{"gauge", p.gauge},
                     {"pyramid", p.pyramid},
                     {"position_mm", {p.position.x(), p.position.y(), p.position.z()}},
                     {"error_mm", {p.error.x(), p.error.y(), p.error.z()}},
                     {"noise_gain", p.noise_gain}});
    }
    for (const StepGaugeReport::Tilt& t : g.tilts)
      tilts.push_back({{"gauge", t.gauge},
                       {"measured", t.measured},
                       {"theta_x_rad", t.theta.x()},
                       {"theta_y_rad", t.theta.y()},
                       {"edge_rms_mm", {t.rms.x(), t.rms.y()}}});
    j["step_gauge"] = {{"pyramids", g.points.size()},
                       {"max_error_mm", g.max_error},
                       {"max_noise_gain", gain},
                       {"points", pts},
                       {"tilts", tilts}};
  }
  j["figures"] = {{"fit", figures(c.fit)}, {"validation", figures(c.validation)}};
  json rows = json::array();
  for (std::size_t i = 0; i < run.data.size(); ++i) {
    const Measurement& m = run.data[i];
    rows.push_back({{"label", m.label},
                    {"file", m.file},
                    {"line", m.line},
                    {"kind", std::string(to_string(m.kind))},
                    {"set", m.validate ? "validate" : "fit"},
                    {"position_before_mm", number(c.before[i].position_mm)},
                    {"position_after_mm", number(c.after[i].position_mm)},
                    {"angle_before_deg", number(c.before[i].angle_deg)},
                    {"angle_after_deg", number(c.after[i].angle_deg)}});
  }
  j["measurements"] = rows;
  j["notes"] = run.notes;
  return j.dump(2) + "\n";
}

std::string report_html(const CalibrationRun& run) {
  const Comparison c = compare(run);
  const IdentifyResult& r = run.result;
  std::string s = R"(<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>postproc calibration report</title>
<style>
body{font-family:sans-serif;margin:1.5em;color:#222}table{border-collapse:collapse;margin:0.5em 0 1.5em}
td,th{border:1px solid #ccc;padding:2px 8px;text-align:right;font-size:13px}th{background:#f3f3f3}
td.l,th.l{text-align:left}.held{color:#b00}.weak{color:#a60}.plot{border:1px solid #ccc}
</style></head><body>
)";
  s += fmt::format("<h1>Calibration of {}</h1>\n", html_escape(run.machine_name));
  s += fmt::format("<p id=\"summary\">Machine file <code>{}</code> (SHA-256 {}), written to <code>{}</code> by postproc {}. Method "
                   "<b>{}</b>{}; {} {} iterations, {:.3f} s; {}.</p>\n",
                   html_escape(run.machine_file), run.machine_sha256, html_escape(run.output_file), run.tool_version,
                   to_string(run.options.method), r.lambda > 0 ? fmt::format(" (λ = {:.3g})", r.lambda) : "",
                   r.iterations, r.solver == Solver::streamed ? "streamed LM" : "Ceres", r.seconds,
                   html_escape(r.message));
  s += "<h2>Data</h2><table id=\"inputs\"><tr><th class=l>file</th><th class=l>kind</th><th>measurements</th><th class=l>SHA-256</th></tr>\n";
  for (const InputFile& f : run.inputs)
    s += fmt::format("<tr><td class=l>{}</td><td class=l>{}</td><td>{}</td><td class=l>{}</td></tr>\n", html_escape(f.path),
                     f.kind, f.measurements, f.sha256);
  s += "</table>\n";
  if (std::any_of(r.files.begin(), r.files.end(), [](const FileFit& f) { return f.declared; })) {
    s += "<h3>Fit per file</h3><p>Residuals weighted by each file's uncertainty: a normalised rms near 1 means the file "
         "fits as well as its σ says; far above 1, the σ is too small, the file holds outliers or the model misses an "
         "error.</p><table id=\"files\"><tr><th class=l>file</th><th>σ (µm)</th><th>σ angle (arcsec)</th><th "
         "class=l>σ from</th><th>rows</th><th>χ²</th><th>normalised rms</th></tr>\n";
    for (const FileFit& f : r.files)
      s += fmt::format("<tr><td class=l>{}</td><td>{:g}</td><td>{:.3g}</td><td class=l>{}</td><td>{}</td><td>{:.4g}</td><td>{:.3f}</td></tr>\n",
                       html_escape(f.file), f.sigma_mm * 1000, f.sigma_rad / kin::kDeg * 3600,
                       f.declared ? "declared" : "default", f.rows, f.chi2, f.normalised_rms);
    s += "</table>\n";
  }
  if (!r.frames.empty()) {
    s += "<h3>Instrument frames</h3><p>Estimated with the machine's parameters: P<sub>workpiece</sub> = R·P<sub>instrument</sub> "
         "+ t. The figures below use the measurements mapped into the workpiece frame.</p><table id=\"frames\"><tr><th "
         "class=l>frame</th><th>n</th><th>tx (µm)</th><th>ty (µm)</th><th>tz (µm)</th><th>rx (arcsec)</th><th>ry "
         "(arcsec)</th><th>rz (arcsec)</th><th class=l>held</th></tr>\n";
    for (const FrameEstimate& f : r.frames) {
      const Eigen::Vector3d w = f.rotation() / kin::kDeg * 3600;
      auto v = [&](int k, double value, double scale) {
        const double sd = f.stddev[static_cast<std::size_t>(k)];
        return std::isfinite(sd) ? fmt::format("{:.3f} ± {:.2g}", value, sd * scale) : fmt::format("{:.3f}", value);
      };
      std::string held;
      for (const std::string& why : f.held_why) held += (held.empty() ? "" : "; ") + why;
      s += fmt::format("<tr><td class=l>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=l>{}</td></tr>\n",
                       html_escape(f.name), f.measurements, v(0, f.t.x() * 1000, 1000), v(1, f.t.y() * 1000, 1000),
                       v(2, f.t.z() * 1000, 1000), v(3, w.x(), 3600 / kin::kDeg), v(4, w.y(), 3600 / kin::kDeg),
                       v(5, w.z(), 3600 / kin::kDeg), held.empty() ? "–" : html_escape(held));
    }
    s += "</table>\n";
  }
  s += "<h2>Residuals</h2><table id=\"figures\"><tr><th class=l>set</th><th>n</th><th>max position before (mm)</th><th>max after (mm)</th><th>rms before (mm)</th><th>rms after (mm)</th><th>max angle before (°)</th><th>max after (°)</th></tr>\n";
  auto fig = [](std::size_t n, double v) { return n > 0 ? fmt::format("{:.5f}", v) : std::string("–"); };
  for (const auto& [name, f] : {std::pair<const char*, const SetFigures&>{"fitted", c.fit}, {"held out", c.validation}})
    if (f.count > 0)
      s += fmt::format("<tr><td class=l>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                       name, f.count, fig(f.positions, f.max_position_before_mm), fig(f.positions, f.max_position_after_mm),
                       fig(f.positions, f.rms_position_before_mm), fig(f.positions, f.rms_position_after_mm),
                       fig(f.angles, f.max_angle_before_deg), fig(f.angles, f.max_angle_after_deg));
  s += "</table>\n<h3>Tool-tip (or strut) error per measurement</h3>\n" + residual_plot(run, c, false) + "\n";
  const std::string angle_plot = residual_plot(run, c, true);
  if (!angle_plot.empty()) s += "<h3>Tool-axis error per measurement</h3>\n" + angle_plot + "\n";
  const Identifiability& a = r.start;
  s += fmt::format("<h2>Identifiability</h2><p id=\"identifiability\">{} parameters requested, rank {} of the column-scaled "
                   "identification Jacobian ({} rows); condition number {:.4g}; O1 {:.4g}, O3 {:.4g}, O4 {:.4g}.</p>\n",
                   a.parameters, a.rank, a.rows, a.condition, a.o1, a.o3, a.o4);
  if (!a.combinations.empty()) {
    s += "<p class=held>Not identifiable from these measurements (a change along each combination changes no "
         "measurement); one parameter of each is held at its start value:</p><ul>\n";
    for (const std::string& comb : a.combinations) s += "<li>" + html_escape(comb) + "</li>\n";
    s += "</ul>\n";
  }
  s += "<h2>Parameters</h2><table id=\"parameters\"><tr><th class=l>name</th><th class=l>status</th><th>start</th><th>identified</th><th>±1σ</th></tr>\n";
  for (std::size_t k = 0; k < run.start->parameters().size(); ++k) {
    const kin::Parameter& p = run.start->parameters()[k];
    const std::string st = parameter_status(run, static_cast<int>(k));
    if (!p.error && st == "fixed") continue;
    const double start = run.start->values()[k] - (p.error ? p.nominal : 0);
    const double value = r.values[k] - (p.error ? p.nominal : 0);
    s += fmt::format("<tr><td class=l>{}</td><td class=\"l{}\">{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                     html_escape(p.name), st == "unidentifiable" ? " held" : st == "poorly determined" ? " weak" : "", st,
                     human(p, start), st != "unidentifiable" && st != "fixed" ? human(p, value) : "–",
                     human(p, r.stddev[k]));
  }
  s += "</table>\n";
  if (run.step_gauge != nullptr) s += step_gauge_html(*run.step_gauge);
  s += "<h2>Measurements</h2><table id=\"measurements\"><tr><th class=l>label</th><th class=l>source</th><th class=l>kind</th><th class=l>set</th><th>position before (mm)</th><th>after (mm)</th><th>angle before (°)</th><th>after (°)</th></tr>\n";
  auto cell = [](double v) { return std::isfinite(v) ? fmt::format("{:.5f}", v) : std::string("–"); };
  for (std::size_t i = 0; i < run.data.size(); ++i) {
    const Measurement& m = run.data[i];
    s += fmt::format("<tr><td class=l>{}</td><td class=l>{}:{}</td><td class=l>{}</td><td class=l>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                     html_escape(m.label), html_escape(m.file), m.line, to_string(m.kind), m.validate ? "validate" : "fit",
                     cell(c.before[i].position_mm), cell(c.after[i].position_mm), cell(c.before[i].angle_deg),
                     cell(c.after[i].angle_deg));
  }
  s += "</table>\n";
  for (const std::string& note : run.notes) s += "<p class=note>" + html_escape(note) + "</p>\n";
  s += "</body></html>\n";
  return s;
}

std::string parameter_status(const CalibrationRun& run, int k) { return status_of_parameter(run, k); }

}  // namespace postproc::cal
