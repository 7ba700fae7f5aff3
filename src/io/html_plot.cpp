// Inline SVG and canvas plots of the self-contained HTML reports (see html_plot.hpp).
#include "src/io/html_plot.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

#include "src/io/html.hpp"

namespace postproc::io {

void Range::add(double v) {
  if (!std::isfinite(v)) return;
  lo = std::min(lo, v);
  hi = std::max(hi, v);
}

double nice_step(double span, int count) {
  if (!(span > 0) || !std::isfinite(span)) return 1;
  const double raw = span / count, mag = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0})
    if (raw <= m * mag) return m * mag;
  return 10 * mag;
}

std::vector<std::size_t> decimate_max_indices(const std::vector<double>& values, std::size_t limit) {
  std::vector<std::size_t> out;
  if (values.size() <= limit || limit < 3) {
    out.resize(values.size());
    for (std::size_t i = 0; i < out.size(); ++i) out[i] = i;
    return out;
  }
  auto key = [&](std::size_t i) { return std::isnan(values[i]) ? -std::numeric_limits<double>::infinity() : values[i]; };
  out.reserve(limit);
  out.push_back(0);
  const std::size_t inner = values.size() - 2, buckets = limit - 2;
  for (std::size_t b = 0; b < buckets; ++b) {
    const std::size_t first = 1 + b * inner / buckets, last = 1 + (b + 1) * inner / buckets;
    if (first >= last) continue;
    std::size_t best = first;
    for (std::size_t i = first + 1; i < last; ++i)
      if (key(i) > key(best)) best = i;
    out.push_back(best);
  }
  out.push_back(values.size() - 1);
  return out;
}

Points2 decimate_max(const Points2& in, std::size_t limit) {
  std::vector<double> y(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) y[i] = in[i].second;
  Points2 out;
  for (std::size_t i : decimate_max_indices(y, limit)) out.push_back(in[i]);
  return out;
}

namespace {

std::string id_attr(std::string_view id) {
  return id.empty() ? std::string() : fmt::format(" id=\"{}\"", html_escape(id));
}

/// Axes of a 860 × 280 px plot: y from 0 (or below) in nice steps, x over its range; the grid,
/// the tick labels and the axis labels.
struct Frame {
  static constexpr double w = 860, h = 280, left = 70, right = 15, top = 12, bottom = 42;
  Range x, y;
  double xstep = 1, ystep = 1, y0 = 0, y1 = 1;

  Frame(Range xr, Range yr) : x(xr), y(yr) {
    if (!(x.hi > x.lo)) x.hi = x.lo + 1;
    if (!(y.hi > y.lo)) y.hi = y.lo + 1;
    ystep = nice_step(y.hi - y.lo, 5);
    xstep = nice_step(x.hi - x.lo, 8);
    y0 = std::floor(y.lo / ystep) * ystep;
    y1 = std::ceil(y.hi / ystep) * ystep;
  }
  [[nodiscard]] double px(double v) const { return left + (w - left - right) * (v - x.lo) / (x.hi - x.lo); }
  [[nodiscard]] double py(double v) const { return top + (h - top - bottom) * (y1 - v) / (y1 - y0); }

