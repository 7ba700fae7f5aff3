// The HTML report of `postproc diff` (see diff_report.hpp): summary, the tool-tip path in
// projections and in 3-D coloured by deviation, the deviation along the path, a histogram, the
// largest changes with their source lines and, optionally, the predicted servo contour errors.
#include "postproc/compensation/diff_report.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <fmt/format.h>

#include "postproc/error.hpp"
#include "src/io/html.hpp"
#include "src/io/html_plot.hpp"
#include "src/compensation/report_units.hpp"

namespace postproc::comp {
namespace {

using io::cell;
using io::html_escape;


/// The program's lines, 1-based (index 0 unused), without line ends.
std::vector<std::string_view> lines_of(std::string_view text) {
  std::vector<std::string_view> out{std::string_view()};
  while (!text.empty()) {
    const std::size_t end = text.find('\n');
    std::string_view line = text.substr(0, end);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    out.push_back(line);
    if (end == std::string_view::npos) break;
    text.remove_prefix(end + 1);
  }
  return out;
}

std::string source_cell(const std::vector<std::string_view>& lines, std::uint64_t line) {
  return line < lines.size() ? "<code>" + html_escape(lines[line]) + "</code>" : std::string("–");
}

/// The pairs with a known point, in stretches of consecutive known points; values in µm.
io::PlotPath plot_path(const DiffResult& d) {
  io::PlotPath p;
  std::size_t begin = 0;
  for (const BlockDiff& b : d.blocks) {
    if (!b.point_known) {
      if (p.points.size() > begin) p.runs.emplace_back(begin, p.points.size());
      begin = p.points.size();
      continue;
    }
    p.points.push_back(b.point_mm);
    p.values.push_back(b.deviation_mm * kUmPerMm);
  }
  if (p.points.size() > begin) p.runs.emplace_back(begin, p.points.size());
  return p;
}

std::string summary_table(const DiffReport& r) {
  const DiffResult& d = *r.result;
  const char* measure = d.with_machine ? "tool-tip distance" : "linear-axis change";
  std::string s = "<h2>Summary</h2>\n<table id=\"summary\">\n";
  auto row = [&](std::string_view name, std::string_view id, const std::string& value) {
    s += fmt::format("<tr><th class=l>{}</th><td id=\"{}\">{}</td></tr>\n", name, id, value);
  };
  row("deviation measured", "measure", measure);
  row("largest deviation (µm)", "max-um", cell(d.deviation.max * kUmPerMm));
  row("RMS deviation (µm)", "rms-um", cell(d.deviation.rms * kUmPerMm));
  row("95th percentile of the deviation (µm)", "p95-um", cell(d.deviation.p95 * kUmPerMm));
  if (d.with_machine) {
    row("largest tool-axis angle (arcsec)", "angle-max-arcsec", cell(d.angle.max * kArcsecPerRad, "{:.2f}"));
    row("RMS tool-axis angle (arcsec)", "angle-rms-arcsec", cell(d.angle.rms * kArcsecPerRad, "{:.2f}"));
    row("95th percentile of the tool-axis angle (arcsec)", "angle-p95-arcsec", cell(d.angle.p95 * kArcsecPerRad, "{:.2f}"));
  }
  row("pairs (count)", "pairs", std::to_string(d.blocks.size()));
  row("changed pairs (count)", "changed", std::to_string(d.changed));
  row("unmatched original motions (count)", "unmatched", std::to_string(d.unmatched));
  row("aligned", "aligned", d.by_block ? "by block" : "by path");
  row("motions in the original (count)", "motions-original", std::to_string(d.motions_original));
  row("motions in the corrected program (count)", "motions-corrected", std::to_string(d.motions_corrected));
  return s + "</table>\n";
}

/// Deviation (µm) and, with a machine, tool-axis angle (arcsec) along the path.
std::string along_path(const DiffResult& d) {
  const bool by_length =
      !d.blocks.empty() && std::all_of(d.blocks.begin(), d.blocks.end(), [](const BlockDiff& b) { return b.point_known; });
  io::Points2 dev, ang;
  double x = 0;
  for (std::size_t i = 0; i < d.blocks.size(); ++i) {
    const BlockDiff& b = d.blocks[i];
    if (by_length && i > 0) x += (b.point_mm - d.blocks[i - 1].point_mm).norm();
    const double at = by_length ? x : static_cast<double>(i);
    dev.emplace_back(at, b.deviation_mm * kUmPerMm);
    if (std::isfinite(b.axis_rad)) ang.emplace_back(at, b.axis_rad * kArcsecPerRad);
  }
  const char* xlabel = by_length ? "path length through the pairs' points (mm)" : "pair (index)";
  std::string s = "<h2>Deviation along the path</h2>\n";
  s += io::line_plot({{"deviation", "#1f6fb4", io::decimate_max(dev, kDiffPlotMaxPoints)}}, xlabel, "deviation (µm)",
                     "along-path") +
       "\n";
  if (d.with_machine)
    s += io::line_plot({{"tool-axis angle", "#7b3294", io::decimate_max(ang, kDiffPlotMaxPoints)}}, xlabel,
                       "tool-axis angle (arcsec)", "along-path-angle") +
         "\n";
  return s;
}

std::string worst_table(const DiffReport& r) {
  const DiffResult& d = *r.result;
  const auto original = lines_of(r.original_text), corrected = lines_of(r.corrected_text);
  std::string s = fmt::format(
      "<h2>Largest deviations</h2>\n<table id=\"worst\"><tr><th>rank</th><th>original line</th><th>corrected line</th>"
      "<th>deviation (µm)</th><th>largest rotary change (deg)</th>{}<th class=l>original source</th>"
      "<th class=l>corrected source</th></tr>\n",
      d.with_machine ? "<th>tool-axis angle (arcsec)</th>" : "");
  std::size_t rank = 0;
  for (std::size_t k : worst_blocks(d, r.worst)) {
    const BlockDiff& b = d.blocks[k];
    s += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>", ++rank, b.line_original,
                     b.line_corrected, cell(b.deviation_mm * kUmPerMm), cell(b.rotary_deg, "{:.5f}"));
    if (d.with_machine) s += fmt::format("<td>{}</td>", cell(b.axis_rad * kArcsecPerRad, "{:.2f}"));
    s += fmt::format("<td class=l>{}</td><td class=l>{}</td></tr>\n", source_cell(original, b.line_original),
                     source_cell(corrected, b.line_corrected));
  }
  return s + "</table>\n";
}

/// Predicted servo contour errors before and after the correction.
std::string contour_section(const DiffReport& r) {
  const contour::Path& path = *r.path;
  const contour::Prediction& before = *r.predicted_before;
  std::string s =
      "<section id=\"contour\"><h2>Predicted servo contour errors</h2>\n<p>The servo following errors of the original "
      "program and of the corrected program, both measured against the original's intended contour.</p>\n"
      "<table id=\"contour-summary\"><tr><th class=l>program</th><th>tip max (µm)</th><th>tip RMS (µm)</th>"
      "<th>tip p95 (µm)</th><th>axis max (arcsec)</th><th>axis RMS (arcsec)</th><th>axis p95 (arcsec)</th></tr>\n";
  const std::vector<std::pair<const char*, const contour::Prediction*>> rows{{"original", &before},
                                                                              {"corrected", r.predicted_after}};
  for (const auto& [name, p] : rows) {
    if (p == nullptr) continue;
    s += fmt::format("<tr><td class=l>{0}</td><td id=\"contour-{0}-tip-max-um\">{1}</td><td>{2}</td><td>{3}</td>"
                     "<td id=\"contour-{0}-axis-max-arcsec\">{4}</td><td>{5}</td><td>{6}</td></tr>\n",
                     name, cell(p->tip.max * kUmPerMm), cell(p->tip.rms * kUmPerMm), cell(p->tip.p95 * kUmPerMm),
                     cell(p->axis.max * kArcsecPerRad, "{:.2f}"), cell(p->axis.rms * kArcsecPerRad, "{:.2f}"),
                     cell(p->axis.p95 * kArcsecPerRad, "{:.2f}"));
  }
  s += "</table>\n";
  for (bool axis : {false, true}) {
    std::vector<io::Series> plot;
    for (const auto& [name, p] : rows) {
      if (p == nullptr) continue;
      io::Series se{name, p == &before ? "#1f6fb4" : "#e67e22", {}};
      for (std::size_t i = 0; i < std::min(p->points.size(), path.points.size()); ++i) {
        const double v = axis ? p->points[i].axis_rad * kArcsecPerRad : p->points[i].tip_mm * kUmPerMm;
        if (std::isfinite(v) && std::isfinite(path.points[i].t)) se.xy.emplace_back(path.points[i].t, v);
      }
      se.xy = io::decimate_max(se.xy, kDiffPlotMaxPoints);
      plot.push_back(std::move(se));
    }
    s += io::line_plot(plot, "time (s)", axis ? "tool-axis contour error (arcsec)" : "tool-tip contour error (µm)",
                       axis ? "contour-axis" : "contour-tip") +
         "\n";
  }
  return s + "</section>\n";
}

}  // namespace

