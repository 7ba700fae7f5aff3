// Klartext path functions (klartext_interp.hpp): the words of a path block, L / LN / LP / C / CR / CT /
// CP geometry in the working plane or the plane of CC, and the tangent a following CT continues.
#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <optional>

#include <Eigen/Geometry>

#include "src/gcode/klartext_interp.hpp"

namespace postproc::gcode::klartext {

bool Interp::collect(const Block& b, Verb v, Words& w) {
  w.axis.fill(-1);
  bool ok = true;
  for (std::size_t i = 0; i < b.words.size(); ++i) {
    const Word& wd = b.words[i];
    const std::string_view name = b.text(wd.name);
    const auto idx = static_cast<std::int16_t>(i);
    const std::string_view up = name;
    const bool inc = up.size() == 2 && (up[0] == 'I' || up[0] == 'i') && axis_index(text::upper(up[1])) >= 0;
    const int ax = up.size() == 1 ? axis_index(text::upper(up[0])) : inc ? axis_index(text::upper(up[1])) : -1;
    if (wd.kind != ValueKind::number) {
      const std::string_view value = b.text(wd.value);
      const std::string q = text::upper(value.substr(value.empty() || (value[0] != '+' && value[0] != '-') ? 0 : 1));
      warn(b, wd.span, codes::kExpressionValue,
           fmt::format("'{}' takes its value from a Q parameter the program does not set before this block{}; the "
                       "block is not followed (what it moves is unknown until programmed); give its value with --set "
                       "'{}=…' if it is known",
                       b.text(wd.span),
                       q == "Q120" || q == "Q121" || q == "Q122"
                           ? " (Q120–Q122: the rotary axis angles a PLANE … STAY computes from the machine's "
                             "kinematics)"
                           : "",
                       q));
      // What the word sets is not known from here on: its axis, or the modal feed.
      if (ax >= 0 && v != Verb::m_only) w.present |= static_cast<AxisMask>(1u << ax);
      if (text::iequals(up, "PR") || text::iequals(up, "IPR") || text::iequals(up, "PA") || text::iequals(up, "IPA")) {
        const PlaneAxes pa = axes();  // a polar end point: both coordinates of the plane
        w.present |= static_cast<AxisMask>((1u << pa.u) | (1u << pa.v));
      }
      if (up.size() == 1 && (up[0] == 'F' || up[0] == 'f')) feed_known_ = false;
      ok = false;
      continue;
    }
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
  // Keywords; "F MAX" / "F AUTO" (hyperMILL writes them so) are FMAX / F AUTO; "MB MAX" the
  // retraction of M140. Any other keyword is not read in silence: the block is not followed.
  int f_at = -1;  // a keyword "F" waiting for MAX or AUTO
  const auto unread_kw = [&](int i) {
    if (w.unread_keyword < 0 && v != Verb::m_only) w.unread_keyword = static_cast<std::int16_t>(i);
  };
  for (std::size_t i = 1; i < b.tokens.size(); ++i) {
    const Token& t = b.tokens[i];
    if (t.kind != TokenKind::keyword) continue;
    const std::string_view s = b.text(t.span);
    const bool after_f = f_at >= 0;
    if (after_f && !text::iequals(s, "MAX") && !text::iequals(s, "AUTO")) unread_kw(f_at);
    f_at = -1;
    if (text::iequals(s, "FMAX") || (after_f && text::iequals(s, "MAX"))) w.fmax = true;
    else if (text::iequals(s, "FAUTO") || text::iequals(s, "AUTO")) w.fauto = true;
    else if (text::iequals(s, "DR+")) w.dr = 1;
    else if (text::iequals(s, "DR-")) w.dr = -1;
    else if (text::iequals(s, "RL")) w.comp = 1, w.comp_at = t.span;
    else if (text::iequals(s, "RR")) w.comp = 2, w.comp_at = t.span;
    else if (text::iequals(s, "R+") || text::iequals(s, "R-")) w.comp = 3, w.comp_at = t.span;
    else if (text::iequals(s, "MAX")) w.mb_max = true;
    else if (text::iequals(s, "F")) f_at = static_cast<int>(i);
    else if (text::iequals(s, "MB") || s == "~") continue;
    else unread_kw(static_cast<int>(i));
  }
  if (f_at >= 0) unread_kw(f_at);
  return ok;
}

void Interp::motion(const Block& b, Verb v, MotionSink& out) {
  Words w;
  const bool ok = collect(b, v, w);
  if (w.unread >= 0)
    warn(b, b.words[static_cast<std::size_t>(w.unread)].span, codes::kKlartextUnresolved,
         fmt::format("'{}' is not read by this version in a {} block; the block is not followed",
                     b.text(b.words[static_cast<std::size_t>(w.unread)].span), to_string(v)));
  if (w.unread_keyword >= 0) {
    w.present |= kLinear;  // where the block goes is not known
    warn(b, b.tokens[static_cast<std::size_t>(w.unread_keyword)].span, codes::kKlartextUnresolved,
         fmt::format("'{}' is not read by this version in a {} block; the block is not followed",
                     b.text(b.tokens[static_cast<std::size_t>(w.unread_keyword)].span), to_string(v)));
  }
  if (!ok || w.unread >= 0 || w.unread_keyword >= 0) {
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
  m.work_offset = preset_;
  m.work_offset_rewritten = preset_unknown_;
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
  if (comp_ != 0 && !cutter_radius_known_) m.cutter_radius = std::numeric_limits<double>::quiet_NaN();
  if (comp_ != 0 && m.type != MotionType::rapid && !cutter_radius_known_ && !comp_reported_) {
    warn(b, w.comp_at.size() > 0 ? w.comp_at : b.tokens.front().span, codes::kCutterComp,
         fmt::format("radius compensation {} with a tool radius the machine file does not give ([tool.radii]): the "
                     "tool centre runs offset from the programmed contour, which this version does not compute",
                     comp_ == 1 ? "RL" : comp_ == 2 ? "RR" : "R+/R-"));
    comp_reported_ = true;
  }
  if (frame_machine_) {  // M91: machine coordinates; the work-frame position of these axes is lost
    known_ &= static_cast<AxisMask>(~w.present);
  } else {
    pos_ = m.end;
    known_ = end_known;
    tangent_from(m);
  }
  out.motion(m, b);
  polar_words_ = false;
  after_motion_m(b, w, out);
}

bool Interp::ln(const Block& b, const Words& w, Motion& m) {
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

bool Interp::centre_ready(const Block& b) {
  if (cc_known_) return true;
  warn(b, b.tokens.front().span, codes::kKlartextUnresolved,
       "the circle centre / pole CC is not known here (not programmed, or relative to an unknown position)");
  return false;
}

bool Interp::start_known_in_plane(const Block& b) {
  const PlaneAxes p = gaxes();
  if ((known_ & (1u << p.u)) && (known_ & (1u << p.v))) return true;
  warn(b, b.tokens.front().span, codes::kUnknownPosition,
       "the arc starts at a position that is not known here; program an absolute position before it");
  return false;
}

void Interp::set_arc(Motion& m, const Eigen::Vector2d& c, double sweep, bool full) {
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

bool Interp::arc_about_centre(const Block& b, const Words& w, Motion& m, AxisMask& end_known) {
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

bool Interp::arc_by_radius(const Block& b, const Words& w, Motion& m, AxisMask& end_known) {
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

bool Interp::arc_tangent(const Block& b, const Words& w, Motion& m, AxisMask& end_known) {
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

bool Interp::polar_line(const Block& b, const Words& w, Motion& m, AxisMask& end_known) {
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

bool Interp::polar_end(const Block& b, const Words& w, Eigen::Vector2d& e) {
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

bool Interp::polar_arc(const Block& b, const Words& w, Motion& m, AxisMask& end_known) {
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

void Interp::tangent_from(const Motion& m) {
  const Eigen::Vector3d dir = end_direction(m);
  tangent_known_ = (m.known & kLinear) == kLinear && dir.norm() > 1e-12;
  if (tangent_known_) tangent_ = dir.normalized();
}

}  // namespace postproc::gcode::klartext
