// Reports of the contour-error prediction, simulation and precompensation: CSV, JSON and a
// self-contained HTML page with inline SVG plots (see report.hpp).
#include "postproc/contour/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string_view>
#include <utility>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "postproc/error.hpp"
#include "src/io/html.hpp"
#include "src/io/html_plot.hpp"

namespace postproc::contour {
namespace {

using nlohmann::json;

constexpr double kUmPerMm = 1000.0;
constexpr double kArcsecPerRad = 180.0 / kin::kPi * 3600.0;
constexpr std::size_t kMaxPlotPoints = 4000;  ///< per plotted series (and path segments per projection)
constexpr std::size_t kOutsideRuns = std::numeric_limits<std::size_t>::max();

double um(double mm) { return mm * kUmPerMm; }
double arcsec(double rad) { return rad * kArcsecPerRad; }
json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

void check(const ContourReport& r) {
  if (r.path == nullptr || r.before == nullptr)
    throw Error(ExitCode::internal, "contour report: the path and the prediction are required");
}

struct JointInfo {
  std::string name;
  std::string unit;  ///< "mm" or "deg"
};

/// Joint names and units from the path's first controller context; "j1", "j2"… (unit mm) when
/// the path has no context.
std::vector<JointInfo> joints_of(const ContourReport& r) {
  const Path& p = *r.path;
  std::vector<JointInfo> out;
  if (!p.maps.empty()) {
    for (const kin::Joint& j : p.maps.front().actual().joints())
      out.push_back({j.name, j.type == kin::JointType::rotary ? "deg" : "mm"});
    return out;
  }
  std::size_t n = p.joints > 0 ? static_cast<std::size_t>(p.joints) : r.before->max_following.size();
  if (n == 0 && !r.before->points.empty()) n = static_cast<std::size_t>(r.before->points.front().following.size());
  for (std::size_t j = 0; j < n; ++j) out.push_back({fmt::format("j{}", j + 1), "mm"});
  return out;
}

/// Run index of every path point (kOutsideRuns outside every run).
std::vector<std::size_t> run_of_points(const Path& p) {
  std::vector<std::size_t> run(p.points.size(), kOutsideRuns);
  for (std::size_t k = 0; k < p.runs.size(); ++k)
    for (std::size_t i = p.runs[k].begin; i < std::min(p.runs[k].end, p.points.size()); ++i) run[i] = k;
  return run;
}

const PointPrediction* at(const Prediction* pr, std::size_t i) {
  return pr != nullptr && i < pr->points.size() ? &pr->points[i] : nullptr;
}

/// The intended tool tip nearest the actual one: the foot point C(u*) = P′ + error.
Eigen::Vector3d intended_tip(const PointPrediction& p) { return p.tip + p.error; }

using io::html_escape;

std::string csv_field(std::string_view s) {
  if (s.find_first_of(",\"\n\r") == std::string_view::npos) return std::string(s);
  std::string o = "\"";
  for (char c : s) {
    if (c == '"') o += '"';
    o += c;
  }
  return o + "\"";
}

// ---- JSON ---------------------------------------------------------------------------------

json summary_json(const Summary& s, double scale) {
  return {{"max", number(s.max * scale)}, {"rms", number(s.rms * scale)}, {"p95", number(s.p95 * scale)},
          {"count", s.count}};
}

json following_json(const std::vector<double>& f, const std::vector<JointInfo>& joints) {
  json o = json::object();
  for (std::size_t j = 0; j < f.size(); ++j) {
    const std::string name = j < joints.size() ? joints[j].name : fmt::format("j{}", j + 1);
    o[name] = {{"max", number(f[j])}, {"unit", j < joints.size() ? joints[j].unit : "mm"}};
  }
  return o;
}

json prediction_json(const Prediction& pr, const Path& path, const std::vector<JointInfo>& joints) {
  auto line_of = [&](std::size_t i) { return i < path.points.size() ? json(path.points[i].line) : json(nullptr); };
  json tip = summary_json(pr.tip, kUmPerMm), axis = summary_json(pr.axis, kArcsecPerRad);
  if (pr.tip.count > 0) {
    tip["worst_point"] = pr.tip.worst;
    tip["worst_line"] = line_of(pr.tip.worst);
  }
  if (pr.axis.count > 0) {
    axis["worst_point"] = pr.axis.worst;
    axis["worst_line"] = line_of(pr.axis.worst);
  }
  return {{"tip_um", tip},
          {"axis_arcsec", axis},
          {"max_following", following_json(pr.max_following, joints)},
          {"unconverged", pr.unconverged}};
}

json simulation_json(const Simulation& s, const std::vector<JointInfo>& joints) {
  return {{"tip_um", summary_json(s.tip, kUmPerMm)},
          {"axis_arcsec", summary_json(s.axis, kArcsecPerRad)},
          {"max_following", following_json(s.max_following, joints)},
          {"samples", s.samples},
          {"worst_tip_line", s.worst_tip_line},
          {"worst_axis_line", s.worst_axis_line}};
}

/// 100·(1 − after/before); null when before is 0 (nothing to reduce) or not finite.
json reduction(double before, double after) {
  if (!(before > 0) || !std::isfinite(before) || !std::isfinite(after)) return nullptr;
  return 100.0 * (1.0 - after / before);
}

/// Indices of the `n` largest values, largest first (ties: the earlier point first; NaN last).
std::vector<std::size_t> largest(const std::vector<PointPrediction>& pts, std::size_t n, bool axis) {
  auto key = [&](std::size_t i) {
    const double v = axis ? pts[i].axis_rad : pts[i].tip_mm;
    return std::isnan(v) ? -std::numeric_limits<double>::infinity() : v;
  };
  std::vector<std::size_t> idx(pts.size());
  for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = i;
  n = std::min(n, idx.size());
  std::partial_sort(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(n), idx.end(),
                    [&](std::size_t a, std::size_t b) { return key(a) != key(b) ? key(a) > key(b) : a < b; });
  idx.resize(n);
  return idx;
}

json worst_json(const ContourReport& r, bool axis) {
  json list = json::array();
  for (std::size_t i : largest(r.before->points, r.worst, axis)) {
    const PointPrediction& p = r.before->points[i];
    const bool on_path = i < r.path->points.size();
    json w = {{"point", i},
              {"line", on_path ? json(r.path->points[i].line) : json(nullptr)},
              {"time_s", on_path ? number(r.path->points[i].t) : json(nullptr)},
              {"tip_um", number(um(p.tip_mm))},
              {"axis_arcsec", number(arcsec(p.axis_rad))}};
    if (const PointPrediction* a = at(r.after, i)) {
      w["after_tip_um"] = number(um(a->tip_mm));
      w["after_axis_arcsec"] = number(arcsec(a->axis_rad));
    }
    list.push_back(std::move(w));
  }
  return list;
}

// ---- HTML ---------------------------------------------------------------------------------

/// The intended tool-tip path (one stretch per run) coloured by the tip contour error before
/// correction, µm.
io::PlotPath plot_path(const ContourReport& r) {
  const Path& path = *r.path;
  const std::size_t n = std::min(path.points.size(), r.before->points.size());
  io::PlotPath p;
  p.points.reserve(n);
  p.values.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.points.push_back(intended_tip(r.before->points[i]));
    p.values.push_back(um(r.before->points[i].tip_mm));
  }
  for (const Run& run : path.runs)
    if (std::min(run.end, n) > run.begin + 1) p.runs.emplace_back(run.begin, std::min(run.end, n));
  return p;
}

using io::cell;

}  // namespace

