// Modal interpreter, part 2: non-modal commands and motion geometry (arcs). End points of axis
// words: interpreter_target.cpp; drilling cycles: interpreter_drill.cpp; polar words: interpreter_polar.cpp; Sinumerik arc forms: interpreter_siemens_arcs.cpp;
// G10, G92/G52 and frames (the origin, not the tool): interpreter_offsets.cpp.
#include <cmath>
#include <limits>
#include <numbers>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {
namespace {

constexpr AxisMask kAllAxes = (1u << kAxisCount) - 1;

}  // namespace

void Interpreter::fill_state(Motion& m) const {
  m.plane = s_.plane;
  m.feed = s_.feed;
  m.feed_known = s_.feed_known;
  m.feed_mode = s_.feed_mode;
  m.work_offset = s_.work_offset;
  m.local_offset = s_.local_offset;
  m.position_offset = s_.position_offset;
  m.position_offset_unknown = s_.position_offset_unknown;
  m.tool_length_active = s_.tool_length_active;
  m.spindle_turning = s_.spindle_turning;
  m.tool_length_h = s_.tool_length_h;
  m.tool_length = s_.tool_length;
  m.tool_length_known = s_.tool_length_known;
  // A length the program rewrote (G10) and this version does not know: never the machine file's.
  m.tool_length_rewritten = s_.tool_length_active && !s_.tool_length_known &&
                            (tool_table_unknown_ || lengths_written_.count(s_.tool_length_h) > 0);
  m.work_offset_rewritten =
      work_table_unknown_ ||
      (!work_written_.empty() && work_written_.count(std::uint32_t{s_.work_offset.code10} * 1000 + s_.work_offset.p) > 0);
  m.work_offset_written = 0;
  if (!work_values_.empty())
    if (const auto it = work_values_.find(std::uint32_t{s_.work_offset.code10} * 1000 + s_.work_offset.p);
        it != work_values_.end()) {
      m.work_offset_written = it->second.first;
      m.work_offset_value = it->second.second;
    }
  m.tcp = s_.tcp;
  m.tilted_plane = s_.tilted_plane;
  m.orientation_machine_frame = s_.ori_mks;
  m.diameter_mode = s_.diameter_mode;
  m.inch_source = s_.inch;
  // Fanuc and Sinumerik G41/G42 (rapids too): the controller offsets the path; not computed here.
  if (s_.cutter_comp != 0 && d_.id != DialectId::linuxcnc)
    m.cutter_radius = s_.cutter_radius_known ? s_.cutter_radius : std::numeric_limits<double>::quiet_NaN();
}

void Interpreter::execute_block(const Block& b, MotionSink& out) {
  if (b.empty()) return;
  if (d_.id == DialectId::linuxcnc && lathe_profile_line(b)) return;
  if (fanuc_cycles_ && !fanuc_replay_ && fanuc_profile_line(b, out)) return;
  BlockWords w;
  const bool ok = collect(b, w);
  apply_tokens(b, w);
  const CompBefore before{s_.cutter_comp, s_.plane, s_.inch};
  apply_modes(b, w);
  if (d_.id == DialectId::linuxcnc && (comp_ || before.comp != 0 || s_.cutter_comp != 0))
    linuxcnc_comp_modes(b, w, before, out);
  if (!ok) {
    // A refused block still moves the machine; what it does is unknown.
    s_.known &= static_cast<AxisMask>(~w.axis_present);
    return;
  }
  non_modal(b, w, out);
  if (d_.id == DialectId::linuxcnc)
    for (int k = 0; k < w.m_count; ++k) {
      const double mc = w.m[static_cast<std::size_t>(k)];
      if (mc == 3 || mc == 4) spindle_turning_ = true;
      if (mc == 5) spindle_turning_ = false;
    }
  if (d_.id == DialectId::siemens && w.siemens_corner_word >= 0 &&
      !corner_word(b, w, w.motion.def ? w.motion.def->meaning : s_.motion))
    corner_words(b, w);
  if (!w.axes_consumed) do_motion(b, w, out);
  if (comp_ && w.m_count != 0) linuxcnc_comp_stop(b, w, out);
}

