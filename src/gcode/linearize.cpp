// convert --linearize. Points are computed in mm from the interpreter's arc, printed in program
// units as exact decimal counts, so that increments add up exactly and the last point is the
// source's own end point text.
#include "src/gcode/linearize.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "postproc/gcode/lexer.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode {
namespace {
using text::upper;

constexpr std::uint64_t kMaxSegments = 1'000'000;



/// Span of the word at 1-based `column` (the motion's G or first axis word), for diagnostics.
Span word_at(const Block& b, std::uint32_t column) {
  for (const Word& w : b.words)
    if (w.span.begin + 1 == column) return w.span;
  return {column - 1, column};
}

}  // namespace

double rounding_mm(int decimals, bool inch) {
  return std::sqrt(2.0) * 0.5 * std::pow(10.0, -decimals) * (inch ? 25.4 : 1.0);
}

std::optional<std::uint64_t> arc_segments(double radius_mm, double sweep_rad, double tol_mm, double rounding) {
  const double allowed = tol_mm - rounding;
  if (!(allowed > 0)) return std::nullopt;
  // A chord of angle φ on radius r lies r·(1 − cos φ/2) inside the arc at its middle.
  double step = std::numbers::pi;
  if (allowed < radius_mm) step = std::min(step, 2 * std::acos(1 - allowed / radius_mm));
  const double n = std::ceil(std::abs(sweep_rad) / step);
  if (!(n < 1e15)) return kMaxSegments + 1;
  return std::max<std::uint64_t>(1, static_cast<std::uint64_t>(n));
}

AxisVector arc_point(const Motion& m, double t) {
  const PlaneAxes p = plane_axes(m.plane);
  AxisVector q = m.start + t * (m.end - m.start);
  const double cu = m.arc.centre[p.u], cv = m.arc.centre[p.v];
  const double su = m.start[p.u] - cu, sv = m.start[p.v] - cv;
  const double eu = m.end[p.u] - cu, ev = m.end[p.v] - cv;
  const double r0 = std::hypot(su, sv), r1 = std::hypot(eu, ev);
  const double angle = std::atan2(sv, su) + t * m.arc.sweep;
  const double r = r0 + t * (r1 - r0);
  q[p.u] = cu + r * std::cos(angle);
  q[p.v] = cv + r * std::sin(angle);
  return q;
}

Linearizer::Linearizer(const Dialect& d, double tol_mm, std::string_view file, DiagnosticSink& sink,
                       ConvertResult& result)
    : d_(d), tol_(tol_mm), file_(file), sink_(sink), r_(result), track_(d) {}

void Linearizer::refuse(const Block& b, Span at, const std::string& why) {
  report_at(LexContext{file_, &sink_}, b, at, Severity::error, codes::kLinearizeRefused,
            fmt::format("--linearize refused: {}", why));
}

void Linearizer::block(const Block& b, std::span<const Motion> motions, const BlockDiags& diags, BlockEditor& ed,
                       std::vector<std::string>& after) {
  if (b.leader) return;
  track_.update(b);
  note_styles(b);  // first, so the precision of this block's own words counts
  // Every G2/G3 becomes G1, so wherever the source relied on a modal arc the output's mode is G1.
  for (const auto& g : track_.block_g) {
    if (g.def->meaning != GMeaning::arc_cw && g.def->meaning != GMeaning::arc_ccw) continue;
    const Word& w = b.words[g.word];
    std::string v(b.text(w.value));
    const auto int_end = std::min(v.find('.'), v.size());
    if (int_end == 0) continue;
    v[int_end - 1] = '1';
    g1_ = fmt::format("{}{}", b.text(w.name), v.substr(0, int_end));
    ed.replace(w.value, std::move(v));
  }
  const Motion* arc = nullptr;
  for (const Motion& m : motions)
    if (m.type == MotionType::arc_cw || m.type == MotionType::arc_ccw) arc = &m;
  if (arc != nullptr) {
    if (check(b, *arc)) linearize(b, *arc, ed, after);
  } else if (track_.motion == GMeaning::arc_cw || track_.motion == GMeaning::arc_ccw) {
    const bool errors = std::any_of(diags.begin(), diags.end(), [](const BlockDiag& d) {
      return d.severity == Severity::error;
    });
    bool reported = errors;  // an impossible arc is refused already
    for (const BlockDiag& d : diags)
      if (!reported && d.code == "PP-U209") {
        refuse(b, span_of(d), "the arc's start or end point is unknown, so its points cannot be computed");
        reported = true;
      }
    if (!reported && track_.axis_consumer() == nullptr)
      for (const Word& w : b.words)
        if (track_.axis_of(w) >= 0) {
          refuse(b, w.span, "the arc is not resolved (a word is given by an expression or parameter)");
          break;
        }
  }
  remember(b, motions, diags);
}

