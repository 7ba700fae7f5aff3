// Modal interpreter, part 3: LinuxCNC lathe profile cycles G70, G71, G72 (G71.1/.2, G72.1/.2).
//
// The cycle names its finished shape by a subroutine number (Q); the resolver passes that
// subroutine's lines, values substituted, as "oN sub" … "oN endsub" just before the cycle's
// block. They are read here the way rs274 reads them for the cycle — only the moves, G0 taken as
// G1, U/W as increments, other words ignored — and the cycle is expanded by turning_cycles.cpp.
#include <cctype>
#include <cmath>
#include <map>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"
#include "src/gcode/turning_cycles.hpp"

namespace postproc::gcode {

/// One move of the profile as written (program units; X and U as written, diameter or radius).
struct ProfileStep {
  std::uint64_t line = 0;
  int motion = -1;           ///< 0 1 2 3: the profile's motion mode for this block, -1 none yet
  bool has_x = false, has_z = false, has_u = false, has_w = false;
  double x = 0, z = 0, u = 0, w = 0;
  bool has_i = false, has_k = false, has_r = false;
  double i = 0, k = 0, r = 0;
  bool has_a = false, has_c = false;  ///< corner at the block's end: fillet radius A, chamfer C
  double a = 0, c = 0;
};

struct Interpreter::LatheProfile {
  long number = -1;          ///< N of "oN sub"
  bool open = false;         ///< between sub and endsub
  bool usable = true;        ///< false when one of its blocks was refused (already reported)
  bool awaiting = false;     ///< just closed: the next block must be the cycle that reads it
  int motion = -1;
  std::uint64_t line = 0;    ///< the sub line
  std::vector<ProfileStep> steps;
  /// The profiles read before this one, by number (a program read without resolving defines all its
  /// subroutines first and names one by Q later).
  std::map<long, std::shared_ptr<LatheProfile>> earlier;
};

namespace {

/// "o100 sub" → {100, 1}; "o100 endsub" → {100, 2}; anything else → {-1, 0}.
std::pair<long, int> sub_marker(std::string_view text) {
  std::string t;
  for (char c : text)
    if (c != ' ' && c != '\t') t += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (t.size() < 2 || t[0] != 'o' || !std::isdigit(static_cast<unsigned char>(t[1]))) return {-1, 0};
  std::size_t p = 1;
  long n = 0;
  while (p < t.size() && std::isdigit(static_cast<unsigned char>(t[p])) && n < 100000000) n = n * 10 + (t[p++] - '0');
  const std::string_view kw = std::string_view(t).substr(p);
  if (kw == "sub") return {n, 1};
  if (kw == "endsub") return {n, 2};
  return {-1, 0};
}

}  // namespace

bool Interpreter::lathe_profile_line(const Block& b) {
  for (const Token& t : b.tokens) {
    if (t.kind != TokenKind::control_flow) continue;
    const auto [n, kind] = sub_marker(b.text(t.span));
    if (kind == 1) {
      auto next = std::make_shared<LatheProfile>();
      if (lathe_profile_) {
        next->earlier = std::move(lathe_profile_->earlier);
        if (!lathe_profile_->open) next->earlier[lathe_profile_->number] = lathe_profile_;
        next->earlier.erase(n);
      }
      lathe_profile_ = std::move(next);
      lathe_profile_->number = n;
      lathe_profile_->open = true;
      lathe_profile_->line = b.line;
      return true;
    }
    if (kind == 2 && lathe_profile_ && lathe_profile_->open) {
      lathe_profile_->open = false;
      lathe_profile_->awaiting = true;
      return true;
    }
  }
  if (lathe_profile_ && lathe_profile_->awaiting) {
    // The resolver passes a subroutine on only right before the G70–G72 that reads it; anywhere
    // else (a program read without resolving) the definition was skipped and is reported.
    lathe_profile_->awaiting = false;
    bool cycle = false, same_q = false;
    for (const Word& wd : b.words) {
      if (wd.letter == 'G' && wd.kind == ValueKind::number && wd.number >= 70 && wd.number < 73) cycle = true;
      if (wd.letter == 'Q' && wd.kind == ValueKind::number && std::lround(wd.number) == lathe_profile_->number) same_q = true;
    }
    if (!(cycle && same_q))
      report(b, Span{0, static_cast<std::uint32_t>(b.raw.size())}, Severity::warning, codes::kControlFlow,
             fmt::format("the subroutine o{} defined at line {} was skipped here; subroutines are followed only when "
                         "the program is resolved",
                         lathe_profile_->number, lathe_profile_->line));
  }
  if (!lathe_profile_ || !lathe_profile_->open) return false;
  // A block of the profile: its moves are data for the cycle (LinuxCNC docs, G71-G72: "This
  // subroutine may contain G0, G1, G2 and G3 motion commands. All other commands are ignored").
  LatheProfile& p = *lathe_profile_;
  BlockWords w;
  if (!collect(b, w)) {
    p.usable = false;
    return true;
  }
  ProfileStep st;
  st.line = b.line;
  if (w.motion.def) {
    const int code10 = w.motion.def->code10;
    if (code10 == 0 || code10 == 10 || code10 == 20 || code10 == 30) {
      p.motion = code10 / 10;
    } else {
      report(b, b.words[static_cast<std::size_t>(w.motion.word)].span, Severity::warning, codes::kLatheCycleUnresolved,
             fmt::format("'{}' in the profile of a lathe cycle: only G0, G1, G2 and G3 make the profile; not followed",
                         b.text(b.words[static_cast<std::size_t>(w.motion.word)].span)));
      p.usable = false;
    }
  }
  st.motion = p.motion;
  const auto take = [&](int axis, bool& has, double& v) {
    if (!(w.axis_present & (1u << axis))) return;
    has = true;
    v = w.axis[axis];
  };
  take(0, st.has_x, st.x);
  take(2, st.has_z, st.z);
  take(6, st.has_u, st.u);
  take(8, st.has_w, st.w);
  // A and C on a profile block round or chamfer the corner at its end (rs274 2.9 reads them as
  // numbers there, not as axes; LinuxCNC docs, G71-G72).
  take(3, st.has_a, st.a);
  take(5, st.has_c, st.c);
  const AxisMask others = static_cast<AxisMask>(
      w.axis_present & ~(bit(Axis::x) | bit(Axis::z) | bit(Axis::u) | bit(Axis::w) | bit(Axis::a) | bit(Axis::c)));
  if ((w.axis_unresolved | w.letter_unresolved) != 0 || others != 0) {
    report(b, Span{0, static_cast<std::uint32_t>(b.raw.size())}, Severity::warning, codes::kLatheCycleUnresolved,
           others != 0 ? "axis other than X Z U W (or A, C: corner finishes) in the profile of a lathe cycle; the "
                         "cycle is not followed"
                       : "value not known in the profile of a lathe cycle; the cycle is not followed");
    p.usable = false;
  }
  for (char L : {'I', 'K', 'R'}) {
    if (!w.has(L)) continue;
    (L == 'I' ? st.has_i : L == 'K' ? st.has_k : st.has_r) = true;
    (L == 'I' ? st.i : L == 'K' ? st.k : st.r) = w.get(L);
  }
  if (st.has_x || st.has_z || st.has_u || st.has_w) p.steps.push_back(st);
  return true;
}

void Interpreter::lathe_cycle(const Block& b, const BlockWords& w, MotionSink& out) {
  const Span at = b.words[static_cast<std::size_t>(w.motion.word)].span;
  const std::string name(b.text(at));
  const int code10 = w.motion.def->code10;
  const auto refuse = [&](std::string_view code, std::string msg) {
    report(b, at, code == codes::kLatheCycleRejected ? Severity::error : Severity::warning, code, std::move(msg));
    s_.known &= static_cast<AxisMask>(~(bit(Axis::x) | bit(Axis::z)));
  };
  // LinuxCNC docs, G70 and G71-G72: "It is an error if: there is no subroutine defined with the
  // number given in Q; … G17-G19.1 has not been used to select the ZX plane".
  if (!w.has('Q') || w.unresolved('Q')) {
    refuse(codes::kLatheCycleRejected, fmt::format("{} needs Q, the number of the profile subroutine", name));
    return;
  }
  const long q = std::lround(w.get('Q'));
  const LatheProfile* profile_of_q = nullptr;
  if (lathe_profile_ && !lathe_profile_->open && lathe_profile_->number == q) {
    profile_of_q = lathe_profile_.get();
  } else if (lathe_profile_) {
    const auto it = lathe_profile_->earlier.find(q);
    if (it != lathe_profile_->earlier.end()) profile_of_q = it->second.get();
  }
  if (profile_of_q == nullptr) {
    refuse(codes::kLatheCycleRejected,
           fmt::format("{}: no profile 'o{} sub' … 'o{} endsub' in this program (rs274: Q routine not found)", name, q, q));
    return;
  }
  const LatheProfile& prof_q = *profile_of_q;
  if (!prof_q.usable) {
    refuse(codes::kLatheCycleUnresolved, fmt::format("{}: its profile o{} was refused above; the cycle is not followed", name, q));
    return;
  }
  if (s_.plane != Plane::zx) {
    refuse(codes::kLatheCycleRejected, fmt::format("{} needs the ZX plane; program G18 before it", name));
    return;
  }
  if (!s_.absolute) {
    // rs274 2.9 runs the cycle under G91 (profile words read as increments); not reproduced here.
    refuse(codes::kLatheCycleUnresolved,
           fmt::format("{} under G91 (incremental distance mode) is not expanded by this version; program G90 "
                       "before the cycle",
                       name));
    return;
  }
  const AxisMask others = static_cast<AxisMask>(w.axis_present & ~(bit(Axis::x) | bit(Axis::z)));
  if (others != 0 || (w.axis_unresolved & (bit(Axis::x) | bit(Axis::z)))) {
    refuse(codes::kLatheCycleUnresolved,
           fmt::format("{} with axis words other than X and Z (U/W displacement of the profile is not in the "
                       "LinuxCNC documentation); not followed",
                       name));
    return;
  }
  for (char L : {'D', 'E', 'I', 'P', 'R'})
    if (w.has(L) && w.unresolved(L)) {
      refuse(codes::kLatheCycleUnresolved, fmt::format("{}: value of {} not known; not followed", name, L));
      return;
    }
  const double scale = s_.inch ? 25.4 : 1.0;
  const double xdiv = s_.diameter_mode ? 2.0 : 1.0;
  turning::CycleWords cw;
  cw.cycle = code10 / 10;
  cw.variant = code10 % 10;
  const bool have_x = w.axis_present & bit(Axis::x), have_z = w.axis_present & bit(Axis::z);
  if ((!have_x && !(s_.known & bit(Axis::x))) || (!have_z && !(s_.known & bit(Axis::z)))) {
    report(b, at, Severity::warning, codes::kUnknownPosition,
           fmt::format("{} starts from the current point, which is unknown here; give X and Z on the block", name));
    s_.known &= static_cast<AxisMask>(~(bit(Axis::x) | bit(Axis::z)));
    return;
  }
  cw.start = turning::Point(have_z ? w.axis[2] : s_.position[2] / scale, have_x ? w.axis[0] / xdiv : s_.position[0] / scale);
  if (w.has('D')) cw.d = w.get('D');
  if (w.has('E')) cw.e = w.get('E');
  if (w.has('P')) cw.passes = w.get('P');
  if (w.has('I')) cw.increment = w.get('I');
  if (w.has('R')) cw.retract = w.get('R');
  if (cw.cycle == 70 && !(cw.passes >= 1 && cw.passes < 1000)) {
    refuse(codes::kLatheCycleRejected, fmt::format("{}: P (number of passes) must be at least 1", name));
    return;
  }
  if (cw.cycle != 70 && !(cw.increment > 0)) {
    refuse(codes::kLatheCycleRejected, fmt::format("{}: I (depth of cut) must be positive", name));
    return;
  }
  // The profile, as rs274 reads it for the cycle: from the start point, each block with a new end
  // point adds a straight (G0, G1) or an arc (G2, G3; centre I K relative to the previous point
  // under G91.1, absolute under G90.1, or R).
  std::vector<turning::Segment> profile;
  turning::Point prev = cw.start;
  for (const ProfileStep& st : prof_q.steps) {
    turning::Point p = prev;
    if (st.has_x) p.imag(st.x / xdiv);
    if (st.has_z) p.real(st.z);
    if (st.has_u) p.imag(p.imag() + st.u / xdiv);
    if (st.has_w) p.real(p.real() + st.w);
    if (p == prev) continue;
    const auto step_refuse = [&](std::string why) {
      refuse(codes::kLatheCycleUnresolved, fmt::format("{}: profile o{} line {}: {}; the cycle is not followed", name, q, st.line, why));
    };
    // Before any G0-G3 in the profile the cycle's own rapid has left G0: a straight element.
    const int motion = st.motion < 0 ? 0 : st.motion;
    turning::Segment s;
    s.a = prev;
    s.b = p;
    if (motion >= 2) {
      s.arc = true;
      s.ccw = motion == 3;  // the profile's motion mode (rs274 2.9: also when G2/G3 is modal)
      if (st.has_r) {
        if (s_.arc_absolute) {
          step_refuse("arc by radius R under G90.1");
          return;
        }
        const double chord2 = std::norm(p - prev);
        if (st.r * st.r < chord2 / 4) {
          step_refuse("arc radius R smaller than half the chord");
          return;
        }
        const turning::Point d = turning::Point(0, 1) * std::sqrt((st.r * st.r - chord2 / 4) / chord2) * (p - prev);
        s.c = (prev + p) / 2.0 + (s.ccw ? d : -d);
      } else if (!st.has_i && !st.has_k) {
        refuse(codes::kLatheCycleRejected, fmt::format("{}: profile o{} line {}: arc needs I or K (or R)", name, q, st.line));
        return;
      } else {
        s.c = turning::Point(st.k, st.i);
        if (!s_.arc_absolute) s.c += prev;
        // rs274 refuses an arc whose radii differ by more than 0.5 mm (0.05 in), or by more than
        // 0.005 mm (0.0005 in) and 0.1 % of the radius (LinuxCNC docs, G2 G3 "It is an error if").
        const double r1 = std::abs(s.a - s.c), r2 = std::abs(s.b - s.c), diff = std::abs(r1 - r2);
        const double big = s_.inch ? 0.05 : 0.5, small = s_.inch ? 0.0005 : 0.005;
        if (r1 < 1e-9 || diff > big || (diff > small && diff > 0.001 * r1)) {
          refuse(codes::kLatheCycleRejected,
                 fmt::format("{}: profile o{} line {}: arc radius at start {:.4f} and at end {:.4f} differ", name, q,
                             st.line, r1, r2));
          return;
        }
      }
    }
    profile.push_back(s);
    prev = p;
    if (st.has_a && st.has_c) {
      refuse(codes::kLatheCycleRejected,
             fmt::format("{}: profile o{} line {}: both A (rounding) and C (chamfer) on one corner (rs274: \"Both A "
                         "and C parameters on a corner\")",
                         name, q, st.line));
      return;
    }
    if ((st.has_a && st.a != 0) || (st.has_c && st.c != 0))
      profile.push_back(turning::Segment{st.has_a, false, p, p, p, st.has_a ? st.a : st.c});
  }
  std::vector<turning::Move> moves;
  const std::string failure = turning::expand_linuxcnc(cw, profile, moves);
  if (failure == "roughing does not end") {
    // rs274 2.9 cuts such a cycle without end (its layers never reach the profile's end).
    refuse(codes::kLatheCycleRejected,
           fmt::format("{}: the controller cannot run this cycle: rs274 keeps cutting layers without end here; "
                       "change the profile, I or D",
                       name));
    return;
  }
  if (!failure.empty()) {
    refuse(codes::kLatheCycleRejected, fmt::format("{}: the controller rejects this cycle (rs274: G7X error: {})", name, failure));
    return;
  }
  // Preliminary rapid to the cycle's X/Z (or the current point), then the cycle's moves.
  moves.insert(moves.begin(), turning::Move{turning::Move::Kind::rapid, cw.start, {}});
  // rs274 makes each arc of the cycle with G2/G3 and their radius check; an arc of the offset
  // path whose ends lie at different distances from its centre (the algorithm's join of an arc
  // with a following element can leave one) stops the program there ("Radius to end of arc
  // differs from radius to start"). Same tolerance as for the profile's own arcs above.
  {
    turning::Point at_pt(s_.position[2] / scale, s_.position[0] / scale);
    for (const turning::Move& mv : moves) {
      if (mv.kind == turning::Move::Kind::arc_cw || mv.kind == turning::Move::Kind::arc_ccw) {
        const double r1 = std::abs(at_pt - mv.centre), r2 = std::abs(mv.end - mv.centre), diff = std::abs(r1 - r2);
        const double big = s_.inch ? 0.05 : 0.5, small = s_.inch ? 0.0005 : 0.005;
        if (diff > big || (diff > small && diff > 0.001 * r1)) {
          refuse(codes::kLatheCycleRejected,
                 fmt::format("{}: the controller rejects this cycle: one of its arcs (to X{:.4f} Z{:.4f}) has radius "
                             "{:.4f} at its start and {:.4f} at its end (rs274: \"Radius to end of arc differs from "
                             "radius to start\")",
                             name, mv.end.imag() * xdiv, mv.end.real(), r1, r2));
          return;
        }
      }
      at_pt = mv.end;
    }
  }
  emit_turning_moves(b, at, moves, scale, out);
  // rs274 leaves the motion mode of the last move it made (a following "X50" feeds in G1).
  switch (moves.back().kind) {
    case turning::Move::Kind::rapid: s_.motion = GMeaning::rapid; s_.motion_code10 = 0; break;
    case turning::Move::Kind::line: s_.motion = GMeaning::linear; s_.motion_code10 = 10; break;
    case turning::Move::Kind::arc_cw: s_.motion = GMeaning::arc_cw; s_.motion_code10 = 20; break;
    case turning::Move::Kind::arc_ccw: s_.motion = GMeaning::arc_ccw; s_.motion_code10 = 30; break;
  }
}

void Interpreter::spindle_synced_move(const Block& b, const BlockWords& w, Motion& m, MotionSink& out) {
  // LinuxCNC docs, G33 "Spindle Synchronized Motion": a straight move from the current point to
  // the axis words, K = distance per revolution (G33.1: and back, below); rs274 refuses it without
  // K ("K word missing with g33/g33.1", also on a modal repeat), with F, and when the spindle is not
  // turning; it asks no F of them, in G93 or after it.
  const Span at = b.words[static_cast<std::size_t>(w.motion.word >= 0 ? w.motion.word : w.axis_word[0] >= 0 ? w.axis_word[0] : 0)].span;
  const AxisMask named = w.axis_present;
  const char* g = s_.motion_code10 == 331 ? "G33.1" : "G33";
  if (!w.has('K')) {
    report(b, at, Severity::error, codes::kLatheCycleRejected,
           fmt::format("{} needs K (distance per revolution) on every {} block (rs274: \"K word missing with "
                       "g33/g33.1\")", g, g));
    s_.known &= static_cast<AxisMask>(~named);
    return;
  }
  if (w.has('F')) {  // rs274 convert_straight: the feed is K per revolution
    report(b, b.words[static_cast<std::size_t>(w.letter_word['F' - 'A'])].span, Severity::error,
           codes::kLatheCycleRejected,
           fmt::format("F with {} (rs274: \"F word used with a g33/g33.1\"): the feed is K per revolution; "
                       "give F in a block of its own", g));
    s_.known &= static_cast<AxisMask>(~named);
    return;
  }
  if (w.unresolved('K')) {
    report(b, b.words[static_cast<std::size_t>(w.letter_word['K' - 'A'])].span, Severity::warning,
           codes::kLatheCycleUnresolved, fmt::format("{} with a K that is not known; not followed", g));
    s_.known &= static_cast<AxisMask>(~named);
    return;
  }
  if (!spindle_turning_) {
    report(b, at, Severity::error, codes::kLatheCycleRejected,
           fmt::format("{} while the spindle is not turning (rs274: \"Spindle not turning in {}\"); program M3 or M4 "
                       "before it", g, g));
    s_.known &= static_cast<AxisMask>(~named);
    return;
  }
  m.type = MotionType::linear;
  const AxisMask known_before = s_.known;
  if (!target(b, w, m)) return;
  m.feed = w.get('K') * (s_.inch ? 25.4 : 1.0);  // Motion::feed is mm per revolution
  m.feed_mode = FeedMode::per_rev;
  m.feed_known = true;
  out.motion(m, b);
  if (s_.motion_code10 != 331) return;
  // G33.1 "Rigid Tapping" (rs274 RIGID_TAP): the spindle reverses at the end point and the tool
  // comes back along the same line to where it started, which is the current point afterwards.
  Motion back = m;
  back.start = m.end;
  back.end = m.start;
  back.known = known_before;
  back.programmed = 0;
  s_.position = m.start;
  s_.known = known_before;
  out.motion(back, b);
}

void Interpreter::emit_turning_moves(const Block& b, Span at, const std::vector<turning::Move>& moves, double scale,
                                     MotionSink& out) {
  const PlaneAxes pa = plane_axes(Plane::zx);
  for (const turning::Move& mv : moves) {
    Motion m;
    m.line = b.line;
    m.column = at.begin + 1;
    fill_state(m);
    m.word_index.fill(-1);
    m.start = s_.position;
    s_.position[2] = mv.end.real() * scale;
    s_.position[0] = mv.end.imag() * scale;
    s_.known |= static_cast<AxisMask>(bit(Axis::x) | bit(Axis::z));
    m.end = s_.position;
    m.known = s_.known;
    m.type = turning::motion_type(mv.kind);
    if (m.type == MotionType::arc_cw || m.type == MotionType::arc_ccw) {
      const Eigen::Vector2d c(mv.centre.real() * scale, mv.centre.imag() * scale);
      const Eigen::Vector2d s(m.start[pa.u], m.start[pa.v]), e(m.end[pa.u], m.end[pa.v]);
      const Eigen::Vector2d rs = s - c, re = e - c;
      const bool clockwise = m.type == MotionType::arc_cw;
      double sweep = std::atan2(rs.x() * re.y() - rs.y() * re.x(), rs.dot(re));
      const bool same = (e - s).norm() < 1e-9;
      if (clockwise && sweep >= 0) sweep -= 2 * std::numbers::pi;
      if (!clockwise && sweep <= 0) sweep += 2 * std::numbers::pi;
      if (same) sweep = clockwise ? -2 * std::numbers::pi : 2 * std::numbers::pi;
      m.arc.centre = Eigen::Vector3d(m.end[0], m.end[1], m.end[2]);
      m.arc.centre[pa.u] = c.x();
      m.arc.centre[pa.v] = c.y();
      m.arc.radius = rs.norm();
      m.arc.sweep = sweep;
      m.arc.full_circle = same;
    }
    out.motion(m, b);
  }
}

}  // namespace postproc::gcode
