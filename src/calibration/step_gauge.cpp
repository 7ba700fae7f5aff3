// The 3-D step gauge of document 002: gauge and edge files, E = T⁻¹δ, tilt removal, chaining, the
// regular grid of the volumetric map and its TOML section (see step_gauge.hpp; the simulator is in
// step_gauge_simulate.cpp).
#include "postproc/calibration/step_gauge.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <random>

#include <Eigen/LU>
#include <Eigen/SVD>
#include <fmt/format.h>

#include "postproc/error.hpp"
#include "postproc/io/input_file.hpp"
#include "src/gcode/text.hpp"
#include "src/calibration/step_gauge_tilt.hpp"

namespace postproc::cal {
namespace {

using Eigen::Vector3d;

using gcode::text::iequals;
using gcode::text::trim;

void report(gcode::DiagnosticSink& sink, const SourceRef& at, std::string_view code, std::string message) {
  gcode::Diagnostic d;
  d.code = std::string(code);
  d.file = at.file;
  d.where = at.where;
  d.source_line = at.line;
  d.length = at.length;
  d.message = std::move(message);
  sink.report(std::move(d));
}

std::string where(const SourceRef& at) { return fmt::format("{}:{}", at.file, at.where.line); }

/// The '# <key>:' comment line of the file's header (key compared case-insensitively, or as a
/// prefix when `prefix`), underlining its value. Without the text: line 1 of the file.
SourceRef meta_ref(const std::string& file, std::string_view text, std::string_view key, bool prefix = false) {
  SourceRef r{file, {1, 1}, {}, 1};
  std::uint64_t no = 0;
  while (!text.empty()) {
    const auto nl = text.find('\n');
    std::string_view line = text.substr(0, nl);
    text = nl == std::string_view::npos ? std::string_view{} : text.substr(nl + 1);
    ++no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const std::string_view c = trim(line);
    if (c.empty()) continue;
    if (c.front() != '#') break;  // the header: comments after it are not metadata
    const std::string_view body = c.substr(1);
    const auto colon = body.find(':');
    if (colon == std::string_view::npos) continue;
    const std::string_view k = trim(body.substr(0, colon));
    if (!(prefix ? k.size() >= key.size() && iequals(k.substr(0, key.size()), key) : iequals(k, key))) continue;
    const std::string_view value = trim(body.substr(colon + 1));
    r.line = std::string(line);
    const auto col = value.empty() ? line.size() : static_cast<std::size_t>(value.data() - line.data());
    r.where = {no, static_cast<std::uint32_t>(col + 1)};
    r.length = static_cast<std::uint32_t>(std::max<std::size_t>(value.size(), 1));
    return r;
  }
  return r;
}

SourceRef cell_ref(const CsvTable& t, std::size_t row, int col) {
  const auto& r = t.rows()[row];
  const auto c = static_cast<std::size_t>(col);
  return {t.file(), {r.line, r.at[c]}, r.raw, static_cast<std::uint32_t>(std::max<std::size_t>(r.cells[c].size(), 1))};
}

std::optional<double> parse_number(std::string_view s) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (s.empty() || ec != std::errc() || p != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

/// Columns of a gauge file: pyramid, x, y, z, ax … cy, dA, dB, dC.
bool read_gauge(CsvTable& t, std::string_view text, StepGaugeData& data, Gauge g) {
  auto& sink = t.sink();
  const std::size_t errors = sink.count(gcode::Severity::error);
  double unused = 1;
  const int id_col = t.quantity_column("pyramid", Quantity::ratio, true, unused);
  std::array<int, 3> pos{};
  std::array<double, 3> pos_scale{1, 1, 1};
  for (std::size_t a = 0; a < 3; ++a)
    pos[a] = t.quantity_column(std::string(1, kAxis[a]), Quantity::length, true, pos_scale[a]);
  static constexpr std::string_view kFace[6] = {"ax", "ay", "bx", "by", "cx", "cy"};
  std::array<int, 6> face{};
  for (std::size_t f = 0; f < 6; ++f) face[f] = t.quantity_column(kFace[f], Quantity::ratio, true, unused);
  static constexpr std::string_view kReading[3] = {"dA", "dB", "dC"};
  std::array<int, 3> rd{};
  std::array<double, 3> rd_scale{1, 1, 1};
  for (std::size_t s = 0; s < 3; ++s) rd[s] = t.quantity_column(kReading[s], Quantity::length, true, rd_scale[s]);
  t.report_unused();
  if (sink.count(gcode::Severity::error) > errors) return false;

  for (std::size_t r = 0; r < t.rows().size(); ++r) {
    Pyramid p;
    p.id = t.rows()[r].cells[static_cast<std::size_t>(id_col)];
    p.at = cell_ref(t, r, id_col);
    bool ok = true;
    if (p.id.empty()) {
      t.error(r, id_col, codes::kCsvSyntax, "empty pyramid id; give every pyramid the id marked on the gauge");
      ok = false;
    }
    for (const Pyramid& q : g.pyramids)
      if (!p.id.empty() && q.id == p.id) {
        t.error(r, id_col, codes::kCsvColumns,
                fmt::format("pyramid '{}' is listed twice in gauge '{}' (also line {}); each pyramid once", p.id,
                            g.name, q.at.where.line));
        ok = false;
      }
    for (std::size_t a = 0; a < 3; ++a) {
      const auto v = t.number(r, pos[a], pos_scale[a]);
      ok = ok && v.has_value();
      if (v) p.position[static_cast<Eigen::Index>(a)] = *v;
    }
    for (std::size_t f = 0; f < 6; ++f) {
      const auto v = t.number(r, face[f]);
      ok = ok && v.has_value();
      if (v) p.t(static_cast<Eigen::Index>(f / 2), static_cast<Eigen::Index>(f % 2)) = *v;
    }
    for (std::size_t s = 0; s < 3; ++s) {
      const auto v = t.number(r, rd[s], rd_scale[s]);
      ok = ok && v.has_value();
      if (v) p.reading[static_cast<Eigen::Index>(s)] = *v;
    }
    p.t.col(2).setOnes();
    if (ok) g.pyramids.push_back(std::move(p));
  }
  if (t.rows().empty()) t.error(CsvTable::kHeader, -1, codes::kCsvSyntax, "no pyramid rows; one row per pyramid read");

  const auto has = [&](const std::string& id) {
    return std::any_of(g.pyramids.begin(), g.pyramids.end(), [&](const Pyramid& p) { return p.id == id; });
  };
  const auto ref_meta = t.meta("reference");
  if (g.chain && !has(g.chain->pyramid))
    report(sink, g.chain->at, codes::kCsvColumns,
           fmt::format("'# chain:' names pyramid '{}', which is not a row of gauge '{}'", g.chain->pyramid, g.name));
  if (ref_meta) {
    g.reference = *ref_meta;
    if (!has(g.reference))
      report(sink, meta_ref(t.file(), text, "reference"), codes::kCsvColumns,
             fmt::format("reference pyramid '{}' is not a row of gauge '{}'", g.reference, g.name));
  } else if (g.chain) {
    g.reference = g.chain->pyramid;
  } else if (!g.pyramids.empty()) {
    g.reference = g.pyramids.front().id;
  }
  if (sink.count(gcode::Severity::error) > errors) return false;
  data.gauges.push_back(std::move(g));
  return true;
}

/// Columns of an edge file: edge (x|y), s, reading.
bool read_edges(CsvTable& t, StepGaugeData& data, EdgeScan e) {
  auto& sink = t.sink();
  const std::size_t errors = sink.count(gcode::Severity::error);
  double unused = 1, s_scale = 1, r_scale = 1;
  const int edge_col = t.quantity_column("edge", Quantity::ratio, true, unused);
  const int s_col = t.quantity_column("s", Quantity::length, true, s_scale);
  const int r_col = t.quantity_column("reading", Quantity::length, true, r_scale);
  t.report_unused();
  if (sink.count(gcode::Severity::error) > errors) return false;
  for (std::size_t r = 0; r < t.rows().size(); ++r) {
    const std::string& name = t.rows()[r].cells[static_cast<std::size_t>(edge_col)];
    const int k = iequals(name, "x") ? 0 : iequals(name, "y") ? 1 : -1;
    if (k < 0) t.error(r, edge_col, codes::kCsvRange, fmt::format("edge '{}' is neither x nor y", name));
    const auto s = t.number(r, s_col, s_scale);
    const auto v = t.number(r, r_col, r_scale);
    if (k < 0 || !s || !v) continue;
    e.s[k].push_back(*s);
    e.reading[k].push_back(*v);
  }
  if (sink.count(gcode::Severity::error) > errors) return false;
  for (int k = 0; k < 2; ++k) {
    const auto [lo, hi] = std::minmax_element(e.s[k].begin(), e.s[k].end());
    if (e.s[k].size() < 2 || *hi - *lo < 1e-6)
      t.error(CsvTable::kHeader, edge_col, codes::kCsvRange,
              fmt::format("edge {} of gauge '{}' has {} reading(s); scan each edge at two or more distinct "
                          "positions s",
                          kAxis[k], e.gauge, e.s[k].size()));
  }
  if (sink.count(gcode::Severity::error) > errors) return false;
  data.edges.push_back(std::move(e));
  return true;
}

/// "<pyramid> = <gauge>:<pyramid>"
std::optional<ChainLink> parse_chain(std::string_view v) {
  const auto eq = v.find('=');
  if (eq == std::string_view::npos) return std::nullopt;
  const std::string_view rhs = trim(v.substr(eq + 1));
  const auto colon = rhs.rfind(':');
  if (colon == std::string_view::npos) return std::nullopt;
  ChainLink c{std::string(trim(v.substr(0, eq))), std::string(trim(rhs.substr(0, colon))),
              std::string(trim(rhs.substr(colon + 1))), {}};
  if (c.pyramid.empty() || c.other_gauge.empty() || c.other_pyramid.empty()) return std::nullopt;
  return c;
}

}  // namespace

bool add_step_gauge_file(CsvTable& t, StepGaugeData& data, std::string_view text) {
  auto& sink = t.sink();
  const auto kind = t.meta("kind");
  const bool edge = kind && iequals(*kind, "step-gauge-edge");
  if (!kind || (!edge && !iequals(*kind, "step-gauge"))) {
    const SourceRef at = kind ? meta_ref(t.file(), text, "kind") : SourceRef{};
    const std::string msg = fmt::format("{}; a step-gauge file starts with '# kind: step-gauge' (pyramid readings) or "
                                        "'# kind: step-gauge-edge' (edge scans)",
                                        kind ? fmt::format("kind '{}' is not a step-gauge file", *kind)
                                             : std::string("no '# kind:' line"));
    if (kind && !text.empty()) report(sink, at, codes::kCsvColumns, msg);
    else t.error(CsvTable::kHeader, -1, kind ? codes::kCsvColumns : codes::kCsvMissing, msg);
    return false;
  }
  static constexpr std::array<std::string_view, 5> settings = {"kind", "gauge", "reference", "chain", "reference_error_*"};
  if (!t.check_header_keys(settings, kInformationalKeys)) return false;
  const auto name = t.meta("gauge");
  if (!name || name->empty()) {
    t.error(CsvTable::kHeader, -1, codes::kCsvMissing,
            "no '# gauge: <name>' line before the header; name the gauge placement (chains refer to it)");
    return false;
  }
  const SourceRef gauge_at = meta_ref(t.file(), text, "gauge");
  if (edge) return read_edges(t, data, EdgeScan{*name, {}, {}, gauge_at});

  Gauge g;
  g.name = *name;
  g.at = gauge_at;
  bool ok = true;
  if (const auto chain = t.meta("chain")) {
    const SourceRef at = meta_ref(t.file(), text, "chain");
    g.chain = parse_chain(*chain);
    if (g.chain) {
      g.chain->at = at;
    } else {
      report(sink, at, codes::kCsvSyntax,
             fmt::format("'# chain: {}' is not '<pyramid> = <gauge>:<pyramid>', e.g. '1 = low:12'", *chain));
      ok = false;
    }
  }
  for (const std::string& c : t.comments()) {
    const auto colon = c.find(':');
    const std::string_view key = trim(std::string_view(c).substr(0, colon == std::string::npos ? c.size() : colon));
    if (key.size() < 16 || !iequals(key.substr(0, 16), "reference_error_")) continue;
    const SourceRef at = meta_ref(t.file(), text, key);
    const auto factor = unit_factor(key.substr(16), Quantity::length);
    std::vector<double> v;
    std::string_view rest = colon == std::string::npos ? std::string_view{} : std::string_view(c).substr(colon + 1);
    while (!trim(rest).empty()) {
      const auto comma = rest.find(',');
      const auto n = parse_number(rest.substr(0, comma));
      if (!n) break;
      v.push_back(*n);
      rest = comma == std::string_view::npos ? std::string_view{} : rest.substr(comma + 1);
    }
    if (!factor || v.size() != 3 || !trim(rest).empty()) {
      report(sink, at, factor ? codes::kCsvNumber : codes::kCsvUnit,
             "write the reference pyramid's known error as '# reference_error_um: ex, ey, ez' (any length unit)");
      ok = false;
    } else {
      g.reference_error = Vector3d(v[0], v[1], v[2]) * *factor;
    }
  }
  return read_gauge(t, text, data, std::move(g)) && ok;
}

bool add_step_gauge_text(std::string file, std::string_view text, StepGaugeData& data, gcode::DiagnosticSink& sink) {
  auto t = CsvTable::parse(std::move(file), text, sink);
  return t && add_step_gauge_file(*t, data, text);
}

std::optional<StepGaugeData> read_step_gauge(std::span<const std::string> paths, gcode::DiagnosticSink& sink) {
  StepGaugeData data;
  bool ok = true;
  for (const std::string& path : paths) {
    ok = add_step_gauge_text(path, io::read_file(path, "measurement file"), data, sink) && ok;
  }
  if (!ok) return std::nullopt;
  return data;
}

// ---------------------------------------------------------------------------------------------

namespace {

struct Fit {
  double slope = 0;
  double rms = 0;
};

Fit line_fit(const std::vector<double>& s, const std::vector<double>& r) {
  const double n = static_cast<double>(s.size());
  double sm = 0, rm = 0;
  for (std::size_t i = 0; i < s.size(); ++i) sm += s[i] / n, rm += r[i] / n;
  double sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < s.size(); ++i) sxx += (s[i] - sm) * (s[i] - sm), sxy += (s[i] - sm) * (r[i] - rm);
  Fit f;
  f.slope = sxy / sxx;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const double e = r[i] - rm - f.slope * (s[i] - sm);
    f.rms += e * e / n;
  }
  f.rms = std::sqrt(f.rms);
  return f;
}

std::string vec(const Vector3d& v) { return fmt::format("({:g}, {:g}, {:g})", v.x(), v.y(), v.z()); }

/// Chains: the offset added to each gauge's relative errors. Depth-first with cycle detection.
struct Chainer {
  const StepGaugeData& data;
  const std::map<std::string, std::size_t>& index;
  const std::vector<std::vector<Vector3d>>& rel;
  double tol;
  gcode::DiagnosticSink& sink;
  std::vector<int> state;  // 0 new, 1 on the stack, 2 done, 3 failed
  std::vector<Vector3d> offset;
  std::vector<std::size_t> stack;

