// Modal interpreter: LinuxCNC cutter radius compensation (G40, G41/G42, G41.1/G42.1). What turns it
// on and off, which tool radius it takes, what LinuxCNC refuses while it is on, and where the
// compensated moves (cutter_offset.cpp) leave the interpreter. Each rule names the LinuxCNC
// function (rs274ngc interp_convert.cc, interp_queue.cc) or G-code reference section it follows.
#include <cmath>

#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"
#include "src/gcode/cutter_offset.hpp"
#include "src/gcode/kept_block.hpp"

namespace postproc::gcode {

struct Interpreter::CutterComp {
  CutterOffset offset;
  bool broken = false;           ///< refused under this activation: tool-centre positions unknown until G40
  bool start_unknown = false;    ///< the point where compensation started is not known
  bool arc_not_allowed = false;  ///< G40 ended an activation: the next move must be straight
  bool off_pending = false;      ///< G40 in this block: the held moves are released after the modes
  bool restore_break = false;    ///< an M72 switched compensation in a way not followed (PP-U222)
  std::optional<AxisVector> exit_start;  ///< where the machine is after G40: the next move starts there
  bool unknown_radius_moved = false;     ///< a move under G41/G42 with a radius the tool table does not give
  bool exit_unknown = false;             ///< G40 ended such moves: where the tool is is not known until it moves
  Plane exit_plane = Plane::xy;
  KeptBlock last;                ///< the block whose move is held last
  bool last_kept = false;
};

namespace {

constexpr const char* kOnlyXyXz = "Cutter radius compensation allowed only in XY, XZ planes";

/// Passes motions on; the first one after G40 starts where compensation left the machine.
struct ExitStart final : MotionSink {
  ExitStart(MotionSink& o, std::optional<AxisVector>& s, const Plane& p, bool& u)
      : out(o), start(s), plane(p), unknown(u) {}
  void motion(const Motion& m, const Block& b) override {
    unknown = false;  // the move after G40 ends at its programmed point
    if (!start || m.cutter_radius > 0) {
      out.motion(m, b);
      return;
    }
    Motion c = m;
    const PlaneAxes p = plane_axes(plane);
    c.start[p.u] = (*start)[p.u];
    c.start[p.v] = (*start)[p.v];
    start.reset();
    out.motion(c, b);
  }
  MotionSink& out;
  std::optional<AxisVector>& start;
  const Plane& plane;
  bool& unknown;
};

AxisMask plane_bits(Plane p) {
  const PlaneAxes a = plane_axes(p);
  return static_cast<AxisMask>((1u << a.u) | (1u << a.v));
}

}  // namespace

Interpreter::CutterComp& Interpreter::cutter_comp() {
  if (!comp_) comp_ = std::make_shared<CutterComp>();
  return *comp_;
}

bool Interpreter::offset_active() const { return comp_ && comp_->offset.on(); }

bool Interpreter::offset_holding() const { return comp_ && comp_->offset.on() && comp_->offset.holding(); }

void Interpreter::execute_linuxcnc(const Block& b, MotionSink& out) {
  CutterComp& cc = cutter_comp();
  ExitStart from(out, cc.exit_start, cc.exit_plane, cc.exit_unknown);
  execute_block(b, from);
}

void Interpreter::comp_refuse(const Block& b, Span at, std::string_view why, std::string_view what) {
  report(b, at, Severity::error, codes::kCutterCompRefused,
         fmt::format("LinuxCNC stops here under cutter radius compensation: \"{}\"; {}", why, what));
}

void Interpreter::linuxcnc_comp_on(const Block& b, const BlockWords& w, std::uint16_t code10, Span at) {
  // convert_cutter_compensation_on. G41.1/G42.1 take the diameter from D (program units) and a lathe
  // orientation from L (G18 only); G41/G42 take the tool table entry of tool D, or of the tool in
  // the spindle without D or with D0 (find_tool_pocket: tool 0 is the spindle's pocket).
  const bool dynamic = code10 == 411 || code10 == 421;
  const std::string name = dynamic ? fmt::format("G{}.1", code10 / 10) : fmt::format("G{}", code10 / 10);
  if (s_.plane != Plane::xy && s_.plane != Plane::zx) {
    comp_refuse(b, at, kOnlyXyXz, "compensate in G17 or G18");
    return;
  }
  if (s_.cutter_comp != 0) {
    comp_refuse(b, at, "Cannot turn cutter radius comp on when on", "program G40 before switching sides");
    return;
  }
  int side = code10 == 410 || code10 == 411 ? 1 : 2;
  double r = 0;
  bool known = true;
  int orientation = 0;
  if (dynamic) {
    if (!w.has('D')) {
      comp_refuse(b, at, fmt::format("{} with no D word", name), "give the tool diameter in D");
      return;
    }
    if (w.has('L')) {
      if (s_.plane != Plane::zx) {
        comp_refuse(b, b.words[static_cast<std::size_t>(w.letter_word['L' - 'A'])].span,
                    fmt::format("{} with L word, but plane is not G18", name), "program G18 before it or drop L");
        return;
      }
      const double l = w.get('L');
      known = !w.unresolved('L') && l == std::floor(l) && std::abs(l) < 1e6;
      orientation = known ? static_cast<int>(l) : 0;
    }
    known = known && !w.unresolved('D');
    r = known ? to_mm(0, w.get('D')) / 2 : 0;
  } else {
    long tool = 0;  // 0: the tool in the spindle
    if (w.has('D')) {
      const Span dat = b.words[static_cast<std::size_t>(w.letter_word['D' - 'A'])].span;
      if (w.unresolved('D')) {
        known = false;
      } else {
        const double d = w.get('D');
        const long near = static_cast<long>(d + 0.5);
        if (!(std::abs(static_cast<double>(near) - d) < 0.0001) || !(std::abs(d) < 1e9)) {
          comp_refuse(b, dat, fmt::format("{} requires D word to be a whole number", name),
                      "D names a tool of the tool table (0 or none: the tool in the spindle)");
          return;
        }
        tool = near;
      }
    }
    if (known && tool == 0) {
      // The spindle: unknown before a tool change (the program does not say what is loaded), and after
      // M61 (rs274 keeps the spindle pocket's data there, a machine loads the new tool's).
      if (s_.current_tool < 0 || s_.current_tool_by_m61) known = false;
      else tool = s_.current_tool;
    }
    if (known && tool > 0) {
      const auto it = d_.tool_radii.find(static_cast<std::uint32_t>(tool));
      known = it != d_.tool_radii.end();
      r = known ? it->second : 0;
      const auto o = d_.tool_orientations.find(static_cast<std::uint32_t>(tool));
      orientation = o != d_.tool_orientations.end() ? o->second : 0;
      if (known && s_.plane != Plane::zx && orientation != 0 && orientation != 9) {
        comp_refuse(b, at, fmt::format("{} with lathe tool, but plane is not G18", name),
                    "program G18 before it, or give the tool orientation 0 or 9");
        return;
      }
    }
  }
  if (r < 0) {  // a negative diameter: the other side, with the positive radius
    r = -r;
    side = 3 - side;
  }
  s_.cutter_comp = side;
  s_.cutter_radius = r;
  s_.cutter_radius_known = known;
  s_.cutter_comp_reported = false;
  s_.cutter_comp_line = b.line;
  if (!known || r <= 0) return;
  CutterComp& cc = cutter_comp();
  cc.offset.start(side == 1 ? CutterOffset::Side::left : CutterOffset::Side::right, r, s_.plane, orientation,
                  s_.position);
  cc.broken = false;
  cc.start_unknown = (s_.known & plane_bits(s_.plane)) != plane_bits(s_.plane);
  if (cc.exit_start) cc.offset.set_released(*cc.exit_start);
  else cc.offset.set_released(s_.position);
  cc.exit_start.reset();
}

void Interpreter::linuxcnc_tool_setup(const Block& b, const BlockWords& w) {
  // convert_setup_tool (G10 L1/L10/L11 P tool): R sets the tool's radius (diameter 2R), Q its
  // orientation; a later G41/G42 takes them. (The radius of an active compensation does not change.)
  (void)b;
  if (!w.has('R') && !w.has('Q')) return;
  const long p = w.whole_or('P', 0, 99999, -1);
  if (p < 0) {  // which tool is not known: no radius in the table is known any more
    if (w.has('R')) d_.tool_radii.clear();
    if (w.has('Q')) d_.tool_orientations.clear();
    return;
  }
  const auto tool = static_cast<std::uint32_t>(p);
  if (w.has('R')) {
    if (w.unresolved('R')) d_.tool_radii.erase(tool);
    else d_.tool_radii[tool] = to_mm(0, w.get('R'));
  }
  if (w.has('Q')) {
    const long q = w.whole_or('Q', 0, 9, -1);
    if (q < 0) d_.tool_orientations.erase(tool);
    else d_.tool_orientations[tool] = static_cast<int>(q);
  }
}

void Interpreter::comp_restore_break() { cutter_comp().restore_break = true; }

void Interpreter::linuxcnc_comp_off() {
  // convert_cutter_compensation_off runs after the block's M codes and before its other G codes and
  // its motion: the held moves are released right after this block's modes (linuxcnc_comp_modes).
  s_.cutter_comp = 0;
  if (comp_ && comp_->offset.on()) comp_->off_pending = true;
  if (comp_ && comp_->unknown_radius_moved) {  // where the tool centre stopped is not known
    comp_->unknown_radius_moved = false;
    comp_->exit_unknown = true;
    comp_->exit_plane = s_.plane;
  }
}

void Interpreter::pass_on(const Block& b, std::vector<Motion>& moves, MotionSink& out) {
  for (Motion& m : moves) out.motion(m, b);
  moves.clear();
}

void Interpreter::comp_break(const Block& b, MotionSink& out) {
  // After a refusal the tool centre is not known until G40: what was held goes out unknown in the plane.
  CutterComp& cc = *comp_;
  const AxisMask plane = plane_bits(s_.plane);
  std::vector<Motion> held = cc.offset.take_held();
  for (Motion& m : held) m.known &= static_cast<AxisMask>(~plane);
  pass_on(b, held, out);
  cc.broken = true;
}

void Interpreter::linuxcnc_comp_modes(const Block& b, BlockWords& w, const CompBefore& before, MotionSink& out) {
  const int comp = s_.cutter_comp;
  const auto g_at = [&](const BlockWords::G& g) { return b.words[static_cast<std::size_t>(g.word)].span; };
  // convert_m (before the G codes): what may not change under compensation.
  if (before.comp != 0)
    for (int i = 0; i < w.m_count; ++i) {
      const double m = w.m[static_cast<std::size_t>(i)];
      const Span at = b.words[static_cast<std::size_t>(w.m_word[static_cast<std::size_t>(i)])].span;
      const bool p_on = !w.has('P') || w.get('P') != 0;
      const char* why = m == 6    ? "Cannot change tools with cutter radius compensation on"
                        : m == 62 ? "Cannot set motion output with cutter radius compensation on"
                        : m == 63 ? "Cannot set motion digital output with cutter radius compensation on"
                        : m == 64 || m == 65 ? "Cannot set auxiliary digital output with cutter radius compensation on"
                        : m == 66 ? (w.has('E') && !w.has('P') ? "Cannot wait for analog input with cutter radius compensation on"
                                                               : "Cannot wait for digital input with cutter radius compensation on")
                        : m == 67 ? "Cannot set motion analog output with cutter radius compensation on"
                        : m == 68 ? "Cannot set auxiliary analog output with cutter radius compensation on"
                        : m == 48 || ((m == 50 || m == 51 || m == 52 || m == 53) && p_on)
                            ? "Cannot enable overrides with cutter radius compensation on"
                        : m == 49 || m == 50 || m == 51 || m == 52 || m == 53
                            ? "Cannot disable overrides with cutter radius compensation on"
                            : nullptr;
      if (why != nullptr) comp_refuse(b, at, why, "program G40 before it");
    }
  // A tool change (M6, M61) makes LinuxCNC read its current point back from the machine
  // (toolchange_flag): after G40 that is where compensation left the tool, not the programmed point.
  if (comp_ && comp_->exit_start && before.comp == 0 && (w.has_m(6) || w.has_m(61))) {
    const PlaneAxes p = plane_axes(comp_->exit_plane);
    s_.position[p.u] = (*comp_->exit_start)[p.u];
    s_.position[p.v] = (*comp_->exit_start)[p.v];
    comp_->exit_start.reset();
  }
  if (comp_ && comp_->exit_unknown && before.comp == 0 && (w.has_m(6) || w.has_m(61))) {
    s_.known &= static_cast<AxisMask>(~plane_bits(comp_->exit_plane));
    comp_->exit_unknown = false;
  }
  // convert_set_plane and convert_length_units run before convert_cutter_compensation.
  if (before.comp != 0)
    for (int k = 0; k < w.ng; ++k) {
      const auto& g = w.g[static_cast<std::size_t>(k)];
      if (g.def->group == GGroup::plane) {
        const Plane p = g.def->meaning == GMeaning::plane_xy ? Plane::xy
                        : g.def->meaning == GMeaning::plane_zx ? Plane::zx
                                                               : Plane::yz;
        if (p != before.plane)
          comp_refuse(b, g_at(g), "Cannot change planes with cutter radius compensation on", "program G40 before it");
      }
      if (g.def->group == GGroup::units && s_.inch != before.inch && offset_holding())
        report(b, g_at(g), Severity::warning, codes::kCutterComp,
               "a change of units while a compensated move is held: LinuxCNC rescales what it holds in a way this "
               "version does not compute; change units before G41/G42 or after G40");
    }
  if (comp_ && comp_->restore_break) {
    comp_->restore_break = false;
    if (comp_->offset.on()) comp_break(b, out);
    if (s_.cutter_comp == 0) {  // restored to G40: the programmed point is the current point again
      comp_->offset.stop();
      comp_->broken = false;
    }
  }
  // G40 (convert_cutter_compensation_off): the held moves end where they are; the programmed point
  // is the current point again, and the next move must be straight.
  if (comp_ && comp_->off_pending) {
    CutterComp& cc = *comp_;
    cc.off_pending = false;
    if (!cc.offset.first_move() && cc.broken) {  // refused under this activation: the tool centre is not known
      cc.exit_unknown = true;
      cc.exit_plane = s_.plane;
    }
    if (!cc.offset.first_move() && !cc.broken) {
      std::vector<Motion> moves;
      const auto e = cc.offset.flush(moves);
      pass_on(b, moves, out);
      if (e) {
        comp_refuse(b, g_at(*w.find(GMeaning::cutter_comp)), e->text, "the inside corner is too tight for the tool");
        comp_break(b, out);
      } else {
        cc.exit_start = cc.offset.released_end();
        cc.exit_plane = s_.plane;
      }
    }
    if (!cc.offset.first_move()) cc.arc_not_allowed = true;
    cc.offset.stop();
    cc.broken = false;
    cc.last_kept = false;
  }
  if (comp == 0) return;
  // What the G codes after G40/G41/G42 may not do while compensation is on.
  const bool active = comp_ && comp_->offset.on();
  for (int k = 0; k < w.ng; ++k) {
    const auto& g = w.g[static_cast<std::size_t>(k)];
    const Span at = g_at(g);
    const GMeaning mn = g.def->meaning;
    if (g.def->group == GGroup::tool_length)
      comp_refuse(b, at, "Cannot change tool offset with cutter radius compensation on", "program G40 before it");
    else if (g.def->group == GGroup::work_offset)
      comp_refuse(b, at, "Cannot change coordinate systems with cutter radius compensation on", "program G40 before it");
    else if (g.def->group == GGroup::path_control)
      comp_refuse(b, at, "Cannot change control mode with cutter radius compensation on", "program G40 before it");
    else if (mn == GMeaning::return_initial || mn == GMeaning::return_r)
      comp_refuse(b, at, "Cannot change retract mode with cutter radius compensation on", "program G40 before it");
    else if (mn == GMeaning::probe)
      comp_refuse(b, at, "Cannot probe with cutter radius comp on", "program G40 before it");
    else if (mn == GMeaning::home_return)
      comp_refuse(b, at, "Cannot use g28 or g30 with cutter radius comp", "program G40 before it");
    else if (mn == GMeaning::home_set)
      comp_refuse(b, at, "Cannot set reference point with cutter compensation in effect", "program G40 before it");
    else if (mn == GMeaning::local_offset || mn == GMeaning::set_position)
      comp_refuse(b, at, "Cannot change axis offsets with cutter radius comp", "program G40 before it");
    else if ((mn == GMeaning::reset_position_offset || mn == GMeaning::restore_position_offset) && active &&
             !s_.position_offset.isZero())
      report(b, at, Severity::warning, codes::kCutterComp,
             "G92.1/G92.2/G92.3 under cutter radius compensation: LinuxCNC moves its current point but not the "
             "programmed one, which this version does not compute; clear the offsets before G41/G42 or after G40");
    else if (mn == GMeaning::set_offsets_g10) {
      // convert_setup: L2/L20 on the active system (P0 is the active one).
      const long l = w.whole_or('L', 0, 1000, -1), p = w.whole_or('P', 0, 10000, -1);
      const std::uint16_t wc = s_.work_offset.code10;
      const long index = wc <= 590 ? (wc - 530) / 10 : 6 + (wc - 590);
      if ((l == 2 || l == 20) && (p == 0 || p == index || p < 0))
        comp_refuse(b, at, "Cannot change the active coordinate system with cutter radius compensation on",
                    "program G40 before it");
    } else if (mn == GMeaning::feed_inverse_time && active)
      report(b, at, Severity::warning, codes::kCutterComp,
             "inverse time feed (G93) under cutter radius compensation: LinuxCNC turns F into a rate from the "
             "programmed length and runs the compensated moves at it, which this version does not compute");
  }
  if (active && s_.feed_mode == FeedMode::inverse_time && w.has_meaning(GMeaning::cutter_comp))
    report(b, g_at(*w.find(GMeaning::cutter_comp)), Severity::warning, codes::kCutterComp,
           "cutter radius compensation under inverse time feed (G93): LinuxCNC turns F into a rate from the "
           "programmed length and runs the compensated moves at it, which this version does not compute");
}

bool Interpreter::linuxcnc_comp_motion(const Block& b, BlockWords& w, GMeaning mode, Span at) {
  // The motion of a block under (or just after) compensation: what LinuxCNC refuses. The block runs
  // its motion when it has a motion G code or axis words (rs274 motion_to_be).
  CutterComp* cc = comp_.get();
  const bool straight = mode == GMeaning::rapid || mode == GMeaning::linear || mode == GMeaning::threading;
  const bool arc = mode == GMeaning::arc_cw || mode == GMeaning::arc_ccw;
  const bool moves = w.axis_present != 0 || w.polar_words != 0;
  if (!moves && w.motion.def == nullptr) return true;
  if (cc != nullptr && cc->arc_not_allowed) {
    if (arc) {
      comp_refuse(b, at, "The move just after exiting cutter compensation mode must be straight, not an arc",
                  "program a straight move after G40");
      return false;
    }
    if (straight) cc->arc_not_allowed = false;
  }
  if (s_.cutter_comp == 0) return true;
  const bool active = cc != nullptr && cc->offset.on();
  const std::uint16_t code = w.motion.def != nullptr ? w.motion.def->code10 : s_.motion_code10;
  std::string why;
  switch (mode) {
    case GMeaning::drill_cycle: why = "Cannot use canned cycles with cutter compensation on"; break;
    case GMeaning::turning_cycle:
      // G71/G72 refuse compensation (interp_g7x.cc). G70 makes its moves with convert_straight and
      // convert_arc, so compensation offsets them as other moves, except at its start: rs274 2.9 first
      // takes the tool to the tool-centre point at the profile's last point (both rapids of the cycle's
      // start go there; checked with rs274 on entry and non-entry cases), then from there to the
      // offset profile's start. That defect is not followed: the cycle is not resolved.
      if (code / 10 != 70) why = fmt::format("G{}.{} cannot be used with cutter compensation enabled", code / 10, code % 10);
      else if (active || !s_.cutter_radius_known) {
        report(b, at, Severity::warning, codes::kCutterComp,
               "G70 under cutter radius compensation: LinuxCNC 2.9's interpreter starts the cycle with a rapid to "
               "the tool-centre point at the profile's end, not at the cycle's X Z (an interpreter defect); the "
               "cycle is not followed (X and Z unknown until the program states them); program the finishing pass as "
               "G1/G2/G3 moves under the compensation instead");
        s_.known &= static_cast<AxisMask>(~(bit(Axis::x) | bit(Axis::z)));
        w.axes_consumed = true;
        return false;
      }
      break;
    case GMeaning::spline:
      if (code != 52) why = "Cannot convert spline with cutter radius compensation";
      break;
    default: break;
  }
  if (!why.empty()) {
    comp_refuse(b, at, why, "program G40 before it");
    return false;
  }
  if (!active) return true;
  if (w.machine_frame && straight) {
    comp_refuse(b, at, "Cannot use g53 with cutter radius comp", "program G40 before it");
    return false;
  }
  if ((mode == GMeaning::threading && code != 760) || mode == GMeaning::spline) {
    report(b, at, Severity::warning, codes::kCutterComp,
           "spindle-synchronised motion or a NURBS under cutter radius compensation is not computed by this version "
           "(LinuxCNC treats it as an offset feed move without synchronisation); program G40 before it");
    s_.known &= static_cast<AxisMask>(~w.axis_present);
    w.axes_consumed = true;
    return false;
  }
  if (!moves && (mode == GMeaning::rapid || mode == GMeaning::linear) && cc->offset.first_move()) {
    // A G0/G1 without axis words is a move to where the tool is: too short an entry move.
    comp_refuse(b, at, "Length of cutter compensation entry move is not greater than the tool radius",
                "the entry move must be longer than the tool radius");
    return false;
  }
  return true;
}

void Interpreter::unknown_radius_emit(Motion& m) {
  // G41/G42 with a tool whose radius the tool table does not give: LinuxCNC offsets the path by a
  // radius this run does not know, so where the tool centre runs in the plane is not known.
  m.known &= static_cast<AxisMask>(~plane_bits(s_.plane));
  cutter_comp().unknown_radius_moved = true;
}

void Interpreter::compensated_emit(Motion& m, const Block& b, MotionSink& out) {
  // The programmed move, in mm, becomes the tool-centre path: convert_straight_comp1/2,
  // convert_arc_comp1/2 (cutter_offset.cpp).
  CutterComp& cc = *comp_;
  const AxisMask plane = plane_bits(s_.plane);
  const Span at{m.column > 0 ? m.column - 1 : 0, m.column > 0 ? m.column : 1};
  m.cutter_radius = cc.offset.radius();
  m.words_transformed = true;
  if (!cc.broken && (cc.start_unknown || (m.known & plane) != plane)) {
    report(b, at, Severity::warning, codes::kCutterComp,
           "a move under cutter radius compensation whose programmed point in the plane is not known (after an "
           "unresolved construct): the tool-centre path is not computed until G40; program the plane's axes "
           "absolutely before G41/G42");
    comp_break(b, out);
  }
  if (cc.broken) {
    m.known &= static_cast<AxisMask>(~plane);
    out.motion(m, b);
    return;
  }
  cc.offset.set_inch(s_.inch);
  std::vector<Motion> moves;
  const auto e = cc.offset.move(m, moves);
  pass_on(b, moves, out);
  if (e) {
    if (e->controller) comp_refuse(b, at, e->text, "the tool does not fit this contour: check the radius and the corner");
    else report(b, at, Severity::warning, codes::kCutterComp, e->text);
    comp_break(b, out);
    m.known &= static_cast<AxisMask>(~plane);
    out.motion(m, b);
    return;
  }
  if (cc.offset.holding()) {
    cc.last.keep(b);
    cc.last_kept = true;
  }
}

void Interpreter::linuxcnc_comp_stop(const Block& b, const BlockWords& w, MotionSink& out) {
  // convert_stop: M0, M1, M2, M30, M60 release the held moves where they end; M2/M30 turn
  // compensation off.
  int stop = -1;
  for (int i = 0; i < w.m_count; ++i) {
    const double m = w.m[static_cast<std::size_t>(i)];
    if (m == 0 || m == 1 || m == 2 || m == 30 || m == 60) stop = i;
  }
  if (stop < 0) return;
  CutterComp& cc = cutter_comp();
  if (cc.offset.on() && !cc.broken) {
    std::vector<Motion> moves;
    const auto e = cc.offset.flush(moves);
    pass_on(b, moves, out);
    if (e) {
      comp_refuse(b, b.words[static_cast<std::size_t>(w.m_word[static_cast<std::size_t>(stop)])].span, e->text,
                  "the inside corner is too tight for the tool");
      comp_break(b, out);
    }
  }
  const double m = w.m[static_cast<std::size_t>(stop)];
  if (m == 2 || m == 30) {
    cc.offset.stop();
    cc.broken = false;
    cc.last_kept = false;
    s_.cutter_comp = 0;
  }
}

void Interpreter::linuxcnc_comp_finish() {
  // The program ends (end of file, or '%') with moves held: LinuxCNC never issues them.
  if (!comp_ || !comp_->offset.holding()) return;
  CutterComp& cc = *comp_;
  const std::vector<Motion> dropped = cc.offset.take_held();
  if (cc.broken || !cc.last_kept || dropped.empty()) return;
  const Block& b = cc.last.get();
  const Motion& m = dropped.back();
  report(b, Span{m.column > 0 ? m.column - 1 : 0, m.column > 0 ? m.column : 1}, Severity::warning,
         codes::kCutterComp,
         "the program ends under cutter radius compensation with this move held for the next one: LinuxCNC never "
         "issues it (only M0/M1/M2/M30/M60 or G40 release it); end the program with G40 and M2");
}

}  // namespace postproc::gcode