// ---- CSV ----------------------------------------------------------------------------------

std::string report_csv(const ContourReport& r) {
  check(r);
  const Path& path = *r.path;
  const std::vector<JointInfo> joints = joints_of(r);
  const std::vector<std::size_t> run = run_of_points(path);
  std::string s = "index,line,time_s,run,x_mm,y_mm,z_mm";
  auto error_heads = [&](std::string_view prefix) {
    for (const JointInfo& j : joints) s += fmt::format(",{}", csv_field(fmt::format("{}following_{}_{}", prefix, j.name, j.unit)));
    s += fmt::format(",{0}tip_um,{0}tip_x_um,{0}tip_y_um,{0}tip_z_um,{0}axis_arcsec", prefix);
  };
  error_heads("");
  if (r.after != nullptr) error_heads("after_");
  s += "\n";
  auto errors = [&](const PointPrediction* p) {
    for (std::size_t j = 0; j < joints.size(); ++j)
      s += p != nullptr && static_cast<Eigen::Index>(j) < p->following.size()
               ? fmt::format(",{:.6g}", p->following[static_cast<Eigen::Index>(j)])
               : std::string(",");
    if (p == nullptr) {
      s += ",,,,,";
      return;
    }
    s += fmt::format(",{:.6g},{:.6g},{:.6g},{:.6g},{:.6g}", um(p->tip_mm), um(p->error.x()), um(p->error.y()),
                     um(p->error.z()), arcsec(p->axis_rad));
  };
  for (std::size_t i = 0; i < path.points.size(); ++i) {
    const PathPoint& pt = path.points[i];
    const PointPrediction* b = at(r.before, i);
    s += fmt::format("{},{},{:.9g},{}", i, pt.line, pt.t, run[i] == kOutsideRuns ? std::string() : std::to_string(run[i]));
    if (b != nullptr) {
      const Eigen::Vector3d p = intended_tip(*b);
      s += fmt::format(",{:.9g},{:.9g},{:.9g}", p.x(), p.y(), p.z());
    } else {
      s += ",,,";
    }
    errors(b);
    if (r.after != nullptr) errors(at(r.after, i));
    s += "\n";
  }
  return s;
}

