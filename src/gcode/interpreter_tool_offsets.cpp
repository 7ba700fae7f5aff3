// Modal interpreter, part 3: what the controller adds to the programmed point for the tool — tool
// length offsets (G43/G43.1/G43.2/G49, Fanuc G43.4/G43.5 H, Sinumerik T/D) and cutter radius
// compensation (G41/G42) — and when that leaves a position the program does not state.
#include <cmath>

#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {
namespace {

constexpr AxisMask kZ = bit(Axis::z);


}  // namespace

namespace {

/// Entry `number` of a tool table: 0 for number 0 (H0 / D0 / tool 0: no offset — Fanuc H00 is
/// always 0, LinuxCNC "an offset value of zero"); what the program wrote (G10) before the file's
/// value; false when unknown.
bool table_entry(long number, bool all_unknown, const std::map<std::uint32_t, std::optional<double>>& written,
                 const std::map<std::uint32_t, double>& file, double& mm) {
  if (number == 0) {
    mm = 0;
    return true;
  }
  if (all_unknown) return false;
  if (const auto w = written.find(static_cast<std::uint32_t>(number)); w != written.end()) {
    if (w->second) mm = *w->second;
    return w->second.has_value();
  }
  const auto it = file.find(static_cast<std::uint32_t>(number));
  if (it == file.end()) return false;
  mm = it->second;
  return true;
}

}  // namespace

bool Interpreter::table_length(long number, double& mm) const {
  return table_entry(number, tool_table_unknown_, lengths_written_, d_.tool_lengths, mm);
}

bool Interpreter::table_radius(long number, double& mm) const {
  return table_entry(number, tool_table_unknown_, radii_written_, d_.tool_radii, mm);
}

void Interpreter::tool_table_write(const Block& b, const BlockWords& w, long l, long p) {
  (void)b;
  if (p < 0) {  // the entry's number is not known: no entry is
    tool_table_unknown_ = true;
    return;
  }
  const auto n = static_cast<std::uint32_t>(p);
  if (d_.id == DialectId::linuxcnc) {
    // LinuxCNC G-code reference "G10 L1 Set Tool Table": Z is the length offset, absolute in the
    // program's units (G91 does not apply), kept until the next write; the offset in force changes
    // only at the next G43. L10/L11 compute it from the machine position (not known here): the
    // entry becomes unknown. (R and Q, the radius and orientation: linuxcnc_tool_setup.)
    if (w.axis_present & bit(Axis::z)) {
      if (l == 1 && !(w.axis_unresolved & bit(Axis::z))) lengths_written_[n] = to_mm(2, w.axis[2]);
      else lengths_written_[n] = std::nullopt;
    }
    return;
  }
  // Fanuc (B-64484EN "Tool compensation values (G10)"): L10/L11 write the geometry/wear of length
  // offset H p (L1 on older series), L12/L13 the geometry/wear of radius D p; the sum is what the
  // control applies, and the other part is not known here: the entry becomes unknown.
  if (l == 1 || l == 10 || l == 11) lengths_written_[n] = std::nullopt;
  if (l == 12 || l == 13) radii_written_[n] = std::nullopt;
}

void Interpreter::tool_length_change(const Block& b, const BlockWords& w, Span at, double mm, bool known) {
  const bool was_known = s_.tool_length_known;
  const double old = s_.tool_length;
  s_.tool_length = mm;
  s_.tool_length_known = known;
  if (was_known && known && old == mm) return;  // the same offset again: nothing changes
  if (d_.id == DialectId::linuxcnc && was_known && known) {
    // LinuxCNC applies an offset change without moving: the current point's program Z changes by
    // the difference (rs274: the next canonical Z is the old one minus the change).
    s_.position[2] -= mm - old;
    return;
  }
  if (!w.axes_consumed && w.states_absolutely(Axis::z, s_.absolute)) return;
  // Where Z was already unknown (e.g. after G28 Z) the change adds nothing the program could state.
  if (!(s_.known & kZ)) return;
  if (d_.id == DialectId::fanuc) {
    // Fanuc with the factory setting of parameter 5006#6 (TOS = 0, "Tool length compensation"):
    // the change is carried out by a Z movement in its own block, so the tip stays at the program
    // Z. A feed move right after it would be read with that Z travel blended in: refused there.
    s_.tool_z_pending = 2;
    s_.tool_length_line = b.line;
    return;
  }
  // Elsewhere (or with a length the tool table does not give) the tip's program Z after the change
  // is not stated (LinuxCNC: shifted by a length the tool table does not give; Sinumerik applies a
  // new D with the next Z travel): Z is known again only where the program states it absolutely.
  s_.known &= static_cast<AxisMask>(~kZ);
  s_.tool_z_pending = 1;
  s_.tool_length_line = b.line;
  (void)at;
}

