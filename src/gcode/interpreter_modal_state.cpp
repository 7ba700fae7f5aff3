// Modal interpreter, part 4: LinuxCNC's saved modal state (M70 save, M71 invalidate, M72 restore,
// M73 auto-restore), LinuxCNC G-code reference "M70–M73".
#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {

void Interpreter::modal_save_restore(const Block& b, BlockWords& w) {
  if (d_.id != DialectId::linuxcnc) return;
  for (int i = 0; i < w.m_count; ++i) {
    const double m = w.m[static_cast<std::size_t>(i)];
    const Span at = b.words[static_cast<std::size_t>(w.m_word[static_cast<std::size_t>(i)])].span;
    if (m == 70) {
      saved_ = s_;
      saved_valid_ = true;
    } else if (m == 71) {
      saved_valid_ = false;
    } else if (m == 72) {
      if (!saved_valid_) {
        // rs274 stops here ("no valid stored context"): so does postproc.
        report(b, at, Severity::error, codes::kControllerRefuses,
               "M72 restores a modal state that was never saved (no M70) or was invalidated (M71); LinuxCNC "
               "stops the program here — save with M70 first");
        continue;
      }
      // What M72 restores (checked against rs274): units, plane, distance and arc-distance modes,
      // feed mode and F, the G54…G59.3 system, G98/G99, G7/G8, cutter compensation and the tool
      // length offset (the program Z changes with it, the machine does not move). Not G92 offsets,
      // not the motion mode.
      s_.inch = saved_.inch;
      s_.plane = saved_.plane;
      s_.absolute = saved_.absolute;
      s_.arc_absolute = saved_.arc_absolute;
      s_.feed_mode = saved_.feed_mode;
      s_.feed = saved_.feed;
      s_.feed_known = saved_.feed_known;
      s_.return_to_r = saved_.return_to_r;
      s_.diameter_mode = saved_.diameter_mode;
      s_.cutter_comp = saved_.cutter_comp;
      s_.cutter_radius = saved_.cutter_radius;
      s_.cutter_radius_known = saved_.cutter_radius_known;
      if (saved_.work_offset.code10 != s_.work_offset.code10 || saved_.work_offset.p != s_.work_offset.p) s_.known = 0;
      s_.work_offset = saved_.work_offset;
      s_.tool_length_active = saved_.tool_length_active;
      s_.tool_length_h = saved_.tool_length_h;
      tool_length_change(b, w, at, saved_.tool_length, saved_.tool_length_known);
    } else if (m == 73) {
      report(b, at, Severity::warning, codes::kModalRestore,
             "M73 restores the modal state when the subroutine returns, which this version does not follow; "
             "the state after the return is unknown — use M70 at the start and M72 before the return instead");
      s_.known = 0;
    }
  }
}

}  // namespace postproc::gcode
