// Modal interpreter, part 3: Fanuc programmable frames that change what axis words mean — G16 polar
// coordinate command, G51 scaling, G51.1 programmable mirror image. Each case is either converted to
// the work frame exactly as the control does, or refused at its word (docs/dialect-fanuc.md).
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

}  // namespace

void Interpreter::fanuc_frame_command(const Block& b, BlockWords& w, const GCodeDef& def, Span at) {
  switch (def.meaning) {
    case GMeaning::polar_coord_on: s_.polar_coords = true; break;
    case GMeaning::polar_coord_off: s_.polar_coords = false; break;
    case GMeaning::scaling_on:
      // B-64484EN "Scaling (G50, G51)": X Y Z are the scaling centre, P or I J K the factors; the block
      // does not move. Scaled motions are refused while it is active (see fanuc_frame).
      w.axes_consumed = true;
      s_.scaling = true;
      break;
    case GMeaning::scaling_off: s_.scaling = false; break;
    case GMeaning::mirror_on: {
      // B-64484EN "Programmable mirror image (G50.1, G51.1)": G51.1 IP_ names the axes to mirror and the
      // position of the axis of symmetry; the block does not move.
      w.axes_consumed = true;
      for (int a = 0; a < kAxisCount; ++a) {
        const AxisMask m = static_cast<AxisMask>(1u << a);
        if (!(w.axis_present & m)) continue;
        s_.mirror |= m;
        s_.mirror_synced &= static_cast<AxisMask>(~m);
        const Span ws = b.words[static_cast<std::size_t>(w.axis_word[static_cast<std::size_t>(a)])].span;
        const bool incremental = (w.axis_incremental & m) || !s_.absolute;
        if ((w.axis_unresolved & m) || incremental) {
          s_.mirror_centre_known &= static_cast<AxisMask>(~m);
          report(b, ws, Severity::warning, codes::kFanucMirror,
                 fmt::format("'{}': the axis of symmetry of G51.1 is {}; motions of axis {} are not resolved while "
                             "the mirror image is active — give it as a literal in G90",
                             b.text(ws), incremental ? "incremental (from a point this version does not follow)"
                                                     : "an expression",
                             kAxisLetters[static_cast<std::size_t>(a)]));
          continue;
        }
        double v = to_mm(a, w.axis[a]);
        if (a == 0 && s_.diameter_mode) v /= 2;
        s_.mirror_centre[a] = v;
        s_.mirror_centre_known |= m;
      }
      break;
    }
    case GMeaning::mirror_off: {
      w.axes_consumed = true;
      AxisMask off = w.axis_present;
      if (off == 0 && s_.mirror != 0) {
        // Which axes G50.1 without axis words cancels is not documented: the mirrored axes' positions
        // become unknown.
        report(b, at, Severity::warning, codes::kFanucMirror,
               "G50.1 without axis words: name the mirrored axes to cancel (e.g. G50.1 X0 Y0); positions of the "
               "mirrored axes are unknown after it");
        s_.known &= static_cast<AxisMask>(~s_.mirror);
        off = s_.mirror;
      }
      // After the cancel, the control's programmed position on an axis that was not re-established under
      // the mirror differs from the actual one; an absolute move re-establishes it.
      s_.known &= static_cast<AxisMask>(~(off & s_.mirror & ~s_.mirror_synced));
      s_.mirror &= static_cast<AxisMask>(~off);
      s_.mirror_synced &= static_cast<AxisMask>(~off);
      break;
    }
    default: break;
  }
}

