// Modal interpreter, part 4: lathe threading cycles (docs/threading.md). LinuxCNC G76; Fanuc lathe
// G32, G92 (G78 in G-code system B) and the two-block G76. The pass plans are worked out in
// threading_cycles.cpp; here the block's words are checked the way the controller checks them and
// the plan becomes Motions of the cycle's block (synchronised moves: linear, feed per revolution
// = the lead).
#include <cmath>
#include <memory>
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

/// What the threading cycles keep from block to block.
struct Interpreter::ThreadingState {
  // Fanuc G92 / G78: X(U), Z(W) and R stay in force while the cycle repeats (B-64304EN / B-64484EN
  // "Threading cycle (G92)": data modal in the canned cycle), in mm, X as a radius.
  bool cycle_data = false;
  double end_x = 0, end_z = 0, taper = 0;
  // Parameter No. 5130 (thread chamfering amount of G92 and G76, 0.1 lead units): a G76 first
  // block's P(m)(r)(a) writes it. -1 = not set by the program (factory setting 0); -2 = set to a
  // value the reader does not know.
  int chamfer_tenths = -1;
};

Interpreter::ThreadingState& Interpreter::threading_state() {
  if (!threading_) threading_ = std::make_shared<ThreadingState>();
  return *threading_;
}

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
  if (d_.id != DialectId::fanuc || !d_.lathe) return false;
  if (code10 == 320) {
    if (w.axis_present == 0) return true;  // G32 without axis words: no motion
    fanuc_g32(b, w, out);
    return true;
  }
  if ((code10 == 920 && d_.gcode_system == 'A') || (code10 == 780 && d_.gcode_system != 'A')) {
    if (w.motion.def != nullptr) threading_state().cycle_data = false;  // a new cycle: its data anew
    if (w.axis_present == 0) return w.motion.def == nullptr;  // G92 alone: refused below as today; F/M alone: no motion
    fanuc_g92(b, w, out);
    return true;
  }
  if (code10 == 760 && w.motion.def != nullptr && (w.axis_present & kXZ) == 0 && w.has('P')) {
    // The first block of the two-block G76 writes parameters 5142 (m), 5130 (r) and 5143 (a)
    // from P(m)(r)(a) (B-64304EN "Multiple threading cycle (G76)"); the chamfer amount r also
    // applies to G92. The cycle itself is not followed by this version (PP-U202 below).
    const Word& pw = b.words[static_cast<std::size_t>(w.letter_word['P' - 'A'])];
    const double p = w.get('P');
    ThreadingState& t = threading_state();
    if (w.unresolved('P') || !pw.whole || !(p >= 0 && p <= 999999))
      t.chamfer_tenths = -2;
    else
      t.chamfer_tenths = static_cast<int>(std::lround(p)) / 100 % 100;
  }
  return false;
}

void Interpreter::fanuc_g32(const Block& b, const BlockWords& w, MotionSink& out) {
  // B-64304EN / B-64484EN "Threading (G32)": G32 X(U) Z(W) F; a straight move synchronised with
  // the spindle, F = the lead (along the longer axis). Read like LinuxCNC G33: a linear move at
  // feed per revolution = F.
  const Span at = b.words[static_cast<std::size_t>(w.motion.word >= 0 ? w.motion.word
                                                   : w.axis_word[2] >= 0 ? w.axis_word[2]
                                                   : w.axis_word[0] >= 0 ? w.axis_word[0]
                                                                         : 0)]
                      .span;
  const auto refuse = [&](std::string msg) {
    report(b, at, Severity::warning, codes::kThreadingUnresolved, std::move(msg));
    s_.known &= static_cast<AxisMask>(~w.axis_present);
  };
  for (char L : {'E', 'I', 'K'})
    if (w.has(L)) {
      // Series 0i/30i G32 takes the lead in F only; some posts write it as K (or E, threads per
      // inch): which one the control uses is not read here.
      refuse(fmt::format("G32 with {}: the Fanuc format is G32 X(U) Z(W) F(lead); a lead given by {} is not followed "
                         "by this version",
                         L, L));
      return;
    }
  if (!s_.feed_known || s_.feed_undefined || s_.feed <= 0) {
    refuse("G32: the lead F is not known here; program F (the lead) on the G32 block");
    return;
  }
  if (s_.polar_coords || s_.scaling || s_.mirror != 0 || s_.polar_interp || s_.cutter_comp != 0) {
    refuse("G32 under polar coordinates, scaling, mirroring or tool nose radius compensation is not followed by "
           "this version");
    return;
  }
  Motion m;
  m.line = b.line;
  for (int a = 0; a < kAxisCount; ++a) m.word_index[static_cast<std::size_t>(a)] = w.axis_word[static_cast<std::size_t>(a)];
  m.column = at.begin + 1;
  fill_state(m);
  m.type = MotionType::linear;
  if (!target(b, w, m)) return;
  m.feed = s_.feed;  // already mm (per revolution: the lead)
  m.feed_mode = FeedMode::per_rev;
  m.feed_known = true;
  out.motion(m, b);
}

