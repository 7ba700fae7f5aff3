// Modal interpreter: the commands that move the program's origin rather than the tool — G10 (work
// offsets and tool-table writes), G92 / G52 and the G92.1 / G92.2 / G92.3 family, Sinumerik
// TRANS/ATRANS/ROT frames. Each rule names the manual section (or rs274ngc function) it follows.
#include <cmath>

#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {

void Interpreter::siemens_frame(const Block& b, const BlockWords& w) {
  // Siemens frames: TRANS/ATRANS X Y Z shift like G52; ROT/SCALE/MIRROR with values are unresolved.
  const bool has_values = w.axis_present != 0;
  if (frame_keyword_ == 3 && has_values) {
    s_.known = 0;
    report(b, frame_span_, Severity::warning, codes::kTiltedPlane,
           "programmable frame rotation/scaling/mirroring is not resolved; positions after it are unknown");
  } else if (!has_values && (frame_keyword_ == 1 || frame_keyword_ == 3)) {
    // TRANS / ROT without values reset the programmable frame: the same point now reads offset more.
    s_.position += s_.local_offset;
    s_.local_offset.setZero();
  } else {
    AxisVector shift = AxisVector::Zero();
    for (int a = 0; a < kAxisCount; ++a)
      if (w.axis_present & (1u << a)) shift[a] = to_mm(a, w.axis[a]);
    const AxisVector old = s_.local_offset;
    if (frame_keyword_ == 1) {
      s_.local_offset = shift;
    } else {
      s_.local_offset += shift;
    }
    s_.position -= s_.local_offset - old;
  }
}

void Interpreter::set_offsets(const Block& b, BlockWords& w) {
  w.axes_consumed = true;
  const long l = w.whole_or('L', 0, 1000, 0);
  const long p = w.whole_or('P', 0, 10000, -1);
  const std::uint16_t wc = s_.work_offset.code10;
  if (d_.id == DialectId::fanuc) {
    // B-64484EN "Changing workpiece coordinate system by programmed command (G10)": G10 L2 P0 writes
    // the external work offset (it shifts every work frame), L2 P1–P6 G54–G59, L20 Pn the
    // additional offset G54.1 Pn; values are absolute in G90, added in G91. G10 never moves the
    // tool: the active frame shifts by new - old value, and the old value is a table entry this
    // version does not know, so the named axes of the active frame become unknown.
    const bool l_known = w.has('L') && !w.unresolved('L');
    const bool p_known = w.has('P') && !w.unresolved('P') && p >= 0;
    bool active = false;
    if (!l_known) active = true;  // which table is written is not known
    else if (l == 2) active = !p_known || p == 0 || (wc >= 540 && wc <= 590 && wc % 10 == 0 && p == (wc - 530) / 10);
    else if (l == 20) active = !p_known || (wc == 541 && s_.work_offset.p == p);
    if (active) s_.known &= static_cast<AxisMask>(~w.axis_present);
    if (!l_known || (l >= 10 && l <= 13) || l == 1) tool_table_write(b, w, l_known ? l : 10, p_known ? p : -1);
    // The table entry written: L2 P0 is the external offset (every system moves), P1-P6 G54-G59,
    // L20 Pn G54.1 Pn; with L or P not known, any of them.
    if (!l_known || ((l == 2 || l == 20) && !p_known) || (l == 2 && p == 0)) work_table_write(-1);
    else if (l == 2 && p >= 1 && p <= 6)
      // Under G90 the values are the entry's (absolute); under G91 they add to a value not known here.
      work_table_values(w, static_cast<std::uint32_t>((530 + 10 * p) * 1000), s_.absolute);
    else if (l == 20) work_table_write(541 * 1000 + p);
    return;
  }
  if (l == 1 || l == 10 || l == 11) linuxcnc_tool_setup(b, w);
  // LinuxCNC: L2/L20 P0 is the active system, P1–P9 = G54–G59.3; L20 makes the current point take
  // the given values (exact), L2 writes the table (the active frame's position becomes unknown).
  if (l == 1 || l == 10 || l == 11) {
    tool_table_write(b, w, l, w.has('P') && !w.unresolved('P') ? p : -1);
    return;
  }
  const long index = wc == 541 ? -1 : wc <= 590 ? (wc - 530) / 10 : 6 + (wc - 590);
  const bool active = p == 0 || p == index;
  if (l == 2 || l == 20) {
    // The table entry written (P0 the active system, P1-P9 G54-G59.3; P not known: any of them).
    // Where it lies on the machine is the program's value now, not the machine file's.
    const long sys = p == 0 ? index : p;
    const bool named = w.has('P') && !w.unresolved('P') && sys >= 1 && sys <= 9;
    if (!named) work_table_write(-1);
    else {
      const auto key = static_cast<std::uint32_t>((sys <= 6 ? 530 + 10 * sys : 590 + (sys - 6)) * 1000);
      // G10 L2 (LinuxCNC G-code reference "G10 L2 Set Coordinate System"): the origin's machine
      // coordinates, absolute whatever the distance mode; an axis not given keeps its value. With R
      // (a rotation) or an X under G7 (a diameter?) the entry is not followed. L20 writes it from
      // the current point, which is not known in machine coordinates here.
      const bool exact = l == 2 && !w.has('R') && !(s_.diameter_mode && (w.axis_present & bit(Axis::x)));
      work_table_values(w, key, exact);
    }
  }
  if ((l == 2 || l == 20) && active) {
    for (int a = 0; a < kAxisCount; ++a) {
      if (!(w.axis_present & (1u << a))) continue;
      if (l == 20 && !(w.axis_unresolved & (1u << a))) {
        // rs274: under G7 the X of G10 L20 is a diameter too (as G92's and G52's).
        s_.position[a] = to_mm(a, w.axis[a]) / (a == 0 && s_.diameter_mode ? 2.0 : 1.0);
        s_.known |= static_cast<AxisMask>(1u << a);
      } else {
        s_.known &= static_cast<AxisMask>(~(1u << a));
      }
    }
    // G10 L2 of the active system with R (a new rotation), or with X or Y under a rotation this run
    // does not know (the var file's): the current point's X and Y both change (checked with rs274).
    const AxisMask xy = bit(Axis::x) | bit(Axis::y);
    if (l == 2 && (w.has('R') || (w.axis_present & xy))) s_.known &= static_cast<AxisMask>(~xy);
  }
}