void Interpreter::non_modal(const Block& b, BlockWords& w, MotionSink& out) {
  if (frame_keyword_ != 0) siemens_frame(b, w);
  if (w.has_meaning(GMeaning::machine_coords)) {
    w.machine_frame = true;
    if (!s_.absolute && w.axis_present != 0) {
      // LinuxCNC refuses G53 in G91; Fanuc ignores G91 for G53 on some series and not on others:
      // the move is ambiguous, so it is refused rather than guessed.
      report(b, b.words[static_cast<std::size_t>(w.find(GMeaning::machine_coords)->word)].span, Severity::error,
             codes::kControllerRefuses,
             "G53 (machine coordinates) under G91: LinuxCNC refuses it and controllers disagree on its meaning; "
             "program G90 in this block or before it");
      s_.known &= static_cast<AxisMask>(~w.axis_present);
      w.axes_consumed = true;
    }
  }
  for (int k = 0; k < w.ng; ++k) {
    const auto& g = w.g[static_cast<std::size_t>(k)];
    const Span at = b.words[static_cast<std::size_t>(g.word)].span;
    switch (g.def->meaning) {
      case GMeaning::dwell: dwell(b, w); break;
      case GMeaning::set_offsets_g10: set_offsets(b, w); break;
      case GMeaning::local_offset:
      case GMeaning::set_position:
      case GMeaning::datum_shift_heidenhain: shift_origin(w, g.def->meaning); break;
      case GMeaning::reset_position_offset: remove_position_offset(std::lround(g.def->code10) == 921); break;
      case GMeaning::restore_position_offset: apply_stored_position_offset(); break;
      case GMeaning::home_return: {
        // Intermediate point (if any) is an ordinary rapid; then the axes go home (unknown here).
        AxisMask named = w.axis_present;
        w.axes_consumed = true;
        if (d_.id == DialectId::fanuc && named != 0 && (s_.polar_coords || s_.scaling || (s_.mirror & named))) {
          report(b, at, Severity::warning,
                 s_.polar_coords ? codes::kFanucPolar : s_.scaling ? codes::kFanucScaling : codes::kFanucMirror,
                 fmt::format("'{}' with axis words under {} is not resolved by this version; cancel it first",
                             b.text(at), s_.polar_coords ? "G16" : s_.scaling ? "G51" : "G51.1"));
          s_.known &= static_cast<AxisMask>(~named);
          break;
        }
        if (g.def->code10 == 290 && d_.id == DialectId::fanuc) {
          fanuc_g29(b, w, at, out);
          break;
        }
        if (named != 0 && g.def->code10 != 290 && d_.id != DialectId::siemens) {
          Motion m;
          m.line = b.line;
          m.column = at.begin + 1;
          m.type = MotionType::rapid;
          fill_state(m);
          m.word_index.fill(-1);
          if (target(b, w, m)) out.motion(m, b);
          if (g.def->code10 == 280 || g.def->code10 == 300) {
            // Fanuc keeps the intermediate point of each named axis for G29 (in the work frame).
            s_.home_mid_known = static_cast<AxisMask>((s_.home_mid_known & ~named) | (s_.known & named));
            for (int a = 0; a < kAxisCount; ++a)
              if (named & (1u << a)) s_.home_mid[a] = s_.position[a];
          }
        }
        s_.known &= static_cast<AxisMask>(~(named == 0 ? kAllAxes : named));
        if (named == 0 || (named & bit(Axis::z))) s_.tool_z_pending = 0;  // Z goes home: known by no one
        break;
      }
      case GMeaning::home_set: w.axes_consumed = true; break;
      case GMeaning::polar_pole:
        w.axes_consumed = true;
        if (d_.id == DialectId::siemens) siemens_pole(b, w, g.def->code10, at);
        break;
      case GMeaning::polar_coord_on:
      case GMeaning::polar_coord_off:
      case GMeaning::scaling_on:
      case GMeaning::scaling_off:
      case GMeaning::mirror_on:
      case GMeaning::mirror_off: fanuc_frame_command(b, w, *g.def, at); break;
      case GMeaning::cancel_motion:
        if (w.motion.def == nullptr) {
          // Fanuc B-64484EN "Canned cycle cancel (G80)": G80 cancels group 09 only; G00–G03 of group 01
          // stay as they were before the cycle.
          s_.motion = d_.g80_keeps_motion ? s_.interp_motion : GMeaning::cancel_motion;
          if (d_.g80_keeps_motion) s_.motion_code10 = s_.interp_code10;
        }
        break;
      case GMeaning::spindle_clamp:
        // Fanuc lathe G50: with X/Z it sets the coordinate system like G92, with S it clamps speed.
        if (w.axis_present != 0) {
          w.axes_consumed = true;
          for (int a = 0; a < kAxisCount; ++a)
            if (w.axis_present & (1u << a)) {
              double v = to_mm(a, w.axis[a]);
              if (a == 0 && s_.diameter_mode) v /= 2;
              s_.position[a] = v;
              s_.known |= static_cast<AxisMask>(1u << a);
            }
        }
        break;
      case GMeaning::machine_move_heidenhain:
        w.machine_frame = true;
        break;
      case GMeaning::tilted_plane_tool_axis:
        // Orients the tool to the tilted plane with a rapid move; G0 stays the motion mode (LinuxCNC remaps).
        w.axes_consumed = true;
        s_.known = 0;
        if (d_.id == DialectId::linuxcnc) s_.motion = GMeaning::rapid;
        break;
      case GMeaning::probe:
        unresolved_motion(b, w, codes::kProbe, "probing (its end point is a runtime measurement)");
        s_.known &= static_cast<AxisMask>(~w.axis_present);
        w.axes_consumed = true;
        break;
      case GMeaning::cylindrical_interp:
        unresolved_motion(b, w, codes::kCylindrical, "cylindrical interpolation");
        break;
      case GMeaning::state_only:
        if (g.def->code10 == 650) {
          report(b, at, Severity::warning, codes::kMacroCall, "G65 macro call is not followed by this version");
          w.axes_consumed = true;
        }
        break;
      default: break;
    }
  }
}

