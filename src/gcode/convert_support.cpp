// Convert helpers: modal tracking over G words, literal spans of words.
#include "src/gcode/convert_support.hpp"

#include <cmath>
#include <string>

#include "src/gcode/number_text.hpp"
#include "src/gcode/klartext.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode {

int g_code10(const Word& w) {
  if (w.letter != 'G' || !plain_letter(w) || w.kind != ValueKind::number) return -1;
  const double c = w.number * 10;
  const long r = std::lround(c);
  if (r < 0 || r >= 20000 || std::abs(c - static_cast<double>(r)) > 1e-6) return -1;
  return static_cast<int>(r);
}

int implied_decimals(const Dialect& d, const Word& w, std::string_view literal, bool inch) {
  if (d.integer_input == Dialect::IntegerInput::calculator || !plain_letter(w)) return 0;
  if (literal.find('.') != std::string_view::npos) return 0;
  if (std::string_view("XYZUVWABCIJKRQ").find(w.letter) == std::string_view::npos) return 0;
  const bool angle = w.letter >= 'A' && w.letter <= 'C';
  return inch && !angle ? 4 : 3;
}

std::optional<Span> literal_span(const Block& b, const Word& w) {
  if (w.kind == ValueKind::number) return w.value;
  if (w.kind != ValueKind::absolute_fn && w.kind != ValueKind::incremental_fn) return std::nullopt;
  const std::string_view t = b.text(w.value);
  const auto open = t.find('('), close = t.rfind(')');
  if (open == std::string_view::npos || close == std::string_view::npos || close <= open) return std::nullopt;
  auto begin = static_cast<std::uint32_t>(open + 1), end = static_cast<std::uint32_t>(close);
  while (begin < end && t[begin] == ' ') ++begin;
  while (end > begin && t[end - 1] == ' ') --end;
  double v = 0;
  if (!parse_number(t.substr(begin, end - begin), v)) return std::nullopt;
  return Span{w.value.begin + begin, w.value.begin + end};
}

void ModalTrack::update(const Block& b) {
  block_g.clear();
  units_in_block = false;
  if (dialect->id == DialectId::heidenhain) {
    // Klartext has no G words; only the path blocks' axis words are positions (CC X Y is a centre,
    // CYCL DEF 7.1 X a shift, BLK FORM X a blank corner).
    using klartext::Verb;
    const Verb v = klartext::verb_of(b);
    axis_words_data = !(v == Verb::l || v == Verb::ln || v == Verb::lp || v == Verb::c || v == Verb::cr ||
                        v == Verb::ct || v == Verb::cp || v == Verb::m_only);
    return;
  }
  for (std::size_t i = 0; i < b.words.size(); ++i) {
    const int c = g_code10(b.words[i]);
    if (c < 0) continue;
    if (const GCodeDef* def = dialect->find_g(static_cast<std::uint16_t>(c))) block_g.push_back({def, i});
  }
  const bool siemens = dialect->id == DialectId::siemens;
  if (siemens)
    for (const Token& t : b.tokens) {
      if (t.kind != TokenKind::keyword) continue;
      const std::string name = text::upper(b.text(t.name));
      if (name == "DIAMON" || name == "DIAM90") diameter = true;
      if (name == "DIAMOF") diameter = false;
      // CIP / CT are group-1 motion commands (arcs given by other words than G2/G3).
      if (name == "CIP") motion = GMeaning::arc_cip;
      if (name == "CT") motion = GMeaning::arc_tangent;
    }
  bool motion_given = false;
  for (const G& g : block_g) {
    switch (g.def->meaning) {
      case GMeaning::inch:
      case GMeaning::mm: {
        const bool to_inch = g.def->meaning == GMeaning::inch;
        inch = to_inch;
        units_in_block = true;
        // Sinumerik G70/G71 change geometry only; feeds stay in the basic system (G700/G710 change both).
        feed_inch = !siemens || g.def->code10 >= 7000 ? to_inch : dialect->basic_inch;
        break;
      }
      case GMeaning::feed_inverse_time: feed_mode = FeedMode::inverse_time; break;
      case GMeaning::feed_per_minute: feed_mode = FeedMode::per_minute; break;
      case GMeaning::feed_per_rev: feed_mode = FeedMode::per_rev; break;
      case GMeaning::absolute: absolute = true; break;
      case GMeaning::arc_absolute: arc_absolute = true; break;
      case GMeaning::arc_incremental: arc_absolute = false; break;
      case GMeaning::diameter_mode: diameter = true; break;
      case GMeaning::radius_mode: diameter = false; break;
      case GMeaning::incremental: absolute = false; break;
      case GMeaning::plane_xy: plane = Plane::xy; break;
      case GMeaning::plane_zx: plane = Plane::zx; break;
      case GMeaning::plane_yz: plane = Plane::yz; break;
      case GMeaning::css_on: css = true; break;
      case GMeaning::css_off: css = false; break;
      case GMeaning::tcp_vector_on: tcp_vector = true; break;
      case GMeaning::tcp_on:
      case GMeaning::tool_length_on:
      case GMeaning::tool_length_off: tcp_vector = false; break;
      case GMeaning::cancel_motion:
        if (!motion_given) {
          motion = dialect->g80_keeps_motion ? interp_motion : GMeaning::cancel_motion;
          if (dialect->g80_keeps_motion) motion_code10 = interp_code10;
        }
        break;
      case GMeaning::polar_coord_on: polar_command = true; break;
      case GMeaning::polar_coord_off: polar_command = false; break;
      default: break;
    }
    if (g.def->group == GGroup::motion) {
      motion = g.def->meaning;
      motion_code10 = g.def->code10;
      motion_given = true;
      if (motion == GMeaning::rapid || motion == GMeaning::linear || motion == GMeaning::arc_cw ||
          motion == GMeaning::arc_ccw) {
        interp_motion = motion;
        interp_code10 = motion_code10;
      }
    }
  }
}

