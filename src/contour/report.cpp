// Reports of the contour-error prediction, simulation and precompensation: CSV, JSON and a
// self-contained HTML page with inline SVG plots (see report.hpp).
#include "postproc/contour/report.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string_view>
#include <utility>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "postproc/error.hpp"
#include "src/io/html.hpp"

namespace postproc::contour {
namespace {

using nlohmann::json;

constexpr double kUmPerMm = 1000.0;
constexpr double kArcsecPerRad = 180.0 / kin::kPi * 3600.0;
constexpr std::size_t kMaxPlotPoints = 4000;  ///< per plotted series (and path segments per projection)
constexpr std::size_t kNoRun = std::numeric_limits<std::size_t>::max();

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

/// Run index of every path point (kNoRun outside every run).
std::vector<std::size_t> run_of_points(const Path& p) {
  std::vector<std::size_t> run(p.points.size(), kNoRun);
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

// ---- SVG ----------------------------------------------------------------------------------

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  [[nodiscard]] bool empty() const { return !(lo <= hi); }
};

/// A step of 1, 2 or 5 × 10^k giving about `count` ticks over `span`.
double nice_step(double span, int count) {
  if (!(span > 0) || !std::isfinite(span)) return 1;
  const double raw = span / count, mag = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0})
    if (raw <= m * mag) return m * mag;
  return 10 * mag;
}

struct Series {
  std::string name;
  std::string colour;
  std::vector<std::pair<double, double>> xy;  ///< x ascending, finite
};

/// Keeps at most `limit` points: the first, the last, and between them the point of largest y in
/// each of `limit` − 2 consecutive buckets (peaks survive the decimation).
std::vector<std::pair<double, double>> decimate_max(const std::vector<std::pair<double, double>>& in, std::size_t limit) {
  if (in.size() <= limit || limit < 3) return in;
  std::vector<std::pair<double, double>> out;
  out.reserve(limit);
  out.push_back(in.front());
  const std::size_t inner = in.size() - 2, buckets = limit - 2;
  for (std::size_t b = 0; b < buckets; ++b) {
    const std::size_t first = 1 + b * inner / buckets, last = 1 + (b + 1) * inner / buckets;
    if (first >= last) continue;
    std::size_t best = first;
    for (std::size_t i = first + 1; i < last; ++i)
      if (in[i].second > in[best].second) best = i;
    out.push_back(in[best]);
  }
  out.push_back(in.back());
  return out;
}

