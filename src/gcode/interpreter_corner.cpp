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
#include "src/gcode/corner_rounding.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode {
namespace {

/// Passes motions on, the first one starting at `start` in the plane (the end of a corner element).
struct StartFromCorner final : MotionSink {
  StartFromCorner(MotionSink& o, const AxisVector& s, PlaneAxes p) : out(o), start(s), plane(p) {}
  void motion(const Motion& m, const Block& b) override {
    if (done) {
      out.motion(m, b);
      return;
    }
    Motion c = m;
    start_at(c, plane, Eigen::Vector2d(start[plane.u], start[plane.v]));  // an arc: its tangent point
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
  bool stops = false;
  std::string why;
  const std::optional<RoundingArc> ra = rounding_arc(m, n, p, c.size_mm, why, stops);
  if (!ra) {
    if (stops) too_large(why);
    else refuse(why);
    return;
  }
  Motion e = round_corner(m, p, *ra, c.size_mm);  // the block's modes and feed, no words of its own
  e.column = c.at.begin + 1;
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