void Interpreter::dwell(const Block& b, BlockWords& w) {
  // LinuxCNC (RS274/NGC, G-code reference "G4 Dwell"): G4 takes its time from P only; axis words in
  // the block belong to the active motion mode, which runs after the dwell (rs274 agrees).
  if (d_.id == DialectId::linuxcnc) return;
  // Fanuc (Series 0i/30i operator's manual, "Dwell (G04)"): the time is X (seconds, lathe U too,
  // which collect() has turned into an incremental X) or P (ms); X is never a position here.
  if (d_.id == DialectId::fanuc) w.axis_present = static_cast<AxisMask>(w.axis_present & ~bit(Axis::x));
  // Any other axis word shares a block with a dwell that takes no axis: Fanuc and Sinumerik (G4 in a
  // block of its own, "Dwell time (G4)") do not move there, so the word is refused, not guessed.
  for (int a = 0; a < kAxisCount; ++a) {
    if (!(w.axis_present & (1u << a))) continue;
    const Span at = b.words[static_cast<std::size_t>(w.axis_word[static_cast<std::size_t>(a)])].span;
    report(b, at, Severity::error, codes::kWordNotAllowed,
           fmt::format("'{}' in a G4 (dwell) block: the {} dwell takes only its time ({}), so this axis word is "
                       "not a move there; program the move in a block of its own",
                       b.text(at), d_.name, d_.id == DialectId::fanuc ? "X, U or P" : "F or S"));
    s_.known &= static_cast<AxisMask>(~(1u << a));
    break;
  }
  w.axes_consumed = true;
}

void Interpreter::tool_vector(const BlockWords& w, Motion& m) const {
  // Siemens TRAORI: A3 B3 C3 (missing components are 0); Fanuc G43.5: I J K on linear moves.
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  bool given = false;
  if (s_.tcp == TcpMode::siemens_traori && w.vector_present != 0) {
    v = w.vector;
    given = true;
  } else if (s_.tcp == TcpMode::fanuc_g43_5 && (w.has('I') || w.has('J') || w.has('K')) &&
             !(w.unresolved('I') || w.unresolved('J') || w.unresolved('K'))) {
    v = Eigen::Vector3d(w.has('I') ? w.get('I') : 0.0, w.has('J') ? w.get('J') : 0.0, w.has('K') ? w.get('K') : 0.0);
    given = true;
  }
  if (given && v.norm() > 1e-12) {
    m.tool_vector = v.normalized();
    m.tool_vector_known = true;
  }
}

namespace {
/// Swallows motions that are computed (to keep the modal state exact) but refused.
struct NullSink final : MotionSink {
  void motion(const Motion&, const Block&) override {}
};
}  // namespace

