// Modal interpreter, part 4: LinuxCNC's saved modal state (M70 save, M71 invalidate, M72 restore,
// M73 auto-restore), LinuxCNC G-code reference "M70–M73".
#include <fmt/format.h>

#include "postproc/gcode/interpreter.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {

namespace {

/// The call level a resolved program's M70–M73 line was executed at: its "(postproc: call level N)"
/// comment (resolve/linuxcnc_statements.cpp), 0 without one.
std::size_t call_level(const Block& b) {
  constexpr std::string_view kMark = "(postproc: call level ";
  for (const Token& t : b.tokens) {
    if (t.kind != TokenKind::paren_comment) continue;
    const std::string_view c = b.text(t.span);
    if (c.substr(0, kMark.size()) != kMark) continue;
    std::size_t n = 0;
    for (std::size_t k = kMark.size(); k < c.size() && c[k] >= '0' && c[k] <= '9' && n < 1000; ++k)
      n = n * 10 + static_cast<std::size_t>(c[k] - '0');
    return n;
  }
  return 0;
}

}  // namespace

void Interpreter::modal_save_restore(const Block& b, BlockWords& w) {
  if (d_.id != DialectId::linuxcnc) return;
  for (int i = 0; i < w.m_count; ++i) {
    const double m = w.m[static_cast<std::size_t>(i)];
    if (m < 70 || m > 73) continue;
    const Span at = b.words[static_cast<std::size_t>(w.m_word[static_cast<std::size_t>(i)])].span;
    // LinuxCNC keeps one saved state per call level (M-code reference "M70–M73").
    const std::size_t level = call_level(b);
    if (level > 0 && level_saved_.size() < level) level_saved_.resize(level);
    ModalState& saved = level == 0 ? saved_ : level_saved_[level - 1].first;
    bool& saved_valid = level == 0 ? saved_valid_ : level_saved_[level - 1].second;
    if (m == 70 || m == 73) {
      // M73 saves as M70 does; LinuxCNC restores it when a subroutine returns, never at M2. In a
      // program read without resolving M73 is in the main program; in a resolved one the resolver
      // writes that restore as an M72 on the return line (resolve/linuxcnc_statements.cpp).
      saved = s_;
      saved_valid = true;
    } else if (m == 71) {
      saved_valid = false;
    } else if (m == 72) {
      if (!saved_valid) {
        // rs274 stops here ("no valid stored context"): so does postproc.
        report(b, at, Severity::error, codes::kControllerRefuses,
               "M72 restores a modal state that was never saved (no M70) or was invalidated (M71); LinuxCNC "
               "stops the program here — save with M70 first");
        continue;
      }
      // What M72 restores (checked against rs274): units, plane, distance and arc-distance modes,
      // feed mode and F, the G54…G59.3 system, G98/G99, G7/G8, cutter compensation, the tool length
      // offset where it switches it on or off (below), and whether a G92/G52 shift is applied
      // (#5210): applied at M70, the stored shift (#5211…) is applied again as by G92.3, else the
      // shift in force is removed as by G92.2. Not the motion mode.
      s_.inch = saved.inch;
      s_.plane = saved.plane;
      s_.absolute = saved.absolute;
      s_.arc_absolute = saved.arc_absolute;
      s_.feed_mode = saved.feed_mode;
      s_.feed = saved.feed;
      s_.feed_known = saved.feed_known;
      s_.return_to_r = saved.return_to_r;
      s_.diameter_mode = saved.diameter_mode;
      if (saved.cutter_comp != s_.cutter_comp &&
          (offset_active() || (saved.cutter_comp != 0 && !(saved.cutter_radius_known && saved.cutter_radius == 0)))) {
        // restore_settings runs "G40" or "G41"/"G42" (without D: the spindle's tool) here: not followed.
        report(b, at, Severity::warning, codes::kModalRestore,
               "M72 switches cutter radius compensation here, which this version does not follow; the tool-centre "
               "path after it is unknown — switch compensation with G40/G41/G42 instead");
        if (offset_active()) comp_restore_break();
        s_.cutter_comp = saved.cutter_comp;
        s_.cutter_radius_known = false;
      } else {
        s_.cutter_comp = saved.cutter_comp;
        s_.cutter_radius = saved.cutter_radius;
        s_.cutter_radius_known = saved.cutter_radius_known;
      }
      if (saved.work_offset.code10 != s_.work_offset.code10 || saved.work_offset.p != s_.work_offset.p) s_.known = 0;
      s_.work_offset = saved.work_offset;
      // The tool length offset (rs274 2.9, tests/resolve/linuxcnc/reader_m72_tool_length.ngc):
      // rs274 records group 8 from the offset's value — G49 when it is zero, G43 otherwise, whether
      // G43, G43.1 or G43.2 set it — and M72 applies the recorded code again only where it differs
      // from the one in force: G43 (the tool in the spindle, not the saved H or G43.1 value) or
      // G49. Otherwise the offset in force stays, whatever its value. Where either value is not
      // known, neither is the offset after M72.
      const auto on = [](bool known, double mm) { return !known ? -1 : mm != 0 ? 1 : 0; };
      const int was = on(saved.tool_length_known, saved.tool_length), now = on(s_.tool_length_known, s_.tool_length);
      if (was < 0 || now < 0) {
        tool_length_change(b, w, at, s_.tool_length, false);
      } else if (was == 1 && now == 0) {
        const long h = s_.current_tool;
        double mm = 0;
        const bool known = h >= 0 && table_length(h, mm);
        s_.tool_length_active = true;
        s_.tool_length_h = static_cast<std::uint16_t>(h > 0 ? h : 0);
        tool_length_change(b, w, at, mm, known);
      } else if (was == 0 && now == 1) {
        s_.tool_length_active = false;
        s_.tool_length_h = 0;
        tool_length_change(b, w, at, 0.0, true);
      }
      if (saved.position_offset_applied) apply_stored_position_offset();
      else remove_position_offset(false);
    }
  }
}

}  // namespace postproc::gcode