// ---- JSON ---------------------------------------------------------------------------------

std::string report_json(const ContourReport& r) {
  check(r);
  const Path& path = *r.path;
  const std::vector<JointInfo> joints = joints_of(r);
  json j;
  j["title"] = r.title;
  j["tool"] = {{"name", "postproc"}, {"version", r.tool_version}};
  j["program"] = r.program;
  j["machine"] = {{"file", r.machine_file}, {"sha256", r.machine_sha256}};
  j["points"] = path.points.size();
  j["runs"] = path.runs.size();
  j["duration_s"] = number(path.duration);
  j["fit_residual_um"] = number(um(r.fit_residual_mm));
  j["predicted"] = prediction_json(*r.before, path, joints);
  if (r.after != nullptr) {
    j["after"] = prediction_json(*r.after, path, joints);
    j["reduction_percent"] = {{"tip", reduction(r.before->tip.max, r.after->tip.max)},
                              {"axis", reduction(r.before->axis.max, r.after->axis.max)}};
  }
  if (r.compensation != nullptr) {
    const Precompensation& c = *r.compensation;
    j["iterations"] = c.iterations;
    j["converged"] = c.converged;
    json hu = json::array(), ha = json::array();
    for (double v : c.history_mm) hu.push_back(number(um(v)));
    for (double v : c.history_rad) ha.push_back(number(arcsec(v)));
    j["history_um"] = hu;
    j["history_arcsec"] = ha;
  }
  if (r.simulated_before != nullptr) j["simulated_before"] = simulation_json(*r.simulated_before, joints);
  if (r.simulated_after != nullptr) j["simulated_after"] = simulation_json(*r.simulated_after, joints);
  j["worst"] = worst_json(r, false);
  j["worst_axis"] = worst_json(r, true);
  return j.dump(2) + "\n";
}

// ---- HTML ---------------------------------------------------------------------------------