bool Linearizer::check(const Block& b, const Motion& m) {
  const Span at = word_at(b, m.column);
  if (m.frame == Frame::machine) {
    refuse(b, at, "an arc in machine coordinates");
    return false;
  }
  if (m.words_transformed) {
    refuse(b, at, "an arc whose axis words are not work coordinates (Fanuc G16 polar or G51.1 mirror image)");
    return false;
  }
  if (track_.motion == GMeaning::arc_cip || track_.motion == GMeaning::arc_tangent) {
    // The chords would be written under the modal CIP / CT, which reads them as arcs.
    refuse(b, at, "a Sinumerik CIP / CT arc (its chords would need the motion mode changed to G1 and back)");
    return false;
  }
  for (const Word& w : b.words) {
    if (!plain_letter(w)) {
      if (upper(b.text(w.name)) == "CR" && w.kind == ValueKind::number) continue;
      refuse(b, w.span, fmt::format("'{}' in an arc block has no linear equivalent here", b.text(w.span)));
      return false;
    }
    // Centre words go and axis words are rewritten, so I=AC(0.) or X=IC(5) is fine; F and P must
    // be plain literals.
    const bool axis_or_centre = track_.axis_of(w) >= 0 || std::string_view("IJKR").find(w.letter) != std::string_view::npos;
    const bool literal = axis_or_centre ? literal_span(b, w).has_value() : w.kind == ValueKind::number;
    if ((axis_or_centre || w.letter == 'P' || w.letter == 'F') && !literal) {
      refuse(b, w.span, fmt::format("'{}' is not a literal number (an expression or parameter)",
                                    b.text(w.span)));
      return false;
    }
    if (axis_or_centre && w.number != 0 &&
        ambiguous_integer(d_, implied_decimals(d_, w, b.text(*literal_span(b, w)), m.inch_source))) {
      refuse(b, w.span, fmt::format("'{}' has no decimal point and the control's integer input is not known, so the "
                                    "arc itself is not known; pass --integer-input increment|calculator",
                                    b.text(w.span)));
      return false;
    }
  }
  for (const Token& t : b.tokens)
    if (t.kind == TokenKind::assignment || t.kind == TokenKind::declaration) {
      refuse(b, t.span, "an assignment in an arc block (it may change the arc)");
      return false;
    }
  // The points need a known start wherever the arc is written absolutely (the interpreter may
  // resolve an arc from an assumed start, e.g. at program start or after G28).
  const PlaneAxes p = plane_axes(m.plane);
  for (int a = 0; a < kAxisCount; ++a) {
    const AxisMask bitmask = static_cast<AxisMask>(1u << a);
    if (!(m.programmed & bitmask) && a != p.u && a != p.v) continue;
    const int wi = m.word_index[static_cast<std::size_t>(a)];
    const bool inc = wi >= 0 ? track_.incremental(b.words[static_cast<std::size_t>(wi)]) : !track_.absolute;
    if (((m.programmed & bitmask) && !(m.known & bitmask)) || (!inc && !(known_ & bitmask))) {
      refuse(b, at, fmt::format("the position of axis {} before the arc is unknown, so its points cannot be computed",
                                kAxisLetters[static_cast<std::size_t>(a)]));
      return false;
    }
  }
  return true;
}

void Linearizer::note_styles(const Block& b) {
  for (const Word& w : b.words) {
    if (!plain_letter(w) || w.kind != ValueKind::number || w.letter < 'A' || w.letter > 'Z') continue;
    NumberStyle st = detect_style(b.text(w.value));
    if (const int implied = implied_decimals(d_, w, b.text(w.value), track_.inch); implied > 0)
      st = NumberStyle{st.plus_sign, true, implied, false, false};  // "X100" = 0.100 mm
    last_style_[static_cast<std::size_t>(w.letter - 'A')] = st;
    if (std::string_view("XYZUVWIJKR").find(w.letter) != std::string_view::npos)
      length_decimals_ = std::max(length_decimals_, st.decimals);
    if (w.letter == 'A' || w.letter == 'B' || w.letter == 'C') rotary_decimals_ = std::max(rotary_decimals_, st.decimals);
  }
}

void Linearizer::remember(const Block& b, std::span<const Motion> motions, const BlockDiags& diags) {
  if (!motions.empty()) known_ = motions.back().known;
  // What makes positions unknown without (or after) the block's motion.
  AxisMask named = 0;
  for (const Word& w : b.words)
    if (const int a = track_.axis_of(w); a >= 0) named = static_cast<AxisMask>(named | (1u << a));
  if (track_.has(GMeaning::home_return)) known_ = static_cast<AxisMask>(known_ & ~(named != 0 ? named : 0xFFFF));
  if (track_.has(GMeaning::machine_coords)) known_ = static_cast<AxisMask>(known_ & ~named);
  // A new work offset (or G10 table write) applies before the block's own motion, whose known
  // mask already says what it re-established.
  if (motions.empty() && (track_.has(GMeaning::work_offset) || track_.has(GMeaning::set_offsets_g10))) known_ = 0;
  for (const BlockDiag& d : diags)
    if (d.code.rfind("PP-U2", 0) == 0 && d.code != "PP-U213" && d.code != "PP-U214" && d.code != "PP-U215")
      known_ = 0;  // an unresolved construct: positions after it are unknown
}

