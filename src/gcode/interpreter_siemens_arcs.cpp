// Modal interpreter: Sinumerik arc forms beyond I J K / CR= — AR=, TURN=, CIP with I1= J1= K1=, CT —
// and the chamfer / rounding words it refuses (Fundamentals, "Circular interpolation types").
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {

void Interpreter::emit(Motion& m, const Block& b, MotionSink& out) {
  if (comp_ && offset_active()) {  // LinuxCNC cutter radius compensation: interpreter_cutter.cpp
    compensated_emit(m, b, out);
    return;
  }
  if (s_.cutter_comp != 0 && !s_.cutter_radius_known && d_.id == DialectId::linuxcnc) unknown_radius_emit(m);
  if (d_.id != DialectId::siemens) {  // only a Sinumerik CT reads the direction: keep the hot path short
    out.motion(m, b);
    return;
  }
  // Direction at the end of the motion, for a following CT (tangential arc).
  const Eigen::Vector3d dir = end_direction(m);
  const AxisMask xyz = bit(Axis::x) | bit(Axis::y) | bit(Axis::z);
  // An axis not written in the block does not move, known or not.
  const AxisMask moved = static_cast<AxisMask>(m.programmed & xyz);
  s_.tangent_known = (m.known & moved) == moved && m.frame == Frame::work && dir.allFinite() && dir.norm() > 1e-12;
  if (s_.tangent_known) s_.tangent = dir.normalized();
  out.motion(m, b);
}

bool Interpreter::check_arc_words(const Block& b, const BlockWords& w) {
  // The combinations the 840D sl accepts (Fundamentals, "Circular interpolation", programming
  // forms): AR= with either the centre or the end point, not with CR=; TURN= a whole number 0…999.
  const auto at = [&](std::int16_t word) { return b.words[static_cast<std::size_t>(word)].span; };
  const PlaneAxes p = plane_axes(s_.plane);
  if (w.has_ar && !(w.ext_unresolved & 2u)) {
    if (w.has_cr) {
      report(b, at(w.ar_word), Severity::error, codes::kSiemensArcWords,
             "AR= (opening angle) and CR= (radius) in one block over-determine the arc; keep one of them");
      return false;
    }
    if (!(w.ar > 0 && w.ar < 360)) {
      report(b, at(w.ar_word), Severity::error, codes::kSiemensArcWords,
             fmt::format("opening angle AR={:g} is outside 0…360 degrees (exclusive); a full circle needs I J K", w.ar));
      return false;
    }
    const bool centre = w.has(centre_letter(p.u)) || w.has(centre_letter(p.v));
    const bool end = (w.axis_present & ((1u << p.u) | (1u << p.v))) != 0;
    if (centre && end) {
      report(b, at(w.ar_word), Severity::error, codes::kSiemensArcWords,
             "AR= with both the centre (I J K) and the end point over-determines the arc; give AR= with one of them");
      return false;
    }
  }
  if (w.has_turn && !(w.ext_unresolved & 4u) && !(w.turn >= 0 && w.turn <= 999)) {
    report(b, at(w.turn_word), Severity::error, codes::kSiemensArcWords,
           fmt::format("TURN={:g}: the number of further full turns runs from 0 to 999", w.turn));
    return false;
  }
  return true;
}

bool Interpreter::turn_fraction(const Block& b, const BlockWords& w) {
  if (!w.has_turn || (w.ext_unresolved & 4u) || w.turn == std::floor(w.turn)) return false;
  // The manual defines whole turns only; how the control reads a fraction is not documented. The
  // block's path is not resolved; its end point is the programmed one either way.
  report(b, b.words[static_cast<std::size_t>(w.turn_word)].span, Severity::warning, codes::kSiemensTurnFraction,
         fmt::format("TURN={:g} is not a whole number of further full turns; how the control reads it is not "
                     "documented, so this helix's path is not resolved (write TURN= as a whole number)",
                     w.turn));
  return true;
}

bool Interpreter::siemens_motion_words(const Block& b, const BlockWords& w, GMeaning mode) {
  const auto at = [&](std::int16_t word) { return b.words[static_cast<std::size_t>(word)].span; };
  const bool arc_mode = mode == GMeaning::arc_cw || mode == GMeaning::arc_ccw;
  // Words that belong to G2/G3 (AR= TURN=) or CIP (I1= J1= K1=) only.
  const std::int16_t misplaced = !arc_mode && w.has_ar ? w.ar_word
                                 : !arc_mode && w.has_turn ? w.turn_word
                                 : mode != GMeaning::arc_cip && w.ip_present ? w.ip_word
                                                                              : -1;
  if (misplaced >= 0) {
    report(b, at(misplaced), Severity::error, codes::kSiemensArcWords,
           fmt::format("'{}' belongs to {} only; this block moves in another mode — remove the word or program the "
                       "arc",
                       b.text(at(misplaced)), misplaced == w.ip_word ? "a CIP arc" : "a G2/G3 arc"));
    return false;
  }
  return true;
}

void Interpreter::corner_words(const Block& b, const BlockWords& w) {
  const auto at = [&](std::int16_t word) { return b.words[static_cast<std::size_t>(word)].span; };
  if (w.siemens_corner_word >= 0) {
    // CHF=/CHR=/RND= insert a chamfer or rounding between this block's move and the next one and
    // shorten both; RNDM= does so at every following corner (840D sl Fundamentals, "Chamfer,
    // rounding: CHF, CHR, RND, RNDM").
    const std::string_view text = b.text(at(w.siemens_corner_word));
    report(b, at(w.siemens_corner_word), Severity::warning, codes::kSiemensCorner,
           fmt::format("'{}' inserts a chamfer or rounding at the corner after this block, which this version does "
                       "not compute: the tool does not reach the programmed corner point (compensation refuses the "
                       "program unless --pass-through; write the chamfer or arc out as its own blocks)",
                       text));
  }
}

bool Interpreter::set_plane_arc(const Block& b, Span at, Motion& m, Plane plane, const Eigen::Vector2d& c,
                                double sweep) {
  const PlaneAxes p = plane_axes(plane);
  const Eigen::Vector2d s(m.start[p.u], m.start[p.v]);
  if ((s - c).norm() < 1e-9) {
    report(b, at, Severity::error, codes::kArcGeometry, "arc of zero radius; check the end and intermediate points");
    return false;
  }
  m.type = sweep >= 0 ? MotionType::arc_ccw : MotionType::arc_cw;
  m.plane = plane;
  m.arc.centre = m.start.head<3>();
  m.arc.centre[p.u] = c.x();
  m.arc.centre[p.v] = c.y();
  m.arc.radius = (s - c).norm();
  m.arc.sweep = sweep;
  m.arc.turns = 1;
  m.arc.full_circle = false;
  return true;
}

bool Interpreter::cip_arc(const Block& b, const BlockWords& w, Motion& m, AxisMask start_known) {
  // 840D sl Fundamentals, "Circular interpolation with intermediate and end points (CIP)": the circle
  // runs from the start through I1= J1= K1= to the end; G90/G91 (or =AC/=IC) apply to the intermediate
  // point as to the end point, incremental ones from the circle's start; an omitted component is 0.
  const Span at = w.motion_keyword_span.size() > 0 ? w.motion_keyword_span
                                                  : b.words[static_cast<std::size_t>(std::max<int>(0, w.ip_word))].span;
  const AxisMask xyz = bit(Axis::x) | bit(Axis::y) | bit(Axis::z);
  if ((start_known & xyz) != xyz || (s_.known & xyz) != xyz || (w.ext_unresolved & 8u)) {
    if (!(w.ext_unresolved & 8u))
      report(b, at, Severity::warning, codes::kUnknownPosition,
             "CIP arc whose start or end point is unknown (after an unresolved construct); it is not resolved");
    s_.known &= static_cast<AxisMask>(~xyz);
    return false;
  }
  if (w.ip_present == 0) {
    report(b, at, Severity::error, codes::kMissingWord,
           "CIP without an intermediate point; write I1= J1= K1= (the point the arc passes through)");
    s_.known &= static_cast<AxisMask>(~xyz);
    return false;
  }
  const Eigen::Vector3d S = m.start.head<3>(), E = m.end.head<3>();
  Eigen::Vector3d P;
  for (int k = 0; k < 3; ++k) {
    const bool incremental = ((w.ip_incremental >> k) & 1u) || (!s_.absolute && !((w.ip_absolute >> k) & 1u));
    const double v = (w.ip_present >> k) & 1u ? to_mm(k, w.ip[k]) : 0.0;
    P[k] = incremental ? S[k] + v : v;
  }
  // The circle must lie in one of the principal planes (the active one first).
  const Plane order[3] = {s_.plane, s_.plane == Plane::xy ? Plane::zx : Plane::xy,
                          s_.plane == Plane::yz ? Plane::zx : Plane::yz};
  const double tol = 1e-6 + 1e-9 * (S - E).norm();
  for (Plane pl : order) {
    const PlaneAxes p = plane_axes(pl);
    if (std::abs(S[p.n] - E[p.n]) > tol || std::abs(S[p.n] - P[p.n]) > tol) continue;
    const Eigen::Vector2d s(S[p.u], S[p.v]), q(P[p.u], P[p.v]), e(E[p.u], E[p.v]);
    const Eigen::Vector2d a = q - s, c2 = e - s;
    const double cross = a.x() * c2.y() - a.y() * c2.x();
    if (std::abs(cross) < 1e-9 * std::max(1.0, a.squaredNorm() + c2.squaredNorm())) {
      report(b, at, Severity::error, codes::kArcGeometry,
             "CIP start, intermediate and end points lie on one line (or coincide); no circle passes through them");
      s_.known &= static_cast<AxisMask>(~xyz);
      return false;
    }
    // Circumcentre of s, q, e (relative to s).
    const double d = 2 * cross;
    const Eigen::Vector2d rel((c2.y() * a.squaredNorm() - a.y() * c2.squaredNorm()) / d,
                              (a.x() * c2.squaredNorm() - c2.x() * a.squaredNorm()) / d);
    const Eigen::Vector2d c = s + rel;
    // Direction from the order start → intermediate → end: counter-clockwise when the end lies left
    // of start → intermediate.
    const bool ccw = cross > 0;
    const Eigen::Vector2d rs = s - c, re = e - c;
    double sweep = std::atan2(rs.x() * re.y() - rs.y() * re.x(), rs.dot(re));
    if (ccw && sweep <= 0) sweep += 2 * std::numbers::pi;
    if (!ccw && sweep >= 0) sweep -= 2 * std::numbers::pi;
    return set_plane_arc(b, at, m, pl, c, sweep);
  }
  report(b, at, Severity::warning, codes::kSiemensSpaceArc,
         fmt::format("CIP circle through start ({:g} {:g} {:g}), intermediate ({:g} {:g} {:g}) and end point lies in no "
                     "plane parallel to XY, ZX or YZ; this version does not resolve circles inclined in space (an "
                     "omitted I1= J1= K1= reads as 0: write all three if the arc is meant to stay in its plane)",
                     S.x(), S.y(), S.z(), P.x(), P.y(), P.z()));
  s_.known &= static_cast<AxisMask>(~xyz);
  return false;
}

bool Interpreter::tangent_arc(const Block& b, const BlockWords& w, Motion& m, AxisMask start_known,
                              const Eigen::Vector3d& tangent, bool tangent_known) {
  // 840D sl Fundamentals, "Circular interpolation with tangential transition (CT)": the arc in the
  // active plane leaves the previous path element tangentially and ends at the programmed point.
  const Span at = w.motion_keyword_span.size() > 0
                      ? w.motion_keyword_span
                      : b.words[static_cast<std::size_t>(std::max<int>(0, w.motion.word))].span;
  const PlaneAxes p = plane_axes(s_.plane);
  const AxisMask need = static_cast<AxisMask>((1u << p.u) | (1u << p.v));
  if ((start_known & need) != need || (s_.known & need) != need) {
    report(b, at, Severity::warning, codes::kUnknownPosition,
           "CT arc whose start or end point is unknown (after an unresolved construct); it is not resolved");
    s_.known &= static_cast<AxisMask>(~need);
    return false;
  }
  const Eigen::Vector2d t(tangent[p.u], tangent[p.v]);
  const bool helix = std::abs(m.end[p.n] - m.start[p.n]) > 1e-9;
  if (!tangent_known || t.norm() < 1e-9 || std::abs(tangent[p.n]) > 1e-9 || helix) {
    report(b, at, Severity::warning, codes::kSiemensSpaceArc,
           !tangent_known ? "CT arc: the direction of the previous path element is not known here (no resolved move "
                            "before it in this program); the arc is not resolved"
                          : "CT arc whose previous path element or end point leaves the active plane; this version "
                            "resolves tangential arcs in the active plane only");
    s_.known &= static_cast<AxisMask>(~need);
    return false;
  }
  const Eigen::Vector2d s(m.start[p.u], m.start[p.v]), e(m.end[p.u], m.end[p.v]);
  const Eigen::Vector2d u = t.normalized();
  const Eigen::Vector2d left(-u.y(), u.x());
  const Eigen::Vector2d d = e - s;
  const double side = left.dot(d);
  if (std::abs(side) < 1e-9 * std::max(1.0, d.norm())) {
    report(b, at, Severity::error, codes::kArcGeometry,
           "CT end point lies on the tangent of the previous element: no arc leaves it tangentially; program G1");
    s_.known &= static_cast<AxisMask>(~need);
    return false;
  }
  // Centre on the normal through the start, equidistant from start and end.
  const double rho = d.squaredNorm() / (2 * side);  // > 0: centre on the left, counter-clockwise
  const Eigen::Vector2d c = s + rho * left;
  const Eigen::Vector2d rs = s - c, re = e - c;
  double sweep = std::atan2(rs.x() * re.y() - rs.y() * re.x(), rs.dot(re));
  if (rho > 0 && sweep <= 0) sweep += 2 * std::numbers::pi;
  if (rho < 0 && sweep >= 0) sweep -= 2 * std::numbers::pi;
  return set_plane_arc(b, at, m, s_.plane, c, sweep);
}

}  // namespace postproc::gcode