void Interpreter::do_motion(const Block& b, BlockWords& w, MotionSink& out_all) {
  // MillPlus G74 is a one-block rapid in machine coordinates.
  GMeaning mode = w.has_meaning(GMeaning::machine_move_heidenhain) ? GMeaning::rapid
                        : w.motion.def                                  ? w.motion.def->meaning
                                                                        : s_.motion;
  const GMeaning prev_motion = s_.motion;  // Fanuc G70–G75 are one-shot (group 00)
  const std::uint16_t prev_code10 = s_.motion_code10;
  if (d_.id == DialectId::linuxcnc && (comp_ || s_.cutter_comp != 0)) {
    Span at{};
    if (w.motion.word >= 0) at = b.words[static_cast<std::size_t>(w.motion.word)].span;
    else
      for (int a = 0; a < kAxisCount; ++a)
        if (w.axis_word[static_cast<std::size_t>(a)] >= 0) {
          at = b.words[static_cast<std::size_t>(w.axis_word[static_cast<std::size_t>(a)])].span;
          break;
        }
    if (!linuxcnc_comp_motion(b, w, mode, at)) {
      s_.known &= static_cast<AxisMask>(~w.axis_present);
      return;
    }
  }
  NullSink refused;
  // (The usual block has no corner word, no pending corner and is not a lathe block: no call.)
  const bool corner = (w.corner_word >= 0 || corner_pending_line_ != 0 || d_.lathe) &&
                      (d_.id == DialectId::fanuc || (d_.id == DialectId::siemens && corner_pending_line_ != 0)) &&
                      corner_refused(b, w, w.motion.def ? w.motion.def->meaning : s_.motion);
  MotionSink& out = corner ? static_cast<MotionSink&>(refused) : out_all;
  if (w.motion.def) {
    const bool was_cycle = s_.motion == GMeaning::drill_cycle;
    s_.motion = mode;
    s_.motion_code10 = w.motion.def->code10;
    if (mode == GMeaning::rapid || mode == GMeaning::linear || mode == GMeaning::arc_cw || mode == GMeaning::arc_ccw) {
      s_.interp_motion = mode;
      s_.interp_code10 = w.motion.def->code10;
    }
    // LinuxCNC keeps the initial level (old_z) while one cycle follows another (G81 … G98 G82 retracts
    // to the level before the first; rs274 agrees); elsewhere a cycle code sets it anew.
    if (mode == GMeaning::drill_cycle && !d_.lathe && !(was_cycle && d_.id == DialectId::linuxcnc)) {
      const int normal = plane_axes(s_.plane).n;
      s_.cycle_bottom_known = false;
      s_.cycle_initial = s_.position[normal];
      s_.cycle_initial_known = (s_.known >> normal) & 1u;
    }
  }
  if (w.motion.def && mode == GMeaning::turning_cycle && d_.id == DialectId::linuxcnc) {
    lathe_cycle(b, w, out);
    return;
  }
  if (d_.id == DialectId::fanuc && d_.lathe && fanuc_cycle(b, w, out, prev_motion, prev_code10)) return;
  if (mode == GMeaning::threading && threading_cycle(b, w, out)) return;
  Eigen::Vector2d polar_end = Eigen::Vector2d::Zero();
  if (w.polar && (d_.id != DialectId::siemens || !siemens_polar_end(b, w, mode, polar_end))) {
    unresolved_motion(b, w, codes::kPolar, "motion in polar coordinates (AP=/RP=)");
    s_.known &= static_cast<AxisMask>(~(bit(Axis::x) | bit(Axis::y) | bit(Axis::z)));
    return;
  }
  if (w.polar_words != 0 && !polar_to_xy(b, w, mode == GMeaning::drill_cycle && !d_.lathe)) return;
  // A full circle may be given by its centre alone (no end words: the end is the start): LinuxCNC
  // (rs274 cuts it) and Fanuc ("Circular interpolation": X Y omitted with I J K = a 360° arc).
  const PlaneAxes pa = plane_axes(s_.plane);
  const bool centre_only_circle =
      w.axis_present == 0 && (mode == GMeaning::arc_cw || mode == GMeaning::arc_ccw) &&
      (d_.id == DialectId::linuxcnc || d_.id == DialectId::fanuc) &&
      (w.has(static_cast<char>('I' + pa.u)) || w.has(static_cast<char>('I' + pa.v))) && !w.has('R');
  // Axis words (or R/Z for cycles) make a motion; a motion G alone does not.
  // Sinumerik G2/G3 with centre and opening angle (AR=) has no end point words: it still moves.
  const bool arc_by_angle = d_.id == DialectId::siemens && w.has_ar &&
                            (mode == GMeaning::arc_cw || mode == GMeaning::arc_ccw);
  if (w.axis_present == 0 && !centre_only_circle && !arc_by_angle && !w.polar) {
    if (w.motion.def && (mode == GMeaning::turning_cycle || mode == GMeaning::threading || mode == GMeaning::spline)) {
      const auto code = mode == GMeaning::turning_cycle ? codes::kTurningCycle
                        : mode == GMeaning::threading   ? codes::kThreading
                                                        : codes::kSpline;
      // A G90 without X/Z on a system-A lathe is usually a system-B program's "absolute" (B-64484EN "G code
      // system"): say so.
      const bool g90_a = d_.id == DialectId::fanuc && d_.lathe && d_.gcode_system == 'A' && w.motion.def->code10 == 900;
      unresolved_motion(b, w, code,
                        fmt::format("{}{}", b.text(b.words[static_cast<std::size_t>(w.motion.word)].span),
                                    g90_a ? " (in Fanuc lathe G-code system A, G90 is the outer-diameter turning "
                                            "cycle; if the program means absolute mode it is system B: pass "
                                            "--gcode-system B)"
                                          : ""));
    }
    return;
  }
  if (s_.polar_interp) {
    unresolved_motion(b, w, codes::kPolar, "motion under polar coordinate interpolation (G12.1/G112)");
    s_.known &= static_cast<AxisMask>(~w.axis_present);
    return;
  }
  if ((s_.polar_coords || s_.scaling || s_.mirror != 0) && !w.machine_frame && !fanuc_frame(b, w, mode)) return;
  if (d_.id == DialectId::fanuc && d_.lathe && d_.gcode_system != 'A' &&
      (w.axis_present & (bit(Axis::u) | bit(Axis::w))) &&
      (mode == GMeaning::rapid || mode == GMeaning::linear || mode == GMeaning::arc_cw || mode == GMeaning::arc_ccw)) {
    // B-64484EN "G code system": in systems B and C absolute/incremental is G90/G91; U and W are the
    // addresses of U and W axes, not incremental X and Z as in system A.
    const int a = (w.axis_present & bit(Axis::u)) ? 6 : 8;
    const Span ws = b.words[static_cast<std::size_t>(w.axis_word[static_cast<std::size_t>(a)])].span;
    report(b, ws, Severity::warning, codes::kFanucSystemB,
           fmt::format("'{}' in lathe G-code system B moves a {} axis (incremental X/Z is G91 X/Z there); if the "
                       "program is written for system A (U/W incremental), pass --gcode-system A",
                       b.text(ws), a == 6 ? 'U' : 'W'));
  }
  const Eigen::Vector3d prev_tangent = s_.tangent;  // for CT
  const bool prev_tangent_known = s_.tangent_known;
  s_.tangent_known = false;  // set again by the motion this block emits
  if (d_.id == DialectId::siemens && !siemens_motion_words(b, w, mode)) {
    s_.known &= static_cast<AxisMask>(~w.axis_present);
    return;
  }
  Motion m;
  m.line = b.line;
  m.word_index = {};
  for (int a = 0; a < kAxisCount; ++a) m.word_index[static_cast<std::size_t>(a)] = w.axis_word[static_cast<std::size_t>(a)];
  const int first_word = w.motion.word >= 0 ? w.motion.word : [&] {
    for (int a = 0; a < kAxisCount; ++a)
      if (w.axis_word[static_cast<std::size_t>(a)] >= 0) return static_cast<int>(w.axis_word[static_cast<std::size_t>(a)]);
    return 0;
  }();
  m.column = b.words[static_cast<std::size_t>(first_word)].span.begin + 1;
  fill_state(m);
  const Span motion_at = b.words[static_cast<std::size_t>(first_word)].span;
  if (s_.cutter_comp != 0 && (mode != GMeaning::rapid || d_.id == DialectId::linuxcnc)) cutter_comp_motion(b, motion_at);
  // LinuxCNC G33/G33.1 run at K per revolution whatever the feed mode (rs274 asks no F of them).
  const bool per_rev_k = d_.id == DialectId::linuxcnc && mode == GMeaning::threading &&
                         (s_.motion_code10 == 330 || s_.motion_code10 == 331);
  const bool feeds = mode == GMeaning::linear || mode == GMeaning::arc_cw || mode == GMeaning::arc_ccw ||
                     mode == GMeaning::drill_cycle || mode == GMeaning::threading || mode == GMeaning::turning_cycle;
  if (feeds && (d_.id == DialectId::linuxcnc || d_.id == DialectId::fanuc) && !w.has('F') &&
      !per_rev_k && (s_.feed_undefined || s_.feed_mode == FeedMode::inverse_time)) {
    report(b, motion_at, Severity::error, codes::kControllerRefuses,
           s_.feed_mode == FeedMode::inverse_time
               ? "a feed move in inverse time (G93) without F: LinuxCNC and Fanuc need F in every such block "
                 "and stop here; add the F word"
               : d_.id == DialectId::linuxcnc
                   ? "a feed move while the feed rate is 0 (no F since the program start, or since G93 was entered "
                     "or left): LinuxCNC stops here (\"Cannot do G1 with zero feed rate\"); program F in this block "
                     "or before it"
                   : "a feed move without F after leaving inverse time (G93): the feed rate is 0 and the controller "
                     "stops here; program F in this block or before it");
    s_.known &= static_cast<AxisMask>(~w.axis_present);
    return;
  }
  if (s_.tool_z_pending) {
    const bool z_absolute = w.states_absolutely(Axis::z, s_.absolute);
    const bool settled = s_.tool_z_pending == 1 ? (s_.known & bit(Axis::z)) != 0 : mode == GMeaning::rapid;
    if (z_absolute || settled) {
      s_.tool_z_pending = 0;
    } else if (mode != GMeaning::rapid) {
      s_.tool_z_pending = 0;
      report(b, motion_at, Severity::warning, codes::kToolLengthZ,
             fmt::format("this move's Z depends on the tool-length offset change at line {}, which the program "
                         "does not resolve ({}); program Z absolutely in that block (e.g. G43 H1 Z50.) or before "
                         "this move, or give the length in the machine file's [tool.lengths]",
                         s_.tool_length_line,
                         d_.id == DialectId::linuxcnc ? "the tool table does not give the length"
                         : d_.id == DialectId::fanuc  ? "Fanuc moves Z in that block (parameter 5006#6 = 0), not "
                                                        "along this feed move"
                                                      : "the control applies it with the next Z travel"));
    }
  }
  m.words_transformed = w.words_transformed;
  if (mode == GMeaning::rapid || mode == GMeaning::linear) tool_vector(w, m);  // arcs use I J K as centre
  if (w.polar) {
    // Sinumerik AP= RP=: the end point in the plane is the pole plus RP at angle AP; G2/G3 turn
    // about the pole (Fundamentals, "Polar coordinates", "Travel commands with polar coordinates").
    const PlaneAxes p = plane_axes(s_.plane);
    const AxisMask plane_bits = static_cast<AxisMask>((1u << p.u) | (1u << p.v));
    const AxisMask known_before = s_.known;
    target(b, w, m);
    s_.position[p.u] = polar_end.x();
    s_.position[p.v] = polar_end.y();
    s_.known |= plane_bits;
    m.end = s_.position;
    m.known = s_.known;
    m.programmed |= plane_bits;
    if (mode == GMeaning::rapid || mode == GMeaning::linear) {
      m.type = mode == GMeaning::rapid ? MotionType::rapid : MotionType::linear;
      emit(m, b, out);
      return;
    }
    const Span at = b.words[static_cast<std::size_t>(first_word)].span;
    if ((known_before & plane_bits) != plane_bits) {
      report(b, at, Severity::warning, codes::kUnknownPosition,
             "arc whose start point is unknown (after an unresolved construct); it is not resolved");
      s_.known &= static_cast<AxisMask>(~plane_bits);
      return;
    }
    const Eigen::Vector2d c = s_.pole;
    const Eigen::Vector2d st(m.start[p.u], m.start[p.v]);
    if (!radii_agree(b, at, st, polar_end, c)) {
      s_.known &= static_cast<AxisMask>(~plane_bits);
      return;
    }
    const bool cw = mode == GMeaning::arc_cw;
    const Eigen::Vector2d rs = st - c, re = polar_end - c;
    double sweep = std::atan2(rs.x() * re.y() - rs.y() * re.x(), rs.dot(re));
    if ((polar_end - st).norm() < 1e-9) sweep = 0;
    if (cw && sweep >= 0) sweep -= 2 * std::numbers::pi;
    if (!cw && sweep <= 0) sweep += 2 * std::numbers::pi;
    if (w.has_turn) sweep += (cw ? -1.0 : 1.0) * 2 * std::numbers::pi * w.turn;
    if (set_plane_arc(b, at, m, s_.plane, c, sweep)) {
      m.type = cw ? MotionType::arc_cw : MotionType::arc_ccw;
      m.arc.turns = w.has_turn ? static_cast<std::uint32_t>(w.turn) + 1 : 1;
      m.arc.full_circle = (polar_end - st).norm() < 1e-9;
      emit(m, b, out);
    } else {
      s_.known &= static_cast<AxisMask>(~plane_bits);
    }
    return;
  }
  switch (mode) {
    case GMeaning::rapid:
    case GMeaning::linear:
      m.type = mode == GMeaning::rapid ? MotionType::rapid : MotionType::linear;
      if (target(b, w, m)) emit(m, b, out);
      break;
    case GMeaning::arc_cw:
    case GMeaning::arc_ccw: {
      m.type = mode == GMeaning::arc_cw ? MotionType::arc_cw : MotionType::arc_ccw;
      if (d_.arc_without_centre_linear && !w.has('R')) {
        // Fanuc parameter 3403#5 CIR = 0 (factory setting): a G02/G03 block with neither the centre
        // (I J K of the plane) nor R moves to its end point in a straight line at the feed; G02/G03
        // stays the modal motion.
        const PlaneAxes p = plane_axes(s_.plane);
        if (!w.has(centre_letter(p.u)) && !w.has(centre_letter(p.v))) {
          m.type = MotionType::linear;
          if (target(b, w, m)) emit(m, b, out);
          break;
        }
      }
      const AxisMask known_before = s_.known;  // the arc needs its start point, not just its end
      if (target(b, w, m) && arc(b, w, m, known_before)) emit(m, b, out);
      break;
    }
    case GMeaning::arc_cip:
    case GMeaning::arc_tangent: {
      if (w.motion_keyword_span.size() > 0) m.column = w.motion_keyword_span.begin + 1;
      const AxisMask known_before = s_.known;
      target(b, w, m);
      const bool ok = mode == GMeaning::arc_cip ? cip_arc(b, w, m, known_before)
                                                : tangent_arc(b, w, m, known_before, prev_tangent, prev_tangent_known);
      if (ok) emit(m, b, out);
      break;
    }
    case GMeaning::drill_cycle:
      if (d_.lathe) {
        unresolved_motion(b, w, codes::kLatheDrill, "lathe / mill-turn drilling cycle");
        s_.known &= static_cast<AxisMask>(~w.axis_present);
      } else {
        drill(b, w, m, out, prev_code10);
      }
      break;
    case GMeaning::threading:
      if (d_.id == DialectId::linuxcnc && (s_.motion_code10 == 330 || s_.motion_code10 == 331)) {
        spindle_synced_move(b, w, m, out);
        break;
      }
      [[fallthrough]];
    case GMeaning::turning_cycle:
    case GMeaning::spline: {
      const auto code = mode == GMeaning::turning_cycle ? codes::kTurningCycle
                        : mode == GMeaning::threading   ? codes::kThreading
                                                        : codes::kSpline;
      unresolved_motion(b, w, code,
                        mode == GMeaning::turning_cycle ? "turning cycle"
                        : mode == GMeaning::threading   ? "threading"
                                                        : "spline motion");
      s_.known &= static_cast<AxisMask>(~w.axis_present);
      break;
    }
    case GMeaning::cancel_motion:
    default:
      if (w.motion.def == nullptr && mode == GMeaning::cancel_motion) {
        const Span at = b.words[static_cast<std::size_t>(first_word)].span;
        report(b, at, Severity::error, codes::kMissingWord,
               "axis words but no motion mode is active (after G80 or at program start); add G0 or G1");
      }
      s_.known &= static_cast<AxisMask>(~w.axis_present);
      break;
  }
  if (mcall_active_ && !w.machine_frame) s_.known &= static_cast<AxisMask>(~bit(Axis::z));
  if (corner && corner_angle_) {
    const PlaneAxes p = plane_axes(s_.plane);
    s_.known &= static_cast<AxisMask>(~((1u << p.u) | (1u << p.v)));
    corner_angle_ = false;
  }
}

