// The HTML report of a geometric compensation (geometric_report.hpp): verify()'s end points, the
// original's error on the calibrated machine beside the corrected program's residual.
#include "postproc/compensation/geometric_report.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

#include "postproc/error.hpp"
#include "src/io/html.hpp"
#include "src/io/html_plot.hpp"
#include "src/compensation/report_units.hpp"

namespace postproc::comp {
namespace {

constexpr std::size_t kMaxPlotPoints = 4000;  ///< per plotted series and per projection
constexpr std::size_t kWorstRows = 15;

/// Largest value, RMS and 95th percentile of the finite values, and the index of the largest.
struct Figures {
  double max = 0, rms = 0, p95 = 0;
  std::size_t count = 0, worst = 0;
};
Figures figures_of(const std::vector<double>& v) {
  Figures f;
  std::vector<double> finite;
  finite.reserve(v.size());
  double sq = 0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i])) continue;
    if (finite.empty() || v[i] > f.max) {
      f.max = v[i];
      f.worst = i;
    }
    finite.push_back(v[i]);
    sq += v[i] * v[i];
  }
  f.count = finite.size();
  if (f.count == 0) return f;
  f.rms = std::sqrt(sq / static_cast<double>(f.count));
  const std::size_t k = std::min(f.count - 1, static_cast<std::size_t>(std::ceil(0.95 * static_cast<double>(f.count))) - 1);
  std::nth_element(finite.begin(), finite.begin() + static_cast<std::ptrdiff_t>(k), finite.end());
  f.p95 = finite[k];
  return f;
}

std::string percent_less(double before, double after) {
  if (!(before > 0) || !std::isfinite(after)) return "–";
  return fmt::format("{:.1f} %", 100.0 * (before - after) / before);
}

}  // namespace

std::string geometric_report_html(const GeometricReport& r) {
  const std::string title = r.title.empty() ? "postproc compensate report" : r.title;
  return io::page_head(title) + geometric_report_section(r) + io::page_tail();
}

