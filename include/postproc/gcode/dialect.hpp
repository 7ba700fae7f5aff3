#pragma once
/// @file
/// Controller dialects as data: which comment syntax, which G code means what, when assignments take
/// effect. The interpreter only ever sees the meanings (GMeaning), never raw G numbers, so a dialect
/// is a table plus a few flags.

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/gcode/rotary_rollover.hpp"

namespace postproc::gcode {

/// heidenhain = Heidenhain conversational (Klartext) programs, heidenhain_iso = the TNC/MillPlus ISO mode.
enum class DialectId : std::uint8_t { fanuc, siemens, linuxcnc, heidenhain_iso, heidenhain };

/// What a G code does. Codes that move the machine in ways this version does not resolve carry
/// their own meaning so that each gets a stable diagnostic.
enum class GMeaning : std::uint8_t {
  unknown,
  // motion group
  rapid, linear, arc_cw, arc_ccw, dwell, cancel_motion,
  drill_cycle,            ///< G73/G74(mill)/G76(mill)/G81–G89: positions resolved, cycle not expanded
  turning_cycle,          ///< G70–G76 lathe cycles, G71.1/G71.2 (LinuxCNC): unresolved
  threading,              ///< G32/G33/G33.1/G76 threading: unresolved
  spline,                 ///< G5/G5.1/G5.2/G6.2 splines: unresolved
  polar_interp_on, polar_interp_off,  ///< G12.1/G112 and G13.1/G113
  cylindrical_interp,     ///< Fanuc G7.1/G107: unresolved
  nurbs_or_ai_contour,    ///< Fanuc G05.1 Q1 (AI contour control): state only
  arc_cip,                ///< Sinumerik CIP: circle through an intermediate point (modal, group 1)
  arc_tangent,            ///< Sinumerik CT: circle tangent to the previous path element (modal, group 1)
  // planes
  plane_xy, plane_zx, plane_yz,
  // distance
  absolute, incremental, arc_absolute, arc_incremental,
  // units
  inch, mm,
  // feed
  feed_inverse_time, feed_per_minute, feed_per_rev,
  // lathe diameter
  diameter_mode, radius_mode,
  // offsets
  work_offset,            ///< G54–G59, G54.1 P, G59.1–G59.3
  local_offset,           ///< G52
  set_position,           ///< G92 (shift so the current point takes the given values)
  reset_position_offset,  ///< G92.1/G92.2
  restore_position_offset,///< G92.3
  set_offsets_g10,        ///< G10: writes controller tables, no motion
  machine_coords,         ///< G53 (non-modal)
  tool_length_on, tool_length_off, tool_length_dynamic,  ///< G43 / G49 / G43.1
  tcp_on,                 ///< Fanuc G43.4 (tool-centre point)
  tcp_vector_on,          ///< Fanuc G43.5 (tool axis by I J K)
  tilted_plane_on,        ///< G68.2
  tilted_plane_tool_axis, ///< G53.1 / G53.6
  tilted_plane_off,       ///< G69
  rotation_on,            ///< G68 (rotation): unresolved
  home_return,            ///< G28/G30: via intermediate point to home (machine position unknown)
  home_set,               ///< G28.1/G30.1
  cutter_comp,            ///< G40/G41/G42 (+ .1): state only
  exact_stop, path_control,  ///< G61/G64 and friends: state only
  css_on, css_off,        ///< G96/G97
  spindle_clamp,          ///< Fanuc lathe G50 S / G92 S (system B/C)
  return_initial, return_r,  ///< G98/G99 on mills
  probe,                  ///< G38.x: unresolved (result is runtime state)
  datum_shift_heidenhain, ///< MillPlus G93 datum shift
  tilted_plane_heidenhain,///< MillPlus G7 tilted plane
  machine_move_heidenhain,///< MillPlus G74 machine-coordinate move
  polar_pole,             ///< Siemens G110–G112 pole definition (axis words are data)
  polar_coord_on,         ///< Fanuc mill G16: plane axis words are radius and angle
  polar_coord_off,        ///< Fanuc mill G15
  scaling_on,             ///< Fanuc mill G51 (axis words are the scaling centre, P/I J K factors)
  scaling_off,            ///< Fanuc mill G50
  mirror_on,              ///< Fanuc G51.1 programmable mirror image (axis words = axis of symmetry)
  mirror_off,             ///< Fanuc G50.1 (axis words name the axes to cancel)
  state_only,             ///< recognised, no effect on geometry (e.g. G05.1 Q0, G08, G174)
};

/// Modal group a G code belongs to (two codes of the same group in one block are an error).
enum class GGroup : std::uint8_t {
  none, motion, plane, distance, arc_distance, units, feed_mode, diameter, work_offset, tool_length,
  tcp, tilted_plane, cutter_comp, path_control, css, return_mode, non_modal,
};

struct GCodeDef {
  std::uint16_t code10 = 0;  ///< G number × 10 (G43.4 → 434)
  GMeaning meaning = GMeaning::unknown;
  GGroup group = GGroup::none;
};

enum class AssignmentTiming : std::uint8_t { immediate, end_of_line };

/// A controller dialect: data plus small hooks (flags) the lexer and interpreter consult.
struct Dialect {
  DialectId id = DialectId::fanuc;
  std::string name;
  bool paren_comments = true;        ///< `( ... )`
  bool semicolon_comments = false;   ///< `; ...` to end of line
  bool star_block_end = false;       ///< Heidenhain ISO: trailing `*` ends the block
  bool multi_letter_identifiers = false;  ///< Siemens: TRAORI, CYCLE800(...), NAME=expr
  bool hash_parameters = true;       ///< `#123`, `#<name>` (Fanuc macro B, LinuxCNC)
  bool r_parameters = false;         ///< Siemens R1 / R1=...
  bool o_word_control = false;       ///< LinuxCNC o100 sub / if / while
  bool spaces_inside_words = false;  ///< LinuxCNC ignores spaces inside words ("G 1 X 1.5")
  /// The writer puts a point on whole numbers (Fanuc: without one, X1 may mean one increment).
  bool decimal_point_required = true;
  /// How a length/angle word written without a decimal point is read (Fanuc parameter DPI):
  /// unknown (warn, read as increments), increment (×0.001 mm / 0.0001 in / 0.001°), calculator (whole units).
  enum class IntegerInput : std::uint8_t { unknown, increment, calculator } integer_input = IntegerInput::calculator;
  bool lathe = false;                ///< lathe: G70–G76 turning cycles, U/W incremental, X diameter
  char gcode_system = 'A';           ///< Fanuc lathe G-code system, 'A' or 'B'; '?' = not stated (read off the program)
  char diameter_axis = 0;            ///< axis programmed as diameter from the start ('X' on lathes)
  AssignmentTiming assignment_timing = AssignmentTiming::immediate;
  /// The controller's tool table, where the machine file (or a tool table file) gives it: tool length
  /// offsets and cutter radii in mm, by H/D offset number (Fanuc, Siemens D) or tool number
  /// (LinuxCNC). A number missing here is unknown: a block whose position depends on it is refused.
  /// Roll-over positioning per program axis (rotary axes only; off elsewhere).
  std::array<RotaryRollover, 9> rollover{};
  std::map<std::uint32_t, double> tool_lengths;
  std::map<std::uint32_t, double> tool_radii;
  /// LinuxCNC lathe tool orientation by tool number (tool table Q, 0–9; missing = 0).
  std::map<std::uint32_t, int> tool_orientations;
  /// Motion mode at power-on: Fanuc G00 (or G01 with parameter 3402#0 G01=1); cancel_motion where
  /// axis words need a motion G first (LinuxCNC powers on in G80).
  GMeaning power_on_motion = GMeaning::cancel_motion;
  /// Fanuc: canned cycles are a modal group of their own, so G80 leaves the G00/G01/G02/G03 that was
  /// active before the cycle; LinuxCNC: G80 leaves no motion mode.
  bool g80_keeps_motion = false;
  /// Fanuc parameter 3403#5 CIR = 0 (factory setting): a G02/G03 block with neither I J K nor R moves
  /// to its end point in a straight line. false: refused (CIR = 1, alarm PS0022; other controllers).
  bool arc_without_centre_linear = false;
  /// Sinumerik basic system (MD10240 $MN_SCALING_SYSTEM_IS_METRIC): false = metric (assumed). G70/G71
  /// leave feeds in the basic system; only G700/G710 change them too.
  bool basic_inch = false;
  /// Motion mode in force before the program's first G0/G1/G2/G3 (Sinumerik: reset value of G group 1,
  /// MD20150 $MC_GCODE_RESET_VALUES[0], factory setting G1). cancel_motion = none (axis words refused).
  GMeaning reset_motion = GMeaning::cancel_motion;
  /// Fanuc lathe G71/G72: a last cut along the profile offset by the finishing allowance (parameter
  /// 5105#1 RF1 = 0, the factory setting); false = RF1 = 1, no such cut.
  bool fanuc_rough_final_cut = true;
  /// Table indexed by code10; GMeaning::unknown where the dialect has no such code.
  std::vector<GCodeDef> gcodes;

