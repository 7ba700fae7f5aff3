// convert --units / --decimals. Only words whose meaning as a length or feed is certain are
// scaled; anything else in a block that changes units is refused (PP-E502) rather than guessed.
#include "src/gcode/convert_units.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "postproc/gcode/lexer.hpp"
#include "src/gcode/number_text.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode {
namespace {
using text::upper;

constexpr double kInch = 25.4;


/// Reads a literal that may contain blanks (LinuxCNC "- 1.5").
double literal_value(std::string_view t) {
  std::string compact;
  for (char c : t)
    if (c != ' ' && c != '\t') compact += c;
  double v = 0;
  parse_number(compact, v);
  return v;
}

/// Constructs whose words hold lengths this pass cannot see or convert (interpreter codes).
struct Unconvertible {
  std::string_view code, what;
};
constexpr Unconvertible kUnconvertible[] = {
    {"PP-U201", "a turning cycle (its depths and allowances are not converted)"},
    {"PP-U202", "threading (lead and depths are not converted)"},
    {"PP-U203", "a spline (its control words are not converted)"},
    {"PP-U204", "polar coordinate interpolation (its hypothetical axis is not converted)"},
    {"PP-U205", "cylindrical interpolation"},
    {"PP-U210", "a vendor cycle call (its arguments hold lengths)"},
    {"PP-U211", "a subprogram call (the called program's lengths are not converted)"},
    {"PP-U212", "control flow (its conditions may compare lengths)"},
    {"PP-U214", "a parameter assignment or declaration (its value may be a length)"},
    {"PP-U216", "a macro call (its arguments may be lengths)"},
};

constexpr std::string_view kSiemensFrameValues[] = {"ROT", "AROT", "SCALE", "ASCALE", "MIRROR", "AMIRROR", "RPL"};

}  // namespace

int converted_decimals(int source_decimals, bool to_inch) {
  return to_inch ? std::max(source_decimals + 1, 4) : std::max(source_decimals - 1, 3);
}

std::string_view unit_word(const Dialect& d, bool inch) {
  switch (d.id) {
    case DialectId::siemens: return inch ? "G700" : "G710";
    case DialectId::heidenhain_iso: return inch ? "G70" : "G71";
    default: return inch ? "G20" : "G21";
  }
}

UnitsPass::UnitsPass(const Dialect& d, const ConvertOptions& opt, std::string_view file, DiagnosticSink& sink,
                     ConvertResult& result)
    : d_(d), opt_(opt), file_(file), sink_(sink), r_(result), track_(d) {}

UnitsPass::Scale UnitsPass::scale(bool from_inch, bool to_inch) {
  if (from_inch == to_inch) return Scale::none;
  return to_inch ? Scale::to_inch : Scale::to_mm;
}

void UnitsPass::refuse(const Block& b, Span at, const std::string& why) {
  report_at(LexContext{file_, &sink_}, b, at, Severity::error, codes::kUnitsRefused,
            fmt::format("--units refused: {}; convert cannot change this program's units exactly", why));
}

void UnitsPass::block(const Block& b, const BlockDiags& diags, BlockEditor& ed, std::vector<std::string>& before) {
  if (b.leader) return;
  track_.update(b);
  const bool address = b.has_n || !b.words.empty();
  if (address && !seen_address_) {
    seen_address_ = true;
    // A program that does not state its units before its first block runs in the control's
    // default (taken as mm, as the interpreter does): state the target units there.
    if (opt_.units && !track_.units_in_block) {
      const bool inch = *opt_.units == Units::inch;
      bool star = false;
      for (const Token& t : b.tokens) star = star || t.kind == TokenKind::block_end;
      before.push_back(fmt::format("{}{}", unit_word(d_, inch), star ? " *" : ""));
      out_inch_ = out_feed_inch_ = inch;
      ++r_.unit_words;
    }
  }
  if (opt_.units) unit_words(b, ed);
  start_carry_ = carry_;
  const Scale s_len = opt_.units ? scale(track_.inch, out_inch_) : Scale::none;
  const Scale s_feed = opt_.units ? scale(track_.feed_inch, out_feed_inch_) : Scale::none;
  if (s_len != Scale::none) check_constructs(b, diags);
  for (const Word& w : b.words) {
    if (g_code10(w) >= 0) continue;
    const Class c = (s_len != Scale::none || s_feed != Scale::none) ? classify(b, w) : Class::none;
    const Scale s = c == Class::length ? s_len : (c == Class::feed ? s_feed : Scale::none);
    if (c == Class::unknown && s_len != Scale::none) {
      refuse(b, w.span, fmt::format("the length meaning of '{}' here is not known", b.text(w.span)));
    } else if (s != Scale::none) {
      scale_word(b, w, c, s, ed);
    } else {
      pad_word(b, w, ed);
    }
  }
  // Positions after a home return or a change of work offset come from the control.
  if (track_.has(GMeaning::home_return)) {
    bool named = false;
    for (const Word& w : b.words)
      if (const int a = track_.axis_of(w); a >= 0) {
        carry_[static_cast<std::size_t>(a)] = 0;
        named = true;
      }
    if (!named) carry_.fill(0);
  }
  if (track_.has(GMeaning::work_offset)) carry_.fill(0);
}

