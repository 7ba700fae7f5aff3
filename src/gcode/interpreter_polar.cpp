// Modal interpreter: polar words — LinuxCNC @ ^ (G-code reference "Polar Coordinates") and the
// Sinumerik pole G110–G112 with AP= RP= (Fundamentals, "Polar coordinates").
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {

namespace {

/// Where a polar step starts, for the steps that need its direction: rs274 stops for a point
/// exactly at the origin; a point a rounding error away from it (|p| ≤ 1e-9 program units) has a
/// direction that is noise, so a step that keeps that direction (@) is not followed.
enum class Origin : std::uint8_t { away, at, near };
Origin origin_of(double x, double y) {
  if (x == 0 && y == 0) return Origin::at;
  return std::hypot(x, y) <= 1e-9 ? Origin::near : Origin::away;
}

}  // namespace

bool Interpreter::polar_to_xy(const Block& b, BlockWords& w, bool cycle) {
  // LinuxCNC polar words (G-code reference "Polar Coordinates"; rs274's find_ends, checked on
  // traps): @ distance and ^ angle (degrees, counter-clockwise from +X) give X and Y about the
  // origin of the current coordinate system, only in G17 and never with G53 or X/Y. G90: both
  // words give the point; @ alone keeps the current angle (refused at the origin), ^ alone the
  // current distance. G91: @ adds to the current distance, then ^ to the current angle, each
  // refused at the origin (even @0 / ^0). Canned cycles (G81…) follow convert_cycle_xy instead:
  // under G90 no origin check; under G91 the steps are taken per hole (drill()).
  const Span at = b.words[static_cast<std::size_t>(w.polar_word)].span;
  const AxisMask xy = bit(Axis::x) | bit(Axis::y);
  const auto refuse = [&](std::string msg) {
    report(b, at, Severity::error, codes::kControllerRefuses, std::move(msg));
    s_.known &= static_cast<AxisMask>(~xy);
    return false;
  };
  if (s_.plane != Plane::xy)
    return refuse("polar words (@ ^) outside the G17 plane: LinuxCNC refuses them (\"Cannot use polar coordinate "
                  "except in G17 plane\") and stops here; select G17 first or give X Y Z words");
  if (w.axis_present & xy)
    return refuse("polar words (@ ^) together with X or Y: LinuxCNC refuses the block; give the point one way");
  if (w.machine_frame)
    return refuse("polar words (@ ^) with G53: LinuxCNC refuses them (\"Cannot use polar coordinates with G53\"); "
                  "give the machine position as X Y");
  if (w.polar_words & 4u) {
    unresolved_motion(b, w, codes::kPolar, "a polar move whose @ or ^ is an expression");
    s_.known &= static_cast<AxisMask>(~xy);
    return false;
  }
  const bool both = (w.polar_words & 3u) == 3u;
  if ((!both || !s_.absolute) && (s_.known & xy) != xy) {
    unresolved_motion(b, w, codes::kPolar, "a polar move relative to an unknown current point");
    s_.known &= static_cast<AxisMask>(~xy);
    return false;
  }
  const double k = s_.inch ? 25.4 : 1.0;
  double x = s_.position[0] / k, y = s_.position[1] / k;
  const double deg = std::numbers::pi / 180.0;
  const bool has_r = (w.polar_words & 1u) != 0, has_a = (w.polar_words & 2u) != 0;
  const auto near_origin = [&] {
    unresolved_motion(b, w, codes::kPolar,
                      "a polar move that keeps the direction of a point a rounding error away from the origin (the "
                      "direction is noise)");
    s_.known &= static_cast<AxisMask>(~xy);
    return false;
  };
  if (cycle && !s_.absolute) {
    // The holes are placed by drill(), one polar step per repeat from where the last one ended.
    w.axis_present |= xy;
    return true;
  }
  if (s_.absolute) {
    if (both) {
      x = w.polar_distance * std::cos(w.polar_angle * deg);
      y = w.polar_distance * std::sin(w.polar_angle * deg);
    } else if (has_r) {
      const Origin o = origin_of(x, y);
      if (o == Origin::at && !cycle)
        return refuse("@ without ^ at the origin: the angle is undefined and LinuxCNC stops here (\"Must specify "
                      "angle in polar coordinate if at the origin\"); give ^ as well");
      if (o == Origin::near) return near_origin();
      const double a = std::atan2(y, x);
      x = w.polar_distance * std::cos(a);
      y = w.polar_distance * std::sin(a);
    } else {
      const double r = std::hypot(x, y);
      x = r * std::cos(w.polar_angle * deg);
      y = r * std::sin(w.polar_angle * deg);
    }
  } else {
    const auto at_origin = [&] {
      return refuse("incremental polar move (G91 @ ^) from the origin: its direction is undefined and LinuxCNC "
                    "refuses it (\"... indeterminate when at the origin\"); move off the origin first or use G90");
    };
    if (has_r) {
      if (origin_of(x, y) == Origin::at) return at_origin();
      if (origin_of(x, y) == Origin::near) return near_origin();
      const double a = std::atan2(y, x), r = std::hypot(x, y) + w.polar_distance;
      x = r * std::cos(a);
      y = r * std::sin(a);
    }
    if (has_a) {
      if (origin_of(x, y) == Origin::at) return at_origin();
      const double a = std::atan2(y, x) + w.polar_angle * deg, r = std::hypot(x, y);
      x = r * std::cos(a);
      y = r * std::sin(a);
    }
  }
  set_polar_xy(w, x, y);
  return true;
}

void Interpreter::set_polar_xy(BlockWords& w, double x, double y) const {
  // The point is in the radius frame even in lathe diameter mode (rs274: G7 does not double polar
  // X); target() halves X in G7, so it is handed over doubled.
  const AxisMask xy = bit(Axis::x) | bit(Axis::y);
  w.axis[0] = s_.diameter_mode ? 2 * x : x;
  w.axis[1] = y;
  w.axis_present |= xy;
  w.axis_absolute |= xy;
  w.axis_incremental &= static_cast<AxisMask>(~xy);
}

bool Interpreter::polar_cycle_step(const Block& b, BlockWords& w) {
  // convert_cycle_xy under G91 (rs274's CYCLE_MACRO): before each hole a non-zero @ adds to the
  // distance of the current point from the origin, then a non-zero ^ to its angle; either step
  // at the origin stops the program. A zero word makes no step (and no check).
  const double k = s_.inch ? 25.4 : 1.0;
  const double deg = std::numbers::pi / 180.0;
  double x = s_.position[0] / k, y = s_.position[1] / k;
  const double dr = (w.polar_words & 1u) ? w.polar_distance : 0.0;
  const double da = (w.polar_words & 2u) ? w.polar_angle : 0.0;
  for (int step = 0; step < 2; ++step) {
    if ((step == 0 ? dr : da) == 0) continue;
    if (step == 0 && origin_of(x, y) == Origin::near) {
      unresolved_motion(b, w, codes::kPolar,
                        "a repeat of the cycle whose polar step keeps the direction of a point a rounding error away "
                        "from the origin (the direction is noise)");
      s_.known &= static_cast<AxisMask>(~(bit(Axis::x) | bit(Axis::y)));
      return false;
    }
    if (origin_of(x, y) == Origin::at) {
      report(b, b.words[static_cast<std::size_t>(w.polar_word)].span, Severity::error, codes::kControllerRefuses,
             "this repeat of the cycle steps in polar coordinates from the origin: the direction is undefined and "
             "LinuxCNC stops here (\"Incremental motion with polar coordinates is indeterminate when at the "
             "origin\"); start the pattern off the origin or give X Y");
      s_.known &= static_cast<AxisMask>(~(bit(Axis::x) | bit(Axis::y)));
      return false;
    }
    const double a = std::atan2(y, x) + (step == 1 ? da * deg : 0.0);
    const double r = std::hypot(x, y) + (step == 0 ? dr : 0.0);
    x = r * std::cos(a);
    y = r * std::sin(a);
  }
  set_polar_xy(w, x, y);
  return true;
}

void Interpreter::siemens_pole(const Block& b, const BlockWords& w, std::uint16_t code10, Span at) {
  // Fundamentals, "Polar coordinates: G110, G111, G112": the pole relative to the last programmed
  // position (G110), to the work origin (G111) or to the last pole (G112), given in X Y (plane axes)
  // or as AP= RP= from that reference. A new pole asks for AP= and RP= again.
  const PlaneAxes p = plane_axes(s_.plane);
  const AxisMask plane_bits = static_cast<AxisMask>((1u << p.u) | (1u << p.v));
  Eigen::Vector2d ref = Eigen::Vector2d::Zero();
  bool known = true;
  if (code10 == 1100) {
    ref = Eigen::Vector2d(s_.position[p.u], s_.position[p.v]);
    known = (s_.known & plane_bits) == plane_bits;
  } else if (code10 == 1120) {
    ref = s_.pole;
    known = s_.pole_known && (s_.pole_plane == s_.plane || !s_.pole_defined);
  }
  const bool cartesian = (w.axis_present & plane_bits) != 0;
  const bool polar = w.has_ap || w.has_rp;
  Eigen::Vector2d off = Eigen::Vector2d::Zero();
  if (cartesian && polar) {
    report(b, at, Severity::error, codes::kSiemensArcWords,
           "a pole is given either by its plane axes or by AP= RP=, not both; keep one");
    known = false;
  } else if (cartesian) {
    if (w.axis_unresolved & plane_bits) known = false;
    if (w.axis_present & (1u << p.u)) off.x() = to_mm(p.u, w.axis[p.u]);
    if (w.axis_present & (1u << p.v)) off.y() = to_mm(p.v, w.axis[p.v]);
  } else if (polar) {
    if (!(w.has_ap && w.has_rp) || (w.ext_unresolved & (16u | 32u)) || w.ap_incremental || w.rp_incremental) {
      known = false;
    } else {
      const double a = w.ap * std::numbers::pi / 180.0, r = to_mm(0, w.rp);
      off = Eigen::Vector2d(r * std::cos(a), r * std::sin(a));
    }
  }
  s_.pole = ref + off;
  s_.pole_known = known;
  s_.pole_defined = true;
  s_.pole_plane = s_.plane;
  s_.polar_angle_set = s_.polar_radius_set = false;
}

bool Interpreter::siemens_polar_end(const Block& b, const BlockWords& w, GMeaning mode, Eigen::Vector2d& end) {
  // Fundamentals, "Travel commands with polar coordinates (G0, G1, G2, G3, AP, RP)": AP= the angle
  // from the plane's first axis (AP=IC(…) from the last angle), RP= the radius; both modal.
  (void)b;
  const bool motion = mode == GMeaning::rapid || mode == GMeaning::linear || mode == GMeaning::arc_cw ||
                      mode == GMeaning::arc_ccw;
  const PlaneAxes p = plane_axes(s_.plane);
  const AxisMask plane_bits = static_cast<AxisMask>((1u << p.u) | (1u << p.v));
  const bool pole_ok = s_.pole_known && (!s_.pole_defined || s_.pole_plane == s_.plane);
  if (!motion || !pole_ok || !s_.absolute || (w.axis_present & plane_bits) || (w.ext_unresolved & (16u | 32u)) ||
      w.rp_incremental)
    return false;
  if (!s_.pole_defined) s_.pole = Eigen::Vector2d::Zero();  // no pole: the work origin
  double ap = s_.polar_angle, rp = s_.polar_radius;
  if (w.has_ap) ap = w.ap_incremental ? s_.polar_angle + w.ap : w.ap;
  if (w.has_rp) rp = to_mm(0, w.rp);
  if ((!w.has_ap || w.ap_incremental) && !s_.polar_angle_set) return false;
  if (!w.has_rp && !s_.polar_radius_set) return false;
  s_.polar_angle = ap;
  s_.polar_radius = rp;
  s_.polar_angle_set = s_.polar_radius_set = true;
  const double a = ap * std::numbers::pi / 180.0;
  end = s_.pole + rp * Eigen::Vector2d(std::cos(a), std::sin(a));
  return true;
}

}  // namespace postproc::gcode