std::string report_html(const ContourReport& r) {
  check(r);
  const Path& path = *r.path;
  const std::vector<JointInfo> joints = joints_of(r);
  const std::string title = r.title.empty() ? "postproc contour report" : r.title;
  std::string s = io::page_head(title);
  s += fmt::format("<h1>{}</h1>\n", html_escape(title));
  s += fmt::format("<p id=\"summary\">Program <code>{}</code>", html_escape(r.program));
  if (!r.machine_file.empty()) s += fmt::format("; machine file <code>{}</code>", html_escape(r.machine_file));
  if (!r.machine_sha256.empty()) s += fmt::format(" (SHA-256 {})", html_escape(r.machine_sha256));
  if (!r.tool_version.empty()) s += fmt::format("; postproc {}", html_escape(r.tool_version));
  s += fmt::format(". {} path points in {} runs, {:.4f} s; largest fit residual of the intended contour {:.4f} µm.</p>\n",
                   path.points.size(), path.runs.size(), path.duration, um(r.fit_residual_mm));

  // Summary table.
  s += "<h2>Contour error</h2><table id=\"figures\"><tr><th class=l></th><th>tip max (µm)</th><th>tip RMS (µm)</th>"
       "<th>tip p95 (µm)</th><th>axis max (arcsec)</th><th>axis RMS (arcsec)</th><th>axis p95 (arcsec)</th>"
       "<th>line of the largest tip error</th>";
  for (const JointInfo& jt : joints) s += fmt::format("<th>max following {} ({})</th>", html_escape(jt.name), jt.unit);
  s += "</tr>\n";
  auto row = [&](const char* name, const Summary& tip, const Summary& axis, std::string line, const std::vector<double>& f) {
    s += fmt::format("<tr><td class=l>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>",
                     name, cell(um(tip.max)), cell(um(tip.rms)), cell(um(tip.p95)), cell(arcsec(axis.max)),
                     cell(arcsec(axis.rms)), cell(arcsec(axis.p95)), line);
    for (std::size_t k = 0; k < joints.size(); ++k) s += fmt::format("<td>{}</td>", k < f.size() ? cell(f[k], "{:.5g}") : "–");
    s += "</tr>\n";
  };
  auto pred_line = [&](const Prediction& p) {
    return p.tip.count > 0 && p.tip.worst < path.points.size() ? std::to_string(path.points[p.tip.worst].line)
                                                                : std::string("–");
  };
  row("predicted, before", r.before->tip, r.before->axis, pred_line(*r.before), r.before->max_following);
  if (r.after != nullptr) row("predicted, after", r.after->tip, r.after->axis, pred_line(*r.after), r.after->max_following);
  if (r.simulated_before != nullptr)
    row("simulated, before", r.simulated_before->tip, r.simulated_before->axis,
        std::to_string(r.simulated_before->worst_tip_line), r.simulated_before->max_following);
  if (r.simulated_after != nullptr)
    row("simulated, after", r.simulated_after->tip, r.simulated_after->axis,
        std::to_string(r.simulated_after->worst_tip_line), r.simulated_after->max_following);
  s += "</table>\n";
  if (r.after != nullptr) {
    auto pct = [](double b, double a) {
      const json v = reduction(b, a);
      return v.is_null() ? std::string("–") : fmt::format("{:.1f} %", v.get<double>());
    };
    s += fmt::format("<p id=\"reduction\">Reduction of the largest error: tool tip {}, tool axis {}.</p>\n",
                     pct(r.before->tip.max, r.after->tip.max), pct(r.before->axis.max, r.after->axis.max));
  }
  if (r.compensation != nullptr) {
    const Precompensation& c = *r.compensation;
    s += fmt::format("<p id=\"iterations\">Precompensation: {} iterations, {}. Largest tip error after each iteration (µm):",
                     c.iterations, c.converged ? "converged" : "<b>not converged</b>");
    for (double v : c.history_mm) s += fmt::format(" {}", cell(um(v)));
    s += "; tool axis (arcsec):";
    for (double v : c.history_rad) s += fmt::format(" {}", cell(arcsec(v)));
    s += ".</p>\n";
  }

  // Error along the path.
  auto series = [&](const Prediction* p, bool axis, const char* name, const char* colour) {
    io::Series se{name, colour, {}};
    if (p == nullptr) return se;
    const std::size_t n = std::min(p->points.size(), path.points.size());
    se.xy.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      const double v = axis ? arcsec(p->points[i].axis_rad) : um(p->points[i].tip_mm);
      if (std::isfinite(v) && std::isfinite(path.points[i].t)) se.xy.emplace_back(path.points[i].t, v);
    }
    se.xy = io::decimate_max(se.xy, kMaxPlotPoints);
    return se;
  };
  for (bool axis : {false, true}) {
    std::vector<io::Series> plot{series(r.before, axis, "before", "#1f6fb4")};
    if (r.after != nullptr) plot.push_back(series(r.after, axis, "after precompensation", "#e67e22"));
    s += axis ? "<h3>Tool-axis contour error along the path</h3>\n" : "<h3>Tool-tip contour error along the path</h3>\n";
    s += io::line_plot(plot, "time (s)", axis ? "tool-axis error (arcsec)" : "tool-tip error (µm)") + "\n";
  }

  // Projections of the intended tool-tip path.
  double max_um = 0;
  for (const PointPrediction& p : r.before->points)
    if (std::isfinite(p.tip_mm)) max_um = std::max(max_um, um(p.tip_mm));
  s += "<h2>Tool-tip path</h2>\n<p>The intended tool tip (mm, workpiece frame), coloured by the predicted tool-tip "
       "contour error before correction.</p>\n<div class=views>";
  const io::PlotPath tips = plot_path(r);
  for (const auto& [u, v] : {std::pair{0, 1}, std::pair{0, 2}, std::pair{1, 2}})
    s += io::projection(tips, u, v, max_um, kMaxPlotPoints);
  s += "</div>\n" + io::colour_bar(max_um, "tool-tip contour error before correction (µm)") + "\n";

  // Worst places.
  for (bool axis : {false, true}) {
    s += fmt::format("<h2>Largest {} errors</h2><table id=\"{}\"><tr><th>point</th><th>line</th><th>time (s)</th>"
                     "<th>tip (µm)</th><th>axis (arcsec)</th>{}</tr>\n",
                     axis ? "tool-axis" : "tool-tip", axis ? "worst_axis" : "worst",
                     r.after != nullptr ? "<th>tip after (µm)</th><th>axis after (arcsec)</th>" : "");
    for (std::size_t i : largest(r.before->points, r.worst, axis)) {
      const PointPrediction& p = r.before->points[i];
      const bool on_path = i < path.points.size();
      s += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>", i,
                       on_path ? std::to_string(path.points[i].line) : "–",
                       on_path ? cell(path.points[i].t, "{:.4f}") : "–", cell(um(p.tip_mm)), cell(arcsec(p.axis_rad)));
      if (r.after != nullptr) {
        const PointPrediction* a = at(r.after, i);
        s += fmt::format("<td>{}</td><td>{}</td>", a != nullptr ? cell(um(a->tip_mm)) : "–",
                         a != nullptr ? cell(arcsec(a->axis_rad)) : "–");
      }
      s += "</tr>\n";
    }
    s += "</table>\n";
  }
  return s + r.appendix + io::page_tail();
}

}  // namespace postproc::contour
