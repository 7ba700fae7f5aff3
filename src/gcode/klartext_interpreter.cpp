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
#include <map>
#include <numbers>
#include <optional>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "src/gcode/codes.hpp"
#include "src/gcode/klartext.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode::klartext {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;
constexpr AxisMask kLinear = bit(Axis::x) | bit(Axis::y) | bit(Axis::z);
constexpr AxisMask kRotary = bit(Axis::a) | bit(Axis::b) | bit(Axis::c);
constexpr AxisMask kAll = static_cast<AxisMask>((1u << kAxisCount) - 1);

/// Address words of a motion block, by meaning.
struct Words {
  std::array<std::int16_t, kAxisCount> axis{};  ///< word index per axis, -1 none
  AxisMask present = 0, incremental = 0;
  std::array<double, kAxisCount> value{};
  std::int16_t pr = -1, pa = -1;     ///< polar radius / angle words
  bool ipr = false, ipa = false;
  double pr_v = 0, pa_v = 0;
  std::int16_t r = -1;               ///< CR radius / RND radius
  double r_v = 0;
  std::int16_t f = -1;
  double f_v = 0;
  bool fmax = false, fauto = false, fu = false, fz = false;
  int dr = 0;                        ///< DR+ = +1, DR- = -1
  int comp = -1;                     ///< R0 = 0, RL = 1, RR = 2, R+/R- = 3; -1 not stated
  Span comp_at;
  std::array<std::int16_t, 3> n{-1, -1, -1}, t{-1, -1, -1};  ///< NX NY NZ, TX TY TZ
  Eigen::Vector3d n_v = Eigen::Vector3d::Zero(), t_v = Eigen::Vector3d::Zero();
  std::vector<std::pair<int, Span>> m;  ///< M numbers in order
  std::int16_t mb = -1;              ///< M140 MB distance word
  bool mb_max = false;
  std::int16_t unread = -1;          ///< first word this version does not read here
};

class Interp {
 public:
  Interp(const Dialect& d, std::string_view file, DiagnosticSink& sink) : d_(d), file_(file), sink_(sink) {
    for (int a = 0; a < kAxisCount; ++a) rollover_[static_cast<std::size_t>(a)] = d.rollover[static_cast<std::size_t>(a)];
  }

  [[nodiscard]] bool inch() const { return inch_; }

