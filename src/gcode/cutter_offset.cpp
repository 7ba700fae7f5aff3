// LinuxCNC cutter radius compensation: the tool-centre path (cutter_offset.hpp). Each step names the
// LinuxCNC function whose rule it follows (rs274ngc interp_convert.cc, interp_queue.cc).
#include "src/gcode/cutter_offset.hpp"

#include <cmath>
#include <numbers>

#include <fmt/format.h>

namespace postproc::gcode {
namespace crc {

constexpr double kPi = std::numbers::pi;
constexpr double kHalfPi = std::numbers::pi / 2;
/// TOLERANCE_CONCAVE_CORNER: directions closer than this (rad) need no corner element.
constexpr double kCorner = 0.05;
/// TOLERANCE_EQUAL, as convert_arc_comp1 uses it on a cosine.
constexpr double kEqual = 0.0001;

Eigen::Vector2d dir(double a) { return {std::cos(a), std::sin(a)}; }
double angle_of(const Eigen::Vector2d& v) { return std::atan2(v.y(), v.x()); }

}  // namespace crc

double cutter_turn_angle(const Eigen::Vector2d& a, const Eigen::Vector2d& c, int turn, const Eigen::Vector2d& b) {
  if (turn == 0) return 0;
  double from = crc::angle_of(a - c), to = crc::angle_of(b - c);
  if (turn > 0) {
    if (to <= from) to += 2 * crc::kPi;
    return to - from + (turn - 1) * 2 * crc::kPi;
  }
  if (from <= to) from += 2 * crc::kPi;
  return to - from + (turn + 1) * 2 * crc::kPi;
}

namespace {

/// The tool on the inside of an arc: left of a counter-clockwise one, right of a clockwise one.
bool inside(CutterOffset::Side side, int turn) {
  return (side == CutterOffset::Side::left && turn > 0) || (side == CutterOffset::Side::right && turn < 0);
}

CutterOffset::Outcome lcnc_stops(std::string text) { return CutterOffset::Refusal{std::move(text), true}; }
CutterOffset::Outcome not_computed(std::string text) { return CutterOffset::Refusal{std::move(text), false}; }

constexpr const char* kEmptyQueue =
    "an inside corner right after M0/M1/M60 released the held move: LinuxCNC's interpreter reads a move it no longer "
    "holds here, so where the tool goes is not computed; move the stop away from the inside corner";

int arc_turn(const Motion& m) {
  const int n = static_cast<int>(std::max<std::uint32_t>(m.arc.turns, 1));
  return m.type == MotionType::arc_ccw ? n : -n;
}

}  // namespace

void CutterOffset::start(Side side, double radius_mm, Plane plane, int orientation, const AxisVector& at) {
  on_ = true;
  first_ = true;
  side_ = side;
  radius_ = radius_mm;
  plane_ = plane;
  orientation_ = orientation;
  tool_ = at;
  released_ = at;
  held_.clear();
}

void CutterOffset::stop() {
  on_ = false;
  first_ = true;
  held_.clear();
}

Eigen::Vector2d CutterOffset::in_plane(const AxisVector& a) const {
  const PlaneAxes p = plane_axes(plane_);
  return {a[p.u], a[p.v]};
}

Eigen::Vector2d CutterOffset::lathe_shift() const {
  // interp_queue.cc latheorigin_x/_z: a lathe tool's controlled point is not the nose centre; in
  // G18 orientations 1–8 move it by the radius along X and Z (u = Z, v = X).
  if (plane_ != Plane::zx) return Eigen::Vector2d::Zero();
  const int o = orientation_;
  const double r = radius_;
  double x = 0, z = 0;
  if (o == 2 || o == 6 || o == 1) x = -r;
  if (o == 3 || o == 8 || o == 4) x = r;
  if (o == 2 || o == 7 || o == 3) z = -r;
  if (o == 1 || o == 5 || o == 4) z = r;
  return {z, x};
}

void CutterOffset::hold_straight(const Motion& p, const Eigen::Vector2d& d, const Eigen::Vector2d& end, double n_end) {
  const PlaneAxes pa = plane_axes(plane_);
  Held h;
  h.m = p;
  h.m.type = p.type == MotionType::rapid ? MotionType::rapid : MotionType::linear;
  h.m.arc = ArcData{};
  h.m.end[pa.u] = end.x();
  h.m.end[pa.v] = end.y();
  h.m.end[pa.n] = n_end;
  h.m.words_transformed = true;
  h.m.cutter_radius = radius_;
  h.dir = d;
  held_.push_back(std::move(h));
}

void CutterOffset::hold_arc(const Motion& p, const Eigen::Vector2d& end, const Eigen::Vector2d& centre, int turn,
                            double sweep0, double n_end, bool corner) {
  const PlaneAxes pa = plane_axes(plane_);
  Held h;
  h.m = p;
  h.m.type = turn > 0 ? MotionType::arc_ccw : MotionType::arc_cw;
  h.m.end[pa.u] = end.x();
  h.m.end[pa.v] = end.y();
  h.m.end[pa.n] = n_end;
  h.m.words_transformed = true;
  h.m.cutter_radius = radius_;
  if (corner) {
    // An inserted corner arc has no words of its own.
    h.m.programmed = 0;
    h.m.word_index.fill(-1);
  }
  h.arc = true;
  h.turn = turn;
  h.centre = centre;
  h.sweep0 = sweep0;
  held_.push_back(std::move(h));
}

void CutterOffset::release(std::vector<Motion>& out) {
  // dequeue_canons: the held moves are issued in order, each from where the last one ended.
  const PlaneAxes pa = plane_axes(plane_);
  const Eigen::Vector2d shift = lathe_shift();
  for (Held& h : held_) {
    Motion m = std::move(h.m);
    m.start = released_;
    m.end[pa.u] += shift.x();
    m.end[pa.v] += shift.y();
    if (h.arc) {
      const Eigen::Vector2d c = h.centre + shift;
      const Eigen::Vector2d s(m.start[pa.u], m.start[pa.v]), e(m.end[pa.u], m.end[pa.v]);
      m.arc = ArcData{};
      m.arc.centre = Eigen::Vector3d(m.end[0], m.end[1], m.end[2]);
      m.arc.centre[pa.u] = c.x();
      m.arc.centre[pa.v] = c.y();
      m.arc.centre[pa.n] = m.start[pa.n];
      m.arc.radius = (s - c).norm();
      m.arc.sweep = cutter_turn_angle(s, c, h.turn, e);
      m.arc.turns = static_cast<std::uint32_t>(std::abs(h.turn));
      m.arc.full_circle = (e - s).norm() < 1e-9;
    }
    released_ = m.end;
    out.push_back(std::move(m));
  }
  held_.clear();
  from_valid_ = false;
}

CutterOffset::Outcome CutterOffset::end_held_at(const Eigen::Vector2d& to, std::vector<Motion>& out) {
  // move_endpoint_and_flush: nothing held, nothing moves (and the start of what follows is not set).
  if (held_.empty()) return std::nullopt;
  const PlaneAxes pa = plane_axes(plane_);
  for (Held& h : held_) {
    if (h.arc) {
      const double r1 = (in_plane(h.m.end) - h.centre).norm();
      const double r2 = (to - h.centre).norm();
      const double sweep = cutter_turn_angle(from_, h.centre, h.turn, to);
      if (std::abs(r1 - r2) > 0.01 * unit_)
        return lcnc_stops(fmt::format("BUG: cutter compensation has generated an invalid arc with mismatched radii r1 {:f} r2 {:f}",
                           r1 / unit_, r2 / unit_));
      // The arc may not grow by more than 0.0254 rad in a mm program, 0.001 rad in an inch one (the
      // constants of LinuxCNC 2.9's move_endpoint_and_flush).
      if (h.sweep0 != 0 && from_valid_ && std::abs(sweep) > std::abs(h.sweep0) + (unit_ == 1.0 ? 0.0254 : 0.001))
        return lcnc_stops("Arc move in concave corner cannot be reached by the tool without gouging");
    } else {
      // The move must still run the way it was programmed to (the shortened move did not reverse).
      if (from_valid_ && h.dir.dot(to - from_) < 0)
        return lcnc_stops(h.m.type == MotionType::rapid
                               ? "Straight traverse in concave corner cannot be reached by the tool without gouging"
                               : "Straight feed in concave corner cannot be reached by the tool without gouging");
    }
    h.m.end[pa.u] = to.x();
    h.m.end[pa.v] = to.y();
  }
  release(out);
  set_from(to);
  return std::nullopt;
}

CutterOffset::Outcome CutterOffset::flush(std::vector<Motion>& out) {
  // convert_stop / convert_cutter_compensation_off: move_endpoint_and_flush to the current point.
  auto e = end_held_at(in_plane(tool_), out);
  if (!e) release(out);
  return e;
}

std::vector<Motion> CutterOffset::take_held() {
  std::vector<Motion> held;
  for (Held& h : held_) held.push_back(std::move(h.m));
  held_.clear();
  return held;
}

CutterOffset::Outcome CutterOffset::move(const Motion& p, std::vector<Motion>& out) {
  const bool arc = p.type == MotionType::arc_cw || p.type == MotionType::arc_ccw;
  if (arc) return first_ ? arc_entry(p, out) : this->arc(p, out);
  return first_ ? straight_entry(p, out) : straight(p, out);
}

CutterOffset::Outcome CutterOffset::straight_entry(const Motion& p, std::vector<Motion>&) {
  // convert_straight_comp1: a line from the tool to the programmed end, tangent to the tool circle
  // about the current point; the tool ends one radius beside the end, at right angles to it.
  const PlaneAxes pa = plane_axes(plane_);
  const Eigen::Vector2d c = in_plane(tool_), e = in_plane(p.end);
  if ((e - c).norm() <= radius_)
    return lcnc_stops("Length of cutter compensation entry move is not greater than the tool radius");
  const double a = crc::angle_of(e - c) + (side_ == Side::left ? crc::kHalfPi : -crc::kHalfPi);
  const Eigen::Vector2d end = e + radius_ * crc::dir(a);
  set_from(c);
  // LinuxCNC keeps the normal's direction for this move's gouge check.
  hold_straight(p, crc::dir(a), end, p.end[pa.n]);
  first_ = false;
  tool_ = held_.back().m.end;
  return std::nullopt;
}

CutterOffset::Outcome CutterOffset::straight(const Motion& p, std::vector<Motion>& out) {
  // convert_straight_comp2.
  const PlaneAxes pa = plane_axes(plane_);
  const Eigen::Vector2d c = in_plane(tool_), o = in_plane(p.start), e = in_plane(p.end);
  const double n_end = p.end[pa.n];
  const bool rapid = p.type == MotionType::rapid;
  if (e.x() == o.x() && e.y() == o.y()) {
    // No move in the plane: held behind the last move, ending where the tool is in the plane.
    hold_straight(p, Eigen::Vector2d::Zero(), c, n_end);
    tool_ = held_.back().m.end;
    return std::nullopt;
  }
  const bool left = side_ == Side::left;
  double theta = crc::angle_of(c - o);  // from the programmed corner to the tool: normal of the last move
  double alpha = crc::angle_of(e - o);  // direction of this move
  double beta = 0, gamma = 0;
  if (left) {
    if (theta < alpha) theta += 2 * crc::kPi;
    beta = theta - alpha - crc::kHalfPi;
    gamma = crc::kHalfPi;
  } else {
    if (alpha < theta) alpha += 2 * crc::kPi;
    beta = alpha - theta - crc::kHalfPi;
    gamma = -crc::kHalfPi;
  }
  const Eigen::Vector2d end = e + radius_ * crc::dir(alpha + gamma);
  const Eigen::Vector2d mid = o + radius_ * crc::dir(alpha + gamma);
  bool concave = beta < -crc::kCorner || beta > crc::kPi + crc::kCorner;
  // An "h" shape: over the round top of an arc, then along the straight side. LinuxCNC keeps the tool
  // above and beside it, as at an inside corner.
  if (!concave && beta > crc::kPi - crc::kCorner && !held_.empty() && held_.front().arc &&
      ((!left && held_.front().turn > 0) || (left && held_.front().turn < 0)))
    concave = true;
  if (!concave && beta > crc::kCorner) {
    // Outside corner: the held moves end where they are; an arc about the programmed corner takes the
    // tool to the new direction (a rapid goes straight there: there is no arc traverse). The corner
    // element carries this block's rotary and other axes, not its move along the normal.
    if (auto err = end_held_at(c, out)) return err;
    Motion corner = p;
    corner.end = p.end;
    if (rapid) {
      hold_straight(corner, Eigen::Vector2d::Zero(), mid, tool_[pa.n]);
      held_.back().m.programmed = 0;
      held_.back().m.word_index.fill(-1);
    } else {
      hold_arc(corner, mid, o, left ? -1 : 1, 0.0, tool_[pa.n], true);
    }
    release(out);
    set_from(mid);
  } else if (concave) {
    if (held_.empty()) {
      // LinuxCNC reads the front of its queue here, which M0/M1/M60 emptied: what it then does
      // depends on memory it no longer holds.
      return not_computed(kEmptyQueue);
    }
    if (!held_.front().arc) {
      // Line to line: back along the last offset line to where the two offset lines meet.
      const double half = (beta + crc::kPi) / 2;
      if (half == 0) return lcnc_stops("Zero degree inside corner is invalid for cutter compensation");
      const double retreat = radius_ / std::tan(half);
      const Eigen::Vector2d at = c + retreat * crc::dir(theta + gamma);
      if (auto err = end_held_at(at, out)) return err;
    } else {
      // Arc to line: where the offset line meets the held (offset) arc.
      const Held& prev = held_.front();
      const double oldrad = (prev.centre - in_plane(prev.m.end)).norm();
      const double base = crc::angle_of(e - o);
      const double th = prev.turn > 0 ? base + crc::kHalfPi : base - crc::kHalfPi;
      const double phi = crc::angle_of(prev.centre - o);
      const bool in = inside(side_, prev.turn);
      const double programmed_radius = in ? oldrad + radius_ : oldrad - radius_;
      const double d = programmed_radius * std::cos(th - phi);
      const double l = (in ? d - radius_ : d + radius_) / oldrad;
      if (l > 1.0 || l < -1.0)
        return lcnc_stops("Arc to straight motion makes a corner the compensated tool can't fit in without gouging");
      const double ac = std::acos(l);
      const double from_centre = (in == (prev.turn > 0)) ? -ac + th + crc::kPi : ac + th + crc::kPi;
      const Eigen::Vector2d at = prev.centre + oldrad * crc::dir(from_centre);
      if (auto err = end_held_at(at, out)) return err;
    }
  } else {
    // Collinear, or tangent after an arc: nothing inserted.
    release(out);
    set_from(c);
  }
  hold_straight(p, e - o, end, n_end);
  tool_ = held_.back().m.end;
  return std::nullopt;
}

CutterOffset::Outcome CutterOffset::arc_entry(const Motion& p, std::vector<Motion>&) {
  // convert_arc_comp1: the programmed arc from the tool's point (arc_data_comp_*); the tool ends one
  // radius beside the end, radially, and runs along an arc about a centre moved so that it stays
  // tangent to the programmed one.
  const PlaneAxes pa = plane_axes(plane_);
  const Eigen::Vector2d c = in_plane(tool_), e = in_plane(p.end);
  const Eigen::Vector2d centre(p.arc.centre[pa.u], p.arc.centre[pa.v]);
  const int turn = arc_turn(p);
  if ((e - c).norm() <= radius_)
    return lcnc_stops("Radius of cutter compensation entry arc is not greater than the tool radius");
  if (inside(side_, turn) && p.arc.radius <= radius_) return lcnc_stops("Tool radius not less than arc radius with comp");
  const double gamma = inside(side_, turn) ? crc::angle_of(centre - e) : crc::angle_of(e - centre);
  const Eigen::Vector2d end = e + radius_ * crc::dir(gamma);
  // The new centre: on the line from the end towards the programmed centre, equally far from the
  // tool's point and the new end.
  const double half_chord = (c - end).norm() / 2;
  const double towards = crc::angle_of(centre - end);
  const double a = crc::angle_of(c - end) - towards;
  if (std::abs(std::cos(a)) < crc::kEqual) return lcnc_stops("Tool radius not less than arc radius with comp");
  const Eigen::Vector2d nc = end + (half_chord / std::cos(a)) * crc::dir(towards);
  const double spiral = (unit_ == 1.0 ? 2 * 0.01 * std::numbers::sqrt2 : 2 * 0.001 * std::numbers::sqrt2) * unit_;
  if (std::abs((nc - end).norm() - (nc - c).norm()) > spiral) return lcnc_stops("Bug in tool radius comp");
  first_ = false;
  if (orientation_ != 0 && orientation_ != 9) {
    // A lathe tool first moves its controlled point to the offset start (zero length in the plane).
    hold_straight(p, Eigen::Vector2d::Zero(), c, tool_[pa.n]);
    held_.back().m.programmed = 0;
    held_.back().m.word_index.fill(-1);
    set_from(c);
  }
  hold_arc(p, end, nc, turn, cutter_turn_angle(c, nc, turn, end), p.end[pa.n], false);
  tool_ = held_.back().m.end;
  return std::nullopt;
}

CutterOffset::Outcome CutterOffset::arc(const Motion& p, std::vector<Motion>& out) {
  // convert_arc_comp2.
  const PlaneAxes pa = plane_axes(plane_);
  const Eigen::Vector2d c = in_plane(tool_), o = in_plane(p.start), e = in_plane(p.end);
  const Eigen::Vector2d centre(p.arc.centre[pa.u], p.arc.centre[pa.v]);
  const int turn = arc_turn(p);
  const bool left = side_ == Side::left;
  const double arc_radius = (centre - e).norm();
  double theta = crc::angle_of(c - o);
  theta = left ? theta - crc::kHalfPi : theta + crc::kHalfPi;  // direction at the end of the last move
  double delta = crc::angle_of(centre - o);
  const double alpha = turn > 0 ? delta - crc::kHalfPi : delta + crc::kHalfPi;  // direction at the arc's start
  double beta = left ? theta - alpha : alpha - theta;
  beta = beta > 1.5 * crc::kPi ? beta - 2 * crc::kPi : beta < -crc::kHalfPi ? beta + 2 * crc::kPi : beta;
  const bool in = inside(side_, turn);
  double gamma = 0;
  if (in) {
    gamma = crc::angle_of(centre - e);
    if (arc_radius <= radius_) return lcnc_stops("Tool radius not less than arc radius with comp");
  } else {
    gamma = crc::angle_of(e - centre);
    delta += crc::kPi;
  }
  const Eigen::Vector2d new_end = e + radius_ * crc::dir(gamma);
  const double sweep0 = cutter_turn_angle(o, centre, turn, e);
  // Inside corner; also a tangent junction where the tool would have to go round the far side (the
  // top of an "m" after an arc, or of an "h" after a line).
  const bool concave = beta < -crc::kCorner || beta > crc::kPi + crc::kCorner ||
                       (std::abs(beta - crc::kPi) < crc::kCorner && !in);
  if (concave) {
    if (held_.empty())
      return not_computed(kEmptyQueue);
    Eigen::Vector2d at;
    if (!held_.front().arc) {
      // Line to arc: where the held offset line meets the offset arc.
      const double toward_line = arc_radius * std::sin(beta - crc::kHalfPi);
      double from_centre = 0, dist = 0;
      if (in) {
        dist = arc_radius - radius_;
        const double l = (toward_line + radius_) / dist;
        if (l > 1.0 || l < -1.0) return lcnc_stops("Arc move in concave corner cannot be reached by the tool without gouging");
        from_centre = turn > 0 ? theta + std::asin(l) : theta - std::asin(l);
      } else {
        dist = arc_radius + radius_;
        const double l = (toward_line - radius_) / dist;
        if (l > 1.0 || l < -1.0) return lcnc_stops("Arc move in concave corner cannot be reached by the tool without gouging");
        from_centre = turn > 0 ? theta + crc::kPi - std::asin(l) : theta + crc::kPi + std::asin(l);
      }
      at = centre + dist * crc::dir(from_centre);
    } else {
      // Arc to arc: where the two offset circles meet.
      const Held& prev = held_.front();
      const double oldrad = (prev.centre - in_plane(prev.m.end)).norm();
      const double newrad = in ? arc_radius - radius_ : arc_radius + radius_;
      const double between = (prev.centre - centre).norm();
      if (oldrad == 0 || between == 0) return lcnc_stops("Arc to arc motion is invalid because the arcs have the same center");
      const double a = (oldrad * oldrad + between * between - newrad * newrad) / (2 * oldrad * between);
      if (a > 1.0 || a < -1.0)
        return lcnc_stops("Arc to arc motion makes a corner the compensated tool can't fit in without gouging");
      const double pullback = std::acos(a);
      const double cc = crc::angle_of(centre - prev.centre);
      const bool plus = inside(side_, prev.turn) == (turn > 0);
      at = prev.centre + oldrad * crc::dir(plus ? cc + pullback : cc - pullback);
    }
    if (auto err = end_held_at(at, out)) return err;
    hold_arc(p, new_end, centre, turn, sweep0, p.end[pa.n], false);
  } else if (beta > crc::kCorner) {
    // Outside corner: an arc about the programmed corner, then the arc.
    const Eigen::Vector2d mid = o + radius_ * crc::dir(delta);
    release(out);
    hold_arc(p, mid, o, left ? -1 : 1, 0.0, tool_[pa.n], true);
    release(out);
    set_from(mid);
    hold_arc(p, new_end, centre, turn, sweep0, p.end[pa.n], false);
  } else {
    release(out);
    set_from(c);
    hold_arc(p, new_end, centre, turn, sweep0, p.end[pa.n], false);
  }
  tool_ = held_.back().m.end;
  return std::nullopt;
}

}  // namespace postproc::gcode
