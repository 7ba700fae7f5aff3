// Modal interpreter: the end point of a block's axis words — absolute, incremental, machine
// coordinates, and rotary axes that roll over at a full turn (rotary_rollover.hpp).
#include <cmath>

#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"
#include "src/gcode/rotary_direction.hpp"

namespace postproc::gcode {

bool Interpreter::target(const Block& b, const BlockWords& w, Motion& m) {
  m.start = s_.position;
  m.programmed = w.axis_present;
  m.frame = w.machine_frame ? Frame::machine : Frame::work;
  for (int a = 0; a < kAxisCount; ++a) {
    const AxisMask bitmask = static_cast<AxisMask>(1u << a);
    if (!(w.axis_present & bitmask)) continue;
    if (w.axis_unresolved & bitmask) {
      s_.known &= static_cast<AxisMask>(~bitmask);
      continue;
    }
    double v = to_mm(a, w.axis[a]);
    if (a == 0 && s_.diameter_mode) v /= 2;  // X (and U) in diameter; centre words stay radius
    const bool incremental =
        (w.axis_incremental & bitmask) || (!s_.absolute && !(w.axis_absolute & bitmask) && !w.machine_frame);
    const RotaryRollover roll = d_.rollover[static_cast<std::size_t>(a)];
    const auto dir = static_cast<RotaryDirection>(w.axis_direction[static_cast<std::size_t>(a)]);
    if (dir != RotaryDirection::none) {
      // Sinumerik C=DC(w) / ACP(w) / ACN(w): a position within the turn, reached the shortest,
      // the positive or the negative way (rotary_direction.hpp).
      const int wi = w.axis_word[static_cast<std::size_t>(a)];
      const Span at = wi >= 0 ? b.words[static_cast<std::size_t>(wi)].span : Span{};
      const char letter = kAxisLetters[static_cast<std::size_t>(a)];
      const std::string_view fn = function_name(dir);
      if (a < 3 || a > 5) {
        report(b, at, Severity::error, codes::kControllerRefuses,
               fmt::format("{}={}(…): {} positions rotary axes only (the control raises an alarm); write {}={:g}",
                           letter, fn, fn, letter, v));
        return false;
      }
      if (roll != RotaryRollover::modulo && roll != RotaryRollover::shortest) {
        report(b, at, Severity::error, codes::kControllerRefuses,
               fmt::format("{}={}(…) needs {} to be a modulo rotary axis (the control's MD30310 ROT_IS_MODULO = 1), "
                           "and the machine file says [axes.{}] rollover = \"{}\"; set rollover = \"modulo\" (or "
                           "\"shortest\", as the control's MD30455 says) if the axis is one",
                           letter, fn, letter, letter, to_string(roll)));
        return false;
      }
      if (!(v >= 0.0 && v < 360.0)) {
        report(b, at, Severity::error, codes::kControllerRefuses,
               fmt::format("{}={}({:g}): a position with a direction must lie within the turn, 0 ≤ value < 360 "
                           "(the control raises an alarm otherwise); write it within the turn",
                           letter, fn, v));
        return false;
      }
      s_.position[a] = directed_target(dir, v, (s_.known & bitmask) ? s_.position[a] : 0.0);
      s_.known |= bitmask;
      continue;
    }
    if (incremental) {
      s_.position[a] += v;  // unknown stays unknown
    } else if (roll != RotaryRollover::off && !w.machine_frame) {
      // A rotary axis that rolls over at a full turn ([axes.C] rollover): the word is a target
      // within the turn, reached the way the controller's rule says; positions stay continuous.
      if (d_.id == DialectId::linuxcnc && std::abs(v) >= 360.0) {
        const int wi = w.axis_word[static_cast<std::size_t>(a)];
        report(b, wi >= 0 ? b.words[static_cast<std::size_t>(wi)].span : Span{}, Severity::error,
               codes::kControllerRefuses,
               fmt::format("absolute position {:g} of wrapped rotary axis {}: LinuxCNC refuses values of a full turn or "
                           "more on a WRAPPED_ROTARY axis; program the angle within ±360 (the sign gives the direction)",
                           v, kAxisLetters[static_cast<std::size_t>(a)]));
        return false;
      }
      // Where the controller stands is not known to us before the first absolute word: the
      // target's position within the turn is all that the first move fixes.
      s_.position[a] = (s_.known & bitmask) ? rollover_target(roll, v, s_.position[a]) : rollover_target(roll, v, 0.0);
      s_.known |= bitmask;
    } else {
      s_.position[a] = v;
      s_.known |= bitmask;
    }
  }
  m.end = s_.position;
  m.known = s_.known;
  if (w.machine_frame) {
    // Machine coordinates: the row carries them, but the work-frame position is now unknown.
    m.known = w.axis_present & ~w.axis_unresolved;
    s_.known &= static_cast<AxisMask>(~w.axis_present);
  }
  return true;
}

}  // namespace postproc::gcode