void Interpreter::tool_offsets(const Block& b, BlockWords& w) {
  // Most blocks are bare moves: nothing here can apply to them.
  if (w.ng == 0 && w.m_count == 0 && !w.has('T') && !w.has('D')) return;
  // Tool numbers (LinuxCNC): T selects, M6 loads the selected tool, M61 Q sets the tool in the spindle.
  if (w.has('T') && !w.unresolved('T') && d_.id != DialectId::siemens) s_.selected_tool = static_cast<int>(w.whole_or('T', 0, 99999, -1));
  for (int i = 0; i < w.m_count; ++i) {
    const double m = w.m[static_cast<std::size_t>(i)];
    if (m == 6 && s_.selected_tool >= 0) {
      s_.current_tool = s_.selected_tool;
      s_.current_tool_by_m61 = false;
    }
    if (m == 61 && d_.id == DialectId::linuxcnc) {
      s_.current_tool = static_cast<int>(w.whole_or('Q', 0, 99999, -1));
      s_.current_tool_by_m61 = true;
    }
  }
  if (d_.id == DialectId::siemens && (w.has('D') || w.has('T'))) {
    // Sinumerik (840D sl Fundamentals, "Tool offset call (D)"): D selects the cutting edge whose
    // length and radius apply (D0: none) and a new T brings the default edge of the new tool. Their
    // values live in the control's tool management: the change is exact only for D0 or a D the
    // tool table gives. The edge number stays in tool_length_h for the machine file's lookup.
    long d = -1;  // no D in this block
    Span at = b.words[static_cast<std::size_t>(w.letter_word[(w.has('D') ? 'D' : 'T') - 'A'])].span;
    if (w.has('D')) {
      d = w.unresolved('D') ? -2 : w.whole_or('D', 0, 32000, -2);
      if (d == -2 && !w.unresolved('D'))
        report(b, at, Severity::error, codes::kOutOfRange,
               fmt::format("'{}': a cutting edge number is a whole number from 0 (no offset) to 32000", b.text(at)));
      if (d == -2) s_.known &= static_cast<AxisMask>(~(bit(Axis::x) | bit(Axis::y) | kZ));  // radius and length unknown
    }
    if (d >= 0) {
      s_.siemens_d = static_cast<int>(d);
      s_.tool_length_active = d != 0;
      s_.tool_length_h = static_cast<std::uint16_t>(d);
    } else if (d == -2 || w.has('T')) {
      s_.siemens_d = -1;
    }
    double mm = 0;
    const bool known = d >= 0 && table_length(d, mm);
    tool_length_change(b, w, at, mm, known);
  }
  for (int k = 0; k < w.ng; ++k) {
    const auto& g = w.g[static_cast<std::size_t>(k)];
    const Span at = b.words[static_cast<std::size_t>(g.word)].span;
    if (g.def->group == GGroup::cutter_comp) {
      const std::uint16_t c = g.def->code10;
      if (d_.id == DialectId::linuxcnc) {  // interpreter_cutter.cpp
        if (c == 400) linuxcnc_comp_off();
        else linuxcnc_comp_on(b, w, c, at);
        continue;
      }
      if (c == 400) {
        s_.cutter_comp = 0;
        continue;
      }
      s_.cutter_comp = (c == 420 || c == 421 || c == 422) ? 2 : 1;
      s_.cutter_comp_reported = false;
      s_.cutter_comp_line = b.line;
      double r = 0;
      bool known = false;
      if (c == 412 || c == 422) {
        known = false;  // Fanuc G41.2/G42.2: 3-D cutter compensation along the tool vector
      } else if (d_.id == DialectId::linuxcnc && (c == 411 || c == 421)) {
        // LinuxCNC G41.1/G42.1 D: the diameter is in the block.
        known = w.has('D') && !w.unresolved('D');
        r = known ? to_mm(0, w.get('D')) / 2 : 0;
      } else {
        long n = -1;
        if (d_.id == DialectId::siemens) n = s_.siemens_d;
        else if (w.has('D')) n = w.whole_or('D', 0, 99999, -1);
        else if (d_.id == DialectId::linuxcnc) n = s_.current_tool;
        if (n == 0) known = true;  // D0 / tool 0: radius 0
        else if (n > 0) {
          known = table_radius(n, r);
          if (!known) r = 0;
        }
      }
      s_.cutter_radius = r;
      s_.cutter_radius_known = known;
      continue;
    }
    switch (g.def->meaning) {
      case GMeaning::tool_length_on:
        if (g.def->code10 == 440) {
          // Fanuc G44 subtracts the offset: postproc's machine model has no negative tool.
          report(b, at, Severity::warning, codes::kToolLengthZ,
                 "G44 (negative tool length offset) is not resolved by this version; Z after it is unknown — "
                 "use G43 with a positive length");
          s_.tool_length_active = true;
          s_.tool_length_h = 0;
          s_.tool_length_known = false;
          s_.known &= static_cast<AxisMask>(~kZ);
          break;
        }
        [[fallthrough]];
      case GMeaning::tcp_on:
      case GMeaning::tcp_vector_on: {
        const bool additional = d_.id == DialectId::linuxcnc && g.def->code10 == 432;  // G43.2
        if (additional && (!w.has('H') || w.axis_present != 0)) {
          // rs274 2.9 stops on each of these (its messages quoted); the offset after it is unknown.
          const char* why =
              w.has('H')            ? "G43.2 with H and axis words (rs274: \"G43.2: Can not have both H and axis words\")"
              : w.axis_present == 0 ? "G43.2 without H or axis words (rs274: \"G43.2: No axes specified and H word missing\")"
                                    : "G43.2 with axis words and no H (rs274 2.9: \"Requested tool -1 not found in the tool "
                                      "table\"); give the added offset as G43.2 H<tool> or set the whole offset with G43.1";
          report(b, at, Severity::error, codes::kControllerRefuses,
                 fmt::format("{}: LinuxCNC stops the program here", why));
          w.axes_consumed = true;
          s_.tool_length_known = false;
          s_.known &= static_cast<AxisMask>(~kZ);
          break;
        }
        long h = -1;
        if (w.has('H')) h = w.whole_or('H', 0, 99999, -1);
        else if (d_.id == DialectId::linuxcnc && !additional) h = s_.current_tool;  // G43: the loaded tool
        else if (s_.tool_length_active && !additional) h = s_.tool_length_h;      // Fanuc: H stays modal
        double mm = 0;
        bool known = h >= 0 && table_length(h, mm);
        if (additional) {
          // LinuxCNC G43.2 H n: adds tool n's length to the offset in effect (the axis-word form is
          // refused above, as rs274 2.9 stops on it).
          known = known && s_.tool_length_known;
          mm += s_.tool_length;
        }
        s_.tool_length_active = true;
        if (!additional) s_.tool_length_h = static_cast<std::uint16_t>(h > 0 ? h : 0);
        s_.tcp = g.def->meaning == GMeaning::tcp_on          ? TcpMode::fanuc_g43_4
                 : g.def->meaning == GMeaning::tcp_vector_on ? TcpMode::fanuc_g43_5
                                                              : s_.tcp;
        if (g.def->meaning == GMeaning::tool_length_on && s_.tcp != TcpMode::siemens_traori &&
            s_.tcp != TcpMode::heidenhain_m128)
          s_.tcp = TcpMode::off;
        tool_length_change(b, w, at, mm, known);
        break;
      }
      case GMeaning::tool_length_dynamic: {
        // LinuxCNC G43.1: the axis words are the offsets themselves, never a move.
        w.axes_consumed = true;
        s_.tool_length_active = true;
        s_.tool_length_h = 0;
        for (int a = 0; a < kAxisCount; ++a)
          if (a != 2 && (w.axis_present & (1u << a))) {
            const Span ws = b.words[static_cast<std::size_t>(w.axis_word[static_cast<std::size_t>(a)])].span;
            report(b, ws, Severity::warning, codes::kToolOffsetAxis,
                   fmt::format("G43.1 offset along {} ('{}') is not resolved by this version (only Z is); the "
                               "position of {} after it is unknown",
                               kAxisLetters[static_cast<std::size_t>(a)], b.text(ws), kAxisLetters[static_cast<std::size_t>(a)]));
            s_.known &= static_cast<AxisMask>(~(1u << a));
          }
        const bool z = (w.axis_present & kZ) != 0;
        tool_length_change(b, w, at, z ? to_mm(2, w.axis[2]) : 0.0, !(w.axis_unresolved & kZ));
        break;
      }
      case GMeaning::tool_length_off:
        s_.tool_length_active = false;
        s_.tool_length_h = 0;
        if (s_.tcp == TcpMode::fanuc_g43_4 || s_.tcp == TcpMode::fanuc_g43_5) s_.tcp = TcpMode::off;
        tool_length_change(b, w, at, 0.0, true);
        break;
      default: break;
    }
  }
}

void Interpreter::cutter_comp_motion(const Block& b, Span at) {
  if (s_.cutter_comp == 0 || s_.cutter_comp_reported) return;
  if (offset_active()) return;  // LinuxCNC: the tool-centre path is computed (interpreter_cutter.cpp)
  if (s_.cutter_radius_known && s_.cutter_radius == 0) return;  // D0 / a zero radius: the path is the program
  s_.cutter_comp_reported = true;
  report(b, at, Severity::warning, codes::kCutterComp,
         fmt::format("cutter radius compensation ({} since line {}) with {}: the tool centre runs offset from the "
                     "programmed contour, which this version does not compute; give the radius 0 (D0, or the "
                     "machine file's [tool.radii]) when the CAM path is already the tool centre, or compensate "
                     "a program without G41/G42",
                     s_.cutter_comp == 1 ? "G41" : "G42", s_.cutter_comp_line,
                     s_.cutter_radius_known ? fmt::format("a radius of {:g} mm", s_.cutter_radius)
                                            : std::string("a radius the tool table does not give")));
}

}  // namespace postproc::gcode
