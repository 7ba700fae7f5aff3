#pragma once
// Lathe profile cycles: the moves a controller cuts for a turning cycle whose finished shape is a
// profile (LinuxCNC G70 finishing, G71/G72 roughing with G7x.1 / G7x.2 variants).
//
// Points are complex numbers z + i·x in program units with x as a radius (the plane G18 with Z as
// the first axis, so a counter-clockwise turn goes from +Z towards +X, as G3 does there).
#include <complex>
#include <string>
#include <vector>

#include "postproc/gcode/motion.hpp"

namespace postproc::gcode::turning {

using Point = std::complex<double>;  ///< real = Z, imag = X (radius)

/// One element of the profile, or of the tool path cut from it.
struct Segment {
  bool arc = false;
  bool ccw = false;   ///< arcs: G3
  Point a, b;         ///< start, end
  Point c;            ///< arcs: centre
  /// LinuxCNC profile corner (A or C word on a profile block): a zero-length placeholder at the
  /// corner, made into a fillet (`arc`) or a chamfer (straight) of this size before the cycle is
  /// cut; 0 for every other element.
  double corner = 0;
};

/// One move of the expanded cycle.
struct Move {
  enum class Kind { rapid, line, arc_cw, arc_ccw } kind = Kind::rapid;
  Point end;
  Point centre;  ///< arcs
};

/// The motion type a move of an expanded cycle is written as.
[[nodiscard]] inline MotionType motion_type(Move::Kind k) {
  switch (k) {
    case Move::Kind::rapid: return MotionType::rapid;
    case Move::Kind::line: return MotionType::linear;
    case Move::Kind::arc_cw: return MotionType::arc_cw;
    case Move::Kind::arc_ccw: return MotionType::arc_ccw;
  }
  return MotionType::linear;
}

struct CycleWords {
  int cycle = 71;     ///< 70, 71 or 72
  int variant = 0;    ///< 0 (whole profile with pockets), 1 (G7x.1: no pockets), 2 (G7x.2: pockets only)
  Point start;        ///< X/Z of the cycle block, else the current point
  double d = 0;       ///< G71/G72: distance left to the profile; G70: first pass distance
  double e = 0;       ///< G70: last pass distance
  double passes = 1;  ///< G70: P
  double increment = 1;  ///< G71/G72: I (depth of cut)
  double retract = 0.5;  ///< G71/G72: R
};

/// Expands LinuxCNC's G70/G71/G72 (linuxcnc.org/docs/html/gcode/g-code.html#gcode:g70,
/// #gcode:g71-g72) over `profile` (the moves of the Q subroutine, the first starting at
/// `w.start`) into `out`. Returns an empty string, or the reason the controller rejects the
/// cycle (the message rs274 gives: "Not monotonic", "Cannot intersect parallel lines", …).
std::string expand_linuxcnc(const CycleWords& w, std::vector<Segment> profile, std::vector<Move>& out);

/// Fanuc G71 / G72 type I (Series 0i/30i lathe, "Stock removal in turning / facing"): the tool
/// stands at A; the profile runs from A' (the ns block's end) to B; the area between A, A', B and
/// the closing point C (B's cut coordinate on A's infeed level) is cut away in layers of `depth`,
/// leaving `allowance` (Δw, Δu/2) on the profile.
struct FanucRough {
  bool facing = false;       ///< G72: layers parallel to X, infeed along Z
  Point start;               ///< A
  double depth = 0;          ///< Δd, > 0
  double escape = 0;         ///< e, >= 0: 45° retraction after each layer
  Point allowance;           ///< (Δw, Δu/2), added to every point of the profile
  bool infeed_rapid = true;  ///< the ns block is G00 (G01: layers are fed in at cutting feed)
  bool final_cut = true;     ///< parameter 5105#1 RF1 = 0: a last cut along the allowance profile
};

/// Expands FanucRough over `profile` (A' → B; every element must run monotonically, type I) into
/// `out`, ending with the return to A. Returns an empty string, or why the cycle is refused; the
/// refusal starts with "alarm: " where the controller itself stops with an alarm.
std::string expand_fanuc_rough(const FanucRough& w, std::vector<Segment> profile, std::vector<Move>& out);

/// Fanuc G73 (pattern repeating): `passes` copies of the profile, the first shifted by
/// relief + allowance, the last by the allowance alone; each pass starts from A (a move in the
/// ns block's mode to the shifted A'), follows the shifted profile and returns to A at rapid.
std::string expand_fanuc_pattern(Point start, Point relief, Point allowance, int passes, bool infeed_rapid,
                                 const std::vector<Segment>& profile, std::vector<Move>& out);

}  // namespace postproc::gcode::turning
