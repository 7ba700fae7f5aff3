// Modal interpreter, part 4: lathe threading cycles (docs/threading.md). LinuxCNC G76; Fanuc lathe
// G32, G92 (G78 in G-code system B) and the two-block G76. The pass plans are worked out in
// threading_cycles.cpp; here the block's words are checked the way the controller checks them and
// the plan becomes Motions of the cycle's block (synchronised moves: linear, feed per revolution
// = the lead).
#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"
#include "src/gcode/threading_cycles.hpp"

namespace postproc::gcode {
namespace {

constexpr AxisMask kXZ = static_cast<AxisMask>(bit(Axis::x) | bit(Axis::z));

}  // namespace

void Interpreter::thread_moves(const Block& b, Span at, const std::vector<threading::Move>& moves, MotionSink& out) {
  const double scale = s_.inch ? 25.4 : 1.0;
  for (const threading::Move& mv : moves) {
    Motion m;
    m.line = b.line;
    m.column = at.begin + 1;
    fill_state(m);
    m.word_index.fill(-1);  // the block's words are not these end points
    m.start = s_.position;
    s_.position[2] = mv.z * scale;
    s_.position[0] = mv.x * scale;
    s_.known |= kXZ;
    m.end = s_.position;
    m.known = s_.known;
    if (mv.kind == threading::Move::Kind::rapid) {
      m.type = MotionType::rapid;
    } else {
      // A move synchronised with the spindle: a straight feed at lead per revolution.
      m.type = MotionType::linear;
      m.feed = std::abs(mv.lead) * scale;  // rs274 runs a negative P as its magnitude along the same path
      m.feed_mode = FeedMode::per_rev;
      m.feed_known = true;
    }
    out.motion(m, b);
  }
}

bool Interpreter::threading_cycle(const Block& b, const BlockWords& w, MotionSink& out) {
  const int code10 = s_.motion_code10;
  if (d_.id == DialectId::linuxcnc && code10 == 760) {
    if (w.motion.def == nullptr && w.axis_present == 0) return true;  // e.g. "F10" while G76 is the mode: no motion
    linuxcnc_g76(b, w, out);
    return true;
  }
  return false;
}

void Interpreter::linuxcnc_g76(const Block& b, const BlockWords& w, MotionSink& out) {
  const Span at = b.words[static_cast<std::size_t>(w.motion.word >= 0 ? w.motion.word
                                                   : w.axis_word[2] >= 0 ? w.axis_word[2]
                                                                         : 0)]
                      .span;
  const auto refuse = [&](std::string_view code, std::string msg) {
    report(b, at, code == codes::kThreadingRejected ? Severity::error : Severity::warning, code, std::move(msg));
    s_.known &= static_cast<AxisMask>(~(kXZ | w.axis_present));
  };
  // What rs274 (LinuxCNC 2.9) refuses, in its words; the G-code reference ("G76 Threading Cycle",
  // "It is an error if") lists most of them.
  if (w.axis_present == 0) {
    refuse(codes::kThreadingRejected, "G76 without an axis word (rs274: \"All axes missing with motion code\"); "
                                      "give Z, the end of the thread");
    return;
  }
  if (!w.has('P')) {
    refuse(codes::kThreadingRejected,
           "G76 needs P, the thread pitch, on every G76 block (rs274: \"P word missing with G76\")");
    return;
  }
  if (!w.has('I') || !w.has('J') || !w.has('K')) {
    refuse(codes::kThreadingRejected, "G76 needs I, J and K (rs274: \"I J or K words missing with G76\")");
    return;
  }
  if (w.axis_present & (bit(Axis::a) | bit(Axis::b) | bit(Axis::c))) {
    refuse(codes::kThreadingRejected, "G76 with a rotary axis word (rs274: \"Cannot move rotary axes with G76\")");
    return;
  }
  if (w.axis_present & (bit(Axis::u) | bit(Axis::v) | bit(Axis::w))) {
    refuse(codes::kThreadingUnresolved, "G76 with a U, V or W word is not followed by this version; move those axes "
                                        "in a block of their own");
    return;
  }
  for (char L : {'P', 'I', 'J', 'K', 'Q', 'R', 'H', 'E', 'L'})
    if (w.has(L) && w.unresolved(L)) {
      refuse(codes::kThreadingUnresolved, fmt::format("G76: the value of {} is not known here; the cycle is not followed", L));
      return;
    }
  if (w.axis_unresolved != 0) {
    refuse(codes::kThreadingUnresolved, "G76: an axis value is not known here; the cycle is not followed");
    return;
  }
  const double div = s_.diameter_mode ? 2.0 : 1.0;  // G7: I J K are diameters (G-code reference, G76 note)
  threading::LinuxcncG76 c;
  c.pitch = w.get('P');
  c.i = w.get('I') / div;
  c.j = w.get('J') / div;
  c.k = w.get('K') / div;
  if (c.i == 0) {
    refuse(codes::kThreadingRejected, "G76: I must not be 0 (rs274: \"In G76, I must not be 0\")");
    return;
  }
  if (!(c.j > 0)) {
    refuse(codes::kThreadingRejected, "G76: J must be greater than 0 (rs274: \"In G76, J must be greater than 0\")");
    return;
  }
  if (!(c.k > c.j)) {
    refuse(codes::kThreadingRejected, "G76: K must be greater than J (rs274: \"In G76, K must be greater than J\")");
    return;
  }
  if (s_.cutter_comp != 0) {
    refuse(codes::kThreadingRejected, "G76 with cutter radius compensation on (rs274: \"Cannot use G76 threading "
                                      "cycle with cutter radius compensation on\"); program G40 before it");
    return;
  }
  if (!spindle_turning_) {
    refuse(codes::kThreadingRejected,
           "G76 while the spindle is not turning (rs274: \"Chosen spindle (0) not turning in G76\"); program M3 or M4 "
           "before it");
    return;
  }
  for (char L : {'H', 'L'})
    if (w.has(L) && w.get(L) != std::floor(w.get(L))) {
      refuse(codes::kThreadingRejected,
             fmt::format("G76: {} must be a whole number (rs274: \"Non integer value for integer\")", L));
      return;
    }
  if (w.has('L') && w.get('L') < 0) {
    refuse(codes::kThreadingRejected, "G76: L must not be negative (rs274: \"Negative l word used\")");
    return;
  }
  if ((s_.known & kXZ) != kXZ) {
    report(b, at, Severity::warning, codes::kUnknownPosition,
           "G76 starts from the current point (the drive line is its X, the thread starts at its Z), which is unknown "
           "here; position X and Z before the cycle");
    s_.known &= static_cast<AxisMask>(~(kXZ | w.axis_present));
    return;
  }
  const double scale = s_.inch ? 25.4 : 1.0;
  c.start_x = s_.position[0] / scale;
  c.start_z = s_.position[2] / scale;
  // The block's axis words are its end point (rs274 ends the cycle with a rapid there): X Y Z as
  // for G0, G91 and G7 included.
  const AxisVector start = s_.position;
  const AxisMask known_before = s_.known;
  Motion last;
  target(b, w, last);
  const AxisVector end = s_.position;
  const AxisMask known_after = s_.known;
  s_.position = start;
  s_.known = known_before;
  c.end_z = end[2] / scale;
  c.has_q = w.has('Q');
  c.q = c.has_q ? w.get('Q') : 0;
  c.has_r = w.has('R');
  c.r = c.has_r ? w.get('R') : 1;
  c.h = w.has('H') ? static_cast<long>(w.get('H')) : 0;
  c.has_e = w.has('E');
  c.e = c.has_e ? w.get('E') : 0;
  c.has_l = w.has('L');
  c.l = c.has_l ? static_cast<long>(w.get('L')) : 0;
  std::vector<threading::Move> moves;
  const std::string failure = threading::plan_linuxcnc_g76(c, moves);
  if (!failure.empty()) {
    refuse(codes::kThreadingUnresolved, fmt::format("G76: {}; the cycle is not followed", failure));
    return;
  }
  thread_moves(b, at, moves, out);
  // The final rapid to the block's end point.
  Motion m;
  m.line = b.line;
  m.column = at.begin + 1;
  fill_state(m);
  m.word_index.fill(-1);
  m.type = MotionType::rapid;
  m.start = s_.position;
  s_.position = end;
  s_.known = known_after;
  m.end = end;
  m.known = known_after;
  out.motion(m, b);
}

}  // namespace postproc::gcode