/// Line plot of y (≥ 0) against x, inline SVG, with a legend when there are several series.
std::string line_plot(const std::vector<Series>& series, const std::string& xlabel, const std::string& ylabel) {
  Range xr, yr;
  yr.add(0);
  for (const Series& s : series)
    for (const auto& [x, y] : s.xy) {
      xr.add(x);
      yr.add(y);
    }
  if (xr.empty()) return "<p>No points to plot.</p>";
  if (!(xr.hi > xr.lo)) xr.hi = xr.lo + 1;
  if (!(yr.hi > yr.lo)) yr.hi = yr.lo + 1;
  const double ystep = nice_step(yr.hi - yr.lo, 5), xstep = nice_step(xr.hi - xr.lo, 8);
  const double y0 = std::floor(yr.lo / ystep) * ystep, y1 = std::ceil(yr.hi / ystep) * ystep;
  const double w = 860, h = 280, left = 70, right = 15, top = 12, bottom = 42;
  auto px = [&](double x) { return left + (w - left - right) * (x - xr.lo) / (xr.hi - xr.lo); };
  auto py = [&](double y) { return top + (h - top - bottom) * (y1 - y) / (y1 - y0); };
  std::string s = fmt::format(
      R"(<svg class="plot" xmlns="http://www.w3.org/2000/svg" width="{0}" height="{1}" viewBox="0 0 {0} {1}">)", w, h);
  for (double t = y0; t <= y1 + 0.5 * ystep; t += ystep) {
    s += fmt::format(R"(<line x1="{}" x2="{}" y1="{:.1f}" y2="{:.1f}" stroke="#ddd"/>)", left, w - right, py(t), py(t));
    s += fmt::format(R"(<text x="{}" y="{:.1f}" font-size="11" text-anchor="end">{:g}</text>)", left - 4, py(t) + 4, t);
  }
  for (double t = std::ceil(xr.lo / xstep) * xstep; t <= xr.hi + 1e-9 * xstep; t += xstep) {
    s += fmt::format(R"(<line x1="{0:.1f}" x2="{0:.1f}" y1="{1}" y2="{2}" stroke="#eee"/>)", px(t), top, h - bottom);
    s += fmt::format(R"(<text x="{:.1f}" y="{}" font-size="11" text-anchor="middle">{:g}</text>)", px(t),
                     h - bottom + 14, t);
  }
  s += fmt::format(R"(<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="#999"/>)", left, top,
                   w - left - right, h - top - bottom);
  for (const Series& se : series) {
    if (se.xy.empty()) continue;
    s += fmt::format(R"(<polyline fill="none" stroke="{}" stroke-width="1" points=")", se.colour);
    for (std::size_t i = 0; i < se.xy.size(); ++i)
      s += fmt::format("{}{:.1f},{:.1f}", i == 0 ? "" : " ", px(se.xy[i].first), py(se.xy[i].second));
    s += "\"/>";
  }
  s += fmt::format(R"(<text x="{}" y="{}" font-size="12" text-anchor="middle">{}</text>)", (left + w - right) / 2,
                   h - 8, html_escape(xlabel));
  s += fmt::format(R"svg(<text x="14" y="{0:.1f}" font-size="12" text-anchor="middle" transform="rotate(-90 14 {0:.1f})">{1}</text>)svg",
                   (top + h - bottom) / 2, html_escape(ylabel));
  if (series.size() > 1) {
    const double lx = w - right - 190;
    s += fmt::format(R"(<rect x="{}" y="{}" width="184" height="{}" fill="#fff" fill-opacity="0.85" stroke="#ccc"/>)",
                     lx - 6, top + 2, 16 * static_cast<double>(series.size()) + 6);
    for (std::size_t k = 0; k < series.size(); ++k) {
      const double ly = top + 14 + 16 * static_cast<double>(k);
      s += fmt::format(R"(<line x1="{0}" x2="{1}" y1="{2}" y2="{2}" stroke="{3}" stroke-width="2"/>)", lx, lx + 20, ly - 4,
                       series[k].colour);
      s += fmt::format(R"(<text x="{}" y="{}" font-size="12">{}</text>)", lx + 26, ly, html_escape(series[k].name));
    }
  }
  return s + "</svg>";
}

/// Blue (0) → red (1).
std::string colour_of(double f) {
  f = std::isfinite(f) ? std::clamp(f, 0.0, 1.0) : 1.0;
  const std::array<double, 3> a{0x2c, 0x7b, 0xb6}, b{0xd7, 0x19, 0x1c};
  auto c = [&](int k) {
    const auto ku = static_cast<std::size_t>(k);
    return static_cast<int>(std::lround(a[ku] + (b[ku] - a[ku]) * f));
  };
  return fmt::format("#{:02x}{:02x}{:02x}", c(0), c(1), c(2));
}

constexpr int kColourLevels = 32;

/// The intended tool-tip path in one projection (axes u, v of x y z), drawn as polylines coloured
/// by the tip contour error before correction. At most kMaxPlotPoints segments: long paths take
/// every k-th point, a segment coloured by the largest error along the points it spans.
std::string projection(const ContourReport& r, int u, int v, double max_um) {
  static constexpr std::array<const char*, 3> kAxis{"X", "Y", "Z"};
  const Path& path = *r.path;
  const std::size_t n = std::min(path.points.size(), r.before->points.size());
  Range ur, vr;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p = intended_tip(r.before->points[i]);
    ur.add(p[u]);
    vr.add(p[v]);
  }
  const double size = 400, margin = 40;
  std::string s = fmt::format(
      R"(<svg class="plot" xmlns="http://www.w3.org/2000/svg" width="{0}" height="{0}" viewBox="0 0 {0} {0}">)", size);
  s += fmt::format(R"(<text x="{}" y="16" font-size="13" text-anchor="middle">{}{} (mm)</text>)", size / 2, kAxis[u],
                   kAxis[v]);
  if (ur.empty() || vr.empty()) return s + "</svg>";
  const double du = ur.hi - ur.lo, dv = vr.hi - vr.lo, span = std::max({du, dv, 1e-9});
  const double scale = (size - 2 * margin) / span;
  const double ou = margin + (size - 2 * margin - du * scale) / 2, ov = margin + (size - 2 * margin - dv * scale) / 2;
  auto pu = [&](double a) { return ou + (a - ur.lo) * scale; };
  auto pv = [&](double b) { return size - ov - (b - vr.lo) * scale; };
  s += fmt::format(R"(<rect x="{:.1f}" y="{:.1f}" width="{:.1f}" height="{:.1f}" fill="none" stroke="#ccc"/>)", pu(ur.lo),
                   pv(vr.hi), du * scale, dv * scale);
  s += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="10">{} {:.6g}…{:.6g}</text>)", margin, size - 22, kAxis[u],
                   ur.lo, ur.hi);
  s += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="10">{} {:.6g}…{:.6g}</text>)", margin, size - 8, kAxis[v],
                   vr.lo, vr.hi);
  std::size_t total = 0;
  for (const Run& run : path.runs) total += std::min(run.end, n) > run.begin ? std::min(run.end, n) - run.begin : 0;
  const std::size_t stride = std::max<std::size_t>(1, (total + kMaxPlotPoints - 1) / kMaxPlotPoints);
  auto level = [&](double e_um) {
    const double f = max_um > 0 && std::isfinite(e_um) ? e_um / max_um : 0;
    return std::clamp(static_cast<int>(f * kColourLevels), 0, kColourLevels - 1);
  };
  // Polylines of one colour level each; drawn lowest level first so that the large errors stay
  // visible where the path passes over itself.
  std::vector<std::pair<int, std::string>> lines;
  for (const Run& run : path.runs) {
    const std::size_t end = std::min(run.end, n);
    if (end <= run.begin + 1) continue;
    std::size_t a = run.begin;
    while (a + 1 < end) {
      const std::size_t b = std::min(a + stride, end - 1);
      double e = 0;
      for (std::size_t i = a; i <= b; ++i) e = std::max(e, um(r.before->points[i].tip_mm));
      const int lv = level(e);
      if (lines.empty() || lines.back().first != lv || a == run.begin) {
        const Eigen::Vector3d pa = intended_tip(r.before->points[a]);
        lines.emplace_back(lv, fmt::format("{:.1f},{:.1f}", pu(pa[u]), pv(pa[v])));
      }
      const Eigen::Vector3d pb = intended_tip(r.before->points[b]);
      lines.back().second += fmt::format(" {:.1f},{:.1f}", pu(pb[u]), pv(pb[v]));
      a = b;
    }
  }
  std::stable_sort(lines.begin(), lines.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  for (const auto& [lv, points] : lines)
    s += fmt::format(R"(<polyline fill="none" stroke-width="1.5" stroke="{}" points="{}"/>)",
                     colour_of((lv + 0.5) / kColourLevels), points);
  return s + "</svg>";
}