  [[nodiscard]] std::string open(std::string_view id, std::string_view xlabel, std::string_view ylabel) const {
    std::string s = fmt::format(
        R"(<svg class="plot"{2} xmlns="http://www.w3.org/2000/svg" width="{0}" height="{1}" viewBox="0 0 {0} {1}">)", w,
        h, id_attr(id));
    for (double t = y0; t <= y1 + 0.5 * ystep; t += ystep) {
      s += fmt::format(R"(<line x1="{}" x2="{}" y1="{:.1f}" y2="{:.1f}" stroke="#ddd"/>)", left, w - right, py(t), py(t));
      s += fmt::format(R"(<text x="{}" y="{:.1f}" font-size="11" text-anchor="end">{:g}</text>)", left - 4, py(t) + 4, t);
    }
    for (double t = std::ceil(x.lo / xstep) * xstep; t <= x.hi + 1e-9 * xstep; t += xstep) {
      s += fmt::format(R"(<line x1="{0:.1f}" x2="{0:.1f}" y1="{1}" y2="{2}" stroke="#eee"/>)", px(t), top, h - bottom);
      s += fmt::format(R"(<text x="{:.1f}" y="{}" font-size="11" text-anchor="middle">{:g}</text>)", px(t),
                       h - bottom + 14, t);
    }
    s += fmt::format(R"(<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="#999"/>)", left, top,
                     w - left - right, h - top - bottom);
    s += fmt::format(R"(<text x="{}" y="{}" font-size="12" text-anchor="middle">{}</text>)", (left + w - right) / 2,
                     h - 8, html_escape(xlabel));
    s += fmt::format(
        R"svg(<text x="14" y="{0:.1f}" font-size="12" text-anchor="middle" transform="rotate(-90 14 {0:.1f})">{1}</text>)svg",
        (top + h - bottom) / 2, html_escape(ylabel));
    return s;
  }
};

}  // namespace

std::string line_plot(const std::vector<Series>& series, std::string_view xlabel, std::string_view ylabel,
                      std::string_view id) {
  Range xr, yr;
  yr.add(0);
  for (const Series& s : series)
    for (const auto& [x, y] : s.xy) {
      xr.add(x);
      yr.add(y);
    }
  if (xr.empty()) return fmt::format("<p{}>No points to plot.</p>", id_attr(id));
  const Frame f(xr, yr);
  std::string s = f.open(id, xlabel, ylabel);
  for (const Series& se : series) {
    if (se.xy.empty()) continue;
    s += fmt::format(R"(<polyline fill="none" stroke="{}" stroke-width="1" points=")", se.colour);
    for (std::size_t i = 0; i < se.xy.size(); ++i)
      s += fmt::format("{}{:.1f},{:.1f}", i == 0 ? "" : " ", f.px(se.xy[i].first), f.py(se.xy[i].second));
    s += "\"/>";
  }
  if (series.size() > 1) {
    const double lx = Frame::w - Frame::right - 190;
    s += fmt::format(R"(<rect x="{}" y="{}" width="184" height="{}" fill="#fff" fill-opacity="0.85" stroke="#ccc"/>)",
                     lx - 6, Frame::top + 2, 16 * static_cast<double>(series.size()) + 6);
    for (std::size_t k = 0; k < series.size(); ++k) {
      const double ly = Frame::top + 14 + 16 * static_cast<double>(k);
      s += fmt::format(R"(<line x1="{0}" x2="{1}" y1="{2}" y2="{2}" stroke="{3}" stroke-width="2"/>)", lx, lx + 20, ly - 4,
                       series[k].colour);
      s += fmt::format(R"(<text x="{}" y="{}" font-size="12">{}</text>)", lx + 26, ly, html_escape(series[k].name));
    }
  }
  return s + "</svg>";
}

std::string histogram(const std::vector<double>& values, int bins, std::string_view xlabel, std::string_view id) {
  Range vr;
  vr.add(0);
  for (double v : values) vr.add(v);
  bins = std::max(bins, 1);
  if (!(vr.hi > vr.lo)) vr.hi = vr.lo + 1;
  const double width = (vr.hi - vr.lo) / bins;
  std::vector<std::size_t> count(static_cast<std::size_t>(bins), 0);
  for (double v : values)
    if (std::isfinite(v)) ++count[static_cast<std::size_t>(std::clamp(static_cast<int>((v - vr.lo) / width), 0, bins - 1))];
  Range cr;
  cr.add(0);
  for (std::size_t c : count) cr.add(static_cast<double>(c));
  const Frame f(vr, cr);
  std::string s = f.open(id, xlabel, "count");
  for (std::size_t b = 0; b < count.size(); ++b) {
    if (count[b] == 0) continue;
    const double x0 = f.px(vr.lo + width * static_cast<double>(b)), x1 = f.px(vr.lo + width * static_cast<double>(b + 1));
    const double yt = f.py(static_cast<double>(count[b]));
    s += fmt::format(R"(<rect x="{:.1f}" y="{:.1f}" width="{:.1f}" height="{:.1f}" fill="#1f6fb4" stroke="#fff" stroke-width="0.5"><title>{}</title></rect>)",
                     x0, yt, std::max(x1 - x0, 0.5), f.py(0) - yt, count[b]);
  }
  return s + "</svg>";
}

std::string colour_of(double f) {
  f = std::isfinite(f) ? std::clamp(f, 0.0, 1.0) : 1.0;
  const std::array<double, 3> a{0x2c, 0x7b, 0xb6}, b{0xd7, 0x19, 0x1c};
  auto c = [&](std::size_t k) { return static_cast<int>(std::lround(a[k] + (b[k] - a[k]) * f)); };
  return fmt::format("#{:02x}{:02x}{:02x}", c(0), c(1), c(2));
}

namespace {

int level_of(double value, double max_value) {
  const double f = max_value > 0 && std::isfinite(value) ? value / max_value : 0;
  return std::clamp(static_cast<int>(f * kColourLevels), 0, kColourLevels - 1);
}

double value_at(const PlotPath& p, std::size_t i) {
  return i < p.values.size() && std::isfinite(p.values[i]) ? p.values[i] : 0.0;
}

}  // namespace

std::string projection(const PlotPath& path, int u, int v, double max_value, std::size_t max_segments,
                       std::string_view id) {
  static constexpr std::array<const char*, 3> kAxis{"X", "Y", "Z"};
  const std::size_t n = path.points.size();
  const auto ui = static_cast<Eigen::Index>(u), vi = static_cast<Eigen::Index>(v);
  Range ur, vr;
  for (const auto& [begin, end] : path.runs)
    for (std::size_t i = begin; i < std::min(end, n); ++i) {
      ur.add(path.points[i][ui]);
      vr.add(path.points[i][vi]);
    }
  const double size = 400, margin = 40;
  std::string s = fmt::format(
      R"(<svg class="plot"{1} xmlns="http://www.w3.org/2000/svg" width="{0}" height="{0}" viewBox="0 0 {0} {0}">)", size,
      id_attr(id));
  s += fmt::format(R"(<text x="{}" y="16" font-size="13" text-anchor="middle">{}{} (mm)</text>)", size / 2, kAxis[u],
                   kAxis[v]);
  if (ur.empty() || vr.empty()) return s + "</svg>";
  const double du = ur.hi - ur.lo, dv = vr.hi - vr.lo, span = std::max({du, dv, 1e-9});
  const double scale = (size - 2 * margin) / span;
  const double ou = margin + (size - 2 * margin - du * scale) / 2, ov = margin + (size - 2 * margin - dv * scale) / 2;
  auto pu = [&](double a) { return ou + (a - ur.lo) * scale; };
  auto pv = [&](double b) { return size - ov - (b - vr.lo) * scale; };
  auto at = [&](std::size_t i) { return fmt::format("{:.1f},{:.1f}", pu(path.points[i][ui]), pv(path.points[i][vi])); };
  s += fmt::format(R"(<rect x="{:.1f}" y="{:.1f}" width="{:.1f}" height="{:.1f}" fill="none" stroke="#ccc"/>)", pu(ur.lo),
                   pv(vr.hi), du * scale, dv * scale);
  s += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="10">{} {:.6g}…{:.6g}</text>)", margin, size - 22, kAxis[u],
                   ur.lo, ur.hi);
  s += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="10">{} {:.6g}…{:.6g}</text>)", margin, size - 8, kAxis[v],
                   vr.lo, vr.hi);
  std::size_t total = 0;
  for (const auto& [begin, end] : path.runs) total += std::min(end, n) > begin ? std::min(end, n) - begin : 0;
  const std::size_t limit = std::max<std::size_t>(max_segments, 1);
  const std::size_t stride = std::max<std::size_t>(1, (total + limit - 1) / limit);
  // Polylines (or dots) of one colour level each, drawn lowest level first.
  std::vector<std::pair<int, std::string>> lines;
  for (const auto& [begin, end_] : path.runs) {
    const std::size_t end = std::min(end_, n);
    if (end == begin + 1) {
      lines.emplace_back(level_of(value_at(path, begin), max_value), "dot " + at(begin));
      continue;
    }
    if (end <= begin + 1) continue;
    std::size_t a = begin;
    while (a + 1 < end) {
      const std::size_t b = std::min(a + stride, end - 1);
      double e = 0;
      for (std::size_t i = a; i <= b; ++i) e = std::max(e, value_at(path, i));
      const int lv = level_of(e, max_value);
      if (lines.empty() || lines.back().first != lv || a == begin) lines.emplace_back(lv, at(a));
      lines.back().second += " " + at(b);
      a = b;
    }
  }
  std::stable_sort(lines.begin(), lines.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
  for (const auto& [lv, points] : lines) {
    const std::string colour = colour_of((lv + 0.5) / kColourLevels);
    if (points.rfind("dot ", 0) == 0) {
      const std::string_view xy = std::string_view(points).substr(4);
      const std::size_t comma = xy.find(',');
      s += fmt::format(R"(<circle cx="{}" cy="{}" r="2" fill="{}"/>)", xy.substr(0, comma), xy.substr(comma + 1), colour);
    } else {
      s += fmt::format(R"(<polyline fill="none" stroke-width="1.5" stroke="{}" points="{}"/>)", colour, points);
    }
  }
  return s + "</svg>";
}

