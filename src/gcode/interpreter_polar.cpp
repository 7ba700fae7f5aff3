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

bool Interpreter::polar_to_xy(const Block& b, BlockWords& w) {
  // LinuxCNC polar words (G-code reference "Polar Coordinates", checked against rs274): @ distance
  // and ^ angle (degrees, counter-clockwise from +X) always give X and Y; absolute from the origin,
  // a missing one keeps the current point's; under G91 both add to the current point's.
  const Span at = b.words[static_cast<std::size_t>(w.polar_word)].span;
  const AxisMask xy = bit(Axis::x) | bit(Axis::y);
  if (w.axis_present & xy) {
    report(b, at, Severity::error, codes::kControllerRefuses,
           "polar words (@ ^) together with X or Y: LinuxCNC refuses the block; give the point one way");
    s_.known &= static_cast<AxisMask>(~xy);
    return false;
  }
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
  const double x0 = s_.position[0] / k, y0 = s_.position[1] / k;
  double r = std::hypot(x0, y0);
  double a = std::atan2(y0, x0) * 180.0 / std::numbers::pi;
  if (!s_.absolute && r == 0) {
    report(b, at, Severity::error, codes::kControllerRefuses,
           "incremental polar move from the origin: its direction is undefined and LinuxCNC refuses it");
    return false;
  }
  const double dr = (w.polar_words & 1u) ? w.polar_distance : 0.0;
  const double da = (w.polar_words & 2u) ? w.polar_angle : 0.0;
  if (s_.absolute) {
    if (w.polar_words & 1u) r = w.polar_distance;
    if (w.polar_words & 2u) a = w.polar_angle;
  } else {
    r += dr;
    a += da;
  }
  const double rad = a * std::numbers::pi / 180.0;
  w.axis[0] = r * std::cos(rad);
  w.axis[1] = r * std::sin(rad);
  w.axis_present |= xy;
  w.axis_absolute |= xy;
  w.axis_incremental &= static_cast<AxisMask>(~xy);
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