std::string colour_bar(double max_um) {
  const double w = 420, h = 46, left = 10, bar = 360;
  std::string s = fmt::format(
      R"(<svg class="bar" xmlns="http://www.w3.org/2000/svg" width="{0}" height="{1}" viewBox="0 0 {0} {1}">)", w, h);
  for (int k = 0; k < kColourLevels; ++k)
    s += fmt::format(R"(<rect x="{:.2f}" y="4" width="{:.2f}" height="14" fill="{}"/>)",
                     left + bar * k / kColourLevels, bar / kColourLevels + 0.3, colour_of((k + 0.5) / kColourLevels));
  for (int k = 0; k <= 4; ++k)
    s += fmt::format(R"(<text x="{:.1f}" y="32" font-size="11" text-anchor="middle">{:.3g}</text>)", left + bar * k / 4,
                     max_um * k / 4);
  s += fmt::format(R"(<text x="{}" y="44" font-size="11" text-anchor="middle">tool-tip contour error before correction (µm)</text>)",
                   left + bar / 2);
  return s + "</svg>";
}

std::string cell(double v, const char* spec = "{:.3f}") {
  return std::isfinite(v) ? fmt::format(fmt::runtime(spec), v) : std::string("–");
}

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
    s += fmt::format("{},{},{:.9g},{}", i, pt.line, pt.t, run[i] == kNoRun ? std::string() : std::to_string(run[i]));
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
  std::string s = fmt::format(R"(<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{}</title>
<style>
body{{font-family:sans-serif;margin:1.5em;color:#222}}table{{border-collapse:collapse;margin:0.5em 0 1.5em}}
td,th{{border:1px solid #ccc;padding:2px 8px;text-align:right;font-size:13px}}th{{background:#f3f3f3}}
td.l,th.l{{text-align:left}}.plot{{border:1px solid #ccc;margin:0 8px 8px 0}}.views{{display:flex;flex-wrap:wrap}}
</style></head><body>
)",
                              html_escape(title));
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
    Series se{name, colour, {}};
    if (p == nullptr) return se;
    const std::size_t n = std::min(p->points.size(), path.points.size());
    se.xy.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      const double v = axis ? arcsec(p->points[i].axis_rad) : um(p->points[i].tip_mm);
      if (std::isfinite(v) && std::isfinite(path.points[i].t)) se.xy.emplace_back(path.points[i].t, v);
    }
    se.xy = decimate_max(se.xy, kMaxPlotPoints);
    return se;
  };
  for (bool axis : {false, true}) {
    std::vector<Series> plot{series(r.before, axis, "before", "#1f6fb4")};
    if (r.after != nullptr) plot.push_back(series(r.after, axis, "after precompensation", "#e67e22"));
    s += axis ? "<h3>Tool-axis contour error along the path</h3>\n" : "<h3>Tool-tip contour error along the path</h3>\n";
    s += line_plot(plot, "time (s)", axis ? "tool-axis error (arcsec)" : "tool-tip error (µm)") + "\n";
  }

  // Projections of the intended tool-tip path.
  double max_um = 0;
  for (const PointPrediction& p : r.before->points)
    if (std::isfinite(p.tip_mm)) max_um = std::max(max_um, um(p.tip_mm));
  s += "<h2>Tool-tip path</h2>\n<p>The intended tool tip (mm, workpiece frame), coloured by the predicted tool-tip "
       "contour error before correction.</p>\n<div class=views>";
  s += projection(r, 0, 1, max_um) + projection(r, 0, 2, max_um) + projection(r, 1, 2, max_um);
  s += "</div>\n" + colour_bar(max_um) + "\n";

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
  s += "</body></html>\n";
  return s;
}

}  // namespace postproc::contour