const ModalTrack::G* ModalTrack::find(GMeaning m) const {
  for (const G& g : block_g)
    if (g.def->meaning == m) return &g;
  return nullptr;
}

const ModalTrack::G* ModalTrack::block_motion() const {
  // The last one: Fanuc takes the last G code of a group given twice in a block (the interpreter
  // refuses that elsewhere).
  for (auto g = block_g.rbegin(); g != block_g.rend(); ++g)
    if (g->def->group == GGroup::motion) return &*g;
  return nullptr;
}

const ModalTrack::G* ModalTrack::axis_consumer() const {
  for (const G& g : block_g) {
    switch (g.def->meaning) {
      case GMeaning::dwell:
      case GMeaning::set_offsets_g10:
      case GMeaning::local_offset:
      case GMeaning::set_position:
      case GMeaning::home_return:
      case GMeaning::home_set:
      case GMeaning::tilted_plane_on:
      case GMeaning::rotation_on:
      case GMeaning::tilted_plane_tool_axis:
      case GMeaning::tool_length_dynamic:
      case GMeaning::spindle_clamp:
      case GMeaning::datum_shift_heidenhain:
      case GMeaning::tilted_plane_heidenhain:
      case GMeaning::polar_pole:
      case GMeaning::probe:
      case GMeaning::scaling_on:
      case GMeaning::mirror_on:
      case GMeaning::mirror_off:
        return &g;
      default: break;
    }
  }
  return nullptr;
}

int ModalTrack::axis_of(const Word& w) const {
  // Heidenhain Klartext: X+10 absolute, IX+10 incremental (TNC 640 "Path functions").
  // The Klartext lexer stores the axis of IX…IC as index = 1 + axis.
  if (dialect->id == DialectId::heidenhain && w.name_len == 2 && w.letter == 'I')
    return w.index >= 1 && w.index <= kAxisCount ? w.index - 1 : -1;
  if (!plain_letter(w)) return -1;
  if (dialect->lathe && dialect->id == DialectId::fanuc && dialect->gcode_system == 'A' &&
      (w.letter == 'U' || w.letter == 'W' || w.letter == 'H'))
    return w.letter == 'U' ? 0 : (w.letter == 'W' ? 2 : 5);
  return axis_index(w.letter);
}

bool ModalTrack::incremental(const Word& w) const {
  if (dialect->id == DialectId::heidenhain) return w.name_len == 2 && w.letter == 'I';
  if (w.kind == ValueKind::incremental_fn) return true;
  if (w.kind == ValueKind::absolute_fn) return false;
  if (dialect->lathe && dialect->id == DialectId::fanuc && dialect->gcode_system == 'A' &&
      (w.letter == 'U' || w.letter == 'W' || w.letter == 'H'))
    return true;
  return !absolute && !has(GMeaning::machine_coords);
}

}  // namespace postproc::gcode