bool Interpreter::fanuc_frame(const Block& b, BlockWords& w, GMeaning& mode) {
  Span at = w.motion.word >= 0 ? b.words[static_cast<std::size_t>(w.motion.word)].span : Span{};
  for (int a = 0; a < kAxisCount; ++a)
    if (w.axis_word[static_cast<std::size_t>(a)] >= 0) {
      at = b.words[static_cast<std::size_t>(w.axis_word[static_cast<std::size_t>(a)])].span;
      break;
    }
  const PlaneAxes p = plane_axes(s_.plane);
  const AxisMask ub = static_cast<AxisMask>(1u << p.u), vb = static_cast<AxisMask>(1u << p.v);
  const bool is_arc = mode == GMeaning::arc_cw || mode == GMeaning::arc_ccw;
  const auto refuse = [&](Span where, std::string_view code, std::string msg) {
    report(b, where, Severity::warning, code, std::move(msg));
    s_.known &= static_cast<AxisMask>(~(w.axis_present | (is_arc ? (ub | vb) : 0)));
    if (mode == GMeaning::drill_cycle) s_.known &= static_cast<AxisMask>(~(1u << p.n));
    return false;
  };
  if (s_.scaling)
    return refuse(at, codes::kFanucScaling,
                  "motion under G51 scaling: the scale factor and whether it applies per axis are set by parameters "
                  "(No. 5400 SCR/XSC, 5411), so this version does not resolve scaled positions; cancel with G50 "
                  "before the motions that need compensation");
  if (s_.polar_coords && s_.mirror != 0)
    return refuse(at, codes::kFanucMirror, "polar coordinate command (G16) under a mirror image (G51.1) is not "
                                           "resolved by this version; cancel one of them");
  const double scale = s_.inch ? 25.4 : 1.0;
  if (s_.polar_coords && (w.axis_present & (ub | vb))) {
    // B-64484EN "Polar coordinate command (G15, G16)": the first axis of the plane is the radius, the
    // second the angle (degrees, counterclockwise from the first axis). A radius in G90 (or an omitted
    // radius) is measured from the work (or G52 local) origin; a radius in G91 makes the current
    // position the pole. An omitted radius is the distance of the current position from the origin, an
    // omitted angle is the current angle; an angle in G91 is added to the current angle.
    const bool has_r = w.axis_present & ub, has_a = w.axis_present & vb;
    const bool inc = !s_.absolute;
    if (inc && has_r) {
      const Span rs = b.words[static_cast<std::size_t>(w.axis_word[static_cast<std::size_t>(p.u)])].span;
      return refuse(rs, codes::kFanucPolar,
                    fmt::format("'{}': a radius in G91 under G16 makes the current position the pole, and the "
                                "reference of the angle is then not resolved by this version; give the radius in G90",
                                b.text(rs)));
    }
    if (((w.axis_unresolved & ub) && has_r) || ((w.axis_unresolved & vb) && has_a)) {
      w.axis_present |= static_cast<AxisMask>(ub | vb);
      w.axis_unresolved |= static_cast<AxisMask>(ub | vb);
      w.words_transformed = true;
      return true;
    }
    const Eigen::Vector2d cur(s_.position[p.u], s_.position[p.v]);
    const bool cur_known = (s_.known & (ub | vb)) == (ub | vb);
    const bool need_cur = !has_r || !has_a || inc;
    const double r = has_r ? w.axis[p.u] * scale : cur.norm();
    const double cur_angle = std::atan2(cur.y(), cur.x());
    const double angle = has_a ? (inc ? cur_angle + w.axis[p.v] * kDeg : w.axis[p.v] * kDeg) : cur_angle;
    w.axis[p.u] = r * std::cos(angle) / scale;
    w.axis[p.v] = r * std::sin(angle) / scale;
    w.axis_present |= static_cast<AxisMask>(ub | vb);
    w.axis_absolute |= static_cast<AxisMask>(ub | vb);
    w.axis_incremental &= static_cast<AxisMask>(~(ub | vb));
    if (need_cur && !cur_known) w.axis_unresolved |= static_cast<AxisMask>(ub | vb);
    w.words_transformed = true;
  }
  if (s_.mirror != 0) {
    if (mode == GMeaning::drill_cycle && (s_.mirror & (1u << p.n)))
      return refuse(at, codes::kFanucMirror,
                    "drilling cycle with its hole axis mirrored (G51.1) is not resolved by this version");
    const AxisMask synced_before = s_.mirror_synced;
    if (is_arc) {
      for (const int a : {p.u, p.v}) {
        const AxisMask m = static_cast<AxisMask>(1u << a);
        if (!(s_.mirror & m)) continue;
        const char cl = static_cast<char>('I' + a);
        if ((!(w.axis_present & m) || w.has(cl)) && !(synced_before & m))
          return refuse(at, codes::kFanucMirror,
                        fmt::format("arc under the mirror image of axis {} before an absolute move of that axis: the "
                                    "control's programmed start differs from the actual one; program {} absolutely "
                                    "first",
                                    kAxisLetters[static_cast<std::size_t>(a)], kAxisLetters[static_cast<std::size_t>(a)]));
        if (w.has(cl)) w.letter[static_cast<std::size_t>(cl - 'A')] = -w.get(cl);
      }
      // Mirroring exactly one axis of the plane reverses the direction of the arc.
      if (((s_.mirror & ub) != 0) != ((s_.mirror & vb) != 0))
        mode = mode == GMeaning::arc_cw ? GMeaning::arc_ccw : GMeaning::arc_cw;
      w.words_transformed = true;
    }
    for (int a = 0; a < kAxisCount; ++a) {
      const AxisMask m = static_cast<AxisMask>(1u << a);
      if (!(w.axis_present & m) || !(s_.mirror & m)) continue;
      const Span ws = w.axis_word[static_cast<std::size_t>(a)] >= 0
                          ? b.words[static_cast<std::size_t>(w.axis_word[static_cast<std::size_t>(a)])].span
                          : at;
      if (!(s_.mirror_centre_known & m))
        return refuse(ws, codes::kFanucMirror,
                      fmt::format("axis {} is mirrored about an axis of symmetry that is not known (see the G51.1 "
                                  "block)",
                                  kAxisLetters[static_cast<std::size_t>(a)]));
      const bool incremental = (w.axis_incremental & m) || (!s_.absolute && !(w.axis_absolute & m));
      if (incremental)
        return refuse(ws, codes::kFanucMirror,
                      fmt::format("'{}': an incremental move of a mirrored axis (G51.1) is mirrored about the control's "
                                  "programmed position, which this version does not follow; program it in G90",
                                  b.text(ws)));
      if (w.axis_unresolved & m) continue;
      // Work-frame value of the mirrored point, written back in program units for target().
      double v = to_mm(a, w.axis[a]);
      const bool dia = a == 0 && s_.diameter_mode;
      if (dia) v /= 2;
      v = 2 * s_.mirror_centre[a] - v;
      if (dia) v *= 2;
      w.axis[a] = is_rotary(a) ? v : v / scale;
      s_.mirror_synced |= m;
      w.words_transformed = true;
    }
  }
  return true;
}