  std::size_t find(const Gauge& g, const std::string& id) const {
    for (std::size_t i = 0; i < g.pyramids.size(); ++i)
      if (g.pyramids[i].id == id) return i;
    return g.pyramids.size();
  }

  bool visit(std::size_t gi) {
    if (state[gi] == 2) return true;
    if (state[gi] == 3) return false;
    const Gauge& g = data.gauges[gi];
    state[gi] = 1;
    stack.push_back(gi);
    bool ok = true;
    if (!g.chain) {
      offset[gi] = g.reference_error.value_or(Vector3d::Zero());
    } else {
      const ChainLink& c = *g.chain;
      const auto it = index.find(c.other_gauge);
      std::size_t oi = 0, om = 0;
      if (it == index.end()) {
        std::string known;
        for (const auto& [name, _] : index) known += (known.empty() ? "" : ", ") + name;
        report(sink, c.at, codes::kCsvColumns,
               fmt::format("gauge '{}' chains to gauge '{}', which no file names (gauges: {}); give its file too or "
                           "correct the name",
                           g.name, c.other_gauge, known));
        ok = false;
      } else if (oi = it->second; state[oi] == 1) {
        std::string cycle;
        for (auto s = std::find(stack.begin(), stack.end(), oi); s != stack.end(); ++s)
          cycle += data.gauges[*s].name + " → ";
        report(sink, c.at, codes::kCsvColumns,
               fmt::format("chain cycle {}{}: every chain must end at one root gauge without '# chain:'", cycle,
                           c.other_gauge));
        ok = false;
      } else if (!visit(oi)) {
        ok = false;
      } else if (om = find(data.gauges[oi], c.other_pyramid); om == data.gauges[oi].pyramids.size()) {
        report(sink, c.at, codes::kCsvColumns,
               fmt::format("gauge '{}' has no pyramid '{}'", c.other_gauge, c.other_pyramid));
        ok = false;
      } else if (g.reference_error) {
        report(sink, g.at, codes::kCsvColumns,
               fmt::format("gauge '{}' is chained, so its reference error comes from gauge '{}'; remove its "
                           "'# reference_error' line",
                           g.name, c.other_gauge));
        ok = false;
      } else {
        const std::size_t k = find(g, c.pyramid);
        if (k == g.pyramids.size()) {
          report(sink, c.at, codes::kCsvColumns, fmt::format("gauge '{}' has no pyramid '{}'", g.name, c.pyramid));
          stack.pop_back();
          state[gi] = 3;
          return false;
        }
        const Vector3d d = g.pyramids[k].position - data.gauges[oi].pyramids[om].position;
        if (d.cwiseAbs().maxCoeff() > tol) {
          report(sink, c.at, codes::kCsvColumns,
                 fmt::format("chained pyramids are not at the same place: {}:{} at {} mm, {}:{} at {} mm; a chain "
                             "joins two readings of one machine position",
                             g.name, c.pyramid, vec(g.pyramids[k].position), c.other_gauge, c.other_pyramid,
                             vec(data.gauges[oi].pyramids[om].position)));
          ok = false;
        } else {
          // E_OP = E_OO' + E_O'P: the linked pyramid's absolute error, then this gauge relative to it.
          offset[gi] = offset[oi] + rel[oi][om] - rel[gi][k];
        }
      }
    }
    stack.pop_back();
    state[gi] = ok ? 2 : 3;
    return ok;
  }
};

/// Node planes along one axis: coordinates closer than tol are one plane (mean, member count).
struct Plane {
  double at = 0;
  std::size_t members = 0;
};

std::vector<Plane> planes(std::vector<double> v, double tol) {
  std::sort(v.begin(), v.end());
  std::vector<Plane> c;
  std::size_t start = 0;
  for (std::size_t i = 1; i <= v.size(); ++i)
    if (i == v.size() || v[i] - v[start] > tol) {
      double sum = 0;
      for (std::size_t j = start; j < i; ++j) sum += v[j];
      c.push_back({sum / static_cast<double>(i - start), i - start});
      start = i;
    }
  return c;
}

/// The regular grid along one axis that holds the most pyramids: the spacing is the most supported
/// gap between neighbouring planes (weighted by their pyramids), the origin the plane from which
/// most pyramids lie on whole multiples of it. A lone misplaced pyramid then is the one off the
/// grid, not its correct neighbours; a missing plane shows as missing nodes.
struct AxisGrid {
  double origin = 0, spacing = 0;
  int count = 0;
  [[nodiscard]] bool on(double x, double tol) const {
    return std::abs(x - (origin + std::round((x - origin) / spacing) * spacing)) <= tol;
  }
};

AxisGrid axis_grid(const std::vector<Plane>& c, double tol) {
  double h = 0;
  std::size_t best = 0;
  for (std::size_t i = 0; i + 1 < c.size(); ++i) {
    const double g = c[i + 1].at - c[i].at;
    std::size_t support = 0;
    for (std::size_t j = 0; j + 1 < c.size(); ++j)
      if (std::abs(c[j + 1].at - c[j].at - g) <= 2 * tol) support += std::min(c[j].members, c[j + 1].members);
    if (support > best) best = support, h = g;
  }
  AxisGrid grid{c.front().at, h, 0};
  best = 0;
  for (const Plane& o : c) {
    const AxisGrid trial{o.at, h, 0};
    std::size_t support = 0;
    for (const Plane& p : c)
      if (trial.on(p.at, tol)) support += p.members;
    if (support > best) best = support, grid.origin = o.at;
  }
  double lo = grid.origin, hi = grid.origin;
  for (const Plane& p : c)
    if (grid.on(p.at, tol)) lo = std::min(lo, p.at), hi = std::max(hi, p.at);
  grid.count = static_cast<int>(std::lround((hi - lo) / h)) + 1;
  grid.origin = lo;
  if (grid.count > 1) grid.spacing = (hi - lo) / (grid.count - 1);
  return grid;
}

}  // namespace