std::string colour_bar(double max_value, std::string_view label) {
  const double w = 420, h = 46, left = 10, bar = 360;
  std::string s = fmt::format(
      R"(<svg class="bar" xmlns="http://www.w3.org/2000/svg" width="{0}" height="{1}" viewBox="0 0 {0} {1}">)", w, h);
  for (int k = 0; k < kColourLevels; ++k)
    s += fmt::format(R"(<rect x="{:.2f}" y="4" width="{:.2f}" height="14" fill="{}"/>)",
                     left + bar * k / kColourLevels, bar / kColourLevels + 0.3, colour_of((k + 0.5) / kColourLevels));
  for (int k = 0; k <= 4; ++k)
    s += fmt::format(R"(<text x="{:.1f}" y="32" font-size="11" text-anchor="middle">{:.3g}</text>)", left + bar * k / 4,
                     max_value * k / 4);
  s += fmt::format(R"(<text x="{}" y="44" font-size="11" text-anchor="middle">{}</text>)", left + bar / 2,
                   html_escape(label));
  return s + "</svg>";
}

namespace {

/// Draws the embedded data: rotation about the vertical Z axis (yaw) and a tilt (pitch), segments
/// batched per colour level; pointer drag rotates, the wheel zooms.
constexpr std::string_view kView3dScript = R"js(
(function (ID) {
  var c = document.getElementById(ID), d = JSON.parse(document.getElementById(ID + '-data').textContent);
  var g = c.getContext('2d'), P = d.p, V = d.v, S = d.s, n = V.length, L = d.palette.length;
  var lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity], i, k;
  for (i = 0; i < n; i++) for (k = 0; k < 3; k++) { lo[k] = Math.min(lo[k], P[3 * i + k]); hi[k] = Math.max(hi[k], P[3 * i + k]); }
  var mid = [0, 1, 2].map(function (k) { return n ? (lo[k] + hi[k]) / 2 : 0; });
  var span = n ? Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-9) : 1;
  var lev = new Int32Array(n);
  for (i = 0; i < n; i++) {
    var v = Math.max(V[i], i > 0 && !S[i] ? V[i - 1] : 0);
    lev[i] = d.max > 0 ? Math.max(0, Math.min(L - 1, Math.floor(v / d.max * L))) : 0;
  }
  var yaw = -0.7, pitch = 0.6, zoom = 1, drag = null, X = new Float64Array(n), Y = new Float64Array(n);
  function draw() {
    var W = c.width, H = c.height, cy = Math.cos(yaw), sy = Math.sin(yaw), cp = Math.cos(pitch), sp = Math.sin(pitch);
    var s = zoom * 0.8 * Math.min(W, H) / span;
    g.fillStyle = '#ffffff';
    g.fillRect(0, 0, W, H);
    for (i = 0; i < n; i++) {
      var x = P[3 * i] - mid[0], y = P[3 * i + 1] - mid[1], z = P[3 * i + 2] - mid[2];
      X[i] = W / 2 + s * (cy * x - sy * y);
      Y[i] = H / 2 - s * (cp * z + sp * (sy * x + cy * y));
    }
    g.lineWidth = 1.5;
    for (var l = 0; l < L; l++) {
      g.strokeStyle = d.palette[l];
      g.fillStyle = d.palette[l];
      g.beginPath();
      for (i = 0; i < n; i++) {
        if (lev[i] !== l) continue;
        if (S[i]) { if (i + 1 >= n || S[i + 1]) g.fillRect(X[i] - 1.5, Y[i] - 1.5, 3, 3); continue; }
        g.moveTo(X[i - 1], Y[i - 1]);
        g.lineTo(X[i], Y[i]);
      }
      g.stroke();
    }
    var o = [40, H - 40], names = ['X', 'Y', 'Z'], axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
    g.strokeStyle = '#444'; g.fillStyle = '#444'; g.font = '12px sans-serif';
    axes.forEach(function (a, k) {
      var ex = o[0] + 25 * (cy * a[0] - sy * a[1]), ey = o[1] - 25 * (cp * a[2] + sp * (sy * a[0] + cy * a[1]));
      g.beginPath(); g.moveTo(o[0], o[1]); g.lineTo(ex, ey); g.stroke();
      g.fillText(names[k], ex + 2, ey - 2);
    });
  }
  c.addEventListener('pointerdown', function (e) { drag = [e.clientX, e.clientY]; c.setPointerCapture(e.pointerId); });
  c.addEventListener('pointermove', function (e) {
    if (!drag) return;
    yaw += 0.01 * (e.clientX - drag[0]);
    pitch = Math.max(-1.57, Math.min(1.57, pitch + 0.01 * (e.clientY - drag[1])));
    drag = [e.clientX, e.clientY];
    draw();
  });
  c.addEventListener('pointerup', function () { drag = null; });
  c.addEventListener('wheel', function (e) { e.preventDefault(); zoom *= Math.exp(-0.001 * e.deltaY); draw(); }, {passive: false});
  draw();
}))js";

}  // namespace