void Interpreter::work_table_values(const BlockWords& w, std::uint32_t key, bool exact) {
  if (!exact || w.axis_unresolved != 0 || work_written_.count(key) > 0) {
    work_table_write(key);
    return;
  }
  auto& [mask, value] = work_values_[key];
  for (int a = 0; a < kAxisCount; ++a)
    if (w.axis_present & (1u << a)) {
      value[a] = to_mm(a, w.axis[a]);
      mask |= static_cast<AxisMask>(1u << a);
    }
}

void Interpreter::work_table_write(long p_index) {
  // p_index: the entry written, as work_written_ keys it (code10 * 1000 + P); -1: not known which.
  if (p_index < 0) work_table_unknown_ = true;
  else work_written_.insert(static_cast<std::uint32_t>(p_index));
}

void Interpreter::shift_origin(BlockWords& w, GMeaning meaning) {
  w.axes_consumed = true;
  for (int a = 0; a < kAxisCount; ++a) {
    if (!(w.axis_present & (1u << a))) continue;
    const AxisMask m = static_cast<AxisMask>(1u << a);
    if (w.axis_unresolved & m) {
      s_.known &= static_cast<AxisMask>(~m);
      continue;
    }
    double v = to_mm(a, w.axis[a]);
    if (a == 0 && s_.diameter_mode) v /= 2;
    if (meaning == GMeaning::set_position) {
      // G92: the current point takes the value v; the shift absorbs the difference.
      if (s_.known & m) s_.position_offset[a] += s_.position[a] - v;
      else s_.position_offset_unknown |= m;  // the shift is the unknown position minus v
      s_.position[a] = v;
      s_.known |= m;
    } else if (d_.id == DialectId::linuxcnc && meaning == GMeaning::local_offset) {
      // LinuxCNC G52 writes the G92 offset itself (G-code reference "G52"): it replaces a G92
      // shift instead of adding to it, and G92.1 clears both.
      const double old = s_.position_offset[a];
      s_.position_offset[a] = v;
      s_.position[a] -= v - old;
      if (s_.position_offset_unknown & m) s_.known &= static_cast<AxisMask>(~m);  // old shift unknown
      s_.position_offset_unknown &= static_cast<AxisMask>(~m);
    } else {
      const double old = s_.local_offset[a];
      s_.local_offset[a] = v;
      s_.position[a] -= v - old;
    }
  }
  if (meaning == GMeaning::set_position || d_.id == DialectId::linuxcnc) {
    // rs274: G92 and G52 write the shift to #5211–#5219 (all axes), from where G92.3 takes it.
    s_.saved_position_offset = s_.position_offset;
    s_.saved_position_offset_unknown = s_.position_offset_unknown;
    s_.position_offset_applied = true;
  }
}

void Interpreter::remove_position_offset(bool clear) {
  s_.position += s_.position_offset;
  s_.known &= static_cast<AxisMask>(~s_.position_offset_unknown);
  if (clear) {  // G92.1 clears the parameters too; G92.2 keeps them
    s_.saved_position_offset.setZero();
    s_.saved_position_offset_unknown = 0;
  }
  s_.position_offset.setZero();
  s_.position_offset_unknown = 0;
  s_.position_offset_applied = false;
}

void Interpreter::apply_stored_position_offset() {
  // The shift in force is replaced (it is not 0 unless G92.1/G92.2 came before).
  s_.position += s_.position_offset - s_.saved_position_offset;
  s_.known &= static_cast<AxisMask>(~(s_.position_offset_unknown | s_.saved_position_offset_unknown));
  s_.position_offset = s_.saved_position_offset;
  s_.position_offset_unknown = s_.saved_position_offset_unknown;
  s_.position_offset_applied = true;
}

}  // namespace postproc::gcode
