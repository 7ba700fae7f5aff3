// Modal interpreter: drilling cycles on mills (G73/G74/G76/G81–G89 with G98/G99 and repeat counts).
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {

void Interpreter::drill(const Block& b, const BlockWords& w, Motion& m, MotionSink& out) {
  const PlaneAxes p = plane_axes(s_.plane);
  const double scale = s_.inch ? 25.4 : 1.0;
  const AxisMask normal_bit = static_cast<AxisMask>(1u << p.n);
  if (w.has('R') && !w.unresolved('R')) {
    const double r = w.get('R') * scale;
    s_.cycle_r = s_.absolute ? r : s_.cycle_initial + r;
    s_.cycle_r_known = s_.absolute || s_.cycle_initial_known;
  } else if (w.has('R')) {
    s_.cycle_r_known = false;
  }
  if (w.axis_present & normal_bit) {
    const double z = w.axis[p.n] * scale;
    s_.cycle_bottom = s_.absolute ? z : s_.cycle_r + z;
    s_.cycle_bottom_known = !(w.axis_unresolved & normal_bit);
  }
  // A repeat count that is not a small whole number is treated like any repeat (not expanded).
  const long repeats = w.has('L') ? w.whole_or('L', 0, 100000, -1) : (w.has('K') ? w.whole_or('K', 0, 100000, -1) : 1);
  // L (LinuxCNC) / K (Fanuc) repeats the hole: in G91 the plane move is repeated each time, in G90
  // the same hole is drilled again; R and the bottom are those computed once above (rs274 agrees).
  // L0/K0 (store the cycle without drilling) and polar repeats are not followed.
  if (repeats < 1 || repeats > 10000 || (repeats > 1 && w.polar_words != 0)) {
    report(b, b.words[static_cast<std::size_t>(w.letter_word[(w.has('L') ? 'L' : 'K') - 'A'])].span,
           Severity::warning, codes::kCycleRepeat,
           "drilling cycle with this repeat count is not expanded (L0/K0, above 10000, or repeated polar "
           "moves); positions after it are unknown");
    s_.known &= static_cast<AxisMask>(~(w.axis_present | normal_bit));
    return;
  }
  for (long k = 1; k < repeats; ++k) drill_hole(b, w, m, out, normal_bit, p);
  drill_hole(b, w, m, out, normal_bit, p);
}

void Interpreter::drill_hole(const Block& b, const BlockWords& w, Motion& m, MotionSink& out, AxisMask normal_bit,
                             const PlaneAxes& p) {
  // Position in the plane (incremental in G91), then the cycle; it ends at R (G99) or initial level.
  BlockWords plane_only = w;
  plane_only.axis_present = static_cast<AxisMask>(w.axis_present & ~normal_bit);
  target(b, plane_only, m);
  m.type = MotionType::drill_cycle;
  m.cycle_code10 = s_.motion_code10;
  m.programmed = w.axis_present;
  m.cycle_r = s_.cycle_r;
  m.cycle_bottom = s_.cycle_bottom;
  // G98 returns to the higher of initial level and R: unknown if the initial level was unknown
  // (e.g. after G28). G99 returns to R, known once R was given literally.
  const double retract = s_.return_to_r ? s_.cycle_r : std::max(s_.cycle_initial, s_.cycle_r);
  const bool retract_known = s_.cycle_r_known && (s_.return_to_r || s_.cycle_initial_known);
  s_.position[p.n] = retract;
  if (retract_known) s_.known |= normal_bit;
  else s_.known &= static_cast<AxisMask>(~normal_bit);
  m.end = s_.position;
  m.known = s_.known;
  out.motion(m, b);
}

}  // namespace postproc::gcode
