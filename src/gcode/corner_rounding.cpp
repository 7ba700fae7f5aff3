// Rounding arc between two path elements (corner_rounding.hpp).
#include "src/gcode/corner_rounding.hpp"

#include <cmath>
#include <numbers>
#include <vector>

namespace postproc::gcode {
namespace {

/// One element of a corner in plane coordinates: a line or an arc, with its direction at `at`.
struct Element {
  bool arc = false;
  bool ccw = false;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double radius = 0;
  Eigen::Vector2d point = Eigen::Vector2d::Zero(), dir = Eigen::Vector2d::Zero();  ///< lines: a point and the unit direction

  static Element of(const Motion& m, PlaneAxes p) {
    Element e;
    const Eigen::Vector2d s(m.start[p.u], m.start[p.v]), t(m.end[p.u], m.end[p.v]);
    if (m.type == MotionType::arc_cw || m.type == MotionType::arc_ccw) {
      e.arc = true;
      e.ccw = m.type == MotionType::arc_ccw;
      e.centre = Eigen::Vector2d(m.arc.centre[p.u], m.arc.centre[p.v]);
      e.radius = m.arc.radius;
    } else {
      e.point = s;
      e.dir = (t - s).normalized();
    }
    return e;
  }
  /// Unit tangent in the direction of travel at `x` (on the element).
  [[nodiscard]] Eigen::Vector2d tangent(const Eigen::Vector2d& x) const {
    if (!arc) return dir;
    const Eigen::Vector2d r = (x - centre).normalized();
    return ccw ? Eigen::Vector2d(-r.y(), r.x()) : Eigen::Vector2d(r.y(), -r.x());
  }
  /// The element's point nearest `q` (the foot of the perpendicular / the radial point).
  [[nodiscard]] Eigen::Vector2d foot(const Eigen::Vector2d& q) const {
    if (!arc) return point + (q - point).dot(dir) * dir;
    return centre + radius * (q - centre).normalized();
  }
};

}  // namespace

double sweep_between(const Eigen::Vector2d& c, const Eigen::Vector2d& a, const Eigen::Vector2d& b, bool ccw) {
  const Eigen::Vector2d u = a - c, v = b - c;
  double s = std::atan2(u.x() * v.y() - u.y() * v.x(), u.dot(v));
  if (ccw && s < 0) s += 2 * std::numbers::pi;
  if (!ccw && s > 0) s -= 2 * std::numbers::pi;
  return s;
}

namespace {

/// Centres of circles of radius r tangent to both elements on side `side` (+1 left of travel,
/// −1 right): the intersections of the two elements offset by r to that side.
std::vector<Eigen::Vector2d> tangent_centres(const Element& e1, const Element& e2, double r, double side) {
  std::vector<Eigen::Vector2d> out;
  const auto offset_radius = [&](const Element& e) { return e.radius - (e.ccw ? 1.0 : -1.0) * side * r; };
  const auto line_circle = [&](const Element& l, const Eigen::Vector2d& c, double rad) {
    const Eigen::Vector2d nrm(-l.dir.y(), l.dir.x());
    const Eigen::Vector2d p0 = l.point + side * r * nrm;
    const Eigen::Vector2d f = p0 + (c - p0).dot(l.dir) * l.dir;  // foot of the centre on the offset line
    const double h2 = rad * rad - (f - c).squaredNorm();
    if (h2 < -1e-12 || rad <= 0) return;
    const double h = std::sqrt(std::max(0.0, h2));
    out.push_back(f - h * l.dir);
    out.push_back(f + h * l.dir);
  };
  if (!e1.arc && e2.arc) line_circle(e1, e2.centre, offset_radius(e2));
  else if (e1.arc && !e2.arc) line_circle(e2, e1.centre, offset_radius(e1));
  else if (e1.arc && e2.arc) {
    const double r1 = offset_radius(e1), r2 = offset_radius(e2);
    const Eigen::Vector2d d = e2.centre - e1.centre;
    const double dist = d.norm();
    if (r1 <= 0 || r2 <= 0 || dist < 1e-12 || dist > r1 + r2 + 1e-12 || dist < std::abs(r1 - r2) - 1e-12) return out;
    const double a = (r1 * r1 - r2 * r2 + dist * dist) / (2 * dist);
    const double h = std::sqrt(std::max(0.0, r1 * r1 - a * a));
    const Eigen::Vector2d mid = e1.centre + a * d / dist, perp(-d.y() / dist, d.x() / dist);
    out.push_back(mid - h * perp);
    out.push_back(mid + h * perp);
  }
  return out;
}

}  // namespace

std::optional<RoundingArc> rounding_arc(const Motion& m, const Motion& n, PlaneAxes p, double r, std::string& why,
                                        bool& stops) {
  stops = false;
  const bool m_arc = m.type == MotionType::arc_cw || m.type == MotionType::arc_ccw;
  const bool n_arc = n.type == MotionType::arc_cw || n.type == MotionType::arc_ccw;
  if ((m_arc && (m.arc.turns != 1 || m.arc.full_circle || std::abs(m.arc.sweep) >= 2 * std::numbers::pi)) ||
      (n_arc && (n.arc.turns != 1 || n.arc.full_circle || std::abs(n.arc.sweep) >= 2 * std::numbers::pi))) {
    why = "a rounding at a full circle or a multi-turn arc";
    return std::nullopt;
  }
  const Eigen::Vector2d s1(m.start[p.u], m.start[p.v]), p1(m.end[p.u], m.end[p.v]), e2(n.end[p.u], n.end[p.v]);
  if ((p1 - s1).norm() < 1e-9 || (e2 - p1).norm() < 1e-9) {
    why = "one of the two moves has no length in the plane";
    return std::nullopt;
  }
  const Element a = Element::of(m, p), b = Element::of(n, p);
  const Eigen::Vector2d t1 = a.tangent(p1), t2 = b.tangent(p1);
  const double cross = t1.x() * t2.y() - t1.y() * t2.x();
  if (std::abs(cross) < 1e-9) {
    why = "the two moves meet tangentially (no corner), or the second reverses the first";
    return std::nullopt;
  }
  const double side = cross > 0 ? 1.0 : -1.0;
  // Of the candidate centres, the one nearest the corner whose tangent points lie on both elements.
  const auto on_element = [&](const Element& e, const Motion& mo, const Eigen::Vector2d& x) {
    const Eigen::Vector2d st(mo.start[p.u], mo.start[p.v]), en(mo.end[p.u], mo.end[p.v]);
    if (!e.arc) {
      const double len = (en - st).norm(), t = (x - st).dot(e.dir);
      return t >= -1e-9 && t <= len + 1e-9;
    }
    const double full = std::abs(mo.arc.sweep), part = std::abs(sweep_between(e.centre, st, x, e.ccw));
    return part <= full + 1e-9 || std::abs(part - 2 * std::numbers::pi) < 1e-9;
  };
  std::optional<RoundingArc> best;
  double best_d = 0;
  for (const Eigen::Vector2d& cand : tangent_centres(a, b, r, side)) {
    const Eigen::Vector2d f1 = a.foot(cand), f2 = b.foot(cand);
    if (!on_element(a, m, f1) || !on_element(b, n, f2)) continue;
    const double d = (cand - p1).norm();
    if (!best || d < best_d) {
      best = RoundingArc{cand, f1, f2, side > 0};
      best_d = d;
    }
  }
  if (!best) {
    why = "the rounding does not fit on the two moves";
    stops = true;
  }
  return best;
}

namespace {
bool is_arc(const Motion& m) { return m.type == MotionType::arc_cw || m.type == MotionType::arc_ccw; }
Eigen::Vector2d in_plane(const Eigen::Vector3d& v, PlaneAxes p) { return {v[p.u], v[p.v]}; }
Eigen::Vector2d in_plane(const AxisVector& v, PlaneAxes p) { return {v[p.u], v[p.v]}; }
}  // namespace

Motion round_corner(Motion& first, PlaneAxes p, const RoundingArc& ra, double r) {
  Motion e = first;
  const Eigen::Vector2d start = in_plane(first.start, p);
  first.end[p.u] = ra.from.x();
  first.end[p.v] = ra.from.y();
  if (is_arc(first))
    first.arc.sweep = sweep_between(in_plane(first.arc.centre, p), start, ra.from, first.type == MotionType::arc_ccw);
  e.start = first.end;
  e.end = first.end;
  e.end[p.u] = ra.to.x();
  e.end[p.v] = ra.to.y();
  e.programmed = 0;
  e.word_index.fill(-1);
  e.words_transformed = true;
  e.type = ra.ccw ? MotionType::arc_ccw : MotionType::arc_cw;
  e.arc = ArcData{};
  e.arc.centre = Eigen::Vector3d(e.start[0], e.start[1], e.start[2]);
  e.arc.centre[p.u] = ra.centre.x();
  e.arc.centre[p.v] = ra.centre.y();
  e.arc.radius = r;
  e.arc.sweep = sweep_between(ra.centre, ra.from, ra.to, ra.ccw);
  return e;
}

void start_at(Motion& next, PlaneAxes p, const Eigen::Vector2d& at) {
  next.start[p.u] = at.x();
  next.start[p.v] = at.y();
  if (is_arc(next))  // same centre, shorter sweep
    next.arc.sweep = sweep_between(in_plane(next.arc.centre, p), at, in_plane(next.end, p),
                                   next.type == MotionType::arc_ccw);
}

}  // namespace postproc::gcode
