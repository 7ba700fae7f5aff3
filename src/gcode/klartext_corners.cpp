// Klartext corner elements: RND R (rounding) between straight moves and arcs, CHF L (chamfer) between two straight moves
// (TNC 640 User's Manual, "Path functions: rounding corners RND, chamfer CHF"). The element joins
// the two lines tangentially (RND) or cuts the corner at L from it on both lines (CHF); both moves
// are shortened to where the element begins and ends.
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "src/gcode/corner_rounding.hpp"
#include "src/gcode/klartext.hpp"

namespace postproc::gcode::klartext {
namespace {

/// RND next to an arc (TNC 640: "tangentially connected to both the preceding and subsequent contour
/// elements"): the arc of corner_rounding.hpp; the arcs beside it keep their centres and end (or
/// start) at the tangent points.
std::optional<Motion> rounding_with_arcs(Motion& a, Motion& c, PlaneAxes p, double size, std::string& why) {
  bool stops = false;
  const std::optional<RoundingArc> ra = rounding_arc(a, c, p, size, why, stops);
  if (!ra) {
    if (stops) why += " (the control stops with an error)";
    return std::nullopt;
  }
  Motion m = round_corner(a, p, *ra, size);
  m.known = c.known;
  a.words_transformed = true;
  start_at(c, p, ra->to);
  c.words_transformed = true;
  return m;
}

}  // namespace

std::optional<Motion> corner_element(Motion& a, Motion& c, bool rounding, double size, std::string& why) {
  const PlaneAxes p = plane_axes(a.plane);
  const AxisMask plane = static_cast<AxisMask>((1u << p.u) | (1u << p.v));
  const auto straight = [](const Motion& m) { return m.type == MotionType::linear || m.type == MotionType::rapid; };
  const auto arc = [](const Motion& m) { return m.type == MotionType::arc_cw || m.type == MotionType::arc_ccw; };
  const bool lines = straight(a) && straight(c);
  if (!lines && !(rounding && (straight(a) || arc(a)) && (straight(c) || arc(c)))) {
    why = rounding ? "this version builds it only between straight moves and arcs"
                   : "a chamfer joins two straight moves (L) only";  // TNC 640: "CHF … between two straight lines"
    return std::nullopt;
  }
  if (a.plane != c.plane || (a.known & plane) != plane || (c.known & plane) != plane || a.frame != Frame::work ||
      c.frame != Frame::work) {
    why = "the corner's moves are not both known in the working plane";
    return std::nullopt;
  }
  for (int k = 0; k < kAxisCount; ++k) {
    if (k == p.u || k == p.v) continue;
    if (std::abs(a.end[k] - a.start[k]) > 1e-9 || std::abs(c.end[k] - c.start[k]) > 1e-9) {
      why = "a move of the corner leaves the working plane";
      return std::nullopt;
    }
  }
  if (!lines) return rounding_with_arcs(a, c, p, size, why);
  const Eigen::Vector2d s(a.start[p.u], a.start[p.v]), q(a.end[p.u], a.end[p.v]), e(c.end[p.u], c.end[p.v]);
  const double l1 = (q - s).norm(), l2 = (e - q).norm();
  if (l1 < 1e-9 || l2 < 1e-9 || !(size > 0)) {
    why = size > 0 ? "a move of the corner has no length" : "its size must be positive";
    return std::nullopt;
  }
  const Eigen::Vector2d u1 = (q - s) / l1, u2 = (e - q) / l2;
  const double cross = u1.x() * u2.y() - u1.y() * u2.x(), dot = u1.dot(u2);
  const double turn = std::atan2(cross, dot);  // signed turning angle at the corner
  if (std::abs(turn) < 1e-9 || std::abs(std::abs(turn) - std::numbers::pi) < 1e-9) {
    why = "the two moves are collinear: there is no corner";
    return std::nullopt;
  }
  const double t = rounding ? size * std::tan(std::abs(turn) / 2) : size;
  if (t > l1 + 1e-9 || t > l2 + 1e-9) {
    why = fmt::format("it needs {:.4f} mm of each move but the moves are {:.4f} and {:.4f} mm long (the control stops "
                      "with an error)",
                      t, l1, l2);
    return std::nullopt;
  }
  const Eigen::Vector2d t1 = q - t * u1, t2 = q + t * u2;
  Motion m = a;
  m.start = a.end;
  m.start[p.u] = t1.x();
  m.start[p.v] = t1.y();
  m.end = m.start;
  m.end[p.u] = t2.x();
  m.end[p.v] = t2.y();
  m.programmed = 0;
  m.word_index.fill(-1);
  m.type = MotionType::linear;
  m.known = c.known;
  m.words_transformed = true;  // the element's block has no end point words
  if (rounding) {
    const Eigen::Vector2d n = cross > 0 ? Eigen::Vector2d(-u1.y(), u1.x()) : Eigen::Vector2d(u1.y(), -u1.x());
    const Eigen::Vector2d centre = t1 + size * n;
    m.type = cross > 0 ? MotionType::arc_ccw : MotionType::arc_cw;
    m.arc.centre = m.start.head<3>();
    m.arc.centre[p.u] = centre.x();
    m.arc.centre[p.v] = centre.y();
    m.arc.radius = size;
    m.arc.sweep = turn;
    m.arc.turns = 1;
    m.arc.full_circle = false;
  }
  // The moves end and start at the element; their words still name the corner.
  a.end[p.u] = t1.x();
  a.end[p.v] = t1.y();
  a.words_transformed = true;
  c.start = m.end;
  c.words_transformed = true;
  return m;
}

}  // namespace postproc::gcode::klartext