std::optional<kin::VolumetricMap> build_volumetric_map(const StepGaugeData& data, const StepGaugeOptions& options,
                                                       gcode::DiagnosticSink& sink, StepGaugeReport* report_out) {
  const std::size_t errors = sink.count(gcode::Severity::error);
  const auto failed = [&] { return sink.count(gcode::Severity::error) > errors; };
  const double tol = options.grid_tolerance_mm;
  StepGaugeReport rep;

  std::map<std::string, std::size_t> index;
  for (std::size_t i = 0; i < data.gauges.size(); ++i) {
    const Gauge& g = data.gauges[i];
    if (const auto [it, fresh] = index.emplace(g.name, i); !fresh)
      report(sink, g.at, codes::kCsvColumns,
             fmt::format("gauge '{}' is also defined at {}; give each placement its own name", g.name,
                         where(data.gauges[it->second].at)));
  }
  if (data.gauges.empty()) {
    report(sink, {}, codes::kCsvMissing, "no step-gauge file (# kind: step-gauge) was given");
    return std::nullopt;
  }

  // Tilt per gauge from its edge scans.
  std::vector<Eigen::Vector2d> theta(data.gauges.size(), Eigen::Vector2d::Zero());
  rep.tilts.resize(data.gauges.size());
  for (std::size_t i = 0; i < data.gauges.size(); ++i) rep.tilts[i].gauge = data.gauges[i].name;
  std::vector<const EdgeScan*> edge_of(data.gauges.size(), nullptr);
  for (const EdgeScan& e : data.edges) {
    const auto it = index.find(e.gauge);
    if (it == index.end()) {
      report(sink, e.at, codes::kCsvColumns,
             fmt::format("edge scans of gauge '{}', but no gauge file names it; check '# gauge:'", e.gauge));
      continue;
    }
    if (edge_of[it->second] != nullptr) {
      report(sink, e.at, codes::kCsvColumns,
             fmt::format("gauge '{}' already has edge scans at {}; give one edge file per gauge", e.gauge,
                         where(edge_of[it->second]->at)));
      continue;
    }
    edge_of[it->second] = &e;
    auto& tilt = rep.tilts[it->second];
    tilt.measured = true;
    for (int k = 0; k < 2; ++k) {
      const Fit f = line_fit(e.s[k], e.reading[k]);
      tilt.theta[k] = f.slope;
      tilt.rms[k] = f.rms;
    }
    theta[it->second] = tilt.theta;
  }

  // E = T⁻¹δ relative to the reference pyramid, tilt removed.
  std::vector<std::vector<Vector3d>> rel(data.gauges.size());
  std::vector<std::vector<double>> gain(data.gauges.size());
  for (std::size_t gi = 0; gi < data.gauges.size(); ++gi) {
    const Gauge& g = data.gauges[gi];
    const Pyramid* ref = nullptr;
    for (const Pyramid& p : g.pyramids) {
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(p.t);
      const Vector3d sv = svd.singularValues();
      gain[gi].push_back(sv[2] > 0 ? 1 / sv[2] : std::numeric_limits<double>::infinity());
      if (!(sv[2] >= options.min_condition * sv[0])) {
        report(sink, p.at, codes::kCsvRange,
               fmt::format("pyramid '{}' of gauge '{}': T = [[ax, ay, 1], [bx, by, 1], [cx, cy, 1]] is singular "
                           "(σmin/σmax = {:.2g}); the face points (ax, ay), (bx, by), (cx, cy) lie on a line — "
                           "check the face coefficients",
                           p.id, g.name, sv[0] > 0 ? sv[2] / sv[0] : 0.0));
        rel[gi].push_back(Vector3d::Zero());
        continue;
      }
      rel[gi].push_back(p.t.partialPivLu().solve(p.reading));
      if (p.id == g.reference) ref = &p;
    }
    if (ref == nullptr) {
      if (!failed())  // else: reported (singular T at the reference)
        report(sink, g.at, codes::kCsvColumns,
               fmt::format("gauge '{}' has no reference pyramid '{}'", g.name, g.reference));
      continue;
    }
    const Vector3d e_ref = rel[gi][static_cast<std::size_t>(ref - g.pyramids.data())];
    for (std::size_t i = 0; i < g.pyramids.size(); ++i)
      rel[gi][i] += tilt_shift(theta[gi], g.pyramids[i].position - ref->position) - e_ref;
  }
  if (failed()) return std::nullopt;

  // Chains and the single root.
  Chainer chainer{data, index, rel, tol, sink, std::vector<int>(data.gauges.size(), 0),
                  std::vector<Vector3d>(data.gauges.size(), Vector3d::Zero()), {}};
  const Gauge* root = nullptr;
  for (std::size_t gi = 0; gi < data.gauges.size(); ++gi) {
    chainer.visit(gi);
    const Gauge& g = data.gauges[gi];
    if (g.chain) continue;
    if (root != nullptr)
      report(sink, g.at, codes::kCsvColumns,
             fmt::format("gauge '{}' has no '# chain:' line, but '{}' ({}) is the root already; chain it: '# chain: "
                         "{} = <gauge>:<pyramid at the same place>'",
                         g.name, root->name, where(root->at), g.reference));
    else root = &g;
  }
  if (failed()) return std::nullopt;

  // The nodes: every pyramid, except the chained pyramid that repeats its link.
  struct Node {
    std::size_t g, p;
  };
  std::vector<Node> nodes;
  for (std::size_t gi = 0; gi < data.gauges.size(); ++gi) {
    const Gauge& g = data.gauges[gi];
    for (std::size_t p = 0; p < g.pyramids.size(); ++p) {
      const Vector3d e = chainer.offset[gi] + rel[gi][p];
      rep.points.push_back({g.name, g.pyramids[p].id, g.pyramids[p].position, e, gain[gi][p]});
      rep.max_error = std::max(rep.max_error, e.norm());
      if (!(g.chain && g.chain->pyramid == g.pyramids[p].id)) nodes.push_back({gi, p});
    }
  }
  const auto pyr = [&](const Node& n) -> const Pyramid& { return data.gauges[n.g].pyramids[n.p]; };
  const auto name = [&](const Node& n) { return fmt::format("pyramid '{}' of gauge '{}'", pyr(n).id, data.gauges[n.g].name); };

  // The regular grid.
  Vector3d origin, spacing;
  Eigen::Vector3i counts;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> v;
    for (const Node& n : nodes) v.push_back(pyr(n).position[a]);
    const std::vector<Plane> c = planes(v, tol);
    const AxisGrid grid = c.size() < 2 ? AxisGrid{} : axis_grid(c, tol);
    if (grid.count < 2) {
      report(sink, root->at, codes::kCsvColumns,
             fmt::format("every pyramid lies at {} = {:g} mm: a volumetric map needs two or more node planes along "
                         "{}; chain a gauge placed at another {}",
                         kAxis[a], c.front().at, kAxis[a], kAxis[a]));
      continue;
    }
    if (grid.count > 1000) {
      report(sink, root->at, codes::kCsvColumns,
             fmt::format("the pyramids' {} coordinates make a grid of {} planes {:g} mm apart (at most 1000); check "
                         "the positions",
                         kAxis[a], grid.count, grid.spacing));
      continue;
    }
    origin[a] = grid.origin;
    spacing[a] = grid.spacing;
    counts[a] = grid.count;
    std::size_t off = 0;
    for (const Node& n : nodes)
      if (!grid.on(pyr(n).position[a], tol) && ++off <= 20)
        report(sink, pyr(n).at, codes::kCsvColumns,
               fmt::format("{} at {} = {:g} mm is off the regular grid ({} = {:g} + k·{:g} mm, tolerance {:g} mm); "
                           "the pyramids of all gauges must form one regular grid",
                           name(n), kAxis[a], pyr(n).position[a], kAxis[a], grid.origin, grid.spacing, tol));
  }
  if (failed()) return std::nullopt;

  std::vector<int> slot(static_cast<std::size_t>(counts.prod()), -1);
  const auto node_index = [&](const Vector3d& p) {
    const Eigen::Vector3i i = ((p - origin).cwiseQuotient(spacing)).array().round().cast<int>();
    return static_cast<std::size_t>(i[0] + counts[0] * (i[1] + counts[1] * i[2]));
  };
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    int& s = slot[node_index(pyr(nodes[k]).position)];
    if (s >= 0) {
      const Node& first = nodes[static_cast<std::size_t>(s)];
      report(sink, pyr(nodes[k]).at, codes::kCsvColumns,
             fmt::format("{} is at node {} mm, already measured by {} ({}); each node once — remove one, or join "
                         "them with '# chain:'",
                         name(nodes[k]), vec(pyr(nodes[k]).position), name(first), where(pyr(first).at)));
    } else {
      s = static_cast<int>(k);
    }
  }
  std::size_t missing = 0;
  for (std::size_t n = 0; n < slot.size(); ++n) {
    if (slot[n] >= 0) continue;
    const int i = static_cast<int>(n) % counts[0], j = (static_cast<int>(n) / counts[0]) % counts[1],
              k = static_cast<int>(n) / (counts[0] * counts[1]);
    const Vector3d p = origin + spacing.cwiseProduct(Vector3d(i, j, k));
    if (++missing > 20) continue;
    const auto near = std::min_element(nodes.begin(), nodes.end(), [&](const Node& a, const Node& b) {
      return (pyr(a).position - p).norm() < (pyr(b).position - p).norm();
    });
    report(sink, pyr(*near).at, codes::kCsvColumns,
           fmt::format("grid node [{}, {}, {}] at {} mm has no pyramid (nearest: {}); the pyramids of all gauges "
                       "must fill the {} × {} × {} grid",
                       i, j, k, vec(p), name(*near), counts[0], counts[1], counts[2]));
  }
  if (missing > 20)
    report(sink, root->at, codes::kCsvColumns, fmt::format("{} more grid nodes have no pyramid", missing - 20));
  if (failed()) return std::nullopt;

  std::vector<Vector3d> values;
  for (const int s : slot) {
    const Node& n = nodes[static_cast<std::size_t>(s)];
    values.push_back(chainer.offset[n.g] + rel[n.g][n.p]);
  }
  if (report_out != nullptr) *report_out = std::move(rep);
  return kin::VolumetricMap(origin, spacing, counts, std::move(values), options.interpolation, options.outside);
}

