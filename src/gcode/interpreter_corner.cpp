// Modal interpreter: chamfers and corner roundings between two straight moves.
//
// Fanuc (B-64484EN II "Chamfering and corner R": ",C" is the distance from the virtual corner to
// the start and end of the chamfer, ",R" the radius of the rounding arc tangent to both moves) and
// Sinumerik (840D sl Fundamentals, "Chamfer, rounding: CHF, CHR, RND": CHR= the leg length as ,C,
// CHF= the length of the chamfer itself, RND= the rounding radius) insert the element at the end of
// the block that carries the word: that block's move stops short of the programmed corner and the
// next block's move starts where the element ends. Its end point is still the programmed one, and
// the programmed corner stays the reference of the next block's incremental words.
//
// The element needs the next block's move, so run_program hands the next line to resolve_corner
// before the block is passed on; a quiet copy of the interpreter reads it. This version builds the
// element between two straight moves in the active plane; beside an arc, outside the plane, or when
// the next line is not the move, both moves are refused at their words (as before).
#include <cctype>
#include <cmath>
#include <numbers>
#include <vector>

#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode {
namespace {

double sweep_between(const Eigen::Vector2d& c, const Eigen::Vector2d& a, const Eigen::Vector2d& b, bool ccw);

/// Passes motions on, the first one starting at `start` in the plane (the end of a corner element).
struct StartFromCorner final : MotionSink {
  StartFromCorner(MotionSink& o, const AxisVector& s, PlaneAxes p) : out(o), start(s), plane(p) {}
  void motion(const Motion& m, const Block& b) override {
    if (done) {
      out.motion(m, b);
      return;
    }
    Motion c = m;
    c.start[plane.u] = start[plane.u];
    c.start[plane.v] = start[plane.v];
    if (c.type == MotionType::arc_cw || c.type == MotionType::arc_ccw) {
      // The arc now starts at the rounding's tangent point on it: same centre, shorter sweep.
      const Eigen::Vector2d ctr(c.arc.centre[plane.u], c.arc.centre[plane.v]);
      c.arc.sweep = sweep_between(ctr, Eigen::Vector2d(c.start[plane.u], c.start[plane.v]),
                                  Eigen::Vector2d(c.end[plane.u], c.end[plane.v]), c.type == MotionType::arc_ccw);
    }
    done = true;
    out.motion(c, b);
  }
  MotionSink& out;
  AxisVector start;
  PlaneAxes plane;
  bool done = false;
};

struct Collect final : MotionSink {
  void motion(const Motion& m, const Block&) override { motions.push_back(m); }
  std::vector<Motion> motions;
};

/// True when the move changes no axis but the plane's two.
bool in_plane(const Motion& m, PlaneAxes p) {
  for (int a = 0; a < kAxisCount; ++a)
    if (a != p.u && a != p.v && std::abs(m.end[a] - m.start[a]) > 1e-9) return false;
  return true;
}

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

/// Signed sweep from `a` to `b` around `c` in the arc's direction, in (−2π, 2π).
double sweep_between(const Eigen::Vector2d& c, const Eigen::Vector2d& a, const Eigen::Vector2d& b, bool ccw) {
  const Eigen::Vector2d u = a - c, v = b - c;
  double s = std::atan2(u.x() * v.y() - u.y() * v.x(), u.dot(v));
  if (ccw && s < 0) s += 2 * std::numbers::pi;
  if (!ccw && s > 0) s -= 2 * std::numbers::pi;
  return s;
}

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

void Interpreter::round_with_arcs(const Block& current, const Corner& c, Motion& m, const Motion& n,
                                  std::vector<Motion>& motions) {
  // The rounding arc is tangent to both elements (B-63944EN-1 "Optional chamfering and corner R";
  // 840D sl Fundamentals, RND=): its centre lies at r from both, on the side the path turns to; the
  // tangent points must lie on the elements, else the control alarms.
  const PlaneAxes p = plane_axes(c.plane);
  const std::string word(current.text(c.at));
  const auto refuse = [&](std::string why) {
    withhold_corner(current, c, Severity::warning,
                    fmt::format("'{}': {}; this version does not build it, both moves are refused — write the rounding "
                                "as its own block",
                                word, why),
                    motions);
  };
  const auto too_large = [&](std::string why) {
    withhold_corner(current, c, Severity::error,
                    fmt::format("'{}': {}: the control stops with an alarm; make the rounding smaller", word, why),
                    motions);
  };
  const bool m_arc = m.type != MotionType::linear, n_arc = n.type != MotionType::linear;
  if ((m_arc && (m.arc.turns != 1 || m.arc.full_circle || std::abs(m.arc.sweep) >= 2 * std::numbers::pi)) ||
      (n_arc && (n.arc.turns != 1 || n.arc.full_circle || std::abs(n.arc.sweep) >= 2 * std::numbers::pi))) {
    refuse("a rounding at a full circle or a multi-turn arc");
    return;
  }
  const Eigen::Vector2d s1(m.start[p.u], m.start[p.v]), p1(m.end[p.u], m.end[p.v]), e2(n.end[p.u], n.end[p.v]);
  if ((p1 - s1).norm() < 1e-9 || (e2 - p1).norm() < 1e-9) {
    refuse("one of the two moves has no length in the plane");
    return;
  }
  const Element a = Element::of(m, p), b = Element::of(n, p);
  const Eigen::Vector2d t1 = a.tangent(p1), t2 = b.tangent(p1);
  const double cross = t1.x() * t2.y() - t1.y() * t2.x();
  if (std::abs(cross) < 1e-9) {
    refuse("the two moves meet tangentially (no corner), or the second reverses the first");
    return;
  }
  const double side = cross > 0 ? 1.0 : -1.0;
  const double r = c.size_mm;
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
  bool found = false;
  Eigen::Vector2d q, k1, k2;
  double best = 0;
  for (const Eigen::Vector2d& cand : tangent_centres(a, b, r, side)) {
    const Eigen::Vector2d f1 = a.foot(cand), f2 = b.foot(cand);
    if (!on_element(a, m, f1) || !on_element(b, n, f2)) continue;
    const double d = (cand - p1).norm();
    if (!found || d < best) {
      found = true;
      best = d;
      q = cand;
      k1 = f1;
      k2 = f2;
    }
  }
  if (!found) {
    too_large("the rounding does not fit on the two moves");
    return;
  }
  Motion e = m;  // the rounding arc: the block's modes and feed, no words of its own
  m.end[p.u] = k1.x();
  m.end[p.v] = k1.y();
  if (m_arc) m.arc.sweep = sweep_between(a.centre, s1, k1, a.ccw);
  e.start = m.end;
  e.end = m.end;
  e.end[p.u] = k2.x();
  e.end[p.v] = k2.y();
  e.column = c.at.begin + 1;
  e.programmed = 0;
  e.word_index.fill(-1);
  e.words_transformed = true;
  e.type = side > 0 ? MotionType::arc_ccw : MotionType::arc_cw;
  e.arc = ArcData{};
  e.arc.centre = Eigen::Vector3d(e.start[0], e.start[1], e.start[2]);
  e.arc.centre[p.u] = q.x();
  e.arc.centre[p.v] = q.y();
  e.arc.radius = r;
  e.arc.sweep = sweep_between(q, k1, k2, side > 0);
  motions.push_back(e);
  corner_start_ = e.end;
}

void Interpreter::execute(const Block& b, MotionSink& out) {
  corner_.reset();
  if (comp_) {  // LinuxCNC after a G41/G42: interpreter_cutter.cpp
    execute_linuxcnc(b, out);
    return;
  }
  if (!corner_start_) {
    execute_block(b, out);
    return;
  }
  StartFromCorner from(out, *corner_start_, plane_axes(s_.plane));
  corner_start_.reset();
  execute_block(b, from);
}

bool Interpreter::corner_word(const Block& b, const BlockWords& w, GMeaning mode) {
  // Which word asks for a corner element, and is it one this version builds?
  int word = -1;
  Corner::Kind kind = Corner::Kind::leg;
  if (d_.id == DialectId::fanuc && d_.lathe && w.corner_word < 0) return lathe_corner(b, w, mode);
  if (d_.id == DialectId::fanuc && !d_.lathe && w.corner_word >= 0) {
    word = w.corner_word;
    const std::string_view name = b.text(b.words[static_cast<std::size_t>(word)].name);
    if (name.size() != 2 || (std::toupper(static_cast<unsigned char>(name[1])) != 'C' &&
                             std::toupper(static_cast<unsigned char>(name[1])) != 'R'))
      return false;  // ,A (an angle) stays refused
    kind = std::toupper(static_cast<unsigned char>(name[1])) == 'C' ? Corner::Kind::leg : Corner::Kind::radius;
  } else if (d_.id == DialectId::siemens && w.siemens_corner_word >= 0) {
    word = w.siemens_corner_word;
    const std::string_view name = b.text(b.words[static_cast<std::size_t>(word)].name);
    if (text::iequals(name, "CHR")) kind = Corner::Kind::leg;
    else if (text::iequals(name, "CHF")) kind = Corner::Kind::length;
    else if (text::iequals(name, "RND")) kind = Corner::Kind::radius;
    else return false;  // RNDM= (modal rounding) stays refused
  } else {
    return false;
  }
  const Word& cw = b.words[static_cast<std::size_t>(word)];
  // A rounding may also follow an arc (Fanuc "Optional chamfering and corner R", Sinumerik RND=).
  const bool arc = mode == GMeaning::arc_cw || mode == GMeaning::arc_ccw;
  if ((mode != GMeaning::linear && !(arc && kind == Corner::Kind::radius)) || cw.kind != ValueKind::number || w.polar ||
      w.machine_frame)
    return false;
  double v = cw.number;
  if (d_.id == DialectId::fanuc && cw.whole && d_.integer_input != Dialect::IntegerInput::calculator) {
    if (d_.integer_input == Dialect::IntegerInput::unknown) return false;
    v *= s_.inch ? 0.0001 : 0.001;  // least input increments, like the axis words
  }
  if (!(v > 0) || !(v < 1e6)) return false;
  corner_ = Corner{kind, s_.inch ? v * 25.4 : v, cw.span, s_.plane};
  return true;
}

bool Interpreter::lathe_corner(const Block& b, const BlockWords& w, GMeaning mode) {
  // B-63944EN-1 §4.5 "Chamfering and corner R" (lathe, G18): a G01 along one axis with I (after a Z
  // move), K (after an X move) or R inserts a 45° chamfer or a quarter-circle corner before the next
  // G01, which must run along the other axis; the sign of i/k/r is that move's direction. The
  // amounts are per side (the chamfer is 45° in the part). C (parameter 3405#4 CCR) and direct
  // drawing (X and Z, or A) stay refused.
  if (mode != GMeaning::linear || s_.polar_interp || s_.plane != Plane::zx || s_.tcp != TcpMode::off || w.polar ||
      w.machine_frame)
    return false;
  const AxisMask xs = bit(Axis::x) | bit(Axis::u), zs = bit(Axis::z) | bit(Axis::w);
  const bool along_x = (w.axis_present & xs) != 0, along_z = (w.axis_present & zs) != 0;
  if (along_x == along_z || (w.axis_present & ~(xs | zs)) != 0 || w.has('A') || w.has('C')) return false;
  char letter = 0;
  for (char L : {'I', 'K', 'R'})
    if (w.has(L)) {
      if (letter != 0) return false;  // two of them: not this format
      letter = L;
    }
  if (letter == 0 || w.unresolved(letter) || (letter == 'I' && !along_z) || (letter == 'K' && !along_x)) return false;
  const double v = w.get(letter);
  if (!(std::abs(v) > 0) || !(std::abs(v) < 1e6)) return false;
  const int word = w.letter_word[static_cast<std::size_t>(letter - 'A')];
  Corner c{letter == 'R' ? Corner::Kind::radius : Corner::Kind::leg, std::abs(v) * (s_.inch ? 25.4 : 1.0),
           b.words[static_cast<std::size_t>(word)].span, s_.plane};
  c.next_axis = along_z ? 0 : 2;
  c.next_sign = v > 0 ? 1 : -1;
  corner_ = c;
  return true;
}

void Interpreter::withhold_corner(const Block& current, const Corner& c, Severity sev, std::string message,
                                  std::vector<Motion>& motions) {
  // An error is the control's own alarm; a warning, a corner this version does not build. Either
  // way the block's moves are withheld and the next block's move, whose start the corner moves, too.
  report(current, c.at, sev,
         sev == Severity::error ? codes::kControllerRefuses
         : d_.id == DialectId::siemens ? codes::kSiemensCorner
                                       : codes::kFanucCorner,
         std::move(message));
  std::erase_if(motions, [&](const Motion& mo) { return mo.line == current.line; });
  corner_pending_line_ = current.line;
}

void Interpreter::resolve_corner(const Block& current, const Block& next, std::vector<Motion>& motions) {
  if (!corner_) return;
  const Corner c = *corner_;
  corner_.reset();
  const std::string word(current.text(c.at));
  const auto refuse = [&](std::string why) {
    withhold_corner(current, c, Severity::warning,
                    fmt::format("'{}': {}; this version does not build it, both moves are refused — write the chamfer "
                                "or rounding as its own block",
                                word, why),
                    motions);
  };
  const PlaneAxes p = plane_axes(c.plane);
  const auto is_arc = [](const Motion& mo) { return mo.type == MotionType::arc_cw || mo.type == MotionType::arc_ccw; };
  if (motions.empty() || motions.back().line != current.line ||
      !(motions.back().type == MotionType::linear || (is_arc(motions.back()) && c.kind == Corner::Kind::radius))) {
    refuse("the block's own move is not a straight move");
    return;
  }
  Motion& m = motions.back();
  const AxisMask need = static_cast<AxisMask>((1u << p.u) | (1u << p.v));
  if ((m.known & need) != need || !in_plane(m, p)) {
    refuse("the move is not known, or leaves the plane of the corner");
    return;
  }
  // Read the next line as the controller will: a quiet copy of this interpreter.
  DiagnosticSink quiet(0);
  Interpreter probe(*this);
  probe.sink_ = &quiet;
  Collect after;
  probe.execute(next, after);
  if (after.motions.size() != 1 || quiet.has_errors()) {
    refuse(fmt::format("the chamfer or rounding goes between this move and the next line's move, and line {} is not "
                       "one move",
                       next.line));
    return;
  }
  const Motion& n = after.motions.front();
  if ((is_arc(m) || is_arc(n)) && c.kind == Corner::Kind::radius && c.next_axis < 0) {
    if ((n.known & need) != need || !in_plane(n, p) || n.plane != c.plane) {
      refuse("the next move is not known, or leaves the plane of the corner");
      return;
    }
    round_with_arcs(current, c, m, n, motions);
    return;
  }
  if (n.type != MotionType::linear) {
    refuse(n.type == MotionType::arc_cw || n.type == MotionType::arc_ccw
               ? "the next move is an arc"
               : fmt::format("line {} is not a straight feed move (G01)", next.line));
    return;
  }
  if ((n.known & need) != need || !in_plane(n, p) || n.plane != c.plane) {
    refuse("the next move is not known, or leaves the plane of the corner");
    return;
  }
  if (c.next_axis >= 0) {
    // Lathe chamfer / corner R: the next move runs along the other axis, in the sign's direction.
    const int other = c.next_axis == 0 ? 2 : 0;
    const double along = n.end[c.next_axis] - n.start[c.next_axis];
    if (std::abs(n.end[other] - n.start[other]) > 1e-9 || along * c.next_sign <= 0) {
      withhold_corner(current, c, Severity::error,
                      fmt::format("'{}' needs the next move (line {}) to run along {} in the {} direction only; the "
                                  "control stops with an alarm",
                                  word, next.line, c.next_axis == 0 ? 'X' : 'Z', c.next_sign > 0 ? "+" : "-"),
                      motions);
      return;
    }
  }
  const Eigen::Vector2d p0(m.start[p.u], m.start[p.v]), p1(m.end[p.u], m.end[p.v]), p2(n.end[p.u], n.end[p.v]);
  const double l1 = (p1 - p0).norm(), l2 = (p2 - p1).norm();
  if (l1 < 1e-9 || l2 < 1e-9) {
    refuse("one of the two moves has no length in the plane");
    return;
  }
  const Eigen::Vector2d d1 = (p1 - p0) / l1, d2 = (p2 - p1) / l2;
  const double cross = d1.x() * d2.y() - d1.y() * d2.x();
  const double turn = std::atan2(std::abs(cross), d1.dot(d2));  // 0 = straight on, π = reversal
  if (turn < 1e-9 || turn > std::numbers::pi - 1e-9) {
    refuse("the two moves are in line (no corner), or the second reverses the first");
    return;
  }
  double leg = c.size_mm;                                                    // ,C / CHR=
  if (c.kind == Corner::Kind::length) leg = c.size_mm / (2 * std::cos(turn / 2));  // CHF=: the chamfer's own length
  if (c.kind == Corner::Kind::radius) leg = c.size_mm * std::tan(turn / 2);  // tangent length of the rounding
  if (leg > l1 + 1e-9 || leg > l2 + 1e-9) {
    // Fanuc PS0055 / Sinumerik alarm 10800-range: the element does not fit on the moves.
    withhold_corner(current, c, Severity::error,
                    fmt::format("'{}' needs {:.4f} mm of each move, but the moves are {:.4f} mm and {:.4f} mm long in "
                                "the plane: the control stops with an alarm; make the chamfer or rounding smaller",
                                word, leg, l1, l2),
                    motions);
    return;
  }
  const Eigen::Vector2d t1 = p1 - leg * d1, t2 = p1 + leg * d2;
  Motion e = m;  // the corner element: the block's modes and feed, no words of its own
  m.end[p.u] = t1.x();
  m.end[p.v] = t1.y();
  e.start = m.end;
  e.end[p.u] = t2.x();
  e.end[p.v] = t2.y();
  e.column = c.at.begin + 1;
  e.programmed = 0;
  e.word_index.fill(-1);
  e.words_transformed = true;
  if (c.kind == Corner::Kind::radius) {
    const Eigen::Vector2d left(-d1.y(), d1.x());
    const Eigen::Vector2d centre = t1 + (cross > 0 ? 1.0 : -1.0) * c.size_mm * left;
    e.type = cross > 0 ? MotionType::arc_ccw : MotionType::arc_cw;
    e.arc = ArcData{};
    e.arc.centre = Eigen::Vector3d(e.start[0], e.start[1], e.start[2]);
    e.arc.centre[p.u] = centre.x();
    e.arc.centre[p.v] = centre.y();
    e.arc.radius = c.size_mm;
    e.arc.sweep = cross > 0 ? turn : -turn;
  }
  motions.push_back(e);
  corner_start_ = e.end;
}

}  // namespace postproc::gcode
