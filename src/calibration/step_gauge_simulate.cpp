// The step-gauge simulator: the readings gauges would give on a machine with a known error field
// (see step_gauge.hpp).
#include <cmath>
#include <random>
#include <span>

#include <fmt/format.h>

#include "postproc/calibration/step_gauge.hpp"
#include "postproc/error.hpp"
#include "src/calibration/step_gauge_tilt.hpp"

namespace postproc::cal {

using Eigen::Vector3d;

std::vector<GaugeLayout> grid_layouts(const Vector3d& origin, const Vector3d& spacing, const Eigen::Vector3i& counts,
                                      std::span<const Eigen::Vector2d> tilts, std::uint64_t seed) {
  std::vector<GaugeLayout> g;
  for (int k = 0; k < counts.z(); ++k) {
    const Vector3d o = origin + Vector3d(0, 0, k * spacing.z());
    g.push_back(plate_layout(fmt::format("plate{}", k + 1), o, spacing.head<2>(), counts.x(), counts.y(),
                             seed + static_cast<std::uint64_t>(k)));
    if (!tilts.empty()) g.back().tilt = tilts[static_cast<std::size_t>(k) % tilts.size()];
    if (k == 0) g.back().write_reference_error = true;
    else g.back().chain = fmt::format("1 = column:{}", k + 1);
  }
  GaugeLayout column = plate_layout("column", origin, spacing.head<2>(), 1, 1, seed + 1000);
  column.pyramids.clear();
  for (int k = 0; k < counts.z(); ++k) {
    PyramidLayout p = g.front().pyramids.front();
    p.id = std::to_string(k + 1);
    p.position = origin + Vector3d(0, 0, k * spacing.z());
    column.pyramids.push_back(p);
  }
  column.reference = "1";
  column.chain = "1 = plate1:1";
  column.edges = false;
  g.push_back(column);
  return g;
}

GaugeLayout plate_layout(std::string name, const Vector3d& origin, const Eigen::Vector2d& spacing, int nx, int ny,
                         std::uint64_t seed) {
  constexpr double kDeg = 3.14159265358979323846 / 180;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> turn(-3 * kDeg, 3 * kDeg);
  GaugeLayout g;
  g.name = std::move(name);
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      PyramidLayout p;
      p.id = std::to_string(1 + i + nx * j);
      p.position = origin + Vector3d(i * spacing.x(), j * spacing.y(), 0);
      const double rot = turn(rng);
      for (int f = 0; f < 3; ++f) {
        const double azimuth = (90 + 120 * f) * kDeg + rot;
        const double slope = std::tan(40 * kDeg + turn(rng) / 1.5);
        p.faces.row(f) << slope * std::cos(azimuth), slope * std::sin(azimuth);
      }
      g.pyramids.push_back(std::move(p));
    }
  g.reference = g.pyramids.front().id;
  return g;
}

std::vector<SimulatedGauge> simulate_step_gauge(const std::function<Vector3d(const Vector3d&)>& field,
                                                std::span<const GaugeLayout> layouts, const StepGaugeSimulateOptions& o) {
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto noise = [&] { return o.noise_mm * unit(rng); };
  const auto num = [&](double v, int extra = 0) {
    v += 0.0;  // no "-0"
    return o.decimals < 0 ? fmt::format("{}", v) : fmt::format("{:.{}f}", v, o.decimals + extra);
  };
  std::string head;
  for (std::size_t a = 0, b = 0; !o.comment.empty() && a <= o.comment.size(); a = b + 1) {
    b = std::min(o.comment.find('\n', a), o.comment.size());
    head += "# " + o.comment.substr(a, b - a) + "\n";
  }
  std::vector<SimulatedGauge> out;
  for (const GaugeLayout& g : layouts) {
    const auto ref = std::find_if(g.pyramids.begin(), g.pyramids.end(),
                                  [&](const PyramidLayout& p) { return p.id == g.reference; });
    if (ref == g.pyramids.end())
      throw Error(ExitCode::usage, fmt::format("simulate: gauge '{}' has no reference pyramid '{}'", g.name, g.reference));
    const Vector3d e_ref = field(ref->position);
    SimulatedGauge s;
    s.gauge_csv = head + "# kind: step-gauge\n# gauge: " + g.name + "\n# reference: " + g.reference + "\n";
    if (g.chain) s.gauge_csv += "# chain: " + *g.chain + "\n";
    if (g.write_reference_error)
      s.gauge_csv += fmt::format("# reference_error_um: {}, {}, {}\n", num(e_ref.x() * 1000), num(e_ref.y() * 1000),
                                 num(e_ref.z() * 1000));
    s.gauge_csv += "pyramid,x_mm,y_mm,z_mm,ax,ay,bx,by,cx,cy,dA_um,dB_um,dC_um\n";
    for (const PyramidLayout& p : g.pyramids) {
      // The tool's error relative to the reference, minus the pyramid's shift by the plate's tilt.
      const Vector3d e = field(p.position) - e_ref - tilt_shift(g.tilt, p.position - ref->position);
      Eigen::Matrix3d t;
      t << p.faces, Vector3d::Ones();
      // The sensors were zeroed at the reference pyramid: its readings are 0 by definition.
      const bool zeroed = &p == &*ref;
      const Vector3d d = t * e + (zeroed ? Vector3d::Zero() : Vector3d(noise(), noise(), noise()));
      s.gauge_csv += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{}\n", p.id, num(p.position.x()),
                                 num(p.position.y()), num(p.position.z()), num(p.faces(0, 0), 2), num(p.faces(0, 1), 2),
                                 num(p.faces(1, 0), 2), num(p.faces(1, 1), 2), num(p.faces(2, 0), 2),
                                 num(p.faces(2, 1), 2), num(d.x() * 1000), num(d.y() * 1000), num(d.z() * 1000));
    }
    if (g.edges) {
      s.edge_csv = head + "# kind: step-gauge-edge\n# gauge: " + g.name + "\nedge,s_mm,reading_um\n";
      for (int k = 0; k < 2; ++k) {
        double lo = 0, hi = 0;
        for (const PyramidLayout& p : g.pyramids) lo = std::min(lo, p.position[k] - ref->position[k]);
        for (const PyramidLayout& p : g.pyramids) hi = std::max(hi, p.position[k] - ref->position[k]);
        if (hi - lo < 1) hi = lo + 100;
        const int n = std::max(g.edge_points, 2);
        for (int i = 0; i < n; ++i) {
          const double sv = lo + (hi - lo) * i / (n - 1);
          s.edge_csv += fmt::format("{},{},{}\n", kAxis[k], num(sv), num((0.012 + g.tilt[k] * sv + noise()) * 1000));
        }
      }
    }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace postproc::cal