std::string volumetric_map_toml(const kin::VolumetricMap& map) {
  const auto v3 = [](const auto& v) { return fmt::format("[{}, {}, {}]", v[0], v[1], v[2]); };
  std::string s = "[volumetric_map]\n";
  s += fmt::format("origin = {}    # mm, machine coordinates of the first node\n", v3(map.origin()));
  s += fmt::format("spacing = {}   # mm\n", v3(map.spacing()));
  s += fmt::format("counts = {}\n", v3(map.counts()));
  s += "unit = \"um\"\n";
  s += fmt::format("interpolation = \"{}\"\n",
                   map.interpolation() == kin::VolumetricMap::Interpolation::smooth ? "smooth" : "trilinear");
  const auto o = map.outside();
  s += fmt::format("outside = \"{}\"\n", o == kin::VolumetricMap::Outside::clamp  ? "clamp"
                                         : o == kin::VolumetricMap::Outside::zero ? "zero"
                                                                                  : "refuse");
  s += "errors = [   # [Ex, Ey, Ez] per node, x fastest, then y, then z\n";
  const auto& c = map.counts();
  for (std::size_t n = 0; n < map.values().size(); ++n) {
    const Vector3d e = map.values()[n] * 1000.0 + Vector3d::Zero();  // + 0: no "-0.0000"
    const int i = static_cast<int>(n) % c[0], j = (static_cast<int>(n) / c[0]) % c[1], k = static_cast<int>(n) / (c[0] * c[1]);
    s += fmt::format("  [{:.4f}, {:.4f}, {:.4f}],   # [{}, {}, {}]\n", e.x(), e.y(), e.z(), i, j, k);
  }
  s += "]\n";
  return s;
}

}  // namespace postproc::cal
