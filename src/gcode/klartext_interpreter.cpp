// Klartext interpreter: Heidenhain conversational blocks into Motion records (klartext.hpp).
//
// Each rule names the TNC 640 / iTNC 530 User's Manual chapter it follows ("Programming contours",
// "Path functions with Cartesian / polar coordinates", "Cycles for coordinate transformation",
// "Miscellaneous functions"); docs/dialect-heidenhain.md lists them. What this version does not
// follow is reported at its word with a PP-U code and leaves the affected axes unknown, so nothing
// is read differently from the control in silence.
#include <algorithm>
#include <cmath>
#include <deque>
#include <optional>

#include <Eigen/Geometry>

#include "src/gcode/klartext_interp.hpp"

namespace postproc::gcode::klartext {

void Interp::execute(const Block& b, MotionSink& out) {
  if (ended_) return;
  const Verb v = verb_of(b);
  if (continuation_) {  // a line of a block continued with '~' (cycle parameters)
    continuation_ = ends_continued(b);
    if (v == Verb::q_assign) cycle_parameter(b);
    return;
  }
  continuation_ = ends_continued(b);
  if (v == Verb::q_assign && cycle_params_open_) {  // a parameter line of the cycle just defined
    cycle_parameter(b);
    return;
  }
  cycle_params_open_ = false;
  preset_pending_ = false;
  switch (v) {
    case Verb::none:
    case Verb::comment:
    case Verb::blk_form:
    case Verb::tool_def:
    case Verb::lbl:
    case Verb::stop:
    case Verb::pattern_def:
    case Verb::declare:
      return;
    case Verb::begin_pgm: {
      inch_ = find_keyword(b, "INCH") >= 0;
      return;
    }
    case Verb::end_pgm:
      ended_ = true;
      return;
    case Verb::tool_call: return tool_call(b);
    case Verb::l:
    case Verb::ln:
    case Verb::lp:
    case Verb::c:
    case Verb::cr:
    case Verb::ct:
    case Verb::cp:
    case Verb::m_only: return motion(b, v, out);
    case Verb::cc: return circle_centre(b);
    case Verb::cycl_def: return cycle_def(b);
    case Verb::cycl_call: return cycle_call(b, b.tokens.front().span, out);
    case Verb::plane: return plane(b);
    case Verb::function: return function(b);
    case Verb::rnd:
    case Verb::chf:
      warn(b, b.tokens.front().span, codes::kKlartextUnresolved,
           fmt::format("{} (a corner element between two moves) is not built by this version: both neighbouring "
                       "moves change; program the corner as moves",
                       to_string(v)));
      known_ &= static_cast<AxisMask>(~kLinear);
      return;
    case Verb::appr:
    case Verb::dep:
      warn(b, b.tokens.front().span, codes::kKlartextUnresolved,
           fmt::format("{} (approach/departure path) is not followed by this version; positions after it are "
                       "unknown until the program states them",
                       to_string(v)));
      known_ &= static_cast<AxisMask>(~kLinear);
      return;
    case Verb::tch_probe:
      warn(b, b.tokens.front().span, codes::kProbe,
           "probing cycle: it moves the machine to a measured point (known only when the program runs); positions "
           "after it are unknown until the program states them");
      known_ = 0;
      return;
    case Verb::call_lbl:
    case Verb::call_pgm:
    case Verb::fn:
    case Verb::q_assign:
      // The resolver executes these; here only when it could not.
      warn(b, b.tokens.front().span, codes::kSubprogramCall,
           fmt::format("{} is not executed by this version here; positions after it are unknown", to_string(v)));
      known_ = 0;
      return;
    case Verb::sel:
      if (find_keyword(b, "TABLE") >= 0) return;  // SEL TABLE: the datum table a later cycle 7 reads
      warn(b, b.tokens.front().span, codes::kSubprogramCall,
           "SEL selects a program or cycle to call later; the call is not followed by this version");
      return;
    case Verb::other:
      // The lexer reported the verb, except on an indented line that continues no block.
      if (unread_text(b))
        report(b, b.tokens.front().span, Severity::error, "PP-E101",
               fmt::format("'{}' is not a Klartext block this version reads (and the line before does not end "
                           "with '~' to continue its block here); the block is not followed",
                           b.text(b.tokens.front().span)));
      known_ = 0;
      return;
  }
}

void Interp::tool_call(const Block& b) {
  // TOOL CALL n|"NAME" [X|Y|Z] [S…] [F…] [DL…] [DR…]: the tool axis selects the working plane;
  // a new tool brings its length, so the tool-axis coordinate of the current point changes by
  // the length difference (the TNC keeps the tool tip as the programmed point).
  bool tool = false;
  for (std::size_t i = 1; i < b.tokens.size(); ++i) {
    const Token& t = b.tokens[i];
    if (t.kind != TokenKind::keyword) continue;
    const std::string_view s = b.text(t.span);
    if (s == "~") continue;
    if (s.front() == '"' || s.front() == '\'' || (s.front() >= '0' && s.front() <= '9')) {
      tool = true;
      double n = 0;
      if (parse_number(s, n)) tool_number_ = static_cast<int>(n);
      else tool_number_ = 0;
    } else if (s.size() == 1 && (s[0] == 'X' || s[0] == 'Y' || s[0] == 'Z' || s[0] == 'x' || s[0] == 'y' || s[0] == 'z')) {
      const char a = text::upper(s[0]);
      plane_ = a == 'Z' ? Plane::xy : a == 'Y' ? Plane::zx : Plane::yz;
    }
  }
  for (const Word& w : b.words) {
    const std::string_view n = b.text(w.name);
    if (text::iequals(n, "DL") && w.number != 0) tool = true;
    if (text::iequals(n, "F") && w.kind == ValueKind::number) {
      feed_ = len(w.number);
      feed_known_ = !inch_;
    }
  }
  if (tool) {
    tool_active_ = true;
    known_ &= static_cast<AxisMask>(~(1u << axes().n));
    cutter_radius_known_ = d_.tool_radii.count(static_cast<std::uint32_t>(std::max(0, tool_number_))) > 0 &&
                           d_.tool_radii.at(static_cast<std::uint32_t>(std::max(0, tool_number_))) == 0.0;
  }
}

void Interp::circle_centre(const Block& b) {
  // CC X Y (absolute, or IX IY from the current point); CC alone: the current point. The two
  // axes of CC also choose the plane of the arcs about it (C, CP, LP): "CC Y… Z…" makes the
  // following CP an arc in the Y/Z plane whatever the tool axis (TNC 640 User's Manual, "Circle
  // centre CC"; CAM posts write every arc of a ramp this way).
  Words w;
  if (!collect(b, Verb::cc, w)) {
    cc_known_ = false;
    return;
  }
  const AxisMask xy = bit(Axis::x) | bit(Axis::y), yz = bit(Axis::y) | bit(Axis::z), zx = bit(Axis::z) | bit(Axis::x);
  Plane pl = plane_;
  if (w.present == xy) pl = Plane::xy;
  else if (w.present == yz) pl = Plane::yz;
  else if (w.present == zx) pl = Plane::zx;
  else if (w.present != 0) {
    warn(b, b.tokens.front().span, codes::kKlartextUnresolved,
         "CC needs both coordinates of its plane (or none: the current point); the pole is not followed");
    cc_known_ = false;
    return;
  }
  const PlaneAxes p = plane_axes(pl);
  bool all_known = true;
  for (const int a : {p.u, p.v}) {
    const auto k = static_cast<std::size_t>(a);
    double v = 0;
    bool kn = true;
    if (w.present == 0) {  // CC alone: the last programmed position
      v = pos_[a];
      kn = (known_ & (1u << a)) != 0;
    } else if (w.incremental & (1u << a)) {
      v = pos_[a] + len(w.value[k]);
      kn = (known_ & (1u << a)) != 0;
    } else {
      v = len(w.value[k]);
    }
    cc_[a == p.u ? 0 : 1] = v;
    all_known = all_known && kn;
  }
  cc_known_ = all_known;
  cc_plane_ = pl;
}

void Interp::before_motion_m(const Block& b, int m, Span at) {
  switch (m) {
    case 91: frame_machine_ = true; break;
    case 92:
    case 130:
      m92_at_ = at, m92_ = m;
      break;
    case 128: tcp_ = true; break;
    case 129: tcp_ = false; break;
    case 126:
      for (int a = 3; a < 6; ++a) rollover_[static_cast<std::size_t>(a)] = RotaryRollover::shortest;
      break;
    case 127:
      for (int a = 3; a < 6; ++a) rollover_[static_cast<std::size_t>(a)] = d_.rollover[static_cast<std::size_t>(a)];
      break;
    case 3:
    case 4:
    case 13:
    case 14: spindle_ = true; break;
    case 5: spindle_ = false; break;
    case 114:
    case 144:
      warn(b, at, codes::kKlartextUnresolved,
           fmt::format("M{} makes the control correct positions for the machine's kinematics, which this version does "
                       "not follow; positions are not followed while it is active", m));
      kinematic_m_ = true;
      break;
    case 115:
    case 145: kinematic_m_ = false; break;
    default: break;
  }
}

bool Interp::block_frame_unfollowed(const Block& b) {
  Span at = b.tokens.empty() ? Span{0, 1} : b.tokens.front().span;
  std::string why;
  if (m92_ == 92) why = "M92 refers the block to the machine's second reference point, which the program does not state";
  else if (m92_ == 130 && tilted_) why = "M130 under a tilted working plane moves in the untilted system";
  else if (mirror_) why = "a mirror image (cycle 8) is active";
  else if (rotation_) why = "a rotation (cycle 10) is active";
  else if (scaling_) why = "a scaling (cycle 11/26) is active";
  else if (kinematic_m_) why = "M114/M144 (kinematic correction of positions) is active";
  else if (turning_mode_) why = "FUNCTION MODE TURN (turning: X in diameters, turning cycles) is active";
  else if (tcp_ && tcp_refpnt_) why = "FUNCTION TCPM with REFPNT other than TIP-TIP is active";
  if (m92_ != 0 && why.empty()) {
    m92_ = 0;
    return false;
  }
  if (why.empty()) return false;
  if (m92_ != 0) at = m92_at_;
  m92_ = 0;
  warn(b, at, codes::kKlartextUnresolved,
       fmt::format("the move is not followed by this version: {}; positions stay unknown until the program states "
                   "them after it ends",
                   why));
  return true;
}

void Interp::after_motion_m(const Block& b, const Words& w, MotionSink& out) {
  frame_machine_ = false;
  m92_ = 0;
  for (const auto& [m, at] : w.m) {
    switch (m) {
      case 2:
      case 30: ended_ = true; spindle_ = false; break;
      case 99: cycle_call(b, at, out); break;
      case 94: {  // reduce the display of the rotary axes below 360°
        for (int a = 3; a < 6; ++a) {
          double r = std::fmod(pos_[a], 360.0);
          if (r < 0) r += 360.0;
          pos_[a] = r;
        }
        break;
      }
      case 140: retract(b, w, at, out); break;
      default: break;
    }
  }
}

void Interp::retract(const Block& b, const Words& w, Span at, MotionSink& out) {
  // M140 MB: along the tool axis, by a distance or to the travel limit (MAX).
  const PlaneAxes p = axes();
  const AxisMask tool_axis = static_cast<AxisMask>(1u << p.n);
  if (w.mb_max || w.mb < 0 || tcp_ || tilted_ || !(known_ & tool_axis)) {
    known_ &= static_cast<AxisMask>(tcp_ || tilted_ ? ~(kLinear | 0u) : ~tool_axis);
    if (!w.mb_max && w.mb < 0)
      warn(b, at, codes::kKlartextUnresolved, "M140 without MB: the retract distance comes from the machine");
    return;
  }
  const double dist = len(b.words[static_cast<std::size_t>(w.mb)].number);
  Motion m;
  m.line = b.line;
  m.column = at.begin + 1;
  m.type = MotionType::rapid;
  m.plane = plane_;
  m.start = pos_;
  m.end = pos_;
  m.end[p.n] += dist;
  m.known = known_;
  m.word_index.fill(-1);
  m.local_offset = datum_;
  m.work_offset = preset_;
  m.work_offset_rewritten = preset_unknown_;
  m.tool_length_active = tool_active_;
  m.tool_length_h = static_cast<std::uint16_t>(std::max(0, tool_number_));
  m.inch_source = inch_;
  m.words_transformed = true;  // the MB word is a distance, not an end point
  pos_ = m.end;
  out.motion(m, b);
}

namespace {


class Collect final : public MotionSink {
 public:
  std::vector<Motion> motions;
  void motion(const Motion& m, const Block&) override { motions.push_back(m); }
};


}  // namespace

ProgramStats run(LineReader& reader, const Dialect& d, std::string_view file, DiagnosticSink& sink,
                 BlockVisitor& visitor) {
  // A path block followed by RND / CHF is held until the block after the corner is read: the
  // element shortens both (klartext_corners.cpp). Only then are the lines copied; every other
  // line streams from the reader's buffer.
  Interp interp(d, file, sink);
  const LexContext ctx{file, &sink};
  struct Line {
    std::string text, eol;
    std::uint64_t number = 0;
  };
  std::deque<Line> ahead;
  std::string_view line, eol;
  const auto fetch = [&](Line& out) {
    if (!ahead.empty()) {
      out = std::move(ahead.front());
      ahead.pop_front();
      return true;
    }
    if (!reader.next(line, eol)) return false;
    out.text.assign(line);
    out.eol.assign(eol);
    out.number = reader.line_number();
    return true;
  };
  Block b, bn, bc;
  Collect ca, cn, cc;
  ProgramStats st;
  Line cur, nx, third;
  const auto set = [](Block& blk, const Line& l) {
    blk.raw = l.text;
    blk.eol = l.eol;
    blk.line = l.number;
  };
  DiagnosticSink quiet(0);
  bool carried = false;  // `cur` is the block after a corner: lexed, executed, its motions in `ca`
  bool ok = true;
  while (carried || fetch(cur)) {
    Verb v;
    if (carried) {
      set(b, cur);
      (void)lex_block(d, b, LexContext{file, &quiet});  // reported when it was first lexed
      v = verb_of(b);
      carried = false;
    } else {
      set(b, cur);
      ok = lex_block(d, b, ctx);
      v = verb_of(b);
      ca.motions.clear();
      interp.execute(b, ca);
      ++st.blocks;
    }
    const bool path = v == Verb::l || v == Verb::lp || v == Verb::c || v == Verb::cr || v == Verb::ct || v == Verb::cp;
    if (!path || ca.motions.empty() || !fetch(nx)) {
      visitor.block(b, ca.motions, ok);
      continue;
    }
    set(bn, nx);
    const bool okn = lex_block(d, bn, ctx);
    const Verb vn = verb_of(bn);
    if (vn != Verb::rnd && vn != Verb::chf) {
      visitor.block(b, ca.motions, ok);
      ahead.push_front(std::move(nx));
      continue;
    }
    // RND R… / CHF … between this block and the next.
    const bool rounding = vn == Verb::rnd;
    double size = 0, feed = -1;
    bool size_ok = false;
    for (const Word& w : bn.words) {
      const std::string_view n = bn.text(w.name);
      if (rounding && text::iequals(n, "R") && w.kind == ValueKind::number) size = w.number, size_ok = true;
      if (text::iequals(n, "F") && w.kind == ValueKind::number) feed = w.number;
    }
    if (!rounding)
      for (std::size_t i = 1; i < bn.tokens.size() && !size_ok; ++i)
        size_ok = parse_number(bn.text(bn.tokens[i].span), size);
    if (interp.inch()) size *= 25.4, feed = feed > 0 ? feed * 25.4 : feed;
    bool have3 = fetch(third);
    cc.motions.clear();
    bool okc = true;
    if (have3) {
      set(bc, third);
      okc = lex_block(d, bc, ctx);
      interp.execute(bc, cc);
      ++st.blocks;
    }
    // CC blocks between the corner and the arc after it (TNC programs give the centre right before
    // the arc): executed in order, visited after the corner, the corner built with the arc.
    std::deque<Line> mid_lines;
    std::deque<Block> mid_blocks;
    std::vector<bool> mid_ok;
    while (have3 && okc && cc.motions.empty() && verb_of(bc) == Verb::cc && mid_lines.size() < 16) {
      mid_lines.push_back(std::move(third));
      Block& mb = mid_blocks.emplace_back();
      set(mb, mid_lines.back());
      (void)lex_block(d, mb, LexContext{file, &quiet});  // reported when it was first lexed
      mid_ok.push_back(okc);
      have3 = fetch(third);
      if (have3) {
        set(bc, third);
        okc = lex_block(d, bc, ctx);
        interp.execute(bc, cc);
        ++st.blocks;
      }
    }
    std::string why = size_ok ? "" : "its size is not a number";
    std::optional<Motion> element;
    if (size_ok && have3 && !cc.motions.empty() && okc && verb_of(bc) == Verb::ct)
      why = "a CT after it continues the element before it, not the rounding (write the arc with C or CR)";
    else if (size_ok && have3 && !cc.motions.empty() && okc)
      element = corner_element(ca.motions.back(), cc.motions.front(), rounding, size, why);
    else if (why.empty())
      why = !have3 ? "no block follows it"
                   : "the block after it makes no move (this version builds the corner only between two moves "
                     "written next to it, with at most CC blocks between)";
    cn.motions.clear();
    if (element) {
      element->line = bn.line;
      element->column = bn.tokens.empty() ? 1 : bn.tokens.front().span.begin + 1;
      if (feed > 0) element->feed = feed, element->feed_known = !interp.inch();
      cn.motions.push_back(*element);
    } else {
      // An element larger than its moves stops the control itself: an error, as the control's.
      const bool control_stops = why.find("the control stops") != std::string::npos;
      report_at(ctx, bn, bn.tokens.empty() ? Span{0, 1} : bn.tokens.front().span,
                control_stops ? Severity::error : Severity::warning,
                control_stops ? codes::kControllerRefuses : codes::kKlartextUnresolved,
                fmt::format("{} is not built here: {}; the moves next to it are read up to the corner and not corrected",
                            rounding ? "RND" : "CHF", why));
      if (!ca.motions.empty()) ca.motions.back().words_transformed = true;
      if (!cc.motions.empty()) cc.motions.front().words_transformed = true;
    }
    visitor.block(b, ca.motions, ok);
    visitor.block(bn, cn.motions, okn);
    ++st.blocks;
    for (std::size_t k = 0; k < mid_blocks.size(); ++k) visitor.block(mid_blocks[k], {}, mid_ok[k]);
    if (have3) {  // the block after the corner may start the next corner: it becomes the current one
      std::swap(cur, third);
      ca.motions.swap(cc.motions);
      ok = okc;
      carried = true;
    }
  }
  st.bytes = reader.bytes_read();
  return st;
}

}  // namespace postproc::gcode::klartext