bool Interpreter::corner_refused(const Block& b, const BlockWords& w, GMeaning mode) {
  // B-64484EN II "Chamfering and corner rounding" (,C / ,R on G01/G02/G03) and, on lathes, "Direct
  // drawing dimension programming" (C R A) and "Chamfering and corner R" (I K R on G01): the end of
  // this block is moved back and a chamfer line or rounding arc is inserted before the next block.
  // This version does not build that geometry: the motions of both blocks are refused (their end
  // points stay exact for the blocks that follow).
  if (w.corner_word < 0 && corner_pending_line_ == 0 && !d_.lathe) return false;  // the usual block
  // ,C and ,R between two straight moves are built (interpreter_corner.cpp).
  if (d_.id == DialectId::fanuc && corner_pending_line_ == 0 && (w.corner_word >= 0 || d_.lathe) &&
      corner_word(b, w, mode))
    return false;
  int here = d_.id == DialectId::fanuc ? w.corner_word : -1;
  // (Under G12.1/G112 polar interpolation C is the rotary axis of the polar plane, not a chamfer.)
  if (here < 0 && d_.id == DialectId::fanuc && d_.lathe && mode == GMeaning::linear && !s_.polar_interp) {
    const auto letter = [&](char L) { return w.has(L) ? static_cast<int>(w.letter_word[static_cast<std::size_t>(L - 'A')]) : -1; };
    const bool xz = (w.axis_present & (bit(Axis::x) | bit(Axis::z))) != 0;
    if (letter('R') >= 0) here = letter('R');
    else if (xz && letter('I') >= 0 && s_.tcp == TcpMode::off) here = letter('I');
    else if (xz && letter('K') >= 0 && s_.tcp == TcpMode::off) here = letter('K');
    else if (w.axis_present & bit(Axis::a)) here = w.axis_word[static_cast<std::size_t>(Axis::a)];
    else if (xz && (w.axis_present & bit(Axis::c))) here = w.axis_word[static_cast<std::size_t>(Axis::c)];
  }
  if (here >= 0) {
    const Span at = b.words[static_cast<std::size_t>(here)].span;
    // An angle (,A or lathe A) makes the controller compute the axis the block omits.
    corner_angle_ = b.words[static_cast<std::size_t>(here)].letter == 'A';
    report(b, at, Severity::warning, codes::kFanucCorner,
           fmt::format("'{}': a chamfer / corner rounding (or direct drawing dimension) between this block and the "
                       "next moves the end of this block and the start of the next; this version does not resolve "
                       "it, both motions are refused — write the chamfer or rounding as its own G01/G02/G03 block{}",
                       b.text(at),
                       w.corner_word >= 0 ? "" : " (on a lathe C may also be a C-axis word: write ,C when the machine "
                                                 "has a C axis, parameter 3405#4 CCR)"));
    corner_pending_line_ = b.line;
    return true;
  }
  if (corner_pending_line_ != 0 && w.axis_present != 0) {
    Span at{};
    for (int a = 0; a < kAxisCount; ++a)
      if (w.axis_word[static_cast<std::size_t>(a)] >= 0) {
        at = b.words[static_cast<std::size_t>(w.axis_word[static_cast<std::size_t>(a)])].span;
        break;
      }
    report(b, at, Severity::warning, d_.id == DialectId::siemens ? codes::kSiemensCorner : codes::kFanucCorner,
           fmt::format("the start of this motion is moved by the chamfer / corner rounding of line {}, which this "
                       "version does not resolve; the motion is refused",
                       corner_pending_line_));
    corner_pending_line_ = 0;
    return true;
  }
  return false;
}