void UnitsPass::unit_words(const Block& b, BlockEditor& ed) {
  const bool inch = *opt_.units == Units::inch;
  for (const auto& g : track_.block_g) {
    if (g.def->meaning != GMeaning::inch && g.def->meaning != GMeaning::mm) continue;
    const std::uint16_t c = g.def->code10;
    std::uint16_t target = inch ? 200 : 210;
    if (d_.id == DialectId::siemens) {
      target = c >= 7000 ? (inch ? 7000 : 7100) : (inch ? 700 : 710);
    } else if (d_.id == DialectId::heidenhain_iso) {
      target = inch ? 700 : 710;
    }
    out_inch_ = inch;
    out_feed_inch_ = d_.id != DialectId::siemens || c >= 7000 ? inch : d_.basic_inch;
    if (target == c) continue;
    const Word& w = b.words[g.word];
    const std::string_view old = b.text(w.value);
    const auto dot = old.find('.');
    const std::string_view int_part = old.substr(0, dot);
    std::string digits = fmt::format("{}", target / 10);
    // Keep the source's zero padding (G021 → G020) and anything after a point.
    if (int_part.size() > digits.size() && int_part[0] == '0') digits.insert(0, int_part.size() - digits.size(), '0');
    if (dot != std::string_view::npos) digits += old.substr(dot);
    ed.replace(w.value, std::move(digits));
    ++r_.unit_words;
  }
}

void UnitsPass::check_constructs(const Block& b, const BlockDiags& diags) {
  for (const BlockDiag& d : diags)
    for (const auto& u : kUnconvertible)
      if (d.code == u.code) refuse(b, span_of(d), fmt::format("the block has {} ({})", u.what, u.code));
  if (d_.id != DialectId::siemens || b.words.empty()) return;
  for (const Token& t : b.tokens) {
    if (t.kind != TokenKind::keyword) continue;
    const std::string name = upper(b.text(t.name));
    for (std::string_view k : kSiemensFrameValues)
      if (name == k) refuse(b, t.span, fmt::format("{} takes angles or factors, not lengths, in its axis words", name));
  }
}