void Interpreter::fanuc_g92(const Block& b, const BlockWords& w, MotionSink& out) {
  // B-64304EN / B-64484EN "Threading cycle (G92)" (G78 in G-code system B): from the start point
  // A, (1) rapid to the X of the block (plus the taper R at the start), (2) threading to X Z at
  // F per revolution, (3) rapid back to A's X, (4) rapid back to A's Z. X(U) Z(W) R stay in force:
  // a following block with X (U) alone repeats the cycle at that X.
  const char* name = d_.gcode_system == 'A' ? "G92" : "G78";
  const Span at = b.words[static_cast<std::size_t>(w.motion.word >= 0 ? w.motion.word
                                                   : w.axis_word[0] >= 0 ? w.axis_word[0]
                                                   : w.axis_word[2] >= 0 ? w.axis_word[2]
                                                                         : 0)]
                      .span;
  ThreadingState& t = threading_state();
  const auto refuse = [&](std::string msg) {
    report(b, at, Severity::warning, codes::kThreadingUnresolved, std::move(msg));
    s_.known &= static_cast<AxisMask>(~(kXZ | w.axis_present));
    t.cycle_data = false;
  };
  for (char L : {'E', 'I', 'K'})
    if (w.has(L)) {
      refuse(fmt::format("{} with {}: the format is {} X(U) Z(W) R F(lead); not followed by this version", name, L, name));
      return;
    }
  const AxisMask others = static_cast<AxisMask>(w.axis_present & ~kXZ);
  if (others != 0) {
    refuse(fmt::format("{} with an axis other than X (U) and Z (W) is not followed by this version", name));
    return;
  }
  if ((w.axis_unresolved & kXZ) != 0 || (w.has('R') && w.unresolved('R'))) {
    refuse(fmt::format("{}: a value is not known here; the cycle is not followed", name));
    return;
  }
  if (!t.cycle_data && (w.axis_present & kXZ) != kXZ) {
    refuse(fmt::format("{} needs X (U) and Z (W) on the block that starts the cycle; not followed", name));
    return;
  }
  if (!s_.feed_known || s_.feed_undefined || s_.feed <= 0) {
    refuse(fmt::format("{}: the lead F is not known here; program F (the lead) on the cycle's block{}", name,
                       d_.gcode_system == 'A' ? " (if this G92 sets the coordinate system, the program is written "
                                                "for G-code system B: pass --gcode-system B)"
                                              : ""));
    return;
  }
  if (s_.polar_coords || s_.scaling || s_.mirror != 0 || s_.polar_interp || s_.cutter_comp != 0) {
    refuse(fmt::format("{} under polar coordinates, scaling, mirroring or tool nose radius compensation is not "
                       "followed by this version",
                       name));
    return;
  }
  if (t.chamfer_tenths != -1 && t.chamfer_tenths != 0) {
    // The program set parameter 5130 (G76 P(m)(r)(a)): the thread ends with a chamfer of r·L/10
    // whose angle is parameter 5131, which the program does not state.
    report(b, at, Severity::warning, codes::kThreadingParameter, fmt::format("{}: the thread chamfering amount (parameter 5130) was set {} by a G76 block; the chamfer "
                       "(angle: parameter 5131) is not followed by this version",
                       name, t.chamfer_tenths == -2 ? "to a value not known here" : "to a non-zero value"));
    s_.known &= static_cast<AxisMask>(~(kXZ | w.axis_present));
    t.cycle_data = false;
    return;
  }
  if ((s_.known & kXZ) != kXZ) {
    report(b, at, Severity::warning, codes::kUnknownPosition,
           fmt::format("{} starts and ends at the current point, which is unknown here; position X and Z before the "
                       "cycle",
                       name));
    s_.known &= static_cast<AxisMask>(~(kXZ | w.axis_present));
    t.cycle_data = false;
    return;
  }
  // The end point: the block's X(U) Z(W) read as for G00 (U/W from the start point A), the
  // others from the cycle's data.
  const AxisVector start = s_.position;
  const AxisMask known_before = s_.known;
  Motion probe;
  target(b, w, probe);
  const AxisVector end = s_.position;
  s_.position = start;
  s_.known = known_before;
  if (w.axis_present & bit(Axis::x)) t.end_x = end[0];
  if (w.axis_present & bit(Axis::z)) t.end_z = end[2];
  const double scale = s_.inch ? 25.4 : 1.0;
  if (w.motion.def != nullptr || w.has('R')) t.taper = w.has('R') ? to_mm(0, w.get('R')) : 0.0;  // R: radius
  t.cycle_data = true;
  threading::FanucG92 c;
  c.start_x = start[0] / scale;
  c.start_z = start[2] / scale;
  c.end_x = t.end_x / scale;
  c.end_z = t.end_z / scale;
  c.taper = t.taper / scale;
  c.lead = s_.feed / scale;
  std::vector<threading::Move> moves;
  threading::plan_fanuc_g92(c, moves);
  thread_moves(b, at, moves, out);
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