std::string geometric_report_section(const GeometricReport& r) {
  if (r.verify == nullptr || r.points == nullptr)
    throw Error(ExitCode::internal, "geometric report: the verification and its points are required");
  const std::vector<VerifyPoint>& pts = *r.points;
  const std::size_t n = pts.size();
  std::vector<double> tip_b(n), tip_a(n), ax_b(n), ax_a(n), bound(n), along(n);
  double s = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (i > 0) s += (pts[i].intended - pts[i - 1].intended).norm();
    along[i] = s;
    tip_b[i] = pts[i].before_mm * kUmPerMm;
    tip_a[i] = pts[i].after_mm * kUmPerMm;
    ax_b[i] = pts[i].before_rad * kArcsecPerRad;
    ax_a[i] = pts[i].after_rad * kArcsecPerRad;
    bound[i] = pts[i].bound_mm * kUmPerMm;
  }
  const Figures ftb = figures_of(tip_b), fta = figures_of(tip_a), fab = figures_of(ax_b), faa = figures_of(ax_a);

  const std::string title = r.title.empty() ? "postproc compensate report" : r.title;
  const auto id = [&](std::string_view name) { return r.id_prefix + std::string(name); };
  std::string h = fmt::format("<h1 id=\"{}\">{}</h1>\n", id("title"), io::html_escape(title));
  h += fmt::format("<p id=\"{}\">Program <code>{}</code>", id("summary"), io::html_escape(r.program));
  if (!r.output.empty()) h += fmt::format(", written to <code>{}</code>", io::html_escape(r.output));
  if (!r.machine_file.empty()) h += fmt::format("; machine file <code>{}</code>", io::html_escape(r.machine_file));
  if (!r.machine_sha256.empty()) h += fmt::format(" (SHA-256 {})", io::html_escape(r.machine_sha256));
  if (!r.tool_version.empty()) h += fmt::format("; postproc {}", io::html_escape(r.tool_version));
  h += fmt::format(
      ". {} end points compared, {} skipped (unknown positions, rapids left as written, drilling cycles). Both "
      "programs are read back and run through the calibrated model of the machine; the error is the distance of the "
      "tool tip (and the angle of the tool axis) from where the nominal machine puts them for the original "
      "program.</p>\n",
      r.verify->compared, r.verify->skipped);

  h += "<h2>Error on the calibrated machine</h2><table id=\"" + id("figures") + "\"><tr><th class=l></th><th>tip max (µm)</th>"
       "<th>tip RMS (µm)</th><th>tip p95 (µm)</th><th>axis max (arcsec)</th><th>axis RMS (arcsec)</th>"
       "<th>axis p95 (arcsec)</th><th>line of the largest tip error</th></tr>\n";
  const auto row = [&](const char* name, const char* key, const Figures& t, const Figures& a) {
    h += fmt::format(
        "<tr><td class=l>{}</td><td id=\"{}{}-tip-max-um\">{}</td><td>{}</td><td>{}</td><td id=\"{}{}-axis-max-arcsec\">{}</td>"
        "<td>{}</td><td>{}</td><td>{}</td></tr>\n",
        name, r.id_prefix, key, io::cell(t.max), io::cell(t.rms), io::cell(t.p95), r.id_prefix, key, io::cell(a.max, "{:.2f}"),
        io::cell(a.rms, "{:.2f}"), io::cell(a.p95, "{:.2f}"), t.count > 0 ? std::to_string(pts[t.worst].line) : std::string("–"));
  };
  row("original program (before)", "before", ftb, fab);
  row("compensated program (after)", "after", fta, faa);
  h += "</table>\n";
  h += fmt::format(
      "<p id=\"{}\">Reduction of the largest error: tool tip {}, tool axis {}. The largest rounding bound of the "
      "written words (half a unit of the last written decimal of every axis, carried to the tool tip) is {} µm; the "
      "largest residual beyond it is {} µm (≤ 0: every point within its rounding).</p>\n",
      id("reduction"), percent_less(ftb.max, fta.max), percent_less(fab.max, faa.max), io::cell(r.verify->max_bound_mm * kUmPerMm),
      io::cell(r.verify->max_excess_mm * kUmPerMm));

  const auto series = [&](const std::vector<double>& v, const char* name, const char* colour) {
    io::Series se{name, colour, {}};
    se.xy.reserve(n);
    for (std::size_t i = 0; i < n; ++i)
      if (std::isfinite(v[i])) se.xy.emplace_back(along[i], v[i]);
    se.xy = io::decimate_max(se.xy, kMaxPlotPoints);
    return se;
  };
  const char* x = "path length of the intended tool tip (mm)";
  h += "<h2>Along the path</h2>\n<h3>Tool-tip error, before and after</h3>\n";
  h += io::line_plot({series(tip_b, "before (original program)", "#d7191c"),
                      series(tip_a, "after (compensated program)", "#1f6fb4")},
                     x, "tool-tip error (µm)", id("tip_along")) +
       "\n";
  h += "<h3>Tool-axis error, before and after</h3>\n";
  h += io::line_plot({series(ax_b, "before (original program)", "#d7191c"),
                      series(ax_a, "after (compensated program)", "#1f6fb4")},
                     x, "tool-axis error (arcsec)", id("axis_along")) +
       "\n";
  h += "<h3>Residual after compensation and the rounding bound of the written words</h3>\n";
  h += io::line_plot({series(tip_a, "tool-tip residual", "#1f6fb4"), series(bound, "rounding bound", "#999999")}, x,
                     "tool-tip residual (µm)", id("residual_along")) +
       "\n";

  h += "<h2>Distribution</h2>\n<div class=views>";
  h += io::histogram(tip_b, 30, "tool-tip error before (µm)", id("hist_before"));
  h += io::histogram(tip_a, 30, "tool-tip residual after (µm)", id("hist_after"));
  h += "</div>\n";

  io::PlotPath path;
  path.points.reserve(n);
  for (const VerifyPoint& p : pts) path.points.push_back(p.intended);
  if (n > 0) path.runs.emplace_back(0, n);
  for (const bool after : {false, true}) {
    path.values = after ? tip_a : tip_b;
    const double top = after ? fta.max : ftb.max;
    h += fmt::format("<h2>Tool-tip path coloured by the {}</h2>\n<div class=views>",
                     after ? "residual after compensation" : "error before compensation");
    for (const auto& [u, v] : {std::pair{0, 1}, std::pair{0, 2}, std::pair{1, 2}})
      h += io::projection(path, u, v, top, kMaxPlotPoints);
    h += "</div>\n" +
         io::colour_bar(top, after ? "tool-tip residual after (µm)" : "tool-tip error before (µm)") + "\n";
  }

  for (const bool after : {false, true}) {
    const std::vector<double>& key = after ? tip_a : tip_b;
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), std::size_t{0});
    const std::size_t k = std::min(kWorstRows, n);
    std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(k), order.end(),
                      [&](std::size_t a, std::size_t b) {
                        const double va = std::isfinite(key[a]) ? key[a] : -1, vb = std::isfinite(key[b]) ? key[b] : -1;
                        return va > vb;
                      });
    h += fmt::format("<h2>Largest tool-tip errors {}</h2><table id=\"{}{}\"><tr><th>line</th><th>X (mm)</th><th>Y (mm)</th>"
                     "<th>Z (mm)</th><th>tip before (µm)</th><th>tip after (µm)</th><th>axis before (arcsec)</th>"
                     "<th>axis after (arcsec)</th></tr>\n",
                     after ? "after compensation" : "before compensation", r.id_prefix,
                     after ? "worst_after" : "worst_before");
    for (std::size_t j = 0; j < k; ++j) {
      const std::size_t i = order[j];
      h += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                       pts[i].line, io::cell(pts[i].intended.x(), "{:.4f}"), io::cell(pts[i].intended.y(), "{:.4f}"),
                       io::cell(pts[i].intended.z(), "{:.4f}"), io::cell(tip_b[i]), io::cell(tip_a[i]),
                       io::cell(ax_b[i], "{:.2f}"), io::cell(ax_a[i], "{:.2f}"));
    }
    h += "</table>\n";
  }
  return h;
}

}  // namespace postproc::comp