bool Interpreter::radii_agree(const Block& b, Span at, const Eigen::Vector2d& s, const Eigen::Vector2d& e,
                              const Eigen::Vector2d& c, std::string_view hint) {
  const double r1 = (s - c).norm(), r2 = (e - c).norm();
  const double diff = std::abs(r1 - r2);
  // Inch programs print one decimal more: allow 0.0002 in instead of 0.002 mm.
  if (diff > opt_.arc_radius_tolerance_mm * (s_.inch ? 2.54 : 1.0) && diff > 1e-3 * std::max(r1, r2)) {
    report(b, at, Severity::error, codes::kArcGeometry,
           fmt::format("arc radius at start {:.6f} mm and at end {:.6f} mm differ by {:.6f} mm; fix the centre "
                       "words or the end point{}",
                       r1, r2, diff, hint));
    return false;
  }
  return true;
}

bool Interpreter::arc(const Block& b, const BlockWords& w, Motion& m, AxisMask start_known) {
  const PlaneAxes p = plane_axes(s_.plane);
  const AxisMask need = static_cast<AxisMask>((1u << p.u) | (1u << p.v));
  const Span at = b.words[static_cast<std::size_t>(w.motion.word >= 0 ? w.motion.word : 0)].span;
  const char cu = centre_letter(p.u), cv = centre_letter(p.v);
  if (d_.id == DialectId::linuxcnc && w.has('R') && (w.has('I') || w.has('J') || w.has('K'))) {
    // LinuxCNC G-code "G2, G3 Arc": an arc is given either in radius format or in centre format;
    // mixing R with I/J/K is an error ("mixed radius-ijk format for arc").
    report(b, b.words[static_cast<std::size_t>(w.letter_word['R' - 'A'])].span, Severity::error, codes::kArcGeometry,
           "arc with both R and I/J/K: LinuxCNC refuses mixed radius and centre formats; keep R or the centre words");
    s_.known &= static_cast<AxisMask>(~need);
    return false;
  }
  if (d_.id == DialectId::linuxcnc && w.has(centre_letter(p.n))) {
    // rs274 convert_arc: "K word given for arc in XY plane" (J in XZ, I in YZ): the centre word of
    // the plane's normal axis has no meaning there.
    const char cn = centre_letter(p.n);
    report(b, b.words[static_cast<std::size_t>(w.letter_word[static_cast<std::size_t>(cn - 'A')])].span,
           Severity::error, codes::kArcGeometry,
           fmt::format("{} word in an arc in the {}{} plane: LinuxCNC refuses a centre word along the plane's normal; "
                       "remove it or select the plane the arc lies in",
                       cn, kAxisLetters[static_cast<std::size_t>(p.u)], kAxisLetters[static_cast<std::size_t>(p.v)]));
    s_.known &= static_cast<AxisMask>(~need);
    return false;
  }
  // Fanuc (B-64484EN "Circular interpolation (G02, G03)"): when R and I J K are both given, R is used
  // and I J K are ignored.
  const bool siemens = d_.id == DialectId::siemens;
  const bool by_angle = siemens && w.has_ar;
  const bool by_radius =
      !by_angle && ((w.has('R') && ((!w.has(cu) && !w.has(cv)) || d_.id == DialectId::fanuc)) || w.has_cr);
  const bool centre_ignored = by_radius && d_.id == DialectId::fanuc;  // Fanuc: I J K ignored beside R
  const bool centre_unresolved = (!centre_ignored && (w.unresolved(cu) || w.unresolved(cv))) ||
                                 (by_radius && !w.has_cr && w.has('R') && w.unresolved('R')) ||
                                 (w.ext_unresolved & (1u | 2u | 4u)) != 0;
  if (siemens && !check_arc_words(b, w)) {
    s_.known &= static_cast<AxisMask>(~need);
    return false;
  }
  if (siemens && turn_fraction(b, w)) return false;
  if ((s_.known & need) != need || centre_unresolved || (start_known & need) != need) {
    // Start, end or centre unknown: the arc cannot be resolved.
    if (!centre_unresolved)
      report(b, at, Severity::warning, codes::kUnknownPosition,
             "arc whose start or end point is unknown (after an unresolved construct, or incremental from an "
             "unknown start); it is not resolved");
    s_.known &= static_cast<AxisMask>(~need);
    return false;
  }
  const Eigen::Vector2d s(m.start[p.u], m.start[p.v]);
  Eigen::Vector2d e(m.end[p.u], m.end[p.v]);
  const bool cw = m.type == MotionType::arc_cw;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  const double scale = s_.inch ? 25.4 : 1.0;
  double sweep_given = 0;  // AR=: the sweep is the programmed opening angle
  if (by_angle) {
    // 840D sl Fundamentals, "Circular interpolation with opening angle and centre point (AR, I, J, K)"
    // and "… with opening angle and end point (AR, X, Y, Z)": G3 turns counter-clockwise by AR.
    const double ar = w.ar * std::numbers::pi / 180.0;
    sweep_given = cw ? -ar : ar;
    if (w.has(cu) || w.has(cv)) {
      const double iu = w.has(cu) ? w.get(cu) * scale : 0.0;
      const double iv = w.has(cv) ? w.get(cv) * scale : 0.0;
      const bool abs_u = (w.letter_absolute >> (cu - 'A')) & 1u;
      const bool abs_v = (w.letter_absolute >> (cv - 'A')) & 1u;
      c = Eigen::Vector2d(abs_u ? iu : s.x() + iu, abs_v ? iv : s.y() + iv);
      const Eigen::Rotation2Dd rot(sweep_given);
      const Eigen::Vector2d end = c + rot * (s - c);
      s_.position[p.u] = end.x();
      s_.position[p.v] = end.y();
      m.end[p.u] = end.x();
      m.end[p.v] = end.y();
      e = end;
    } else {
      const Eigen::Vector2d chord = e - s;
      const double d = chord.norm();
      if (d < 1e-9) {
        report(b, b.words[static_cast<std::size_t>(w.ar_word)].span, Severity::error, codes::kArcGeometry,
               "arc by opening angle AR= with its end point on its start point; give the centre (I J K) instead");
        return false;
      }
      const Eigen::Vector2d left(-chord.y() / d, chord.x() / d);
      const double h = d / 2 / std::tan(ar / 2);  // negative beyond 180°: centre on the other side
      c = (s + e) / 2 + (cw ? -h : h) * left;
    }
  } else if (by_radius) {
    double r = (w.has_cr ? w.cr : w.get('R')) * scale;
    const Eigen::Vector2d chord = e - s;
    const double d = chord.norm();
    if (d < 1e-9) {
      report(b, at, Severity::error, codes::kArcGeometry,
             "arc given by radius R with end point equal to start point; a full circle needs I J K centre words");
      return false;
    }
    const double rad = std::abs(r);
    // LinuxCNC (arc_data_r): half the chord may exceed R by RADIUS_TOLERANCE (0.00005 in, 0.00127 mm)
    // and is then a half circle.
    const bool too_small = d_.id == DialectId::linuxcnc ? d / 2 - rad > (s_.inch ? 0.00005 * 25.4 : 0.00127)
                                                       : d > 2 * rad * (1 + 1e-6) + 1e-6;
    if (too_small) {
      report(b, at, Severity::error, codes::kArcGeometry,
             fmt::format("radius {:.6g} mm is smaller than half the chord {:.6g} mm; fix R or the end point", rad, d / 2));
      return false;
    }
    const double h = std::sqrt(std::max(0.0, rad * rad - d * d / 4));
    const Eigen::Vector2d mid = (s + e) / 2;
    const Eigen::Vector2d left(-chord.y() / d, chord.x() / d);  // unit normal to the left of s→e
    // Positive R: the short arc; the centre lies right of the chord for cw, left for ccw.
    const bool short_arc = r > 0;
    const double side = (cw == short_arc) ? -1.0 : 1.0;
    c = mid + side * h * left;
    r = rad;
  } else if (d_.id == DialectId::heidenhain_iso) {
    const unsigned need_cc = (1u << p.u) | (1u << p.v);
    if ((s_.circle_centre_known & need_cc) != need_cc) {
      report(b, at, Severity::error, codes::kMissingWord,
             fmt::format("circle without a centre: program {} {} (circle centre) before G02/G03, or give R", cu, cv));
      return false;
    }
    c = Eigen::Vector2d(s_.circle_centre[p.u], s_.circle_centre[p.v]);
    if (!radii_agree(b, at, s, e, c)) return false;
  } else {
    if (!w.has(cu) && !w.has(cv)) {
      report(b, at, Severity::error, codes::kMissingWord,
             fmt::format("arc without centre ({} {}) or radius (R); add them", cu, cv));
      return false;
    }
    if (s_.arc_absolute && (!w.has(cu) || !w.has(cv))) {
      // LinuxCNC G-code "G90.1, G91.1": in absolute arc distance mode I J K are the centre's
      // coordinates; rs274 refuses an arc that leaves one out ("J word missing in absolute center arc").
      report(b, at, Severity::error, codes::kMissingWord,
             fmt::format("{} word missing in an absolute-centre arc (G90.1): the centre's {} coordinate is not "
                         "given; write both {} and {}",
                         w.has(cu) ? cv : cu, kAxisLetters[static_cast<std::size_t>(w.has(cu) ? p.v : p.u)], cu, cv));
      s_.known &= static_cast<AxisMask>(~need);
      return false;
    }
    const double iu = w.has(cu) ? w.get(cu) * scale : 0.0;
    const double iv = w.has(cv) ? w.get(cv) * scale : 0.0;
    const bool abs_u = s_.arc_absolute || ((w.letter_absolute >> (cu - 'A')) & 1u);
    const bool abs_v = s_.arc_absolute || ((w.letter_absolute >> (cv - 'A')) & 1u);
    c = Eigen::Vector2d(abs_u ? iu : s.x() + iu, abs_v ? iv : s.y() + iv);
    // A lathe post for a radius-programmed machine (parameter DIA, No. 1006#3 = 0) writes X as a
    // radius: say so when the arc closes that way.
    std::string_view hint;
    if (s_.diameter_mode && (p.u == 0 || p.v == 0) && !abs_u && !abs_v) {
      const Eigen::Vector2d k = p.u == 0 ? Eigen::Vector2d(2, 1) : Eigen::Vector2d(1, 2);
      const Eigen::Vector2d s2 = s.cwiseProduct(k), e2 = e.cwiseProduct(k), c2(s2.x() + iu, s2.y() + iv);
      const double r1 = (s2 - c2).norm(), r2 = (e2 - c2).norm();
      if (std::abs(r1 - r2) <= opt_.arc_radius_tolerance_mm * (s_.inch ? 2.54 : 1.0) || std::abs(r1 - r2) <= 1e-3 * std::max(r1, r2))
        hint = "; the arc closes if X is a radius: if the machine is programmed in radius (parameter DIA "
               "No. 1006#3 = 0), pass --diameter-axis none";
    }
    if (!radii_agree(b, at, s, e, c, hint)) return false;
  }
  if ((s - c).norm() < 1e-9) {
    report(b, at, Severity::error, codes::kArcGeometry,
           "arc of zero radius (centre on the start point); fix the centre words");
    return false;
  }
  const Eigen::Vector2d rs = s - c, re = e - c;
  double sweep = std::atan2(rs.x() * re.y() - rs.y() * re.x(), rs.dot(re));  // (-π, π]
  const bool same = (e - s).norm() < 1e-9;
  if (cw && sweep >= 0) sweep -= 2 * std::numbers::pi;
  if (!cw && sweep <= 0) sweep += 2 * std::numbers::pi;
  if (same) sweep = cw ? -2 * std::numbers::pi : 2 * std::numbers::pi;
  if (by_angle) sweep = sweep_given;
  std::uint32_t turns = 1;
  if (siemens && w.has_turn) {
    // TURN=n: n further full circles of a helix (840D sl Fundamentals, "Helical interpolation").
    turns = static_cast<std::uint32_t>(w.turn) + 1;
    sweep += (cw ? -1.0 : 1.0) * 2 * std::numbers::pi * w.turn;
  }
  if (d_.id == DialectId::linuxcnc && w.has('P') && !w.unresolved('P')) {
    const double pv = w.get('P');
    if (!(pv >= 1 && pv <= 1e6) || pv != std::floor(pv)) {
      report(b, b.words[static_cast<std::size_t>(w.letter_word['P' - 'A'])].span, Severity::error,
             codes::kArcGeometry, "P (number of turns) must be a positive whole number");
      return false;
    }
    turns = static_cast<std::uint32_t>(pv);
    sweep += (cw ? -1.0 : 1.0) * 2 * std::numbers::pi * (turns - 1);
  }
  m.arc.centre = Eigen::Vector3d(m.end[0], m.end[1], m.end[2]);
  m.arc.centre[p.u] = c.x();
  m.arc.centre[p.v] = c.y();
  m.arc.centre[p.n] = m.start[p.n];
  m.arc.radius = rs.norm();
  m.arc.sweep = sweep;
  m.arc.turns = turns;
  m.arc.full_circle = same && !by_angle;
  return true;
}

}  // namespace postproc::gcode