  [[nodiscard]] const GCodeDef* find_g(std::uint16_t code10) const {
    return code10 < gcodes.size() && gcodes[code10].meaning != GMeaning::unknown ? &gcodes[code10] : nullptr;
  }
};

/// Options that refine a dialect (later also read from the machine file).
struct DialectOptions {
  bool lathe = false;           ///< Fanuc lathe / Siemens turning
  /// Fanuc lathe G-code system: 'A' (G98/G99 feeds) or 'B' (G94/G95, G90/G91); '?' = not stated:
  /// `settle_gcode_system` (detect.hpp) reads it off the program before it is run.
  char gcode_system = 'A';
  char diameter_axis = 0;       ///< 0 = dialect default
  /// Fanuc only: how whole numbers without a point are read; unknown = warn once (PP-U218).
  Dialect::IntegerInput integer_input = Dialect::IntegerInput::unknown;
  std::map<std::uint32_t, double> tool_lengths;  ///< mm, see Dialect::tool_lengths
  std::array<RotaryRollover, 9> rollover{};       ///< see Dialect::rollover ([axes.C] rollover)
  std::map<std::uint32_t, double> tool_radii;    ///< mm, see Dialect::tool_radii
  std::map<std::uint32_t, int> tool_orientations;  ///< see Dialect::tool_orientations
  /// Fanuc only: power-on motion mode, 0 = G00 (factory setting) or 1 = G01 (parameter 3402#0 G01).
  int power_on_motion = 0;
  /// Fanuc only: parameter 3403#5 CIR = 1: a G02/G03 without I J K or R is an alarm (PS0022);
  /// false (factory setting) = it moves in a straight line.
  bool arc_without_centre_alarm = false;
  /// Siemens only: basic system inch (MD10240 = 0); default metric.
  bool basic_inch = false;
  /// Siemens only: reset motion mode of G group 1 (MD20150[0]): '0' G0, '1' G1; 0 = factory setting (G1).
  char reset_motion = 0;
};

/// Builds the dialect named `name` (fanuc, siemens, linuxcnc, heidenhain-iso, heidenhain); nullopt if unknown.
[[nodiscard]] std::optional<Dialect> make_dialect(std::string_view name, const DialectOptions& opt = {});
[[nodiscard]] Dialect make_dialect(DialectId id, const DialectOptions& opt = {});
[[nodiscard]] std::string_view dialect_names();

/// The longest line the controller reads, in characters (the CR of a CRLF line counted); 0: no
/// limit postproc knows of. LinuxCNC: 252 — rs274ngc reads a line into a buffer of LINELEN (255)
/// bytes with fgets and stops with "Command too long" when it is full (checked against LinuxCNC
/// 2.9's rs274, tests/rs274_line_length.py).
[[nodiscard]] inline std::size_t max_line_length(const Dialect& d) { return d.id == DialectId::linuxcnc ? 252 : 0; }
/// Why the controller stops at a line of `chars` characters (without its end of line; `cr`: a CR
/// ends it), for a diagnostic; nullopt when it reads the line.
[[nodiscard]] std::optional<std::string> line_too_long(const Dialect& d, std::size_t chars, bool cr);
/// line_too_long for a line and its end of line, checked without a call where the line cannot be
/// too long (every line of a dialect without a limit: the per-block cost of a hot path).
[[nodiscard]] inline std::optional<std::string> line_too_long(const Dialect& d, std::string_view line,
                                                              std::string_view eol) {
  const std::size_t limit = max_line_length(d);
  if (limit == 0 || line.size() < limit) return std::nullopt;
  return line_too_long(d, line.size(), !eol.empty() && eol.front() == '\r');
}
/// Rebuilds a Fanuc lathe dialect's G-code table for G-code system `system` ('A' or 'B').
void set_gcode_system(Dialect& d, char system);  ///< "fanuc|siemens|linuxcnc|heidenhain-iso"

}  // namespace postproc::gcode
