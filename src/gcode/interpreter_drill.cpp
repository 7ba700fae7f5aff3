// Modal interpreter: drilling cycles on mills (G73/G74/G76/G81–G89 with G98/G99 and repeat counts).
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {

void Interpreter::drill(const Block& b, const BlockWords& w, Motion& m, MotionSink& out, std::uint16_t prev_code10) {
  const PlaneAxes p = plane_axes(s_.plane);
  const double scale = s_.inch ? 25.4 : 1.0;
  const AxisMask normal_bit = static_cast<AxisMask>(1u << p.n);
  if (d_.id == DialectId::linuxcnc) {
    if (!linuxcnc_cycle_levels(b, w, normal_bit, prev_code10)) return;
  } else {
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
  }
  const long repeats = drill_repeats(b, w, normal_bit);
  if (repeats < 1) return;
  // L (LinuxCNC) / K (Fanuc) repeats the hole: in G91 the plane move is repeated each time, in G90
  // the same hole is drilled again; R and the bottom are those computed once above (rs274 agrees).
  // LinuxCNC polar words under G91 step from each hole to the next about the program origin
  // (polar_cycle_step); under G90 polar_to_xy placed the one hole already.
  const bool polar_steps = w.polar_words != 0 && !s_.absolute;
  if (!polar_steps) {
    for (long k = 0; k < repeats; ++k) drill_hole(b, w, m, out, normal_bit, p);
    return;
  }
  BlockWords hole = w;
  for (long k = 0; k < repeats; ++k) {
    hole.axis_present = w.axis_present;
    hole.axis_absolute = w.axis_absolute;
    hole.axis_incremental = w.axis_incremental;
    if (!polar_cycle_step(b, hole)) return;
    drill_hole(b, hole, m, out, normal_bit, p);
  }
}

bool Interpreter::linuxcnc_cycle_levels(const Block& b, const BlockWords& w, AxisMask normal_bit,
                                        std::uint16_t prev_code10) {
  // rs274 (convert_cycle_xy and its XZ/YZ forms): a block that starts a cycle (the motion mode was
  // another) needs R and the plane-normal word; R and that word are kept as written and every cycle
  // block computes the levels from them again: under G90 as written, under G91 R from the initial
  // level and the bottom from R — so a G91 block without R after a G90 one drills from the initial
  // level + R, and a unit change rescales the kept numbers.
  const PlaneAxes p = plane_axes(s_.plane);
  const Span at = w.motion.word >= 0 ? b.words[static_cast<std::size_t>(w.motion.word)].span
                                     : b.words.empty() ? Span{} : b.words.front().span;
  if (prev_code10 != s_.motion_code10) {
    const char axis = kAxisLetters[static_cast<std::size_t>(p.n)];
    const bool no_r = !w.has('R'), no_n = !(w.axis_present & normal_bit);
    if (no_r || no_n) {
      report(b, at, Severity::error, codes::kControllerRefuses,
             fmt::format("this block starts the cycle {} without {}: LinuxCNC stops here (rs274: \"{}\"); give {} on "
                         "the block that starts a cycle",
                         b.text(at), no_r ? "R" : std::string(1, axis),
                         no_r ? "R clearance plane unspecified in cycle"
                              : fmt::format("{} value unspecified in {} plane canned cycle", axis,
                                            s_.plane == Plane::xy ? "xy" : s_.plane == Plane::zx ? "xz" : "yz"),
                         no_r ? "R" : std::string(1, axis)));
      s_.known &= static_cast<AxisMask>(~(w.axis_present | normal_bit));
      return false;
    }
  }
  if (w.has('R')) {
    s_.cycle_r_word = w.get('R');
    s_.cycle_r_word_known = !w.unresolved('R');
  }
  if (w.axis_present & normal_bit) {
    s_.cycle_n_word = w.axis[p.n];
    s_.cycle_n_word_known = !(w.axis_unresolved & normal_bit);
  }
  const double scale = s_.inch ? 25.4 : 1.0;
  const double r = s_.cycle_r_word * scale, n = s_.cycle_n_word * scale;
  s_.cycle_r = s_.absolute ? r : s_.cycle_initial + r;
  s_.cycle_r_known = s_.cycle_r_word_known && (s_.absolute || s_.cycle_initial_known);
  s_.cycle_bottom = s_.absolute ? n : s_.cycle_r + n;
  s_.cycle_bottom_known = s_.cycle_n_word_known && (s_.absolute || s_.cycle_r_known);
  return true;
}

long Interpreter::drill_repeats(const Block& b, const BlockWords& w, AxisMask normal_bit) {
  if (!w.has('L') && !w.has('K')) return 1;
  const char letter = w.has('L') ? 'L' : 'K';
  const Span at = b.words[static_cast<std::size_t>(w.letter_word[letter - 'A'])].span;
  const auto unknown = [&] { s_.known &= static_cast<AxisMask>(~(w.axis_present | normal_bit)); };
  if (d_.id == DialectId::linuxcnc && letter == 'L' && !w.unresolved('L')) {
    // rs274 reads L as an integer (a value within 0.0001 of one) and refuses the cycle for a
    // fraction, a negative count and zero (LinuxCNC G-code reference "Canned Cycles": L is the
    // number of repeats; rs274: "Cannot do zero repeats of cycle").
    const double v = w.get('L');
    double n = std::floor(v);
    if (v - n > 0.9999) n = std::ceil(v);
    else if (v - n > 0.0001) n = -2;
    const char* why = n == -2 ? "is not a whole number (rs274: \"Non integer value for integer\")"
                      : n < 0 ? "is negative (rs274: \"Negative l word used\")"
                      : n == 0 ? "asks for zero repeats (rs274: \"Cannot do zero repeats of cycle\")"
                               : nullptr;
    if (why != nullptr) {
      report(b, at, Severity::error, codes::kControllerRefuses,
             fmt::format("the repeat count '{}' of this cycle {}: LinuxCNC stops here; give L a whole number of holes, "
                         "1 or more (or leave it out for one)",
                         b.text(at), why));
      unknown();
      return -1;
    }
    if (n <= 10000) return static_cast<long>(n);
  }
  // A repeat count that is not a small whole number is treated like any repeat (not expanded).
  const long repeats = w.whole_or(letter, 0, 100000, -1);
  if (repeats < 1 || repeats > 10000) {
    report(b, at, Severity::warning, codes::kCycleRepeat,
           fmt::format("drilling cycle with the repeat count '{}' is not expanded ({}); positions after it are unknown",
                       b.text(at), d_.id == DialectId::linuxcnc ? "above 10000 or not known" : "K0, above 10000 or not known"));
    unknown();
    return -1;
  }
  return repeats;
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