std::string view3d(const PlotPath& path, double max_value, std::size_t max_points, std::string_view id,
                   std::string_view label) {
  // The points drawn, with a flag where a stretch starts; decimated over all stretches together.
  std::vector<std::size_t> index;
  std::vector<bool> starts;
  std::vector<double> values;
  for (const auto& [begin, end] : path.runs)
    for (std::size_t i = begin; i < std::min(end, path.points.size()); ++i) {
      index.push_back(i);
      starts.push_back(i == begin);
      values.push_back(value_at(path, i));
    }
  std::string p, v, s, palette;
  bool start_pending = false;
  std::size_t prev = 0;
  const std::vector<std::size_t> keep = decimate_max_indices(values, max_points);
  for (std::size_t k = 0; k < keep.size(); ++k) {
    const std::size_t j = keep[k];
    // A stretch starting among the skipped points starts at the next kept one.
    for (std::size_t m = k == 0 ? j : prev + 1; m <= j; ++m) start_pending = start_pending || starts[m];
    prev = j;
    const Eigen::Vector3d& x = path.points[index[j]];
    const char* sep = k == 0 ? "" : ",";
    p += fmt::format("{}{:.4f},{:.4f},{:.4f}", sep, x.x(), x.y(), x.z());
    v += fmt::format("{}{:.6g}", sep, values[j]);
    s += fmt::format("{}{}", sep, start_pending ? 1 : 0);
    start_pending = false;
  }
  for (int k = 0; k < kColourLevels; ++k)
    palette += fmt::format("{}\"{}\"", k == 0 ? "" : ",", colour_of((k + 0.5) / kColourLevels));
  const std::string eid = html_escape(id);
  std::string out = fmt::format(
      "<canvas id=\"{0}\" width=\"860\" height=\"520\" style=\"border:1px solid #ccc;touch-action:none;cursor:grab\">"
      "</canvas>\n<p class=note>{1}; drag to rotate, wheel to zoom; {2} of {3} points drawn.</p>\n"
      "<script type=\"application/json\" id=\"{0}-data\">{{\"max\":{4:.6g},\"palette\":[{5}],\"p\":[{6}],\"v\":[{7}],"
      "\"s\":[{8}]}}</script>\n",
      eid, html_escape(label), keep.size(), values.size(), std::isfinite(max_value) ? max_value : 0.0, palette, p, v, s);
  out += fmt::format("<script>{}(\"{}\");</script>\n", kView3dScript, eid);
  return out;
}

std::string page_head(std::string_view title, std::string_view extra_css) {
  return fmt::format(R"(<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{}</title>
<link rel="icon" href="data:,">
<style>
body{{font-family:sans-serif;margin:1.5em;color:#222}}table{{border-collapse:collapse;margin:0.5em 0 1.5em}}
td,th{{border:1px solid #ccc;padding:2px 8px;text-align:right;font-size:13px}}th{{background:#f3f3f3}}
td.l,th.l{{text-align:left}}.plot{{border:1px solid #ccc;margin:0 8px 8px 0}}.views{{display:flex;flex-wrap:wrap}}
{}</style></head><body>
)",
                     html_escape(title), extra_css);
}

std::string page_tail() { return "</body></html>\n"; }

std::string cell(double v, const char* spec) {
  return std::isfinite(v) ? fmt::format(fmt::runtime(spec), v) : std::string("–");
}

}  // namespace postproc::io