UnitsPass::Class UnitsPass::classify(const Block& b, const Word& w) const {
  const auto* consumer = track_.axis_consumer();
  const GMeaning cm = consumer ? consumer->def->meaning : GMeaning::unknown;
  const GMeaning mode = track_.motion;
  const bool arc = mode == GMeaning::arc_cw || mode == GMeaning::arc_ccw;
  const bool drill = mode == GMeaning::drill_cycle;
  const bool fanuc = d_.id == DialectId::fanuc;
  const bool linuxcnc = d_.id == DialectId::linuxcnc;
  if (!plain_letter(w)) {
    const std::string name = upper(b.text(w.name));
    if (name == "CR" || name == "RP") return Class::length;  // arc radius, polar radius
    if (name == ",C" || name == ",R") return Class::length;  // Fanuc chamfer / corner radius
    if (name == ",A") return Class::none;                     // Fanuc direct-drawing angle
    if ((w.letter == 'A' || w.letter == 'B' || w.letter == 'C') && w.index != 0) return Class::none;  // tool vector
    if (name == "TU" || name == "AP" || name == "AR" || name == "SF") return Class::none;  // turns, angles
    return Class::unknown;
  }
  switch (w.letter) {
    case 'G':
      return w.kind == ValueKind::number ? Class::none : Class::unknown;
    case 'D':
      // LinuxCNC G41.1/G42.1 D is the cutter diameter (program units); elsewhere D names a tool or offset.
      if (linuxcnc)
        if (const auto* g = track_.find(GMeaning::cutter_comp); g && (g->def->code10 == 411 || g->def->code10 == 421))
          return Class::length;
      return Class::none;
    case 'M': case 'T': case 'O': case 'N': case 'L': case 'H': case 'A': case 'B': case 'C':
      return Class::none;
    case 'S':
      return track_.css ? Class::unknown : Class::none;  // G96: surface speed in m/min or ft/min
    case 'F':
      if (cm == GMeaning::dwell) return Class::none;  // Sinumerik G4 F = seconds
      return track_.feed_mode == FeedMode::inverse_time ? Class::none : Class::feed;
    case 'X': case 'Y': case 'Z': case 'U': case 'V': case 'W':
      if (cm == GMeaning::dwell) return fanuc && (w.letter == 'X' || w.letter == 'U') ? Class::none : Class::unknown;
      return track_.polar_command ? Class::unknown : Class::length;
    case 'I': case 'J': case 'K':
      if (cm == GMeaning::tilted_plane_on || cm == GMeaning::rotation_on) return Class::none;  // angles / axis
      if (consumer) return Class::unknown;
      if (arc) return Class::length;
      if (drill && w.letter == 'K' && fanuc) return Class::none;  // repeat count
      if (track_.tcp_vector && (mode == GMeaning::rapid || mode == GMeaning::linear)) return Class::none;
      return Class::unknown;
    case 'R':
      if (d_.id == DialectId::siemens) return Class::unknown;  // R parameters
      if (cm == GMeaning::rotation_on) return Class::none;      // G68 R = angle
      if (cm == GMeaning::set_offsets_g10) return Class::length;
      if (consumer) return Class::unknown;
      return arc || drill ? Class::length : Class::unknown;
    case 'Q':
      if (track_.has(GMeaning::nurbs_or_ai_contour)) return Class::none;  // G5.1 Q1
      if (linuxcnc && track_.has(GMeaning::path_control)) return Class::length;  // G64 P Q
      if (consumer) return Class::unknown;
      if (drill) {
        const auto c = track_.motion_code10;
        return c == 730 || c == 830 || c == 760 || c == 870 ? Class::length : Class::unknown;  // peck, shift
      }
      return Class::unknown;
    case 'P':
      if (cm == GMeaning::dwell || cm == GMeaning::set_offsets_g10 || cm == GMeaning::tilted_plane_on)
        return Class::none;
      if (track_.has(GMeaning::work_offset) || track_.has(GMeaning::state_only) ||
          track_.has(GMeaning::nurbs_or_ai_contour))
        return Class::none;
      if (linuxcnc && track_.has(GMeaning::path_control)) return Class::length;
      for (const Word& o : b.words)
        if (o.letter == 'M' && o.kind == ValueKind::number && (o.number == 98 || o.number == 99)) return Class::none;
      if (consumer) return Class::unknown;
      return drill || arc ? Class::none : Class::unknown;  // dwell, turns
    default:
      return Class::unknown;
  }
}