void Interpreter::fanuc_g29(const Block& b, BlockWords& w, Span at, MotionSink& out) {
  // B-64484EN "Return from reference position (G29)": the named axes move at rapid from the reference
  // position through the intermediate point of the last G28/G30 to the commanded point; in G91 the
  // command is the distance from the intermediate point. Axes not named do not move. The leg from
  // the reference position (unknown in the work frame) is not a resolved motion; the second leg is.
  const AxisMask named = w.axis_present;
  if (named == 0) return;
  Motion m;
  m.line = b.line;
  m.column = at.begin + 1;
  m.type = MotionType::rapid;
  fill_state(m);
  for (int a = 0; a < kAxisCount; ++a) m.word_index[static_cast<std::size_t>(a)] = w.axis_word[static_cast<std::size_t>(a)];
  m.words_transformed = true;  // in G91 the words are relative to the intermediate point
  for (int a = 0; a < kAxisCount; ++a) {
    const AxisMask bitmask = static_cast<AxisMask>(1u << a);
    if (!(named & bitmask)) continue;
    s_.position[a] = s_.home_mid[a];
    s_.known = static_cast<AxisMask>((s_.known & ~bitmask) | (s_.home_mid_known & bitmask));
  }
  target(b, w, m);
  if ((s_.known & named) != named)
    report(b, at, Severity::warning, codes::kFanucReturn,
           "G29 end point is not known: in G91 it is relative to the intermediate point of the last G28/G30, which "
           "was not given (or not known) for every named axis; program G29 in G90");
  out.motion(m, b);
}

}  // namespace postproc::gcode
