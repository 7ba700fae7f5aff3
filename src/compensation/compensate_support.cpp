// compensate: models per tool length; writing corrected words in the program's own style.
#include "src/compensation/compensate_support.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "postproc/gcode/number_style.hpp"
#include "src/gcode/rotary_direction.hpp"
#include "src/gcode/text.hpp"

namespace postproc::comp {

const gcode::Motion* cutter_offset_motion(std::span<const gcode::Motion> motions) {
  for (const gcode::Motion& m : motions)
    if (m.cutter_radius > 0 || std::isnan(m.cutter_radius)) return &m;
  return nullptr;
}

std::string corrected_line_too_long(std::string_view why) {
  return fmt::format("the corrected block would be longer than the controller reads ({}): shorten the block's "
                     "comment or put it on a line of its own",
                     why);
}

std::string cutter_offset_refusal(const gcode::Motion& m) {
  return fmt::format(
      "compensation of a program under cutter radius compensation with {} is not supported: the controller "
      "(G41/G42, RL/RR) offsets every point written here by the radius, so it would offset the corrected points "
      "again; compensate the tool-centre path instead (the program without G41/G42, as the CAM system writes it "
      "with the tool radius applied), or give the radius 0 when the path already is the tool centre (D0, or "
      "the machine file's [tool.radii])",
      std::isnan(m.cutter_radius) ? std::string("a radius the tool table does not give")
                                  : fmt::format("radius {:g} mm", m.cutter_radius));
}

using gcode::AxisVector;
using gcode::Block;
using gcode::Motion;
using gcode::Word;

double unit_scale(int a, const Motion& m) {
  double k = 1.0;
  if (!gcode::is_rotary(a) && m.inch_source) k *= 25.4;
  if (a == 0 && m.diameter_mode) k /= 2;
  return k;
}

double program_units(int a, double v, const Motion& m) {
  if (!gcode::is_rotary(a) && m.inch_source) v /= 25.4;
  if (a == 0 && m.diameter_mode) v *= 2;
  return v;
}

int program_decimals(const machine::Machine& mc, int a, const Motion& m) {
  return mc.decimals(a) + (m.inch_source && !gcode::is_rotary(a) ? 1 : 0);
}

RoundingBound rounding_bound(const machine::Machine& m, const ProgramMap& map, const gcode::Motion& mc,
                             gcode::AxisMask need, machine::Form f, const kin::JointVector& start, const kin::Pose& got) {
  RoundingBound b;
  for (int a = 0; a < gcode::kAxisCount; ++a) {
    if (!((need >> a) & 1u)) continue;
    const double h = 0.5 * std::pow(10.0, -m.decimals(a)) * unit_scale(a, mc);
    double worst = 0, worst_angle = 0;
    for (double sgn : {-1.0, 1.0}) {
      Command c{mc.end, mc.tool_vector};
      c.c[a] += sgn * h;
      kin::Pose p;
      kin::JointVector qq;
      if (map.real(c, start, p, qq).ok()) {
        worst = std::max(worst, (p.p - got.p).norm());
        worst_angle = std::max(worst_angle, std::acos(std::clamp(p.axis().dot(got.axis()), -1.0, 1.0)));
      }
    }
    b.tip_mm += worst;
    b.axis_rad += worst_angle;
  }
  if (f == machine::Form::tcp_vector) {
    b.tip_mm += 3 * 0.5e-6 * 200.0;  // 6-decimal vector components, 200 mm lever
    b.axis_rad += 3 * 0.5e-6;
  }
  return b;
}

void MotionCollector::block(const gcode::Block& b, std::span<const gcode::Motion> motions, bool) {
  track_.update(b);
  if (motions.size() != 1) return;
  gcode::Motion m = motions.front();
  if (m.tool_vector_known) {
    vector_ = m.tool_vector;
    known_ = true;
  } else if (known_) {
    m.tool_vector = vector_;
    m.tool_vector_known = true;
  }
  by_line[b.line] = CollectedMotion{m, track_.has(gcode::GMeaning::home_return)};
}


bool WordWriter::vector_form(const Motion& m) const {
  if (m_.coordinates == machine::ProgramCoordinates::tool_tip) return m_.orientation == machine::Orientation::vector;
  return m.tcp == gcode::TcpMode::fanuc_g43_5 || (m.tcp == gcode::TcpMode::siemens_traori && m.tool_vector_known) ||
         (m.tcp == gcode::TcpMode::heidenhain_m128 && m.tool_vector_known);  // Klartext LN … TX TY TZ
}

namespace {

/// The word carrying vector component k (0..2) of the tool vector: Siemens A3/B3/C3, else I/J/K.
int vector_word(const Block& b, int k, bool siemens, bool klartext = false) {
  for (std::size_t i = 0; i < b.words.size(); ++i) {
    const Word& w = b.words[i];
    if (klartext && w.letter == 'T' && w.name_len == 2 && b.text(w.name).size() == 2 &&
        gcode::text::upper(b.text(w.name)[1]) == "XYZ"[k])  // Klartext LN … TX TY TZ
      return static_cast<int>(i);
    if (!klartext && (siemens ? (w.letter == "ABC"[k] && w.index == 3) : (gcode::plain_letter(w) && w.letter == "IJK"[k])))
      return static_cast<int>(i);
  }
  return -1;
}

std::uint32_t column_of(const Word& w) { return w.span.begin + 1; }

/// Decimals of an inverse-time F written for a piece of a split move (the piece's share of the
/// block's time is 1/F min; at 3 decimals an F of 4 or more is off by at most 1.3e-4 of its time,
/// and the contour stage simulates the F as written).
constexpr int kInverseTimeDecimals = 3;

/// Decimals for a scaled inverse-time F written in the style of the block's own F (`decimals`):
/// those, when the value is exact in them (an F4. scaled by a piece count), else at least
/// kInverseTimeDecimals.
int inverse_time_decimals(double f, int decimals) {
  const double s = gcode::decimal_scale(decimals);
  if (std::abs(f * s - std::round(f * s)) < 1e-9 * std::max(1.0, std::abs(f * s))) return decimals;
  return std::max(decimals, kInverseTimeDecimals);
}

/// A literal with ',' as its decimal separator (Klartext files often carry one) read with '.'.
std::string comma_to_point(std::string_view t) {
  std::string s(t);
  for (char& c : s)
    if (c == ',') c = '.';
  return s;
}

}  // namespace

std::string word_separator(const gcode::Block& b) {
  if (b.raw.find_first_of(" \t") != std::string_view::npos) return " ";
  for (const Word& w : b.words)
    if (w.has_equals) return " ";
  return "";
}

std::optional<double> WordWriter::absolute_word(int a, double target, double from, double like) const {
  // The controller reads a rotary word that rolls over within the turn from where it stands (the
  // written start); before the axis is known, the reader counts from 0° (the interpreter's
  // convention). Every other word is the position itself (rollover_word of "off").
  return gcode::rollover_word(d_.rollover[static_cast<std::size_t>(a)], target, from, like);
}

std::string WordWriter::rollover_refusal(int a, double target, double from) const {
  return fmt::format("the corrected rotary axis {} must move from {:.6f} to {:.6f} deg, which no absolute word reaches "
                     "under the controller's roll-over rule '{}' (docs/machine-file.md); check [axes.{}] rollover or "
                     "program this move incrementally",
                     gcode::kAxisLetters[static_cast<std::size_t>(a)], from, target,
                     gcode::to_string(d_.rollover[static_cast<std::size_t>(a)]),
                     gcode::kAxisLetters[static_cast<std::size_t>(a)]);
}

WordWriter::Outcome WordWriter::rewrite(const Block& b, const Motion& m, gcode::AxisMask mask, const AxisVector& start,
                                        gcode::AxisMask start_known, const Command& target, gcode::BlockEditor& ed,
                                        double g93_scale) {
  Outcome o;
  for (const Word& w : b.words)
    if (w.letter == '@' || w.letter == '^') {
      // LinuxCNC polar words: the corrected point would need X Y, which LinuxCNC refuses beside @ ^.
      return {false, column_of(w),
              "the block is programmed in polar words (@ ^); a corrected point cannot be written in them exactly — "
              "program this move with X and Y",
              0, 0};
    }
  gcode::Span anchor{};
  for (const Word& w : b.words)
    if (track_.axis_of(w) >= 0) anchor.end = std::max(anchor.end, w.span.end);
  if (anchor.end == 0 && !b.words.empty()) anchor.end = b.words.back().span.end;
  const std::string sep = word_separator(b);
  for (int a = 0; a < gcode::kAxisCount; ++a) {
    if (!((mask >> a) & 1u)) continue;
    const int dm = program_decimals(m_, a, m);
    const double pv = program_units(a, target.c[a], m);
    const int wi = m.word_index[static_cast<std::size_t>(a)];
    const bool have_start = (start_known >> a) & 1u;
    const double held = program_units(a, have_start ? start[a] : m.start[a], m);
    if (wi < 0) {
      // An axis the block does not name stays where the controller holds it: write it if the
      // corrected end differs there at the output decimals.
      const double s = gcode::decimal_scale(dm);
      if (std::abs(pv - held) < 1e-9 || std::llround(pv * s) == std::llround(held * s)) continue;
      if (m.words_transformed) {
        o = {false, m.column, "the block's axis words are not work coordinates (Fanuc G16, G51.1 or G29) and a "
                              "correction would need a new word; write the block in plain coordinates", 0, 0};
        return o;
      }
      if (!have_start && !((m.known >> a) & 1u)) {
        o = {false, m.column, fmt::format("axis {} needs a correction but its position is unknown here",
                                          gcode::kAxisLetters[static_cast<std::size_t>(a)]), 0, 0};
        return o;
      }
      double v = pv - held;
      if (track_.absolute) {
        const auto rw = absolute_word(a, pv, have_start ? held : 0.0, pv);
        if (!rw) return {false, m.column, rollover_refusal(a, pv, have_start ? held : 0.0), 0, 0};
        v = *rw;
      }
      ed.insert_after(anchor, sep + std::string(1, gcode::kAxisLetters[static_cast<std::size_t>(a)]) +
                                  decimal_mark(b, gcode::format_counts(std::llround(v * s), dm, insert_style(),
                                                                       d_.decimal_point_required)));
      ++o.inserted;
      continue;
    }
    const Word& w = b.words[static_cast<std::size_t>(wi)];
    if (std::abs(pv - program_units(a, m.end[a], m)) < 1e-9) continue;  // no correction: the word stays
    if (m.words_transformed) {
      o = {false, column_of(w), "the block's axis words are not its end point in work coordinates (Fanuc G16 "
                                "radius/angle, G51.1 mirror image, G29 relative to the intermediate point; or a "
                                "chamfer or rounding built next to it: Heidenhain RND/CHF, Fanuc ,C/,R, Sinumerik "
                                "CHF=/RND=) and need a correction; write the block in plain coordinates (a corner as "
                                "its own move)", 0, 0};
      return o;
    }
    const auto lit = gcode::literal_span(b, w);
    const bool inc = track_.incremental(w);
    if (!lit) {
      const double s = gcode::decimal_scale(dm);
      const double was = program_units(a, m.end[a], m);
      if (std::abs(pv - was) < 1e-9 || std::llround(pv * s) == std::llround(was * s)) continue;
      o = {false, column_of(w), "the axis word is an expression or parameter and needs a correction; the program "
                                "must be resolved first (issue: expressions are written back in a later version)", 0, 0};
      return o;
    }
    const std::string point_text = comma_to_point(b.text(*lit));
    const std::string_view text = point_text;
    const int implied = gcode::implied_decimals(d_, w, text, m.inch_source);
    gcode::NumberStyle st = gcode::detect_style(text);
    if (implied > 0) st = gcode::NumberStyle{st.plus_sign, true, implied, false, false};
    if (d_.id == gcode::DialectId::heidenhain) st.plus_sign = true;  // Klartext signs every coordinate
    const int dec = std::max(st.decimals, dm);
    const double s = gcode::decimal_scale(dec);
    if (inc && !have_start) {
      o = {false, column_of(w), "an incremental word needs a correction but the position before it is unknown", 0, 0};
      return o;
    }
    double v = pv - held;
    const gcode::RotaryDirection dir =
        w.kind == gcode::ValueKind::absolute_fn ? gcode::direction_of(b.text(w.value)) : gcode::RotaryDirection::none;
    if (dir != gcode::RotaryDirection::none) {
      // Sinumerik C=DC(w) / ACP(w) / ACN(w): the word stays a position within the turn that the
      // function's direction takes from where the axis stands to the corrected position.
      const double from = have_start ? held : 0.0;
      const auto rw = gcode::directed_word(dir, pv, from);
      if (!rw)
        return {false, column_of(w),
                fmt::format("the corrected rotary axis {} must move from {:.6f} to {:.6f} deg, which {}(…) cannot reach "
                            "(it moves {}); program this move with another function (AC, IC) or incrementally",
                            gcode::kAxisLetters[static_cast<std::size_t>(a)], from, pv, gcode::function_name(dir),
                            dir == gcode::RotaryDirection::shortest   ? "at most half a turn"
                            : dir == gcode::RotaryDirection::positive ? "the positive way, less than a turn"
                                                                      : "the negative way, less than a turn"),
                0, 0};
      v = *rw;
      // Written at the word's decimals, a value just below a full turn reads 360, which the
      // control refuses: it is 0 of the next turn.
      if (std::llround(v * s) >= std::llround(360.0 * s)) v = 0;
    } else if (!inc) {
      const auto rw = absolute_word(a, pv, have_start ? held : 0.0, w.whole ? pv : w.number);
      if (!rw) return {false, column_of(w), rollover_refusal(a, pv, have_start ? held : 0.0), 0, 0};
      v = *rw;
    }
    const std::int64_t want = std::llround(v * s);
    std::int64_t old = 0;
    const bool exact = gcode::literal_counts(text, dec - implied, old);
    if (exact && want == old) continue;
    if (gcode::ambiguous_integer(d_, implied)) {
      o = {false, column_of(w), "the word is a whole number whose meaning depends on the integer-input setting; "
                                "pass --integer-input", 0, 0};
      return o;
    }
    ed.replace(*lit, decimal_mark(b, gcode::format_counts(want, dec, st, d_.decimal_point_required)));
    ++o.changed;
  }
  if (vector_form(m)) {
    const bool siemens = d_.id == gcode::DialectId::siemens;
    // A block that writes any component writes all three: a missing one reads as 0.
    bool any = false;
    for (int k = 0; k < 3; ++k)
      any = any || vector_word(b, k, siemens, d_.id == gcode::DialectId::heidenhain) >= 0 || std::abs(target.vector[k] - m.tool_vector[k]) >= 5e-7;
    for (int k = 0; k < 3 && any; ++k) {
      const int wi = vector_word(b, k, siemens, d_.id == gcode::DialectId::heidenhain);
      const double v = target.vector[k];
      if (wi < 0) {
        ed.insert_after(anchor, sep + vector_name(k) +
                                    decimal_mark(b, gcode::format_number(v, insert_style(), 6, d_.decimal_point_required)));
        ++o.inserted;
        continue;
      }
      const Word& w = b.words[static_cast<std::size_t>(wi)];
      const auto lit = gcode::literal_span(b, w);
      if (!lit) {
        o = {false, column_of(w), "the tool-vector word is an expression and needs a correction", 0, 0};
        return o;
      }
      const std::string vtext = comma_to_point(b.text(*lit));
      gcode::NumberStyle st = gcode::detect_style(vtext);
      if (d_.id == gcode::DialectId::heidenhain) st.plus_sign = true;
      const int dec = std::max(st.decimals, 6);
      std::int64_t old = 0;
      const std::int64_t want = std::llround(v * gcode::decimal_scale(dec));
      if (gcode::literal_counts(vtext, dec, old) && old == want) continue;
      ed.replace(*lit, decimal_mark(b, gcode::format_counts(want, dec, st, d_.decimal_point_required)));
      ++o.changed;
    }
  }
  if (g93_scale > 1) {
    int fw = -1;
    for (std::size_t i = 0; i < b.words.size(); ++i)
      if (gcode::plain_letter(b.words[i]) && b.words[i].letter == 'F') fw = static_cast<int>(i);
    const double f = m.feed * g93_scale;
    if (fw >= 0) {
      const auto lit = gcode::literal_span(b, b.words[static_cast<std::size_t>(fw)]);
      if (!lit) {
        o = {false, column_of(b.words[static_cast<std::size_t>(fw)]),
             "the inverse-time F word is an expression; it cannot be scaled for the subdivided move", 0, 0};
        return o;
      }
      const gcode::NumberStyle st = gcode::detect_style(b.text(*lit));
      ed.replace(*lit, gcode::format_number(f, st, inverse_time_decimals(f, st.decimals), d_.decimal_point_required));
    } else {
      ed.insert_after(anchor, sep + "F" + gcode::format_number(f, default_style(), 3, d_.decimal_point_required));
    }
  }
  return o;
}

std::optional<std::string> WordWriter::segment_line(const Block& b, const Motion& m, gcode::AxisMask mask, const AxisVector& from,
                                     const Command& to, double g93_scale) {
  const std::string sep = word_separator(b);
  std::string line;
  if (b.block_delete) line = std::string(b.text(b.block_delete_span)) + sep;
  bool first = true;
  // Klartext: a new block is a line of its own kind (L, or LN with the tool vector), no number.
  if (d_.id == gcode::DialectId::heidenhain) {
    line += vector_form(m) ? "LN" : "L";
    first = false;
  }
  auto add = [&](std::string word) {
    line += (first ? "" : sep) + word;
    first = false;
  };
  for (int a = 0; a < gcode::kAxisCount; ++a) {
    if (!((mask >> a) & 1u)) continue;
    const int dm = program_decimals(m_, a, m);
    const double s = gcode::decimal_scale(dm);
    const double pv = program_units(a, to.c[a], m);
    const double pf = program_units(a, from[a], m);
    if (std::abs(pv - pf) < 1e-9 || std::llround(pv * s) == std::llround(pf * s)) continue;
    double v = pv - pf;
    if (track_.absolute) {
      const auto rw = absolute_word(a, pv, pf, pv);
      if (!rw) return std::nullopt;
      v = *rw;
    }
    add(std::string(1, gcode::kAxisLetters[static_cast<std::size_t>(a)]) +
        decimal_mark(b, gcode::format_counts(std::llround(v * s), dm, insert_style(), d_.decimal_point_required)));
  }
  if (vector_form(m)) {
    for (int k = 0; k < 3; ++k)
      add(vector_name(k) +
          decimal_mark(b, gcode::format_number(to.vector[k], insert_style(), 6, d_.decimal_point_required)));
  }
  if (g93_scale > 1)
    add("F" + gcode::format_number(m.feed * g93_scale, default_style(), kInverseTimeDecimals,
                                   d_.decimal_point_required));
  for (const gcode::Token& t : b.tokens)
    if (t.kind == gcode::TokenKind::block_end) add("*");
  return line;
}

}  // namespace postproc::comp