std::string diff_report_html(const DiffReport& r) {
  if (r.result == nullptr) throw Error(ExitCode::internal, "diff report: the diff result is required");
  const DiffResult& d = *r.result;
  const std::string title = fmt::format("diff {} → {}", r.original_file, r.corrected_file);
  std::string s = io::page_head(title, ".note{color:#555;font-size:13px}code{white-space:pre}\n");
  s += fmt::format("<h1>{}</h1>\n<p>Original <code>{}</code>, corrected <code>{}</code>", html_escape(title),
                   html_escape(r.original_file), html_escape(r.corrected_file));
  if (!r.machine_file.empty())
    s += fmt::format("; machine file <code>{}</code> (SHA-256 {})", html_escape(r.machine_file),
                     html_escape(r.machine_sha256));
  if (!r.tool_version.empty()) s += fmt::format("; postproc {}", html_escape(r.tool_version));
  s += fmt::format(".</p>\n<p class=note>Deviation: {}</p>\n",
                   d.with_machine ? "the distance between the two intended tool tips in the workpiece frame, each "
                                    "command through the controller's nominal map (µm)."
                                  : "the length of the change of the linear axes X, Y, Z… (µm; no machine file, so "
                                    "the points are axis values).");
  s += summary_table(r);

  const io::PlotPath tips = plot_path(d);
  double max_um = 0;
  for (double v : tips.values) max_um = std::max(max_um, v);
  const char* bar = "deviation (µm)";
  s += fmt::format("<h2>Tool-tip path</h2>\n<p>{} (mm), coloured by the deviation; {} of {} pairs have a point.</p>\n"
                   "<div class=views>",
                   d.with_machine ? "The original's intended tool tip in the workpiece frame"
                                  : "The original's X, Y, Z axis values",
                   tips.points.size(), d.blocks.size());
  s += io::projection(tips, 0, 1, max_um, kDiffPlotMaxPoints, "projection-xy") +
       io::projection(tips, 0, 2, max_um, kDiffPlotMaxPoints, "projection-xz") +
       io::projection(tips, 1, 2, max_um, kDiffPlotMaxPoints, "projection-yz");
  s += "</div>\n" + io::colour_bar(max_um, bar) + "\n<h2>3-D view</h2>\n";
  s += io::view3d(tips, max_um, kDiffView3dMaxPoints, "view3d", "the same path in 3-D, coloured by the deviation (µm)");
  s += along_path(d);
  std::vector<double> dev;
  dev.reserve(d.blocks.size());
  for (const BlockDiff& b : d.blocks) dev.push_back(b.deviation_mm * kUmPerMm);
  s += "<h2>Histogram of the deviations</h2>\n" + io::histogram(dev, 40, bar, "histogram") + "\n";
  s += worst_table(r);
  if (r.path != nullptr && r.predicted_before != nullptr) s += contour_section(r);
  return s + io::page_tail();
}

}  // namespace postproc::comp
