// Modal interpreter, part 4: Fanuc lathe turning cycles (docs/fanuc-turning-cycles.md).
//
// Multiple repetitive cycles (Series 0i/30i lathe operator's manual B-64484EN-1 / B-64604EN,
// "Multiple repetitive cycle (G70-G76)"): G71/G72 stock removal, G73 pattern repeating, G70
// finishing, G74/G75 peck drilling and grooving. Single cycles ("Canned cycle (G90, G92, G94)"):
// G90 outer diameter and G94 end face cutting (system A; G77/G79 in system B).
//
// G71–G73 name their finished shape by the sequence numbers of its first and last block (P ns,
// Q nf); the shape follows the cycle block in the program. The interpreter streams, so the blocks
// N(ns)…N(nf) are kept as they arrive (not executed: the control reads them as data and continues
// after N(nf)), and the cycle is expanded when N(nf) has been read. Each kept shape serves a later
// G70 P(ns) Q(nf), which executes its blocks and returns to its start point. What a cycle does not
// state (retraction amounts left to parameters, forms of other series) is refused at its word.
#include <cmath>
#include <map>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"
#include "src/gcode/kept_block.hpp"
#include "src/gcode/turning_cycles.hpp"

namespace postproc::gcode {

namespace {

constexpr AxisMask kXZ = static_cast<AxisMask>(bit(Axis::x) | bit(Axis::z));

/// The first address letter (other than G M N and the axes) of `present` that `allowed` lacks, or 0.
char letter_beyond(std::uint32_t present, std::string_view allowed) {
  for (int i = 0; i < 26; ++i)
    if (((present >> i) & 1u) && allowed.find(static_cast<char>('A' + i)) == std::string_view::npos)
      return static_cast<char>('A' + i);
  return 0;
}

/// Forwards the motions of G70's profile blocks as motions of the G70 block.
struct Relabel final : MotionSink {
  MotionSink& out;
  const Block& cycle;
  std::uint32_t column;
  Relabel(MotionSink& o, const Block& c, std::uint32_t col) : out(o), cycle(c), column(col) {}
  void motion(const Motion& m, const Block&) override {
    Motion r = m;
    r.line = cycle.line;
    r.column = column;
    r.word_index.fill(-1);
    r.programmed = 0;
    out.motion(r, cycle);
  }
};

}  // namespace

struct Interpreter::FanucCycles {
  // Modal values of the first blocks (mm; nullopt-like flags where the program has not stated them).
  bool rough_depth_set = false, rough_escape_set = false;
  double rough_depth = 0, rough_escape = 0;            ///< G71 U / G72 W (Δd), R (e): parameters 5132, 5133
  bool pattern_set[3] = {false, false, false};
  double pattern_i = 0, pattern_k = 0;                 ///< G73 U W (Δi Δk): parameters 5135, 5136
  int pattern_d = 0;                                   ///< G73 R (d): parameter 5137
  bool peck_escape_set = false;
  double peck_escape = 0;                              ///< G74/G75 R (e): parameter 5139
  // Single cycles G90/G94 (G77/G79): X Z R stay modal while the cycle repeats.
  bool single_x = false, single_z = false;
  double single_xv = 0, single_zv = 0, single_r = 0;   ///< mm, X as radius
  // The G71/G72/G73 block whose shape is being read.
  bool collecting = false, started = false;
  bool expand = true;                                  ///< false: the cycle was refused, its shape is passed over
  KeptBlock cycle;
  Span cycle_at;
  int code = 0;                                        ///< 71, 72, 73
  long ns = 0, nf = 0;
  double du = 0, dw = 0;                               ///< finishing allowance (mm; du as radius)
  AxisVector start = AxisVector::Zero();
  std::vector<KeptBlock> blocks;
  /// Shapes read so far, by (ns, nf), for G70.
  std::map<std::pair<long, long>, std::vector<KeptBlock>> shapes;
  bool motion_unstated = false;                        ///< after G70–G73: group 01 as the control leaves it
  std::uint64_t unstated_line = 0;
  // The shape as read (mm, X as radius): A', its elements, the ns block's form.
  turning::Point a_prime;
  std::vector<turning::Segment> segs;
  bool first_rapid = true, ns_x = false, ns_z = false;
  std::vector<turning::Move> moves;                    ///< the moves to emit (mm, X as radius)
};

void Interpreter::finish() {
  if (comp_) linuxcnc_comp_finish();
  if (!fanuc_cycles_ || !fanuc_cycles_->collecting) return;
  FanucCycles& fc = *fanuc_cycles_;
  fc.collecting = false;
  const Block& cb = fc.cycle.get();
  report(cb, fc.cycle_at, Severity::error, codes::kFanucCycleAlarm,
         fmt::format("G{}: {} program ends before the block N{} (Q, the last block of the shape); the control "
                     "stops with an alarm (sequence number not found)",
                     fc.code, fc.started ? "the" : fmt::format("N{} does not follow the cycle and the", fc.ns), fc.nf));
}

bool Interpreter::fanuc_profile_line(const Block& b, MotionSink& out) {
  FanucCycles& fc = *fanuc_cycles_;
  if (!fc.collecting) return false;
  const long n = b.has_n ? std::lround(b.n_number) : -1;
  if (!fc.started) {
    if (!b.has_n && b.words.empty()) return false;  // a comment between the cycle and its shape
    if (n != fc.ns) {
      fc.collecting = false;
      const Block& cb = fc.cycle.get();
      report(cb, fc.cycle_at, Severity::warning, codes::kFanucCycleUnresolved,
             fmt::format("G{}: the block N{} (P, first block of the shape) does not follow the cycle block; the "
                         "control searches the program for it and continues after N{}: not followed — put the "
                         "shape N{}…N{} right after the cycle",
                         fc.code, fc.ns, fc.nf, fc.ns, fc.nf));
      s_.known &= static_cast<AxisMask>(~kXZ);
      return false;
    }
    fc.started = true;
  }
  fc.blocks.emplace_back();
  fc.blocks.back().keep(b);
  if (n != fc.nf) return true;
  fc.collecting = false;
  fc.shapes[{fc.ns, fc.nf}] = fc.blocks;
  if (!fc.expand) return true;  // refused at the cycle block (reported there)
  // Expand now, as motions of the cycle's line (the control runs the cycle, then reads on after N(nf)).
  fanuc_shape_cycle(fc.cycle.get(), out);
  return true;
}


bool Interpreter::fanuc_cycle(const Block& b, BlockWords& w, MotionSink& out, GMeaning prev_motion,
                              std::uint16_t prev_code10) {
  if (!fanuc_cycles_) fanuc_cycles_ = std::make_shared<FanucCycles>();
  FanucCycles& fc = *fanuc_cycles_;
  const bool cycle_g = w.motion.def != nullptr && w.motion.def->meaning == GMeaning::turning_cycle;
  if (w.motion.def != nullptr && !(cycle_g && w.motion.def->code10 >= 700 && w.motion.def->code10 <= 750))
    fc.motion_unstated = false;  // a code of group 01 (G70–G75 are one-shot)
  if (!cycle_g) {
    // Another code of group 01 ends a single cycle and its modal X Z R (B-64484EN "Canned cycle").
    if (w.motion.def != nullptr) fc.single_x = fc.single_z = false, fc.single_r = 0;
    if (w.motion.def != nullptr || w.axis_present == 0) return false;
    const int c = s_.motion_code10;
    if (s_.motion == GMeaning::turning_cycle && (c == 900 || c == 940 || c == 770 || c == 790)) {
      fanuc_single(b, w, c / 10, out);  // a block of axis words repeats the single cycle
      return true;
    }
    if (fc.motion_unstated) {
      int first = -1;  // the block's first axis word
      for (int a = 0; a < kAxisCount; ++a) {
        const int wi = w.axis_word[static_cast<std::size_t>(a)];
        if (wi >= 0 && (first < 0 || wi < first)) first = wi;
      }
      const Span at = b.words[static_cast<std::size_t>(first < 0 ? 0 : first)].span;
      report(b, at, Severity::warning, codes::kFanucCycleModal,
             fmt::format("axis words without G00/G01/G02/G03 after the cycle at line {}: the operator's manual does "
                         "not state which mode of group 01 the control is in after G70–G73; write the G code in "
                         "this block",
                         fc.unstated_line));
      s_.known &= static_cast<AxisMask>(~w.axis_present);
      return true;
    }
    return false;
  }
  const int code = w.motion.def->code10 / 10;
  const Span at = b.words[static_cast<std::size_t>(w.motion.word)].span;
  if (w.motion.def->code10 % 10 != 0) return false;
  if (code == 90 || code == 94 || code == 77 || code == 79) {
    if (w.axis_present == 0) return false;  // refused as before (G90 without X/Z: see do_motion)
    if (prev_code10 != w.motion.def->code10 || prev_motion != GMeaning::turning_cycle)
      fc.single_x = fc.single_z = false, fc.single_r = 0;
    fanuc_single(b, w, code, out);
    return true;
  }
  // G70–G75 are one-shot codes (group 00): the motion mode before them stays.
  s_.motion = prev_motion;
  s_.motion_code10 = prev_code10;
  if (fanuc_replay_) {
    report(b, at, Severity::warning, codes::kFanucCycleUnresolved,
           fmt::format("'{}' inside the shape run by G70 is not followed", b.text(at)));
    s_.known &= static_cast<AxisMask>(~kXZ);
    return true;
  }
  fanuc_cycle_words(b, w, code, out);
  return true;
}

void Interpreter::fanuc_cycle_words(const Block& b, const BlockWords& w, int code, MotionSink& out) {
  FanucCycles& fc = *fanuc_cycles_;
  const Span at = b.words[static_cast<std::size_t>(w.motion.word)].span;
  const std::string name(b.text(at));
  const bool system_a = d_.gcode_system == 'A';
  const auto refuse = [&](bool alarm, std::string msg) {
    report(b, at, alarm ? Severity::error : Severity::warning,
           alarm ? codes::kFanucCycleAlarm : codes::kFanucCycleUnresolved, std::move(msg));
    s_.known &= static_cast<AxisMask>(~kXZ);
  };
  // U and W: incremental X Z in system A (collect() gives them as axes 0 and 2, incremental), the
  // U and W axes in system B; in the cycle words they are values (depths, allowances), as written.
  const auto uw = [&](char L, double& v) {
    const int a = system_a ? (L == 'U' ? 0 : 2) : (L == 'U' ? 6 : 8);
    const AxisMask m = static_cast<AxisMask>(1u << a);
    if (!(w.axis_present & m) || (system_a && !(w.axis_incremental & m))) return false;
    v = to_mm(a, w.axis[a]);
    return true;
  };
  const AxisMask u_bit = system_a ? bit(Axis::x) : bit(Axis::u), w_bit = system_a ? bit(Axis::z) : bit(Axis::w);
  const bool has_u = (w.axis_present & u_bit) && (!system_a || (w.axis_incremental & u_bit));
  const bool has_w = (w.axis_present & w_bit) && (!system_a || (w.axis_incremental & w_bit));
  const bool has_x = (w.axis_present & bit(Axis::x)) && !(w.axis_incremental & bit(Axis::x));
  const bool has_z = (w.axis_present & bit(Axis::z)) && !(w.axis_incremental & bit(Axis::z));
  for (char L : {'P', 'Q', 'R', 'D', 'F'})
    if (w.has(L) && w.unresolved(L)) return refuse(false, fmt::format("{}: the value of {} is not known; not followed", name, L));
  if (w.axis_unresolved != 0) return refuse(false, fmt::format("{}: an axis word's value is not known; not followed", name));
  // Address words outside the cycle's format (B-64484EN formats of G70–G75) are not guessed at.
  const bool with_pq = w.has('P') || w.has('Q');
  const std::string_view allowed = code == 70                    ? "PQST"
                                   : code == 74 || code == 75     ? (with_pq || w.axis_present != 0 ? "PQRFST" : "RFST")
                                   : with_pq                      ? "PQDFST"
                                                                  : "RFST";
  const bool shape_cycle = code >= 71 && code <= 73 && with_pq;  // checked below, passing over the shape
  if (const char L = letter_beyond(w.letter_present, allowed); L != 0 && !shape_cycle)
    return refuse(false, fmt::format("{}: the address {} is not part of the cycle's format; not followed", name, L));
  if (code == 70) return fanuc_g70(b, w, out);
  if (code == 74 || code == 75) return fanuc_peck(b, w, code, out);
  // G71 / G72 / G73.
  const bool cycle_block = w.has('P') || w.has('Q');
  if (!cycle_block) {
    // First block: G71 U(Δd) R(e); G72 W(Δd) R(e); G73 U(Δi) W(Δk) R(d). The values are modal
    // (and replace parameters 5132/5133, 5135–5137).
    const AxisMask allowed_axes = code == 71 ? u_bit : code == 72 ? w_bit : static_cast<AxisMask>(u_bit | w_bit);
    if ((w.axis_present & ~allowed_axes) != 0 || (code == 71 && has_w) || (code == 72 && has_u) || has_x || has_z)
      return refuse(false, fmt::format("{}: axis words other than {} in the first block of the cycle are not part of "
                                       "its format; not followed",
                                       name, code == 71 ? "U" : code == 72 ? "W" : "U and W"));
    double v = 0;
    if (code != 73) {
      if (uw(code == 71 ? 'U' : 'W', v)) {
        if (!(v > 0))
          return refuse(v == 0, fmt::format("{}: the depth of cut {} must be positive (given without sign)", name,
                                            code == 71 ? 'U' : 'W'));
        fc.rough_depth = v;
        fc.rough_depth_set = true;
      }
      if (w.has('R')) {
        const double e = w.get('R') * (s_.inch ? 25.4 : 1.0);
        if (e < 0) return refuse(false, fmt::format("{}: a negative escaping amount R is not followed", name));
        fc.rough_escape = e;
        fc.rough_escape_set = true;
      }
    } else {
      if (uw('U', v)) fc.pattern_i = v, fc.pattern_set[0] = true;
      if (uw('W', v)) fc.pattern_k = v, fc.pattern_set[1] = true;
      if (w.has('R')) {
        // d is a number of divisions, not a length: the number as written.
        const Word& rw = b.words[static_cast<std::size_t>(w.letter_word['R' - 'A'])];
        const double d = rw.number;
        if (!(d >= 1 && d <= 100000 && d == std::floor(d)))
          return refuse(true, fmt::format("{}: R (number of divisions) must be a whole number of at least 1", name));
        fc.pattern_d = static_cast<int>(d);
        fc.pattern_set[2] = true;
      }
    }
    return;
  }
  // Cycle block: G7x P(ns) Q(nf) U(Δu) W(Δw) F S T.
  const long ns = w.whole_or('P', 0, 99999999, -1), nf = w.whole_or('Q', 0, 99999999, -1);
  if (ns < 0 || nf < 0)
    return refuse(true, fmt::format("{} needs P and Q, the sequence numbers of the first and last block of the shape "
                                    "(the control stops with an alarm)",
                                    name));
  // The shape N(ns)…N(nf) that follows is the cycle's data, never executed by it: it is kept (for
  // G70) and passed over also when the cycle itself is refused (`expand` false).
  const auto begin = [&](bool expand) {
    fc.code = code;
    fc.ns = ns;
    fc.nf = nf;
    fc.start = s_.position;
    fc.cycle.keep(b);
    fc.cycle_at = at;
    fc.blocks.clear();
    fc.collecting = true;
    fc.started = false;
    fc.expand = expand;
    fc.motion_unstated = true;
    fc.unstated_line = b.line;
  };
  const auto refuse_cycle = [&](std::string msg) {
    refuse(false, std::move(msg));
    begin(false);
  };
  if (const char L = letter_beyond(w.letter_present, "PQDFST"); L != 0)
    return refuse_cycle(fmt::format("{}: the address {} is not part of the cycle's format; not followed", name, L));
  if (w.has('D'))
    return refuse_cycle(fmt::format("{} with D: the one-block format of Series 10/11 (parameter 0001#1 FCV = 1), "
                                    "whose depth D and retraction (parameter 5133) this version does not read; "
                                    "write the two-block format {} …; {} P Q U W F",
                                    name, name, name));
  if (has_x || has_z || (w.axis_present & ~static_cast<AxisMask>(u_bit | w_bit)) != 0)
    return refuse_cycle(fmt::format("{}: X or Z in the cycle block is not part of its format; not followed", name));
  if (code != 73 && !(fc.rough_depth_set && fc.rough_escape_set))
    return refuse_cycle(fmt::format("{}: the {} is not stated in the program (first block {} {}… R…); it is "
                                    "parameter {} of the control, which this version does not know",
                                    name, !fc.rough_depth_set ? "depth of cut" : "escaping amount", name,
                                    code == 71 ? "U" : "W", !fc.rough_depth_set ? "5132" : "5133"));
  if (code == 73 && !(fc.pattern_set[0] && fc.pattern_set[1] && fc.pattern_set[2]))
    return refuse_cycle(fmt::format("{}: the relief {} is not stated in the program (first block G73 U… W… R…); it "
                                    "is parameter {} of the control, which this version does not know",
                                    name, !fc.pattern_set[0] ? "in X" : !fc.pattern_set[1] ? "in Z" : "count",
                                    !fc.pattern_set[0] ? "5135" : !fc.pattern_set[1] ? "5136" : "5137"));
  if (const char* mode = cycle_blocking_mode())
    return refuse_cycle(fmt::format("{} under {} is not followed; cancel it before the cycle", name, mode));
  if ((s_.known & kXZ) != kXZ) {
    report(b, at, Severity::warning, codes::kUnknownPosition,
           fmt::format("{} starts from the current point, which is unknown here; position X and Z before it", name));
    s_.known &= static_cast<AxisMask>(~kXZ);
    begin(false);
    return;
  }
  double v = 0;
  fc.du = uw('U', v) ? (s_.diameter_mode ? v / 2 : v) : 0.0;
  fc.dw = uw('W', v) ? v : 0.0;
  begin(true);
}

bool Interpreter::fanuc_shape(const Block& cb) {
  FanucCycles& fc = *fanuc_cycles_;
  const std::string name = fmt::format("G{}", fc.code == 0 ? 70 : fc.code);
  fc.segs.clear();
  const double xdiv = s_.diameter_mode ? 2.0 : 1.0;
  const bool system_a = d_.gcode_system == 'A';
  turning::Point prev(fc.start[2], fc.start[0]);
  int mode = -1;
  const auto refuse = [&](const Block& pb, Span sp, bool alarm, std::string msg) {
    report(pb, sp, alarm ? Severity::error : Severity::warning,
           alarm ? codes::kFanucCycleAlarm : codes::kFanucCycleUnresolved,
           fmt::format("{} (shape of the {} at line {}){}", msg, name, cb.line,
                       alarm ? "" : "; the cycle is not followed"));
    return false;
  };
  for (std::size_t i = 0; i < fc.blocks.size(); ++i) {
    const Block& pb = fc.blocks[i].get();
    const Span whole{0, static_cast<std::uint32_t>(pb.raw.size())};
    BlockWords pw;
    if (!collect(pb, pw)) return refuse(pb, whole, false, "this block of the shape is refused");
    int code10 = -1;
    for (int k = 0; k < pw.ng; ++k) {
      const auto& g = pw.g[static_cast<std::size_t>(k)];
      const Span gs = pb.words[static_cast<std::size_t>(g.word)].span;
      switch (g.def->meaning) {
        case GMeaning::rapid: case GMeaning::linear: case GMeaning::arc_cw: case GMeaning::arc_ccw:
          code10 = g.def->code10;
          break;
        case GMeaning::css_on: case GMeaning::css_off: case GMeaning::feed_per_minute: case GMeaning::feed_per_rev:
        case GMeaning::exact_stop: case GMeaning::path_control:
          break;  // ignored while roughing, effective in G70
        default:
          return refuse(pb, gs, false, fmt::format("'{}' in the shape of a turning cycle is not followed", pb.text(gs)));
      }
    }
    if (i == 0) {
      // B-64484EN, G71/G72/G73: the first block of the shape gives A→A' with G00 or G01 (alarm otherwise).
      if (code10 != 0 && code10 != 10)
        return refuse(pb, whole, true,
                      fmt::format("the first block of the shape (N{}) must hold G00 or G01; the control stops with an "
                                  "alarm",
                                  fc.ns));
      fc.first_rapid = code10 == 0;
    }
    if (code10 >= 0) mode = code10 / 10;
    for (int k = 0; k < pw.m_count; ++k) {
      const double m = pw.m[static_cast<std::size_t>(k)];
      if (m == 98 || m == 99 || m == 30 || m == 2 || m == 198)
        return refuse(pb, pb.words[static_cast<std::size_t>(pw.m_word[static_cast<std::size_t>(k)])].span, false,
                      "a program end or subprogram call inside the shape of a turning cycle is not followed");
    }
    constexpr std::uint32_t kAllowed = (1u << ('F' - 'A')) | (1u << ('S' - 'A')) | (1u << ('T' - 'A')) |
                                       (1u << ('I' - 'A')) | (1u << ('K' - 'A')) | (1u << ('R' - 'A'));
    if ((pw.letter_present & ~kAllowed) != 0 || pw.has_cr || pw.polar || pw.polar_words != 0 || pw.corner_word >= 0)
      return refuse(pb, whole, false, "a word other than G X Z U W I K R F S T M in the shape of a turning cycle");
    const AxisMask xz_axes = kXZ;
    if ((pw.axis_present & ~xz_axes) != 0 || (pw.axis_unresolved | pw.letter_unresolved) != 0)
      return refuse(pb, whole, false,
                    (pw.axis_present & ~xz_axes) != 0
                        ? (system_a ? "an axis other than X Z U W in the shape of a turning cycle"
                                    : "an axis other than X Z (U W move their own axes in system B) in the shape")
                        : "a value that is not known in the shape of a turning cycle");
    turning::Point p = prev;
    for (int a : {0, 2}) {
      const AxisMask m = static_cast<AxisMask>(1u << a);
      if (!(pw.axis_present & m)) continue;
      double v = to_mm(a, pw.axis[a]);
      if (a == 0) v /= xdiv;
      const bool inc = (pw.axis_incremental & m) || !s_.absolute;
      if (a == 0) p.imag(inc ? prev.imag() + v : v);
      else p.real(inc ? prev.real() + v : v);
    }
    if (i == 0) {
      fc.ns_x = pw.axis_present & bit(Axis::x);
      fc.ns_z = pw.axis_present & bit(Axis::z);
      fc.a_prime = p;
      prev = p;
      continue;
    }
    if (std::abs(p - prev) < 1e-9) continue;
    if (mode < 0) mode = fc.first_rapid ? 0 : 1;
    turning::Segment sg;
    sg.a = prev;
    sg.b = p;
    if (mode >= 2) {
      sg.arc = true;
      sg.ccw = mode == 3;  // G18 on the lathe: G03 turns from +Z towards +X
      const double scale = s_.inch ? 25.4 : 1.0;
      if (pw.has('R')) {
        const double r = pw.get('R') * scale;
        const double chord2 = std::norm(p - prev);
        if (!(r > 0))
          return refuse(pb, whole, false, "an arc of the shape given by a negative or zero R");
        if (r * r < chord2 / 4 * (1 - 1e-9))
          return refuse(pb, whole, true, "an arc of the shape whose radius R is smaller than half its chord");
        const turning::Point d =
            turning::Point(0, 1) * std::sqrt(std::max(0.0, (r * r - chord2 / 4) / chord2)) * (p - prev);
        sg.c = (prev + p) / 2.0 + (sg.ccw ? d : -d);
      } else if (pw.has('I') || pw.has('K')) {
        sg.c = prev + turning::Point(pw.has('K') ? pw.get('K') * scale : 0.0, pw.has('I') ? pw.get('I') * scale : 0.0);
        const double r1 = std::abs(sg.a - sg.c), r2 = std::abs(sg.b - sg.c);
        if (std::abs(r1 - r2) > opt_.arc_radius_tolerance_mm && std::abs(r1 - r2) > 1e-3 * std::max(r1, r2))
          return refuse(pb, whole, true,
                        fmt::format("an arc of the shape with radius {:.4f} at its start and {:.4f} at its end", r1, r2));
      } else {
        return refuse(pb, whole, true, "an arc of the shape without R or I/K");
      }
    }
    fc.segs.push_back(sg);
    prev = p;
  }
  return true;
}

void Interpreter::fanuc_shape_cycle(const Block& cb, MotionSink& out) {
  FanucCycles& fc = *fanuc_cycles_;
  const std::string name = fmt::format("G{}", fc.code);
  const auto refuse = [&](bool alarm, std::string msg) {
    report(cb, fc.cycle_at, alarm ? Severity::error : Severity::warning,
           alarm ? codes::kFanucCycleAlarm : codes::kFanucCycleUnresolved, std::move(msg));
    s_.known &= static_cast<AxisMask>(~kXZ);
  };
  if (!fanuc_shape(cb)) {
    s_.known &= static_cast<AxisMask>(~kXZ);
    return;
  }
  const turning::Point a(fc.start[2], fc.start[0]);
  fc.moves.clear();
  std::string failure;
  if (fc.code == 73) {
    failure = turning::expand_fanuc_pattern(a, turning::Point(fc.pattern_k, fc.pattern_i),
                                            turning::Point(fc.dw, fc.du), fc.pattern_d, fc.first_rapid,
                                            [&] {
                                              std::vector<turning::Segment> segs = fc.segs;
                                              if (!segs.empty()) segs.front().a = fc.a_prime;
                                              return segs;
                                            }(),
                                            fc.moves);
    if (fc.segs.empty()) failure = "the shape has no move after its first block";
  } else {
    // Type I gives only the infeed axis in the first block; type II (0i-F: X and Z there) cuts pockets.
    const bool type2 = fc.code == 71 ? fc.ns_z : fc.ns_x;
    if (type2)
      return refuse(false, fmt::format("{}: the first block of the shape (N{}) gives both X and Z, which selects type "
                                       "II (pockets); type II is not expanded by this version",
                                       name, fc.ns));
    turning::FanucRough r;
    r.facing = fc.code == 72;
    r.start = a;
    r.depth = fc.rough_depth;
    r.escape = fc.rough_escape;
    r.allowance = turning::Point(fc.dw, fc.du);
    r.infeed_rapid = fc.first_rapid;
    r.final_cut = d_.fanuc_rough_final_cut;
    std::vector<turning::Segment> segs = fc.segs;
    if (!segs.empty()) segs.front().a = fc.a_prime;
    failure = turning::expand_fanuc_rough(r, segs, fc.moves);
  }
  if (!failure.empty()) {
    const bool alarm = failure.rfind("alarm: ", 0) == 0;
    return refuse(alarm, fmt::format("{}: {}{}", name, alarm ? failure.substr(7) : failure,
                                     alarm ? " (the control stops with an alarm)" : "; not followed"));
  }
  fanuc_emit(cb, fc.cycle_at, out);
}

void Interpreter::fanuc_g70(const Block& b, const BlockWords& w, MotionSink& out) {
  FanucCycles& fc = *fanuc_cycles_;
  const Span at = b.words[static_cast<std::size_t>(w.motion.word)].span;
  const long ns = w.whole_or('P', 0, 99999999, -1), nf = w.whole_or('Q', 0, 99999999, -1);
  if (ns < 0 || nf < 0) {
    report(b, at, Severity::error, codes::kFanucCycleAlarm,
           "G70 needs P and Q, the sequence numbers of the first and last block of the shape (the control stops "
           "with an alarm)");
    s_.known &= static_cast<AxisMask>(~kXZ);
    return;
  }
  const auto it = fc.shapes.find({ns, nf});
  if (it == fc.shapes.end()) {
    report(b, at, Severity::warning, codes::kFanucCycleUnresolved,
           fmt::format("G70 P{} Q{}: no G71/G72/G73 before it in this program read the shape N{}…N{}; the control "
                       "searches the program for it: not followed",
                       ns, nf, ns, nf));
    s_.known &= static_cast<AxisMask>(~kXZ);
    return;
  }
  if ((s_.known & kXZ) != kXZ) {
    report(b, at, Severity::warning, codes::kUnknownPosition,
           "G70 returns to its start point, which is unknown here; position X and Z before it");
    s_.known &= static_cast<AxisMask>(~kXZ);
    return;
  }
  // B-64484EN "Finishing cycle (G70)": the blocks ns…nf run as programmed (their F S T apply), then
  // the tool returns to the start point at rapid traverse.
  const AxisVector start = s_.position;
  std::vector<KeptBlock> blocks = it->second;
  Relabel relabel(out, b, at.begin + 1);
  fanuc_replay_ = true;
  fc.motion_unstated = false;
  for (KeptBlock& k : blocks) execute(k.get(), relabel);
  fanuc_replay_ = false;
  fc.motion_unstated = true;
  fc.unstated_line = b.line;
  if ((s_.known & kXZ) != kXZ) {
    s_.known &= static_cast<AxisMask>(~kXZ);  // a block of the shape was refused (reported there)
    return;
  }
  fc.moves.clear();
  fc.moves.push_back({turning::Move::Kind::rapid, turning::Point(start[2], start[0]), {}});
  fanuc_emit(b, at, out);
}

void Interpreter::fanuc_single(const Block& b, const BlockWords& w, int code, MotionSink& out) {
  FanucCycles& fc = *fanuc_cycles_;
  const bool facing = code == 94 || code == 79;
  const Span at = w.motion.word >= 0 ? b.words[static_cast<std::size_t>(w.motion.word)].span
                                     : b.words[static_cast<std::size_t>(w.axis_word[0] >= 0 ? w.axis_word[0]
                                                                        : w.axis_word[2] >= 0 ? w.axis_word[2]
                                                                                              : 0)]
                                           .span;
  const std::string name = fmt::format("G{}", code);
  const auto refuse = [&](std::string msg) {
    report(b, at, Severity::warning, codes::kFanucCycleUnresolved, std::move(msg));
    s_.known &= static_cast<AxisMask>(~kXZ);
  };
  if (const char L = letter_beyond(w.letter_present, "RFST"); L != 0)
    return refuse(fmt::format("{}: the address {} is not part of the cycle's format (X(U) Z(W) R F); not followed", name, L));
  if ((w.axis_present & ~kXZ) != 0 || w.axis_unresolved != 0 || (w.has('R') && w.unresolved('R')))
    return refuse(fmt::format("{}: {}; not followed", name,
                              (w.axis_present & ~kXZ) != 0 ? "an axis other than X Z (U W) in the cycle"
                                                           : "a value that is not known"));
  if (const char* mode = cycle_blocking_mode())
    return refuse(fmt::format("{} under {} is not followed; cancel it before the cycle", name, mode));
  if ((s_.known & kXZ) != kXZ) {
    report(b, at, Severity::warning, codes::kUnknownPosition,
           fmt::format("{} starts from the current point, which is unknown here; position X and Z before it", name));
    s_.known &= static_cast<AxisMask>(~kXZ);
    return;
  }
  const double xa = s_.position[0], za = s_.position[2];
  const double xdiv = s_.diameter_mode ? 2.0 : 1.0;
  for (int a : {0, 2}) {
    const AxisMask m = static_cast<AxisMask>(1u << a);
    if (!(w.axis_present & m)) continue;
    double v = to_mm(a, w.axis[a]);
    if (a == 0) v /= xdiv;
    const bool inc = (w.axis_incremental & m) || !s_.absolute;
    if (a == 0) fc.single_xv = inc ? xa + v : v, fc.single_x = true;
    else fc.single_zv = inc ? za + v : v, fc.single_z = true;
  }
  if (w.has('R')) fc.single_r = w.get('R') * (s_.inch ? 25.4 : 1.0);
  if (!fc.single_x || !fc.single_z)
    return refuse(fmt::format("{}: the cycle's {} is not given (in this block or an earlier block of the same cycle); "
                              "not followed",
                              name, fc.single_x ? "Z (W)" : "X (U)"));
  // B-64484EN "Outer diameter / internal diameter cutting cycle (G90)" and "End face turning cycle
  // (G94)": (1) rapid along the infeed axis to the cut's start (X + R, resp. Z + R, for a taper),
  // (2) cut to X Z, (3) cut back along the other axis to the start's level, (4) rapid to the start.
  const double x = fc.single_xv, z = fc.single_zv, r = fc.single_r;
  fc.moves.clear();
  using K = turning::Move::Kind;
  if (!facing) {
    fc.moves.push_back({K::rapid, turning::Point(za, x + r), {}});
    fc.moves.push_back({K::line, turning::Point(z, x), {}});
    fc.moves.push_back({K::line, turning::Point(z, xa), {}});
  } else {
    fc.moves.push_back({K::rapid, turning::Point(z + r, xa), {}});
    fc.moves.push_back({K::line, turning::Point(z, x), {}});
    fc.moves.push_back({K::line, turning::Point(za, x), {}});
  }
  fc.moves.push_back({K::rapid, turning::Point(za, xa), {}});
  fanuc_emit(b, at, out);
}

void Interpreter::fanuc_peck(const Block& b, const BlockWords& w, int code, MotionSink& out) {
  FanucCycles& fc = *fanuc_cycles_;
  const Span at = b.words[static_cast<std::size_t>(w.motion.word)].span;
  const std::string name = fmt::format("G{}", code);
  const bool system_a = d_.gcode_system == 'A';
  const auto refuse = [&](bool alarm, std::string msg) {
    report(b, at, alarm ? Severity::error : Severity::warning,
           alarm ? codes::kFanucCycleAlarm : codes::kFanucCycleUnresolved, std::move(msg));
    s_.known &= static_cast<AxisMask>(~kXZ);
  };
  if ((w.axis_present & ~kXZ) != 0)
    return refuse(false, fmt::format("{}: an axis other than X Z{} in the cycle; not followed", name,
                                     system_a ? " U W" : " (U W are axes of their own in system B)"));
  const bool cycle_block = w.axis_present != 0 || w.has('P') || w.has('Q');
  if (!cycle_block) {
    // First block G74 R(e) / G75 R(e): the return amount of each peck (modal; parameter 5139).
    if (w.has('R')) {
      const double e = w.get('R') * (s_.inch ? 25.4 : 1.0);
      if (e < 0) return refuse(false, fmt::format("{}: a negative return amount R is not followed", name));
      fc.peck_escape = e;
      fc.peck_escape_set = true;
    }
    return;
  }
  if (!fc.peck_escape_set)
    return refuse(false, fmt::format("{}: the return amount e is not stated in the program (first block {} R…); it is "
                                     "parameter 5139 of the control, which this version does not know",
                                     name, name));
  if (s_.plane != Plane::zx || s_.cutter_comp != 0 || s_.mirror != 0 || s_.scaling || s_.polar_coords)
    return refuse(false, fmt::format("{} under {} is not followed; cancel it before the cycle", name,
                                     s_.plane != Plane::zx ? "a plane other than G18"
                                     : s_.cutter_comp != 0 ? "tool-nose radius compensation (G41/G42)"
                                                           : "mirror image, scaling or polar coordinates"));
  if ((s_.known & kXZ) != kXZ) {
    report(b, at, Severity::warning, codes::kUnknownPosition,
           fmt::format("{} starts from the current point, which is unknown here; position X and Z before it", name));
    s_.known &= static_cast<AxisMask>(~kXZ);
    return;
  }
  // P (Δi, along X) and Q (Δk, along Z) are given without a decimal point in the least input
  // increment (B-64484EN, G74/G75), without sign; Δi is a radius value.
  double pq[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    const char L = k == 0 ? 'P' : 'Q';
    if (!w.has(L)) continue;
    const Word& wd = b.words[static_cast<std::size_t>(w.letter_word[L - 'A'])];
    if (!wd.whole)
      return refuse(true, fmt::format("{}: {} is given in the least input increment, without a decimal point ('{}'); "
                                      "the control stops with an alarm",
                                      name, L, b.text(wd.span)));
    if (wd.number < 0)
      return refuse(false, fmt::format("{}: a negative {} is not followed (given without sign)", name, L));
    pq[k] = wd.number * (s_.inch ? 0.0001 * 25.4 : 0.001);
  }
  const double xdiv = s_.diameter_mode ? 2.0 : 1.0;
  turning::Point a(s_.position[2], s_.position[0]), e = a;
  for (int ax : {0, 2}) {
    const AxisMask m = static_cast<AxisMask>(1u << ax);
    if (!(w.axis_present & m)) continue;
    double v = to_mm(ax, w.axis[ax]);
    if (ax == 0) v /= xdiv;
    const bool inc = (w.axis_incremental & m) || !s_.absolute;
    if (ax == 0) e.imag(inc ? a.imag() + v : v);
    else e.real(inc ? a.real() + v : v);
  }
  const double relief = w.has('R') ? w.get('R') * (s_.inch ? 25.4 : 1.0) : 0.0;
  // Work in (peck axis, shift axis): G74 pecks along Z and steps along X, G75 the other way round.
  const bool g75 = code == 75;
  const auto pk = [&](turning::Point p) { return g75 ? p.imag() : p.real(); };
  const auto sh = [&](turning::Point p) { return g75 ? p.real() : p.imag(); };
  const auto pt = [&](double peck, double shift) {
    return g75 ? turning::Point(shift, peck) : turning::Point(peck, shift);
  };
  const double dpeck = g75 ? pq[0] : pq[1], dshift = g75 ? pq[1] : pq[0];
  const double p0 = pk(a), pe = pk(e), s0 = sh(a), se = sh(e);
  const double dp = pe > p0 ? 1.0 : -1.0, ds = se > s0 ? 1.0 : se < s0 ? -1.0 : 0.0;
  if (std::abs(pe - p0) < 1e-9)
    return refuse(false, fmt::format("{}: the cycle's end point does not lie away from the start along {}; not "
                                     "followed",
                                     name, g75 ? "X" : "Z"));
  if (!(dpeck > 0))
    return refuse(false, fmt::format("{}: the depth of each peck ({}) is not given; not followed", name, g75 ? "P" : "Q"));
  if (ds != 0 && !(dshift > 0))
    return refuse(false, fmt::format("{}: the cycle moves along {} but the step ({}) is not given; not followed", name,
                                     g75 ? "Z" : "X", g75 ? "Q" : "P"));
  // The relief at the bottom of each cut points back against the steps; without steps R's sign says.
  const double rel = ds != 0 ? -ds * std::abs(relief) : relief;
  const double esc = fc.peck_escape;
  fc.moves.clear();
  using K = turning::Move::Kind;
  long guard = 0;
  for (double s = s0;; s += ds * dshift) {
    const bool last_col = ds == 0 || (se - s) * ds <= 1e-9;
    if (last_col) s = se;
    if (s != s0) fc.moves.push_back({K::rapid, pt(p0, s), {}});
    for (double depth = p0 + dp * dpeck;; depth += dp * dpeck) {
      if (++guard > 1000000) return refuse(false, fmt::format("{}: more than a million pecks; not followed", name));
      const bool bottom = (pe - depth) * dp <= 1e-9;
      if (bottom) depth = pe;
      fc.moves.push_back({K::line, pt(depth, s), {}});
      if (bottom) break;
      if (esc > 0) fc.moves.push_back({K::rapid, pt(depth - dp * esc, s), {}});
    }
    if (rel != 0) fc.moves.push_back({K::rapid, pt(pe, s + rel), {}});
    fc.moves.push_back({K::rapid, pt(p0, s + rel), {}});
    if (last_col) break;
  }
  if (std::abs(fc.moves.back().end - a) > 1e-9) fc.moves.push_back({K::rapid, a, {}});
  fanuc_emit(b, at, out);
}

void Interpreter::fanuc_emit(const Block& b, Span at, MotionSink& out) {
  emit_turning_moves(b, at, fanuc_cycles_->moves, 1.0, out);  // Fanuc cycle moves are in mm already
}

const char* Interpreter::cycle_blocking_mode() const {
  if (s_.plane != Plane::zx) return "a plane other than G18";
  if (s_.cutter_comp != 0) return "tool-nose radius compensation (G41/G42)";
  if (s_.mirror != 0 || s_.scaling || s_.polar_coords) return "mirror image, scaling or polar coordinates";
  return nullptr;
}

}  // namespace postproc::gcode
