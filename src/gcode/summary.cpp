#include "postproc/gcode/summary.hpp"

#include <cmath>
#include <numbers>

namespace postproc::gcode {
namespace {

/// Widens [min, max] by the quadrant points an arc passes through (its bulge beyond its ends).
void add_arc_bulge(const Motion& m, AxisVector& min, AxisVector& max) {
  const PlaneAxes axes = plane_axes(m.plane);
  const int u = axes.u, v = axes.v;
  const double a0 = std::atan2(m.start[v] - m.arc.centre[v], m.start[u] - m.arc.centre[u]);
  const double lo = std::min(a0, a0 + m.arc.sweep), hi = std::max(a0, a0 + m.arc.sweep);
  const double quarter = std::numbers::pi / 2;
  for (double k = std::ceil(lo / quarter); k * quarter <= hi && k <= std::ceil(lo / quarter) + 4; k += 1) {
    const double pu = m.arc.centre[u] + m.arc.radius * std::cos(k * quarter);
    const double pv = m.arc.centre[v] + m.arc.radius * std::sin(k * quarter);
    min[u] = std::min(min[u], pu);
    max[u] = std::max(max[u], pu);
    min[v] = std::min(min[v], pv);
    max[v] = std::max(max[v], pv);
  }
}

}  // namespace

void ProgramSummary::add(const Motion& m) {
  ++motions_by_type[static_cast<std::size_t>(m.type)];
  axes_used |= m.programmed;
  if (m.frame == Frame::machine) {
    ++machine_frame_moves;
  } else {
    for (int a = 0; a < kAxisCount; ++a)
      if ((m.known >> a) & 1u) {
        min[a] = std::min(min[a], m.end[a]);
        max[a] = std::max(max[a], m.end[a]);
      }
    if (m.type == MotionType::arc_cw || m.type == MotionType::arc_ccw) add_arc_bulge(m, min, max);
  }
  if (m.type != MotionType::rapid && m.feed_known) {
    auto& f = feeds[static_cast<std::size_t>(m.feed_mode)];
    f.min = std::min(f.min, m.feed);
    f.max = std::max(f.max, m.feed);
    ++f.count;
  }
}

std::uint64_t ProgramSummary::motions() const {
  std::uint64_t n = 0;
  for (auto c : motions_by_type) n += c;
  return n;
}

}  // namespace postproc::gcode