  void execute(const Block& b, MotionSink& out) {
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
        known_ = 0;  // the lexer reported the verb
        return;
    }
  }

 private:
  // ---- reporting ----
  void report(const Block& b, Span at, Severity sev, std::string_view code, std::string msg) {
    report_at(LexContext{file_, &sink_}, b, at, sev, code, std::move(msg));
  }
  void warn(const Block& b, Span at, std::string_view code, std::string msg) {
    report(b, at, Severity::warning, code, std::move(msg));
  }
  void error(const Block& b, Span at, std::string msg) {
    report(b, at, Severity::error, codes::kArcGeometry, std::move(msg));
  }
  static bool ends_continued(const Block& b) { return continued(b.raw); }

  // ---- units and planes ----
  double len(double v) const { return inch_ ? v * 25.4 : v; }
  PlaneAxes axes() const { return plane_axes(plane_); }
  /// The plane of the block's contour geometry: CC's plane for C, CP and LP, else the working plane.
  PlaneAxes gaxes() const { return plane_axes(geo_plane_); }

  // ---- words ----
  bool collect(const Block& b, Verb v, Words& w) {
    w.axis.fill(-1);
    bool ok = true;
    for (std::size_t i = 0; i < b.words.size(); ++i) {
      const Word& wd = b.words[i];
      const std::string_view name = b.text(wd.name);
      const auto idx = static_cast<std::int16_t>(i);
      if (wd.kind != ValueKind::number) {
        warn(b, wd.span, codes::kExpressionValue,
             fmt::format("'{}' takes its value from a Q parameter the program does not set before this block",
                         b.text(wd.span)));
        ok = false;
        continue;
      }
      const std::string_view up = name;
      const bool inc = up.size() == 2 && (up[0] == 'I' || up[0] == 'i') && axis_index(text::upper(up[1])) >= 0;
      const int ax = up.size() == 1 ? axis_index(text::upper(up[0])) : inc ? axis_index(text::upper(up[1])) : -1;
      if (ax >= 0 && !(v == Verb::m_only)) {
        if (w.present & (1u << ax)) {
          error(b, wd.span, fmt::format("{} is programmed twice in one block", kAxisLetters[static_cast<std::size_t>(ax)]));
          ok = false;
          continue;
        }
        w.axis[static_cast<std::size_t>(ax)] = idx;
        w.present |= static_cast<AxisMask>(1u << ax);
        if (inc) w.incremental |= static_cast<AxisMask>(1u << ax);
        w.value[static_cast<std::size_t>(ax)] = wd.number;
        continue;
      }
      if (text::iequals(up, "PR") || text::iequals(up, "IPR")) {
        w.pr = idx, w.ipr = up.size() == 3, w.pr_v = wd.number;
      } else if (text::iequals(up, "PA") || text::iequals(up, "IPA")) {
        w.pa = idx, w.ipa = up.size() == 3, w.pa_v = wd.number;
      } else if (text::iequals(up, "R")) {
        if (v == Verb::cr) {
          w.r = idx, w.r_v = wd.number;
        } else if (wd.number == 0) {
          w.comp = 0, w.comp_at = wd.span;
        } else {
          w.unread = w.unread < 0 ? idx : w.unread;
        }
      } else if (text::iequals(up, "F")) {
        w.f = idx, w.f_v = wd.number;
      } else if (text::iequals(up, "FU") || text::iequals(up, "FZ")) {
        w.f = idx, w.f_v = wd.number;
        (up[1] == 'U' || up[1] == 'u' ? w.fu : w.fz) = true;
      } else if (text::iequals(up, "M")) {
        w.m.emplace_back(static_cast<int>(std::lround(wd.number)), wd.span);
      } else if (text::iequals(up, "MB")) {
        w.mb = idx;
      } else if (up.size() == 2 && (up[0] == 'N' || up[0] == 'n' || up[0] == 'T' || up[0] == 't') &&
                 (v == Verb::ln) && axis_index(text::upper(up[1])) >= 0 && axis_index(text::upper(up[1])) < 3) {
        const int k = axis_index(text::upper(up[1]));
        auto& slot = (up[0] == 'N' || up[0] == 'n') ? w.n : w.t;
        auto& val = (up[0] == 'N' || up[0] == 'n') ? w.n_v : w.t_v;
        slot[static_cast<std::size_t>(k)] = idx;
        val[k] = wd.number;
      } else {
        w.unread = w.unread < 0 ? idx : w.unread;
      }
    }
    for (std::size_t i = 1; i < b.tokens.size(); ++i) {
      const Token& t = b.tokens[i];
      if (t.kind != TokenKind::keyword) continue;
      const std::string_view s = b.text(t.span);
      if (text::iequals(s, "FMAX")) w.fmax = true;
      else if (text::iequals(s, "FAUTO") || text::iequals(s, "AUTO")) w.fauto = true;
      else if (text::iequals(s, "DR+")) w.dr = 1;
      else if (text::iequals(s, "DR-")) w.dr = -1;
      else if (text::iequals(s, "RL")) w.comp = 1, w.comp_at = t.span;
      else if (text::iequals(s, "RR")) w.comp = 2, w.comp_at = t.span;
      else if (text::iequals(s, "R+") || text::iequals(s, "R-")) w.comp = 3, w.comp_at = t.span;
      else if (text::iequals(s, "MAX")) w.mb_max = true;
    }
    return ok;
  }

  // ---- blocks ----
  void tool_call(const Block& b) {
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

  void circle_centre(const Block& b) {
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
      cc_part_known_[a == p.u ? 0 : 1] = kn;
    }
    cc_known_ = cc_part_known_[0] && cc_part_known_[1];
    cc_plane_ = pl;
  }

  void motion(const Block& b, Verb v, MotionSink& out) {
    Words w;
    const bool ok = collect(b, v, w);
    if (w.unread >= 0)
      warn(b, b.words[static_cast<std::size_t>(w.unread)].span, codes::kKlartextUnresolved,
           fmt::format("'{}' is not read by this version in a {} block; the block is not followed",
                       b.text(b.words[static_cast<std::size_t>(w.unread)].span), to_string(v)));
    if (!ok || w.unread >= 0) {
      known_ &= static_cast<AxisMask>(~w.present);
      after_motion_m(b, w, out);
      return;
    }
    // Modal feed and radius compensation.
    if (w.f >= 0) {
      feed_ = len(w.f_v);
      feed_known_ = !inch_ && !w.fz;
      feed_mode_ = w.fu ? FeedMode::per_rev : FeedMode::per_minute;
    } else if (w.fauto) {
      feed_known_ = false;
    }
    if (w.comp >= 0) {
      if (w.comp != comp_) comp_reported_ = false;
      comp_ = w.comp;
    }
    for (const auto& [m, at] : w.m) before_motion_m(b, m, at);

    const bool plane_motion = v == Verb::c || v == Verb::cr || v == Verb::ct || v == Verb::cp || v == Verb::lp;
    geo_plane_ = (v == Verb::c || v == Verb::cp || v == Verb::lp) && cc_known_ ? cc_plane_ : plane_;
    if (v == Verb::m_only || (w.present == 0 && !plane_motion && w.pr < 0 && w.pa < 0)) {
      after_motion_m(b, w, out);
      return;
    }
    if (block_frame_unfollowed(b)) {
      known_ &= static_cast<AxisMask>(~w.present);
      after_motion_m(b, w, out);
      return;
    }
    Motion m;
    m.line = b.line;
    m.column = b.tokens.empty() ? 1 : b.tokens.front().span.begin + 1;
    m.type = w.fmax ? MotionType::rapid : MotionType::linear;
    m.plane = plane_;
    m.start = pos_;
    m.end = pos_;
    m.word_index.fill(-1);
    m.programmed = w.present;
    // End point of every axis word (absolute or incremental).
    AxisMask end_known = known_;
    for (int a = 0; a < kAxisCount; ++a) {
      if (!(w.present & (1u << a))) continue;
      const auto k = static_cast<std::size_t>(a);
      m.word_index[k] = static_cast<std::int8_t>(std::min<int>(w.axis[k], 127));
      const double val = is_rotary(a) ? w.value[k] : len(w.value[k]);
      if (w.incremental & (1u << a)) {
        m.end[a] = pos_[a] + val;
      } else if (is_rotary(a) && (known_ & (1u << a))) {
        m.end[a] = rollover_target(rollover_[k], val, pos_[a]);
      } else {
        m.end[a] = val;
        end_known |= static_cast<AxisMask>(1u << a);
      }
    }
    if (frame_machine_) {
      m.frame = Frame::machine;
      end_known = static_cast<AxisMask>(known_ | w.present);
    }
    bool geometry_ok = true;
    switch (v) {
      case Verb::l: break;
      case Verb::ln: geometry_ok = ln(b, w, m); break;
      case Verb::lp: geometry_ok = polar_line(b, w, m, end_known); break;
      case Verb::c: geometry_ok = arc_about_centre(b, w, m, end_known); break;
      case Verb::cr: geometry_ok = arc_by_radius(b, w, m, end_known); break;
      case Verb::ct: geometry_ok = arc_tangent(b, w, m, end_known); break;
      case Verb::cp: geometry_ok = polar_arc(b, w, m, end_known); break;
      default: break;
    }
    if (!geometry_ok) {
      known_ &= static_cast<AxisMask>(~(w.present | (1u << gaxes().u) | (1u << gaxes().v)));
      after_motion_m(b, w, out);
      return;
    }
    if (m.type == MotionType::arc_cw || m.type == MotionType::arc_ccw) {
      if (w.fmax) {
        warn(b, b.tokens.front().span, codes::kKlartextUnresolved, "an arc at FMAX is not followed by this version");
        known_ &= static_cast<AxisMask>(~kLinear);
        after_motion_m(b, w, out);
        return;
      }
    }
    m.known = end_known;
    m.feed = feed_;
    m.feed_known = feed_known_ && m.type != MotionType::rapid;
    m.feed_mode = feed_mode_;
    m.local_offset = datum_;
    m.tool_length_active = tool_active_;
    m.tool_length_h = static_cast<std::uint16_t>(std::max(0, tool_number_));
    m.tool_length_known = false;
    m.tcp = tcp_ ? TcpMode::heidenhain_m128 : TcpMode::off;
    m.tilted_plane = tilted_;
    m.spindle_turning = spindle_;
    m.inch_source = inch_;
    m.words_transformed = polar_words_;
    if (tcp_ && w.t[0] >= 0 && w.t[1] >= 0 && w.t[2] >= 0) {
      if (w.t_v.norm() > 1e-9) {
        m.tool_vector = w.t_v.normalized();
        m.tool_vector_known = true;
      }
    }
    // Radius compensation: the controller offsets the tool centre by the tool radius (tool table).
    if (comp_ != 0 && m.type != MotionType::rapid && !cutter_radius_known_ && !comp_reported_) {
      warn(b, w.comp_at.size() > 0 ? w.comp_at : b.tokens.front().span, codes::kCutterComp,
           fmt::format("radius compensation {} with a tool radius the machine file does not give ([tool.radii]): the "
                       "tool centre runs offset from the programmed contour, which this version does not compute",
                       comp_ == 1 ? "RL" : comp_ == 2 ? "RR" : "R+/R-"));
      comp_reported_ = true;
    }
    if (frame_machine_) {
      known_ &= static_cast<AxisMask>(~w.present);
    } else {
      pos_ = m.end;
      known_ = end_known;
    }
    if (!frame_machine_) {
      tangent_from(m);
      out.motion(m, b);
    } else {
      out.motion(m, b);
    }
    polar_words_ = false;
    after_motion_m(b, w, out);
  }

  /// M functions that act before the move of their block.
  void before_motion_m(const Block& b, int m, Span at) {
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

  bool block_frame_unfollowed(const Block& b) {
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

  /// M functions that act after the move (and non-modal ones that end here).
  void after_motion_m(const Block& b, const Words& w, MotionSink& out) {
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

  void retract(const Block& b, const Words& w, Span at, MotionSink& out) {
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
    m.tool_length_active = tool_active_;
    m.tool_length_h = static_cast<std::uint16_t>(std::max(0, tool_number_));
    m.inch_source = inch_;
    m.words_transformed = true;  // the MB word is a distance, not an end point
    pos_ = m.end;
    out.motion(m, b);
  }

  bool ln(const Block& b, const Words& w, Motion& m) {
    // LN: a straight line with the surface normal (NX NY NZ, for 3-D radius compensation by the
    // tool's delta values) and, under M128 / FUNCTION TCPM, the tool orientation (TX TY TZ).
    const bool any_t = w.t[0] >= 0 || w.t[1] >= 0 || w.t[2] >= 0;
    if (any_t && !tcp_) {
      warn(b, b.words[static_cast<std::size_t>(w.t[0] >= 0 ? w.t[0] : w.t[1] >= 0 ? w.t[1] : w.t[2])].span,
           codes::kKlartextUnresolved,
           "TX TY TZ orient the tool without M128 / FUNCTION TCPM: the control computes the rotary axes for the "
           "tilted working plane, which this version does not follow");
      return false;
    }
    if (any_t && (w.t[0] < 0 || w.t[1] < 0 || w.t[2] < 0)) {
      report(b, b.tokens.front().span, Severity::error, codes::kMissingWord,
             "an LN block needs all of TX TY TZ to orient the tool");
      return false;
    }
    (void)m;
    return true;
  }

  bool centre_ready(const Block& b) {
    if (cc_known_) return true;
    warn(b, b.tokens.front().span, codes::kKlartextUnresolved,
         "the circle centre / pole CC is not known here (not programmed, or relative to an unknown position)");
    return false;
  }

  bool start_known_in_plane(const Block& b) {
    const PlaneAxes p = gaxes();
    if ((known_ & (1u << p.u)) && (known_ & (1u << p.v))) return true;
    warn(b, b.tokens.front().span, codes::kUnknownPosition,
         "the arc starts at a position that is not known here; program an absolute position before it");
    return false;
  }

  void set_arc(Motion& m, const Eigen::Vector2d& c, double sweep, bool full) {
    const PlaneAxes p = gaxes();
    m.type = sweep >= 0 ? MotionType::arc_ccw : MotionType::arc_cw;
    m.plane = geo_plane_;
    m.arc.centre = m.start.head<3>();
    m.arc.centre[p.u] = c[0];
    m.arc.centre[p.v] = c[1];
    m.arc.radius = (Eigen::Vector2d(m.start[p.u], m.start[p.v]) - c).norm();
    m.arc.sweep = sweep;
    m.arc.full_circle = full;
    m.arc.turns = 1;
  }

  bool arc_about_centre(const Block& b, const Words& w, Motion& m, AxisMask& end_known) {
    const PlaneAxes p = gaxes();
    if (!centre_ready(b) || !start_known_in_plane(b)) return false;
    if (w.dr == 0) {
      report(b, b.tokens.front().span, Severity::error, codes::kMissingWord, "C needs DR+ or DR- (the direction)");
      return false;
    }
    end_known |= static_cast<AxisMask>((1u << p.u) | (1u << p.v));
    const Eigen::Vector2d s(m.start[p.u], m.start[p.v]), e(m.end[p.u], m.end[p.v]);
    const double rs = (s - cc_).norm(), re = (e - cc_).norm();
    if (std::abs(rs - re) > std::max(0.002, 1e-3 * rs)) {
      error(b, b.tokens.front().span,
            fmt::format("the end point is {:.4f} mm from CC, the start {:.4f} mm: the control stops with a circle end "
                        "position error",
                        re, rs));
      return false;
    }
    double a0 = std::atan2(s.y() - cc_.y(), s.x() - cc_.x()), a1 = std::atan2(e.y() - cc_.y(), e.x() - cc_.x());
    double sweep = a1 - a0;
    const bool full = (e - s).norm() < 1e-9;
    if (w.dr > 0) {
      while (sweep <= 0) sweep += 2 * kPi;
      if (full) sweep = 2 * kPi;
    } else {
      while (sweep >= 0) sweep -= 2 * kPi;
      if (full) sweep = -2 * kPi;
    }
    set_arc(m, cc_, sweep, full);
    return true;
  }

  bool arc_by_radius(const Block& b, const Words& w, Motion& m, AxisMask& end_known) {
    const PlaneAxes p = gaxes();
    if (!start_known_in_plane(b)) return false;
    if (w.r < 0 || w.dr == 0 || w.r_v == 0) {
      report(b, b.tokens.front().span, Severity::error, codes::kMissingWord, "CR needs R (not 0) and DR+ or DR-");
      return false;
    }
    end_known |= static_cast<AxisMask>((1u << p.u) | (1u << p.v));
    const Eigen::Vector2d s(m.start[p.u], m.start[p.v]), e(m.end[p.u], m.end[p.v]);
    const double r = len(std::abs(w.r_v));
    const Eigen::Vector2d d = e - s;
    const double l = d.norm();
    if (l < 1e-9 || l > 2 * r + std::max(0.002, 1e-3 * r)) {
      error(b, b.words[static_cast<std::size_t>(w.r)].span,
            fmt::format("no arc of radius {:.4f} mm joins the start and end {:.4f} mm apart", r, l));
      return false;
    }
    const double h = std::sqrt(std::max(0.0, r * r - l * l / 4));
    const Eigen::Vector2d left(-d.y() / l, d.x() / l);
    // R+ : the arc of at most 180°; R- : more. For DR+ (ccw) the short arc's centre is on the left.
    const bool long_arc = w.r_v < 0;
    const double side = (w.dr > 0) != long_arc ? 1.0 : -1.0;
    const Eigen::Vector2d c = (s + e) / 2 + side * h * left;
    double a0 = std::atan2(s.y() - c.y(), s.x() - c.x()), a1 = std::atan2(e.y() - c.y(), e.x() - c.x());
    double sweep = a1 - a0;
    if (w.dr > 0) {
      while (sweep <= 0) sweep += 2 * kPi;
    } else {
      while (sweep >= 0) sweep -= 2 * kPi;
    }
    set_arc(m, c, sweep, false);
    return true;
  }

  bool arc_tangent(const Block& b, const Words& w, Motion& m, AxisMask& end_known) {
    (void)w;
    const PlaneAxes p = gaxes();
    if (!start_known_in_plane(b)) return false;
    if (!tangent_known_) {
      warn(b, b.tokens.front().span, codes::kKlartextUnresolved,
           "CT continues the previous contour element tangentially, which is not known here");
      return false;
    }
    end_known |= static_cast<AxisMask>((1u << p.u) | (1u << p.v));
    const Eigen::Vector2d s(m.start[p.u], m.start[p.v]), e(m.end[p.u], m.end[p.v]);
    const Eigen::Vector2d t(tangent_[p.u], tangent_[p.v]);
    if (t.norm() < 1e-9) {
      warn(b, b.tokens.front().span, codes::kKlartextUnresolved,
           "CT after a move along the tool axis has no tangent in the working plane");
      return false;
    }
    const Eigen::Vector2d tn = t.normalized(), n(-tn.y(), tn.x()), d = e - s;
    const double nd = n.dot(d);
    if (std::abs(nd) < 1e-9 * std::max(1.0, d.squaredNorm())) {
      error(b, b.tokens.front().span, "the end point lies on the tangent: no tangential arc reaches it");
      return false;
    }
    const double k = d.squaredNorm() / (2 * nd);
    const Eigen::Vector2d c = s + k * n;
    double a0 = std::atan2(s.y() - c.y(), s.x() - c.x()), a1 = std::atan2(e.y() - c.y(), e.x() - c.x());
    double sweep = a1 - a0;
    if (k > 0) {
      while (sweep <= 0) sweep += 2 * kPi;
    } else {
      while (sweep >= 0) sweep -= 2 * kPi;
    }
    set_arc(m, c, sweep, false);
    return true;
  }

  bool polar_line(const Block& b, const Words& w, Motion& m, AxisMask& end_known) {
    const PlaneAxes p = gaxes();
    if (!centre_ready(b)) return false;
    if ((w.present & ((1u << p.u) | (1u << p.v))) != 0) {
      report(b, b.tokens.front().span, Severity::error, codes::kWordNotAllowed,
             "LP takes PR and PA (polar), not the working plane's axes");
      return false;
    }
    Eigen::Vector2d e;
    if (!polar_end(b, w, e)) return false;
    m.end[p.u] = e.x();
    m.end[p.v] = e.y();
    end_known |= static_cast<AxisMask>((1u << p.u) | (1u << p.v));
    polar_words_ = true;
    return true;
  }

  /// The end point of PR/PA words about the pole: absolute or incremental to the current point's
  /// polar coordinates (an omitted PR or PA keeps the current one).
  bool polar_end(const Block& b, const Words& w, Eigen::Vector2d& e) {
    const PlaneAxes p = gaxes();
    const bool need_current = w.pr < 0 || w.pa < 0 || w.ipr || w.ipa;
    double r = 0, a = 0;
    if (need_current) {
      if (!start_known_in_plane(b)) return false;
      const Eigen::Vector2d rel = Eigen::Vector2d(pos_[p.u], pos_[p.v]) - cc_;
      r = rel.norm();
      a = std::atan2(rel.y(), rel.x());
    }
    if (w.pr >= 0) r = w.ipr ? r + len(w.pr_v) : len(w.pr_v);
    if (w.pa >= 0) a = w.ipa ? a + w.pa_v * kDeg : w.pa_v * kDeg;
    if (r < 0) {
      error(b, b.words[static_cast<std::size_t>(w.pr)].span, "the polar radius PR is negative");
      return false;
    }
    e = cc_ + r * Eigen::Vector2d(std::cos(a), std::sin(a));
    return true;
  }

  bool polar_arc(const Block& b, const Words& w, Motion& m, AxisMask& end_known) {
    // CP PA|IPA [IZ] DR±: an arc about the pole from the current point; the radius is the current
    // distance to the pole. An incremental angle of more than a turn is a helix (with the tool axis).
    const PlaneAxes p = gaxes();
    if (!centre_ready(b) || !start_known_in_plane(b)) return false;
    if (w.pa < 0 || w.dr == 0 || w.pr >= 0 || (w.present & ((1u << p.u) | (1u << p.v)))) {
      report(b, b.tokens.front().span, Severity::error, codes::kMissingWord,
             "CP takes PA or IPA and DR+ or DR- (its radius is the distance to the pole)");
      return false;
    }
    const Eigen::Vector2d s(m.start[p.u], m.start[p.v]);
    const Eigen::Vector2d rel = s - cc_;
    const double r = rel.norm(), a0 = std::atan2(rel.y(), rel.x());
    double sweep = 0;
    if (w.ipa) {
      sweep = w.pa_v * kDeg;
      if ((sweep > 0) != (w.dr > 0) && sweep != 0) {
        error(b, b.words[static_cast<std::size_t>(w.pa)].span, "IPA and DR have opposite signs");
        return false;
      }
    } else {
      sweep = w.pa_v * kDeg - a0;
      if (w.dr > 0) {
        while (sweep <= 1e-12) sweep += 2 * kPi;
      } else {
        while (sweep >= -1e-12) sweep -= 2 * kPi;
      }
    }
    const Eigen::Vector2d e = cc_ + r * Eigen::Vector2d(std::cos(a0 + sweep), std::sin(a0 + sweep));
    m.end[p.u] = e.x();
    m.end[p.v] = e.y();
    end_known |= static_cast<AxisMask>((1u << p.u) | (1u << p.v));
    const double turns = std::abs(sweep) / (2 * kPi);
    set_arc(m, cc_, sweep, std::abs(turns - std::round(turns)) < 1e-12 && turns >= 1);
    if (turns > 1 + 1e-12) {
      m.arc.turns = static_cast<std::uint32_t>(std::ceil(turns - 1e-9));
      // ArcData.sweep carries the whole signed angle; turns counts started turns.
    }
    polar_words_ = true;
    return true;
  }

  void tangent_from(const Motion& m) {
    const Eigen::Vector3d s = m.start.head<3>(), e = m.end.head<3>();
    Eigen::Vector3d dir = e - s;
    if (m.type == MotionType::arc_cw || m.type == MotionType::arc_ccw) {
      const PlaneAxes p = plane_axes(m.plane);
      Eigen::Vector3d radial = e - m.arc.centre;
      radial[p.n] = 0;
      Eigen::Vector3d normal = Eigen::Vector3d::Zero();
      normal[p.n] = m.arc.sweep >= 0 ? 1.0 : -1.0;
      dir = normal.cross(radial);
    }
    tangent_known_ = (m.known & kLinear) == kLinear && dir.norm() > 1e-12;
    if (tangent_known_) tangent_ = dir.normalized();
  }

  // ---- cycles and frames ----
  int cycle_number(const Block& b, double& sub) const {
    // "CYCL DEF 7.1 …": the first number after the verb.
    for (std::size_t i = 1; i < b.tokens.size(); ++i) {
      const std::string_view s = b.text(b.tokens[i].span);
      double v = 0;
      if (b.tokens[i].kind == TokenKind::keyword && !s.empty() && s[0] >= '0' && s[0] <= '9' && parse_number(s, v)) {
        const double whole = std::floor(v + 1e-9);
        sub = std::round((v - whole) * 10);
        return static_cast<int>(whole);
      }
    }
    sub = -1;
    return -1;
  }

  void cycle_def(const Block& b) {
    double sub = 0;
    const int n = cycle_number(b, sub);
    const Span at = b.tokens.front().span;
    switch (n) {
      case 7: return datum_shift(b, sub);
      case 8: {  // mirror: 8.1 with the mirrored axes, none = off
        if (sub >= 1) mirror_ = has_axis_keyword(b);
        return;
      }
      case 10: {  // rotation: 10.1 ROT±a
        if (sub >= 1) {
          rotation_ = false;
          for (const Word& w : b.words)
            if (text::iequals(b.text(w.name), "ROT") || text::iequals(b.text(w.name), "IROT"))
              rotation_ = rotation_ || w.number != 0 || text::iequals(b.text(w.name), "IROT");
        }
        return;
      }
      case 11:
      case 26: {  // scaling: 11.1 SCL f; 26.1 X f Y f …
        if (sub >= 1) {
          scaling_ = false;
          for (const Word& w : b.words) scaling_ = scaling_ || w.number != 1.0;
        }
        return;
      }
      case 19: {  // working plane by axis angles: 19.1 A B C (none: reset)
        if (sub >= 1) {
          bool any = false;
          for (const Word& w : b.words)
            if (w.name_len == 1 && is_rotary(axis_index(w.letter))) any = any || w.number != 0;
          set_tilt(any);
          known_ &= static_cast<AxisMask>(~kRotary);  // the machine may position the rotary axes (MP)
        }
        return;
      }
      case 9:   // dwell
      case 32:  // tolerance
      case 13:  // spindle orientation
      case 12:  // PGM CALL definition (called by CYCL CALL)
        cycle_ = n;
        return;
      case 247: {  // datum setting: a preset of the preset table
        warn(b, at, codes::kKlartextUnresolved,
             "cycle 247 activates a preset of the preset table (a new datum): positions in the new frame are unknown "
             "until the program states them");
        known_ = 0;
        return;
      }
      default:
        if (sub <= 0) {  // a machining cycle: runs at CYCL CALL / M99; its Q parameters follow
          cycle_ = n;
          cycle_params_.clear();
          cycle_params_open_ = true;
        }
        return;
    }
  }

  bool has_axis_keyword(const Block& b) const {
    for (std::size_t i = 1; i < b.tokens.size(); ++i) {
      const std::string_view s = b.text(b.tokens[i].name);
      if (s.size() == 1 && axis_index(text::upper(s[0])) >= 0) return true;
    }
    return !b.words.empty();
  }

  void datum_shift(const Block& b, double sub) {
    if (sub <= 0) return;  // 7.0: the cycle's header
    for (std::size_t i = 1; i < b.tokens.size(); ++i)
      if (b.text(b.tokens[i].span).starts_with("#")) {
        warn(b, b.tokens[i].span, codes::kKlartextUnresolved,
             "the datum shift comes from a datum table line, which the program does not state; positions after it "
             "are unknown");
        known_ = 0;
        return;
      }
    for (const Word& w : b.words) {
      const std::string_view n = b.text(w.name);
      const bool inc = n.size() == 2 && (n[0] == 'I' || n[0] == 'i');
      const int a = axis_index(text::upper(n.back()));
      if (a < 0 || n.size() > 2 || (n.size() == 2 && !inc) || w.kind != ValueKind::number) {
        warn(b, w.span, codes::kKlartextUnresolved,
             fmt::format("'{}' in a datum shift is not read by this version; positions after it are unknown",
                         b.text(w.span)));
        known_ = 0;
        continue;
      }
      const double v = is_rotary(a) ? w.number : len(w.number);
      const double next = inc ? datum_[a] + v : v;
      pos_[a] -= next - datum_[a];
      datum_[a] = next;
    }
  }

  void set_tilt(bool on) {
    if (on != tilted_) known_ &= static_cast<AxisMask>(~kLinear);  // the coordinate system turns
    tilted_ = on;
  }

  void plane(const Block& b) {
    // PLANE RESET|SPATIAL|PROJECTED|EULER|VECTOR|POINTS|RELATIV|AXIAL … MOVE|TURN|STAY
    const bool reset = find_keyword(b, "RESET") >= 0;
    set_tilt(!reset);
    const bool moves = find_keyword(b, "MOVE") >= 0 || find_keyword(b, "TURN") >= 0;
    // MOVE compensates with the linear axes; TURN with MB retracts along the tool axis first.
    bool linear = find_keyword(b, "MOVE") >= 0 || find_keyword(b, "MB") >= 0;
    for (const Word& w : b.words) linear = linear || text::iequals(b.text(w.name), "MB");
    if (moves) known_ &= static_cast<AxisMask>(linear ? ~(kRotary | kLinear) : ~kRotary);
    if (find_keyword(b, "MOVE") < 0 && find_keyword(b, "TURN") < 0 && find_keyword(b, "STAY") < 0)
      warn(b, b.tokens.front().span, codes::kKlartextUnresolved,
           "PLANE without MOVE, TURN or STAY: how the rotary axes move is not stated; positions after it are unknown");
  }

  void function(const Block& b) {
    if (find_keyword(b, "TCPM") >= 0) {
      tcp_ = find_keyword(b, "RESET") < 0;
      // REFPNT TIP-CENTER / CENTER-CENTER: the programmed point is the tool's centre, offset from
      // the tip by the tool radius R2 of the tool table, which the program does not state.
      if (const int r = find_keyword(b, "REFPNT"); tcp_ && r >= 0 && !b.raw.substr(b.tokens[static_cast<std::size_t>(r)].span.begin).starts_with("REFPNT TIP-TIP")) {
        warn(b, b.tokens[static_cast<std::size_t>(r)].span, codes::kKlartextUnresolved,
             "REFPNT other than TIP-TIP refers the programmed point to the tool's centre (tool radius R2 of the tool "
             "table, not in the program); positions are not followed while it is active");
        tcp_refpnt_ = true;
      } else {
        tcp_refpnt_ = false;
      }
      return;
    }
    if (find_keyword(b, "MODE") >= 0) {
      turning_mode_ = find_keyword(b, "TURN") >= 0;
      return;
    }
    if (find_keyword(b, "FEED") >= 0 || find_keyword(b, "DWELL") >= 0 || find_keyword(b, "COUNT") >= 0 ||
        find_keyword(b, "S-PULSE") >= 0 || find_keyword(b, "LIFTOFF") >= 0)
      return;
    warn(b, b.tokens.front().span, codes::kKlartextUnresolved,
         fmt::format("'{}' is not followed by this version; positions after it are unknown", b.raw.substr(b.tokens.front().span.begin)));
    known_ = 0;
  }

  /// "Q200=+2 ;SET-UP CLEARANCE": a parameter of the cycle being defined (a literal; the resolver
  /// writes the value of a formula there).
  void cycle_parameter(const Block& b) {
    const Token& t = b.tokens.front();
    const std::string_view s = b.text(t.span);
    const std::string_view name = b.text(t.name);
    const std::size_t eq = s.find('=');
    if (name.size() < 2 || !(name[0] == 'Q' || name[0] == 'q') || eq == std::string_view::npos) return;
    double n = 0, v = 0;
    std::string_view rhs = s.substr(eq + 1);
    rhs = rhs.substr(0, std::min(rhs.find(';'), rhs.find('~')));
    while (!rhs.empty() && (rhs.front() == ' ' || rhs.front() == '\t')) rhs.remove_prefix(1);
    while (!rhs.empty() && (rhs.back() == ' ' || rhs.back() == '\t')) rhs.remove_suffix(1);
    if (!parse_number(name.substr(1), n)) return;
    if (parse_number(rhs, v)) cycle_params_[static_cast<int>(n)] = v;
    else cycle_params_.erase(static_cast<int>(n));
  }

  /// Drilling cycles that stay on the hole axis, as one drill_cycle motion per call (TNC 640 User's
  /// Manual, "Cycles: drilling" / "tapping"): to the set-up clearance Q200 above the surface Q203 at
  /// FMAX, down to the depth Q201 (pecks, dwells and chip breaking stay on the axis), back to the
  /// set-up clearance and on to the 2nd set-up clearance Q204.
  bool drill_call(const Block& b, Span at, MotionSink& out) {
    static constexpr int kOnAxis[] = {200, 201, 203, 205, 206, 207, 209, 240, 241};
    if (std::find(std::begin(kOnAxis), std::end(kOnAxis), cycle_) == std::end(kOnAxis)) return false;
    const auto q = [&](int k) -> std::optional<double> {
      if (auto it = cycle_params_.find(k); it != cycle_params_.end()) return it->second;
      return std::nullopt;
    };
    const PlaneAxes p = axes();
    std::string why;
    const auto clearance = q(200), depth = q(201), surface = q(203), second = q(204);
    if (!clearance || !depth || !surface || !second) why = "its Q200, Q201, Q203 or Q204 is not defined with a number";
    else if (*depth >= 0) why = "its depth Q201 is not negative (the control's sign check)";
    else if (cycle_ == 240 && q(343).value_or(0) != 0) why = "Q343=1 centres to a diameter, which depends on the tool's point angle";
    else if (cycle_ == 200 && q(395).value_or(0) != 0) why = "Q395=1 refers the depth to the tool's cylinder, which depends on its point angle";
    else if (cycle_ == 241 && q(379).value_or(0) != 0) why = "Q379 (deepened starting point) is not followed";
    else if ((known_ & ((1u << p.u) | (1u << p.v))) != ((1u << p.u) | (1u << p.v))) why = "the hole position is not known";
    else if (tcp_ || mirror_ || rotation_ || scaling_) why = "a transformation or M128 is active";
    if (!why.empty()) {
      warn(b, at, codes::kVendorCycle,
           fmt::format("machining cycle {} is called here but not expanded: {}; positions after it are unknown", cycle_,
                       why));
      known_ &= static_cast<AxisMask>(~(1u << p.n));
      return true;
    }
    Motion m;
    m.line = b.line;
    m.column = at.begin + 1;
    m.type = MotionType::drill_cycle;
    m.cycle_code10 = static_cast<std::uint16_t>(cycle_ >= 206 && cycle_ <= 209 ? 840 : q(202) && *q(202) < -*depth ? 830 : 810);
    m.plane = plane_;
    m.start = pos_;
    m.cycle_r = len(*surface + *clearance);
    m.cycle_bottom = len(*surface + *depth);
    pos_[p.n] = len(*surface + std::max(*clearance, *second));
    m.end = pos_;
    known_ |= static_cast<AxisMask>(1u << p.n);
    m.known = known_;
    m.word_index.fill(-1);
    m.feed = q(206) ? len(*q(206)) : feed_;
    m.feed_known = !inch_ && (q(206).has_value() || feed_known_);
    m.local_offset = datum_;
    m.tool_length_active = tool_active_;
    m.tool_length_h = static_cast<std::uint16_t>(std::max(0, tool_number_));
    m.tilted_plane = tilted_;
    m.spindle_turning = spindle_;
    m.inch_source = inch_;
    m.words_transformed = true;  // the cycle's levels are Q parameters of CYCL DEF, not words of this block
    out.motion(m, b);
    return true;
  }

  void cycle_call(const Block& b, Span at, MotionSink& out) {
    if (cycle_ < 0 || cycle_ == 9 || cycle_ == 32 || cycle_ == 13) return;
    if (find_keyword(b, "PAT") < 0 && find_keyword(b, "POS") < 0 && drill_call(b, at, out)) return;
    warn(b, at, codes::kVendorCycle,
         fmt::format("machining cycle {} is called here; its moves are not expanded by this version, so positions "
                     "after it are unknown (the tool axis at least) until the program states them",
                     cycle_));
    known_ &= static_cast<AxisMask>(find_keyword(b, "PAT") >= 0 ? ~kLinear : ~(1u << axes().n));
  }

  const Dialect& d_;
  std::string_view file_;
  DiagnosticSink& sink_;
  AxisVector pos_ = AxisVector::Zero();
  AxisMask known_ = 0;
  bool inch_ = false, ended_ = false, continuation_ = false;
  double feed_ = 0;
  bool feed_known_ = false;
  FeedMode feed_mode_ = FeedMode::per_minute;
  int comp_ = 0;
  bool comp_reported_ = false, cutter_radius_known_ = false;
  Plane plane_ = Plane::xy;
  Eigen::Vector2d cc_ = Eigen::Vector2d::Zero();
  std::array<bool, 2> cc_part_known_{false, false};
  bool cc_known_ = false;
  Plane cc_plane_ = Plane::xy;
  Plane geo_plane_ = Plane::xy;
  Eigen::Vector3d tangent_ = Eigen::Vector3d::UnitX();
  bool tangent_known_ = false;
  bool polar_words_ = false;
  AxisVector datum_ = AxisVector::Zero();
  bool mirror_ = false, rotation_ = false, scaling_ = false, tilted_ = false, tcp_ = false;
  bool frame_machine_ = false, kinematic_m_ = false, turning_mode_ = false, spindle_ = false, tcp_refpnt_ = false;
  int m92_ = 0;
  Span m92_at_;
  bool tool_active_ = false;
  int tool_number_ = -1;
  int cycle_ = -1;
  std::map<int, double> cycle_params_;  ///< Q number → value of the cycle defined last
  bool cycle_params_open_ = false;
  std::array<RotaryRollover, 9> rollover_{};
};

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
    const bool have3 = fetch(third);
    cc.motions.clear();
    bool okc = true;
    if (have3) {
      set(bc, third);
      okc = lex_block(d, bc, ctx);
      interp.execute(bc, cc);
      ++st.blocks;
    }
    std::string why = size_ok ? "" : "its size is not a number";
    std::optional<Motion> element;
    if (size_ok && have3 && !cc.motions.empty() && okc)
      element = corner_element(ca.motions.back(), cc.motions.front(), rounding, size, why);
    else if (why.empty())
      why = !have3 ? "no block follows it"
                   : "the block after it makes no move (this version builds the corner only between two straight "
                     "moves written next to it)";
    cn.motions.clear();
    if (element) {
      element->line = bn.line;
      element->column = bn.tokens.empty() ? 1 : bn.tokens.front().span.begin + 1;
      if (feed > 0) element->feed = feed, element->feed_known = !interp.inch();
      cn.motions.push_back(*element);
    } else {
      report_at(ctx, bn, bn.tokens.empty() ? Span{0, 1} : bn.tokens.front().span, Severity::warning,
                codes::kKlartextUnresolved,
                fmt::format("{} is not built here: {}; the moves next to it are read up to the corner and not corrected",
                            rounding ? "RND" : "CHF", why));
      if (!ca.motions.empty()) ca.motions.back().words_transformed = true;
      if (!cc.motions.empty()) cc.motions.front().words_transformed = true;
    }
    visitor.block(b, ca.motions, ok);
    visitor.block(bn, cn.motions, okn);
    ++st.blocks;
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
