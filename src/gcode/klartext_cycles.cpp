// Klartext cycles and frames (klartext_interp.hpp): CYCL DEF 7/8/10/11/19/26/247 and the machining
// cycles, their parameters and calls (drilling cycles as drill motions), PLANE and FUNCTION blocks.
#include <algorithm>
#include <cmath>
#include <deque>
#include <optional>

#include <Eigen/Geometry>

#include "src/gcode/klartext_interp.hpp"

namespace postproc::gcode::klartext {

int Interp::cycle_number(const Block& b, double& sub) const {
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

void Interp::cycle_def(const Block& b) {
  double sub = 0;
  const int n = cycle_number(b, sub);
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
    case 247: {
      // DATUM SETTING (TNC 640 cycles manual, cycle 247): activates row Q339 of the preset table as
      // the datum, effective at its definition. The coordinates that follow refer to it, as after an
      // ISO G55: positions in the new frame are unknown until programmed; the frame is PRESET<Q339>
      // (machine file [work_offsets]). Its parameter follows on the next lines (cycle_parameter).
      preset_pending_ = true;
      preset_ = WorkOffset{2470, 0};
      preset_unknown_ = true;  // until Q339 gives the row
      cycle_params_open_ = true;
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

bool Interp::has_axis_keyword(const Block& b) const {
  for (std::size_t i = 1; i < b.tokens.size(); ++i) {
    const std::string_view s = b.text(b.tokens[i].name);
    if (s.size() == 1 && axis_index(text::upper(s[0])) >= 0) return true;
  }
  return !b.words.empty();
}

void Interp::datum_shift(const Block& b, double sub) {
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

void Interp::set_tilt(bool on) {
  if (on != tilted_) known_ &= static_cast<AxisMask>(~kLinear);  // the coordinate system turns
  tilted_ = on;
}

void Interp::plane(const Block& b) {
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

void Interp::function(const Block& b) {
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

void Interp::cycle_parameter(const Block& b) {
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
  if (preset_pending_) {  // CYCL DEF 247: only Q339, the preset's row
    if (n == 339 && parse_number(rhs, v) && v >= 0 && v <= 65535 && v == std::floor(v)) {
      preset_ = WorkOffset{2470, static_cast<std::uint16_t>(v)};
      preset_unknown_ = false;
    }
    return;
  }
  if (parse_number(rhs, v)) cycle_params_[static_cast<int>(n)] = v;
  else cycle_params_.erase(static_cast<int>(n));
}

bool Interp::drill_call(const Block& b, Span at, MotionSink& out) {
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
  m.work_offset = preset_;
  m.work_offset_rewritten = preset_unknown_;
  m.tool_length_active = tool_active_;
  m.tool_length_h = static_cast<std::uint16_t>(std::max(0, tool_number_));
  m.tilted_plane = tilted_;
  m.spindle_turning = spindle_;
  m.inch_source = inch_;
  m.words_transformed = true;  // the cycle's levels are Q parameters of CYCL DEF, not words of this block
  out.motion(m, b);
  return true;
}

void Interp::cycle_call(const Block& b, Span at, MotionSink& out) {
  if (cycle_ < 0 || cycle_ == 9 || cycle_ == 32 || cycle_ == 13) return;
  if (find_keyword(b, "PAT") < 0 && find_keyword(b, "POS") < 0 && drill_call(b, at, out)) return;
  warn(b, at, codes::kVendorCycle,
       fmt::format("machining cycle {} is called here; its moves are not expanded by this version, so positions "
                   "after it are unknown (the tool axis at least) until the program states them",
                   cycle_));
  known_ &= static_cast<AxisMask>(find_keyword(b, "PAT") >= 0 ? ~kLinear : ~(1u << axes().n));
}

}  // namespace postproc::gcode::klartext