void Linearizer::plan_axes(const Block& b, const Motion& m, std::array<AxisOut, kAxisCount>& ax) {
  const PlaneAxes p = plane_axes(m.plane);
  for (int a = 0; a < kAxisCount; ++a) {
    AxisOut& o = ax[static_cast<std::size_t>(a)];
    o.on = (m.programmed & (1u << a)) || a == p.u || a == p.v;
    if (!o.on) continue;
    o.word = m.word_index[static_cast<std::size_t>(a)];
    const char L = kAxisLetters[static_cast<std::size_t>(a)];
    if (o.word >= 0) {
      const Word& w = b.words[static_cast<std::size_t>(o.word)];
      o.literal = *literal_span(b, w);  // check() made sure it is one
      // Siemens X=AC(…) / X=IC(…): the segments repeat the form, only the number changes.
      o.letter = std::string(b.raw.substr(w.span.begin, o.literal.begin - w.span.begin));
      if (w.kind == ValueKind::number) o.letter = fmt::format("{}{}", b.text(w.name), w.has_equals ? "=" : "");
      o.suffix = std::string(b.raw.substr(o.literal.end, w.span.end - o.literal.end));
      o.style = detect_style(b.text(o.literal));
      o.implied = implied_decimals(d_, w, b.text(o.literal), m.inch_source);
      if (o.implied > 0) o.style = NumberStyle{o.style.plus_sign, true, o.implied, false, false};
      o.incremental = track_.incremental(w);
    } else {
      o.letter = std::string(1, L);
      const auto& last = last_style_[static_cast<std::size_t>(L - 'A')];
      o.style = last ? *last : NumberStyle{false, true, m.inch_source ? 4 : 3, false, false};
      o.incremental = !track_.absolute;
    }
    // One literal may show fewer decimals than the program's precision (trimmed "X45.01", or a
    // zero written "0.0"): print with the finest seen so far, and trimmed ones with at least
    // 3 (mm, degrees) / 4 (inch) decimals. More decimals only shrink the rounding.
    const int seen = is_rotary(a) ? rotary_decimals_ : length_decimals_;
    o.decimals = std::max(o.style.decimals, seen);
    if (!o.style.trailing_zeros) o.decimals = std::max(o.decimals, m.inch_source && !is_rotary(a) ? 4 : 3);
  }
}