void UnitsPass::scale_word(const Block& b, const Word& w, Class c, Scale s, BlockEditor& ed) {
  const auto lit = literal_span(b, w);
  if (!lit) {
    refuse(b, w.span, fmt::format("'{}' is given by an expression or parameter; its value in the new units is not "
                                  "known",
                                  b.text(w.span)));
    return;
  }
  const std::string_view text = b.text(*lit);
  // Fanuc standard input: "X100" is 100 increments (0.1 mm), and precise to them.
  const int implied = implied_decimals(d_, w, text, track_.inch);
  const double v = literal_value(text) * std::pow(10.0, -implied);
  if (v != 0 && ambiguous_integer(d_, implied)) {
    refuse(b, w.span, fmt::format("'{}' has no decimal point and the control's integer input is not known; pass "
                                  "--integer-input increment|calculator",
                                  b.text(w.span)));
    return;
  }
  NumberStyle st = detect_style(text);
  if (implied > 0) st = NumberStyle{st.plus_sign, true, implied, false, false};
  const int min = plain_letter(w) ? opt_.min_decimals_for(w.letter) : -1;
  if (min >= 0) st.trailing_zeros = true;  // --decimals asks for a fixed width
  const bool to_inch = s == Scale::to_inch;
  st.decimals = std::max(converted_decimals(st.decimals, to_inch), min);
  const double exact = to_inch ? v / kInch : v * kInch;
  const int axis = c == Class::length ? track_.axis_of(w) : -1;
  const auto* consumer = track_.axis_consumer();
  const GMeaning cm = consumer ? consumer->def->meaning : GMeaning::unknown;
  const bool sets = cm == GMeaning::set_position || cm == GMeaning::spindle_clamp;
  const bool drill_depth = track_.motion == GMeaning::drill_cycle &&
                           axis == (track_.plane == Plane::xy ? 2 : track_.plane == Plane::zx ? 1 : 0);
  const bool position = axis >= 0 && (consumer == nullptr || sets) && !drill_depth;
  const bool inc = position && !sets && track_.incremental(w);
  const auto ax = static_cast<std::size_t>(axis < 0 ? 0 : axis);
  double target = inc ? exact - carry_[ax] : exact;
  // An incremental centre (I J K) is measured from the printed start point: take the start's
  // rounding out of it, so the printed centre is within half a digit of the exact one too.
  const bool arc = track_.motion == GMeaning::arc_cw || track_.motion == GMeaning::arc_ccw;
  if (arc && c == Class::length && plain_letter(w) && w.letter >= 'I' && w.letter <= 'K' && !track_.arc_absolute &&
      w.kind != ValueKind::absolute_fn) {
    const auto centre_axis = static_cast<std::size_t>(w.letter - 'I');
    target -= start_carry_[centre_axis] / (centre_axis == 0 && track_.diameter ? 2.0 : 1.0);
  }
  const std::string out = format_number(target, st, 0, d_.decimal_point_required);
  const double printed = literal_value(out);
  if (position) carry_[ax] = inc ? carry_[ax] + printed - exact : printed - exact;
  if (v == 0 && printed == 0) {
    pad_word(b, w, ed);  // zero in any unit: kept as written ("X0" stays "X0", not "X0.")
    return;
  }
  ed.replace(*lit, out);
  ++r_.scaled_words;
}

void UnitsPass::pad_word(const Block& b, const Word& w, BlockEditor& ed) {
  if (!plain_letter(w)) return;
  const int min = opt_.min_decimals_for(w.letter);
  if (min < 0 || (w.letter == 'R' && d_.id == DialectId::siemens)) return;
  const auto lit = literal_span(b, w);
  if (!lit) {
    if (w.kind != ValueKind::string) ++r_.decimals_expression;  // the interpreter warned (PP-U213)
    return;
  }
  const std::string_view text = b.text(*lit);
  const int implied = implied_decimals(d_, w, text, track_.inch);
  if (implied > 0 && literal_value(text) != 0) {
    // "X100" read as increments: written with a point it keeps its value only as "X0.1000".
    std::int64_t counts = 0;
    if (min <= implied) {
      if (min < implied) ++r_.decimals_finer;
      return;
    }
    if (ambiguous_integer(d_, implied) || !literal_counts(text, 0, counts)) {
      ++r_.decimals_integer;  // its value depends on --integer-input: left as written
      return;
    }
    const NumberStyle st{detect_style(text).plus_sign, true, implied, false, false};
    ed.replace(*lit, pad_decimals(format_counts(counts, implied, st, true), min));
    ++r_.decimals_raised;
    return;
  }
  const int have = detect_style(text).decimals;
  if (have < min) {
    ed.replace(*lit, pad_decimals(text, min));
    ++r_.decimals_raised;
  } else if (have > min) {
    ++r_.decimals_finer;
  }
}

}  // namespace postproc::gcode
