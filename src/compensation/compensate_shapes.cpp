// compensate: arcs (kept when the correction is rigid over them, else corrected chords),
// drilling cycles (hole corrected at its bottom, levels along the normal) and the contour
// candidate's splits of long moves.
#include "src/compensation/compensator.hpp"
#include "src/gcode/text.hpp"

namespace postproc::comp::detail {

bool Compensator::siemens_unwritable(const Block& b, const Motion& m) {
  if (d_.id != gcode::DialectId::siemens) return false;
  const bool arc = m.type == gcode::MotionType::arc_cw || m.type == gcode::MotionType::arc_ccw;
  std::string what;
  if (arc && (track_.motion == gcode::GMeaning::arc_cip || track_.motion == gcode::GMeaning::arc_tangent)) what = "CIP / CT";
  for (const Word& w : b.words)
    if (what.empty() && !gcode::plain_letter(w)) {
      const std::string name = gcode::text::upper(b.text(w.name));
      if (name == "AP" || name == "RP" ||
          (arc && (name == "AR" || name == "I1" || name == "J1" || name == "K1")))
        what = std::string(b.text(w.span));
    }
  if (what.empty()) return false;
  refuse(b, m.column, kRefused,
         fmt::format("this Sinumerik move is written with {}, whose words this version does not rewrite; program it "
                     "with X Y Z (arcs: G2/G3 with I J K or CR=)",
                     what));
  return true;
}

Compensator::ArcCheck Compensator::arc_check(const Block& b, const Motion& m, const Command& out) {
  if ((written_known_ & mask_) != mask_) {
    if ((out.c - m.end).cwiseAbs().maxCoeff() < 1e-12) return ArcCheck::rigid;
    refuse(b, m.column, kRefused, "the start of this arc is not known, so its correction cannot be checked");
    return ArcCheck::refused;
  }
  const AxisVector shift0 = written_ - m.start;
  for (double t : {0.25, 0.5, 0.75, 1.0}) {
    Command c{gcode::arc_point(m, t), m.tool_vector};
    Command o;
    kin::JointVector qq;
    if (t < 1.0) {
      if (!map_->correct(c, joints_, o, qq).ok()) {
        kin_failure(b, m, {kin::Status::no_convergence});
        return ArcCheck::refused;
      }
    } else {
      o = out;
    }
    const AxisVector d = (o.c - c.c) - shift0;
    double lin = 0, rot = 0;
    for (int a = 0; a < gcode::kAxisCount; ++a)
      if ((mask_ >> a) & 1u) (gcode::is_rotary(a) ? rot : lin) = std::max(gcode::is_rotary(a) ? rot : lin, std::abs(d[a]));
    if (lin > opt_.max_deviation_mm || rot * kin::kDeg > opt_.max_angle_rad) return ArcCheck::linearize;
  }
  return ArcCheck::rigid;
}

void Compensator::restore_arc_mode(const Block& b, gcode::BlockEditor& ed) {
  if (d_.id == gcode::DialectId::heidenhain) return;  // Klartext: every block names its path function
  if (track_.block_motion() != nullptr) {  // the block names its motion (arc_word_ is its G word if an arc)
    arc_mode_broken_ = false;
    return;
  }
  if (!arc_mode_broken_ || b.words.empty()) return;
  const std::string sep = word_separator(b);
  ed.insert_before(b.words.front().span, arc_word_ + sep);
  arc_mode_broken_ = false;
}

// The contour candidate's splits (CompensateOptions::split; the declarations say what each does).
bool Compensator::splittable(const Block& b, const Motion& m, const ProgramMap& map) const {
  if (b.block_delete || m.words_transformed) return false;
  const auto* g = track_.block_motion();
  for (std::size_t i = 0; i < b.words.size(); ++i) {
    const Word& w = b.words[i];
    if (!gcode::plain_letter(w) || w.kind != gcode::ValueKind::number) return false;
    if (w.letter == 'F') continue;
    if (w.letter == 'G' && g != nullptr && g->word == i) continue;
    // The feed mode (G93 / G94 / G95) is modal and set before the move: it holds for every piece.
    if (w.letter == 'G' && std::any_of(track_.block_g.begin(), track_.block_g.end(), [&](const auto& bg) {
          return bg.word == i && bg.def != nullptr && bg.def->group == gcode::GGroup::feed_mode;
        }))
      continue;
    if (const int a = track_.axis_of(w); a >= 0 && ((mask_ >> a) & 1u)) continue;
    if ((w.letter == 'I' || w.letter == 'J' || w.letter == 'K') && map.form() == Form::tcp_vector)
      continue;
    return false;
  }
  for (std::size_t i = 0; i < b.tokens.size(); ++i) {
    const gcode::Token& t = b.tokens[i];
    if (t.kind == gcode::TokenKind::paren_comment || t.kind == gcode::TokenKind::line_comment ||
        t.kind == gcode::TokenKind::block_end)
      continue;
    if (i == 0 && t.kind == gcode::TokenKind::keyword && d_.id == gcode::DialectId::heidenhain &&
        (gcode::text::iequals(b.text(t.name), "L") || gcode::text::iequals(b.text(t.name), "LN")))
      continue;
    return false;
  }
  return true;
}

std::vector<double> Compensator::split_fractions(const Motion& m) const {
  const CompensateOptions::SplitForContour& s = opt_.split;
  if (!m.feed_known || !(m.feed > 0)) return {};
  double len2 = 0;
  for (int a = 0; a < gcode::kAxisCount; ++a)
    if ((mask_ >> a) & 1u) len2 += (m.end[a] - m.start[a]) * (m.end[a] - m.start[a]);
  double t = 0;  // s
  if (m.feed_mode == gcode::FeedMode::inverse_time) t = 60.0 / m.feed;
  else if (m.feed_mode == gcode::FeedMode::per_minute) t = std::sqrt(len2) * 60.0 / m.feed;
  if (!(t > s.step_s)) return {};
  std::vector<double> f;
  if (t <= 2 * s.span_s) {
    const auto n = static_cast<std::uint32_t>(std::min(std::ceil(t / s.step_s), 256.0));
    for (std::uint32_t i = 1; i < n; ++i) f.push_back(static_cast<double>(i) / n);
    return f;
  }
  const auto k = static_cast<std::uint32_t>(std::min(std::floor(s.span_s / s.step_s), 128.0));
  for (std::uint32_t i = 1; i <= k; ++i) f.push_back(i * s.step_s / t);
  for (std::uint32_t i = k; i >= 1; --i) f.push_back(1 - i * s.step_s / t);
  return f;
}

void Compensator::split_for_contour(const Motion& m, const ProgramMap& map, const Command& out, std::vector<Command>& pts,
                                    std::vector<double>& fractions) {
  std::vector<double> f = split_fractions(m);
  if (f.empty()) return;
  const std::size_t n = pts.size() + 1;
  for (std::size_t i = 1; i < n; ++i) f.push_back(static_cast<double>(i) / static_cast<double>(n));
  std::sort(f.begin(), f.end());
  f.erase(std::unique(f.begin(), f.end(), [](double a, double b) { return b - a < 1e-9; }), f.end());
  if (f.size() + 1 > kMaxSegments) return;
  const Command c0{m.start, prev_vector_};
  const Command c1{m.end, m.tool_vector};
  std::vector<Command> cand;
  cand.reserve(f.size());
  Command prev{written_, prev_written_vector_};
  double t_prev = 0;
  for (std::size_t i = 0; i <= f.size(); ++i) {
    const double t = i < f.size() ? f[i] : 1.0;
    Command k = out;
    if (i < f.size()) {
      kin::JointVector qq;
      if (!map.correct(lerp(c0, c1, t), joints_, k, qq).ok()) return;
      cand.push_back(k);
    }
    if (!within(map, lerp(c0, c1, t_prev), lerp(c0, c1, t), prev, k, opt_.max_deviation_mm)) return;
    prev = k;
    t_prev = t;
  }
  pts = std::move(cand);
  fractions = std::move(f);
  ++r_.moves_split;
}

bool Compensator::linearize_arc(const Block& b, const Motion& m, const ProgramMap& map, const Command& out, gcode::BlockEditor& ed) {
  const double tol = opt_.max_deviation_mm / 2;
  const auto n0 = gcode::arc_segments(m.arc.radius, m.arc.sweep, tol, 0.0);
  std::uint64_t n = n0 ? std::max<std::uint64_t>(*n0, 2) : 2;
  std::vector<Command> pts;
  const Command k0{written_, prev_written_vector_};
  for (; n <= kMaxSegments; n *= 2) {
    pts.clear();
    bool ok = true;
    Command prev = k0;
    for (std::uint64_t i = 1; i <= n && ok; ++i) {
      const double t0 = static_cast<double>(i - 1) / static_cast<double>(n);
      const double t1 = static_cast<double>(i) / static_cast<double>(n);
      const Command c1{gcode::arc_point(m, t1), m.tool_vector};
      Command k = out;
      kin::JointVector qq;
      if (i < n) {
        if (!map.correct(c1, joints_, k, qq).ok()) {
          kin_failure(b, m, {kin::Status::no_convergence});
          return false;
        }
        pts.push_back(k);
      }
      if (!within(map, Command{gcode::arc_point(m, t0), m.tool_vector}, c1, prev, k, tol)) ok = false;
      prev = k;
    }
    if (ok) break;
  }
  if (n > kMaxSegments) {
    refuse(b, m.column, kRefused, fmt::format("the arc needs more than {} chords at --max-deviation {} mm", kMaxSegments,
                                              opt_.max_deviation_mm));
    return false;
  }
  // The block becomes the first chord: G2/G3 → G1 (inserted when the arc was modal), centre,
  // radius and turn words go; the other chords follow as new lines.
  const std::string sep = word_separator(b);
  if (d_.id == gcode::DialectId::heidenhain) {
    // Klartext: the arc block (C, CR, CT) becomes a straight line L; DR±, the radius word R and
    // the arc verb go (the CC block before it stays: it only sets the centre).
    if (b.tokens.empty() || b.tokens.front().kind != gcode::TokenKind::keyword) {
      refuse(b, m.column, kRefused, "the arc needs linearising but its block has no path function to replace");
      return false;
    }
    ed.replace(b.tokens.front().span, "L");
    for (std::size_t i = 1; i < b.tokens.size(); ++i) {
      const std::string_view t = b.text(b.tokens[i].span);
      if (gcode::text::iequals(t, "DR+") || gcode::text::iequals(t, "DR-")) {
        // the blank before it goes too
        std::uint32_t from = b.tokens[i].span.begin;
        while (from > 0 && (b.raw[from - 1] == ' ' || b.raw[from - 1] == '\t')) --from;
        ed.remove({from, b.tokens[i].span.end});
      }
    }
    for (std::size_t i = 0; i < b.words.size(); ++i)
      if (gcode::plain_letter(b.words[i]) && b.words[i].letter == 'R') ed.remove_word(i);
    ++r_.arcs_linearized;
    write_segments(b, m, ed, pts, {}, out);
    return !block_error_;
  }
  if (const auto* g = track_.block_motion()) {
    const Word& w = b.words[g->word];
    std::string v(b.text(w.value));
    const auto int_end = std::min(v.find('.'), v.size());
    if (int_end > 0) v[int_end - 1] = '1';
    ed.replace(w.value, std::move(v));
  } else if (!b.words.empty()) {
    ed.insert_before(b.words.front().span, "G1" + sep);
  }
  arc_mode_broken_ = true;
  for (std::size_t i = 0; i < b.words.size(); ++i) {
    const Word& w = b.words[i];
    const bool centre = gcode::plain_letter(w) && (w.letter == 'I' || w.letter == 'J' || w.letter == 'K' || w.letter == 'R');
    const bool turns = gcode::plain_letter(w) && w.letter == 'P' && d_.id == gcode::DialectId::linuxcnc;
    const bool cr = !gcode::plain_letter(w) && w.name_len == 2 && (b.raw[w.span.begin] == 'C' || b.raw[w.span.begin] == 'c') &&
                    (b.raw[w.span.begin + 1] == 'R' || b.raw[w.span.begin + 1] == 'r');
    if (centre || turns || cr) ed.remove_word(i);
  }
  ++r_.arcs_linearized;
  write_segments(b, m, ed, pts, {}, out);
  return !block_error_;
}

void Compensator::drill(const Block& b, const Motion& m, const ProgramMap& map, gcode::BlockEditor& ed) {
  const gcode::PlaneAxes p = gcode::plane_axes(m.plane);
  Command bottom{m.end, m.tool_vector}, rplane{m.end, m.tool_vector}, cb, cr;
  bottom.c[p.n] = m.cycle_bottom;
  rplane.c[p.n] = m.cycle_r;
  kin::JointVector q1, q2;
  if (!map.correct(bottom, joints_, cb, q1).ok() || !map.correct(rplane, joints_, cr, q2).ok()) {
    kin_failure(b, m, {kin::Status::no_convergence});
    return;
  }
  const double skew = std::hypot((cb.c[p.u] - bottom.c[p.u]) - (cr.c[p.u] - rplane.c[p.u]),
                                 (cb.c[p.v] - bottom.c[p.v]) - (cr.c[p.v] - rplane.c[p.v]));
  if (skew > opt_.max_deviation_mm) {
    refuse(b, m.column, kRefused,
           fmt::format("the hole axis leans on the real machine: the correction differs by {:.4f} mm between the R "
                       "plane and the bottom; drill this hole with G0/G1 moves to compensate it",
                       skew));
    return;
  }
  // The hole position (the block's end point) takes the correction at the bottom.
  Command out{m.end, m.tool_vector};
  for (int a = 0; a < gcode::kAxisCount; ++a)
    if (a != p.n && ((mask_ >> a) & 1u)) out.c[a] = cb.c[a];
  const AxisMask mask = static_cast<AxisMask>(mask_ & ~(1u << p.n));
  const WordWriter::Outcome o = writer_.rewrite(b, m, mask, written_, written_known_, out, ed);
  if (!o.ok) {
    refuse(b, o.column, kRefused, o.why);
    return;
  }
  r_.words_changed += o.changed;
  r_.words_inserted += o.inserted;
  const std::string sep = word_separator(b);
  const char normal = gcode::kAxisLetters[static_cast<std::size_t>(p.n)];
  for (const auto& [L, from, to] : {std::tuple{normal, bottom.c[p.n], cb.c[p.n]}, std::tuple{'R', rplane.c[p.n], cr.c[p.n]}}) {
    if (!rounded_change(p.n, from, to, m)) continue;
    if (!track_.absolute) {
      refuse(b, m.column, kRefused,
             fmt::format("the cycle's {} level needs a correction here but the cycle is programmed incrementally "
                         "(G91); program it in G90",
                         L));
      return;
    }
    int wi = -1;
    for (std::size_t i = 0; i < b.words.size(); ++i)
      if (gcode::plain_letter(b.words[i]) && b.words[i].letter == L) wi = static_cast<int>(i);
    int dec = m_.decimals(p.n);
    gcode::NumberStyle st{false, true, dec, false, false};
    if (wi >= 0) {
      const auto lit = gcode::literal_span(b, b.words[static_cast<std::size_t>(wi)]);
      if (!lit) {
        refuse(b, m.column, kRefused, fmt::format("the cycle's {} word is an expression", L));
        return;
      }
      st = gcode::detect_style(b.text(*lit));
      dec = std::max(st.decimals, dec);
      ed.replace(*lit, gcode::format_counts(std::llround(program_units(p.n, to, m) * gcode::decimal_scale(dec)), dec, st,
                                            d_.decimal_point_required));
      ++r_.words_changed;
    } else {
      // The level is modal cycle data: written into this hole's block it applies from this hole.
      gcode::Span anchor{};
      for (const Word& w : b.words) anchor.end = std::max(anchor.end, w.span.end);
      ed.insert_after(anchor, sep + std::string(1, L) +
                                  gcode::format_counts(std::llround(program_units(p.n, to, m) * gcode::decimal_scale(dec)),
                                                       dec, st, d_.decimal_point_required));
      ++r_.words_inserted;
    }
  }
  written_ = out.c;
  written_known_ = m.known | mask;
}

}  // namespace postproc::comp::detail