void Linearizer::linearize(const Block& b, const Motion& m, BlockEditor& ed, std::vector<std::string>& after) {
  const PlaneAxes p = plane_axes(m.plane);
  const Span at = word_at(b, m.column);
  std::array<AxisOut, kAxisCount> ax;
  plan_axes(b, m, ax);
  const bool inch = m.inch_source;
  const int coarse = std::min(ax[static_cast<std::size_t>(p.u)].decimals, ax[static_cast<std::size_t>(p.v)].decimals);
  const double rho = rounding_mm(coarse, inch);
  const double r_end = std::hypot(m.end[p.u] - m.arc.centre[p.u], m.end[p.v] - m.arc.centre[p.v]);
  const auto n_opt = arc_segments(std::max(m.arc.radius, r_end), m.arc.sweep, tol_, rho);
  if (!n_opt) {
    refuse(b, at, fmt::format("the tolerance {} mm is not above the rounding of the printed points ({:.6f} mm at {} "
                              "decimals); raise the tolerance or the decimals (--decimals)",
                              tol_, rho, coarse));
    return;
  }
  if (*n_opt > kMaxSegments) {
    refuse(b, at, fmt::format("the arc would need more than {} segments at this tolerance", kMaxSegments));
    return;
  }
  const std::uint64_t n = *n_opt;
  // Written value of an axis: program units, X as a diameter in diameter mode.
  auto written = [&](int a, const AxisVector& q) {
    double v = q[a];
    if (!is_rotary(a)) v /= inch ? 25.4 : 1.0;
    if (a == 0 && m.diameter_mode) v *= 2;
    return v;
  };
  for (int a = 0; a < kAxisCount; ++a) {
    AxisOut& o = ax[static_cast<std::size_t>(a)];
    if (!o.on) continue;
    const double scale = decimal_scale(o.decimals);
    const double base = o.incremental ? written(a, m.start) : 0.0;
    o.counts.resize(n + 1);
    o.counts[0] = o.incremental ? 0 : std::llround(written(a, m.start) * scale);
    for (std::uint64_t k = 1; k < n; ++k)
      o.counts[k] = std::llround((written(a, arc_point(m, static_cast<double>(k) / static_cast<double>(n))) - base) *
                                 scale);
    // The last point is the source's own end word, exactly; an absent axis ends where it started.
    std::int64_t last = o.counts[0];
    if (o.word >= 0 && !literal_counts(b.text(o.literal), o.decimals - o.implied, last)) {
      refuse(b, at, "an end point word cannot be read exactly");
      return;
    }
    o.counts[n] = last;
  }
  // Counts are cumulative in both modes: an axis moves in step k when they differ from step k-1.
  auto changed = [](const AxisOut& o, std::uint64_t k) { return o.counts[k] != o.counts[k - 1]; };
  auto value = [&](const AxisOut& o, std::uint64_t k) {
    // The last absolute point is the source's own end word, as written.
    if (k == n && !o.incremental && o.word >= 0) return std::string(b.text(o.literal));
    const std::int64_t c = o.incremental ? o.counts[k] - o.counts[k - 1] : o.counts[k];
    return format_counts(c, o.decimals, o.style, d_.decimal_point_required);
  };
  // Segments whose printed point does not move are left out.
  std::vector<std::uint64_t> lines;
  for (std::uint64_t k = 2; k <= n; ++k)
    for (const AxisOut& o : ax)
      if (o.on && changed(o, k)) {
        lines.push_back(k);
        break;
      }
  const std::string sep = b.raw.find_first_of(" \t") == std::string_view::npos ? "" : " ";
  // The arc's block carries the first segment: its axis words get the first point, missing axes
  // that move are added after the last axis word, the centre / radius / turns words go.
  Span anchor{};
  for (const AxisOut& o : ax)
    if (o.on && o.word >= 0) anchor.end = std::max(anchor.end, b.words[static_cast<std::size_t>(o.word)].span.end);
  for (const AxisOut& o : ax) {
    if (!o.on) continue;
    if (o.word >= 0) {
      ed.replace(o.literal, value(o, 1));
    } else if (changed(o, 1)) {
      ed.insert_after(anchor, sep + o.letter + value(o, 1) + o.suffix);
    }
  }
  for (std::size_t i = 0; i < b.words.size(); ++i) {
    const Word& w = b.words[i];
    const bool centre = plain_letter(w) && (w.letter == 'I' || w.letter == 'J' || w.letter == 'K' || w.letter == 'R');
    const bool turns = plain_letter(w) && w.letter == 'P' && d_.id == DialectId::linuxcnc;
    if (centre || turns || (!plain_letter(w) && upper(b.text(w.name)) == "CR")) ed.remove_word(i);
  }
  // Inverse time: each segment takes 1/n of the arc's time, so its F is n times the arc's.
  std::string feed;
  if (m.feed_mode == FeedMode::inverse_time) {
    const std::uint64_t segments = 1 + lines.size();
    int fw = -1;
    for (std::size_t i = 0; i < b.words.size(); ++i)
      if (plain_letter(b.words[i]) && b.words[i].letter == 'F') fw = static_cast<int>(i);
    NumberStyle fs = last_style_['F' - 'A'].value_or(NumberStyle{false, true, 3, false, false});
    std::int64_t f = 0;
    if (fw >= 0) {
      const Word& w = b.words[static_cast<std::size_t>(fw)];
      fs = detect_style(b.text(w.value));
      if (!literal_counts(b.text(w.value), fs.decimals, f)) f = 0;
    } else {
      f = std::llround(m.feed * decimal_scale(fs.decimals));
    }
    const std::string ftext = format_counts(f * static_cast<std::int64_t>(segments), fs.decimals, fs,
                                            d_.decimal_point_required);
    feed = sep + "F" + ftext;
    if (fw >= 0) {
      ed.replace(b.words[static_cast<std::size_t>(fw)].value, ftext);
    } else {
      ed.insert_after(anchor, feed);
    }
  }
  // Further segments: one line each, with the block's block-delete mark and block end.
  std::string prefix;
  if (b.block_delete) {
    prefix = std::string(b.text(b.block_delete_span));
    if (b.block_delete_span.end < b.raw.size() && (b.raw[b.block_delete_span.end] == ' ')) prefix += ' ';
  }
  bool star = false;
  for (const Token& t : b.tokens) star = star || t.kind == TokenKind::block_end;
  for (const std::uint64_t k : lines) {
    std::string line = prefix + g1_;
    for (const AxisOut& o : ax)
      if (o.on && changed(o, k)) line += sep + o.letter + value(o, k) + o.suffix;
    line += feed;
    if (star) line += " *";
    after.push_back(std::move(line));
  }
  ++r_.arcs_linearized;
  r_.segments += 1 + lines.size();
}

}  // namespace postproc::gcode
