// Dialect tables. The base table holds what Fanuc-family, Siemens ISO mode, LinuxCNC and Heidenhain
// ISO agree on; each dialect then adds or overrides the codes where they disagree.
#include "postproc/gcode/dialect.hpp"

#include <initializer_list>

namespace postproc::gcode {
namespace {

using M = GMeaning;
using Gr = GGroup;

constexpr std::uint16_t g(double code) { return static_cast<std::uint16_t>(code * 10 + 0.5); }

void set(std::vector<GCodeDef>& t, std::initializer_list<GCodeDef> defs) {
  for (const auto& d : defs) {
    if (d.code10 >= t.size()) t.resize(d.code10 + 1);
    t[d.code10] = d;
  }
}

void base_table(std::vector<GCodeDef>& t) {
  set(t, {
      {g(0), M::rapid, Gr::motion}, {g(1), M::linear, Gr::motion}, {g(2), M::arc_cw, Gr::motion},
      {g(3), M::arc_ccw, Gr::motion}, {g(4), M::dwell, Gr::non_modal},
      {g(17), M::plane_xy, Gr::plane}, {g(18), M::plane_zx, Gr::plane}, {g(19), M::plane_yz, Gr::plane},
      {g(90), M::absolute, Gr::distance}, {g(91), M::incremental, Gr::distance},
      {g(40), M::cutter_comp, Gr::cutter_comp}, {g(41), M::cutter_comp, Gr::cutter_comp},
      {g(42), M::cutter_comp, Gr::cutter_comp},
      {g(53), M::machine_coords, Gr::non_modal},
      {g(54), M::work_offset, Gr::work_offset}, {g(55), M::work_offset, Gr::work_offset},
      {g(56), M::work_offset, Gr::work_offset}, {g(57), M::work_offset, Gr::work_offset},
      {g(58), M::work_offset, Gr::work_offset}, {g(59), M::work_offset, Gr::work_offset},
      {g(9), M::exact_stop, Gr::non_modal}, {g(61), M::exact_stop, Gr::path_control},
      {g(64), M::path_control, Gr::path_control},
      // G80 may share a block with G0/G1 ("G00 G80"): it cancels cycles, it is not itself a motion.
      {g(80), M::cancel_motion, Gr::non_modal},
      {g(28), M::home_return, Gr::non_modal}, {g(30), M::home_return, Gr::non_modal},
  });
}

/// Fanuc-family mills and LinuxCNC share the drilling cycles, G20/G21 units, G43/G49, G52/G92, G93–G95.
void iso_mill_common(std::vector<GCodeDef>& t) {
  set(t, {
      {g(20), M::inch, Gr::units}, {g(21), M::mm, Gr::units},
      {g(43), M::tool_length_on, Gr::tool_length}, {g(49), M::tool_length_off, Gr::tool_length},
      {g(52), M::local_offset, Gr::non_modal}, {g(92), M::set_position, Gr::non_modal},
      {g(93), M::feed_inverse_time, Gr::feed_mode}, {g(94), M::feed_per_minute, Gr::feed_mode},
      {g(95), M::feed_per_rev, Gr::feed_mode},
      {g(98), M::return_initial, Gr::return_mode}, {g(99), M::return_r, Gr::return_mode},
      {g(73), M::drill_cycle, Gr::motion}, {g(74), M::drill_cycle, Gr::motion},
      {g(76), M::drill_cycle, Gr::motion},
      {g(81), M::drill_cycle, Gr::motion}, {g(82), M::drill_cycle, Gr::motion},
      {g(83), M::drill_cycle, Gr::motion}, {g(84), M::drill_cycle, Gr::motion},
      {g(85), M::drill_cycle, Gr::motion}, {g(86), M::drill_cycle, Gr::motion},
      {g(87), M::drill_cycle, Gr::motion}, {g(88), M::drill_cycle, Gr::motion},
      {g(89), M::drill_cycle, Gr::motion},
      {g(10), M::set_offsets_g10, Gr::non_modal},
      {g(28.1), M::home_set, Gr::non_modal}, {g(30.1), M::home_set, Gr::non_modal},
      {g(68), M::rotation_on, Gr::tilted_plane}, {g(69), M::tilted_plane_off, Gr::tilted_plane},
      {g(96), M::css_on, Gr::css}, {g(97), M::css_off, Gr::css},
      {g(31), M::probe, Gr::non_modal},
  });
}

void fanuc(std::vector<GCodeDef>& t, bool lathe, char system) {
  iso_mill_common(t);
  set(t, {
      {g(43.4), M::tcp_on, Gr::tool_length}, {g(43.5), M::tcp_vector_on, Gr::tool_length},
      {g(44), M::tool_length_on, Gr::tool_length},  // negative offset: refused at its line (interpreter)
      {g(68.2), M::tilted_plane_on, Gr::tilted_plane}, {g(53.1), M::tilted_plane_tool_axis, Gr::non_modal},
      {g(54.1), M::work_offset, Gr::work_offset},
      {g(5.1), M::nurbs_or_ai_contour, Gr::non_modal}, {g(5), M::state_only, Gr::non_modal},
      {g(8), M::state_only, Gr::non_modal}, {g(6.2), M::spline, Gr::motion},
      {g(7.1), M::cylindrical_interp, Gr::non_modal}, {g(107), M::cylindrical_interp, Gr::non_modal},
      {g(12.1), M::polar_interp_on, Gr::non_modal}, {g(13.1), M::polar_interp_off, Gr::non_modal},
      {g(112), M::polar_interp_on, Gr::non_modal}, {g(113), M::polar_interp_off, Gr::non_modal},
      {g(15), M::polar_coord_off, Gr::non_modal}, {g(16), M::polar_coord_on, Gr::non_modal},
      {g(32), M::threading, Gr::motion}, {g(33), M::threading, Gr::motion}, {g(50.1), M::mirror_off, Gr::non_modal},
      {g(51.1), M::mirror_on, Gr::non_modal}, {g(65), M::state_only, Gr::non_modal},
      {g(80.5), M::cancel_motion, Gr::non_modal}, {g(49.1), M::tool_length_off, Gr::tool_length},
      {g(41.2), M::cutter_comp, Gr::cutter_comp}, {g(42.2), M::cutter_comp, Gr::cutter_comp},
      {g(61.1), M::path_control, Gr::path_control}, {g(62), M::path_control, Gr::path_control},
      {g(63), M::path_control, Gr::path_control}, {g(10.6), M::state_only, Gr::non_modal},
      {g(11), M::state_only, Gr::non_modal}, {g(13), M::state_only, Gr::non_modal},
      {g(50), M::scaling_off, Gr::non_modal}, {g(51), M::scaling_on, Gr::non_modal},
      {g(27), M::home_return, Gr::non_modal}, {g(29), M::home_return, Gr::non_modal},
      {g(26), M::state_only, Gr::non_modal}, {g(25), M::state_only, Gr::non_modal},
  });
  if (lathe) {
    // G-code system A: G98/G99 are feed per minute/per revolution, G70–G76 are turning cycles,
    // G90/G92/G94 are single turning cycles (absolute/incremental come from X/U letters), G50 sets
    // the coordinate system or clamps spindle speed (with S).
    set(t, {
        {g(98), M::feed_per_minute, Gr::feed_mode}, {g(99), M::feed_per_rev, Gr::feed_mode},
        {g(70), M::turning_cycle, Gr::motion}, {g(71), M::turning_cycle, Gr::motion},
        {g(72), M::turning_cycle, Gr::motion}, {g(73), M::turning_cycle, Gr::motion},
        {g(74), M::turning_cycle, Gr::motion}, {g(75), M::turning_cycle, Gr::motion},
        {g(76), M::threading, Gr::motion}, {g(92), M::threading, Gr::motion},
        {g(90), M::turning_cycle, Gr::motion}, {g(94), M::turning_cycle, Gr::motion},
        {g(50), M::spindle_clamp, Gr::non_modal},
        {g(83), M::drill_cycle, Gr::motion}, {g(87), M::drill_cycle, Gr::motion},
        {g(87.6), M::drill_cycle, Gr::motion}, {g(88), M::drill_cycle, Gr::motion},
        {g(91), M::unknown, Gr::none},
        {g(7), M::unknown, Gr::none},
    });
    if (system == 'B') {
      // System B: G90/G91 absolute/incremental, G94/G95 feed modes, G98/G99 return levels, G77/G78/G79
      // single cycles, G92 sets the coordinate system (or clamps the spindle with S) like G50.
      set(t, {
          {g(90), M::absolute, Gr::distance}, {g(91), M::incremental, Gr::distance},
          {g(94), M::feed_per_minute, Gr::feed_mode}, {g(95), M::feed_per_rev, Gr::feed_mode},
          {g(98), M::return_initial, Gr::return_mode}, {g(99), M::return_r, Gr::return_mode},
          {g(77), M::turning_cycle, Gr::motion}, {g(78), M::threading, Gr::motion},
          {g(79), M::turning_cycle, Gr::motion}, {g(92), M::spindle_clamp, Gr::non_modal},
      });
    }
  }
}

void linuxcnc(std::vector<GCodeDef>& t) {
  iso_mill_common(t);
  set(t, {
      {g(5), M::spline, Gr::motion}, {g(5.1), M::spline, Gr::motion}, {g(5.2), M::spline, Gr::motion},
      {g(5.3), M::state_only, Gr::non_modal},
      {g(7), M::diameter_mode, Gr::diameter}, {g(8), M::radius_mode, Gr::diameter},
      {g(33), M::threading, Gr::motion}, {g(33.1), M::threading, Gr::motion},
      {g(76), M::threading, Gr::motion},
      {g(70), M::turning_cycle, Gr::motion}, {g(71), M::turning_cycle, Gr::motion},
      {g(71.1), M::turning_cycle, Gr::motion}, {g(71.2), M::turning_cycle, Gr::motion},
      {g(72), M::turning_cycle, Gr::motion}, {g(72.1), M::turning_cycle, Gr::motion},
      {g(72.2), M::turning_cycle, Gr::motion},
      {g(38.2), M::probe, Gr::motion}, {g(38.3), M::probe, Gr::motion}, {g(38.4), M::probe, Gr::motion},
      {g(38.5), M::probe, Gr::motion},
      {g(43.1), M::tool_length_dynamic, Gr::tool_length}, {g(43.2), M::tool_length_on, Gr::tool_length},
      {g(54.1), M::unknown, Gr::none},
      {g(59.1), M::work_offset, Gr::work_offset}, {g(59.2), M::work_offset, Gr::work_offset},
      {g(59.3), M::work_offset, Gr::work_offset},
      {g(61.1), M::exact_stop, Gr::path_control},
      {g(90.1), M::arc_absolute, Gr::arc_distance}, {g(91.1), M::arc_incremental, Gr::arc_distance},
      {g(92.1), M::reset_position_offset, Gr::non_modal}, {g(92.2), M::reset_position_offset, Gr::non_modal},
      {g(92.3), M::restore_position_offset, Gr::non_modal},
      {g(41.1), M::cutter_comp, Gr::cutter_comp}, {g(42.1), M::cutter_comp, Gr::cutter_comp},
      {g(96), M::css_on, Gr::css}, {g(97), M::css_off, Gr::css},
      // Tilted work plane remaps of the 5-axis sim configs (g68.2 … g53.1/g53.6, g68.3/g68.4).
      {g(68.2), M::tilted_plane_on, Gr::tilted_plane}, {g(68.3), M::tilted_plane_on, Gr::tilted_plane},
      {g(68.4), M::tilted_plane_on, Gr::tilted_plane},
      {g(53.1), M::tilted_plane_tool_axis, Gr::non_modal}, {g(53.3), M::tilted_plane_tool_axis, Gr::non_modal},
      {g(53.6), M::tilted_plane_tool_axis, Gr::non_modal},
      {g(68), M::unknown, Gr::none},
  });
}

void siemens(std::vector<GCodeDef>& t) {
  // Sinumerik: G70/G71 inch/mm (G700/G710 incl. feed), no G43/G49, frames via TRANS/ROT keywords,
  // G500 cancels settable offsets, G505–G599 further offsets, G94/G95/G93 feed modes.
  set(t, {
      {g(70), M::inch, Gr::units}, {g(71), M::mm, Gr::units}, {g(700), M::inch, Gr::units},
      {g(710), M::mm, Gr::units},
      {g(93), M::feed_inverse_time, Gr::feed_mode}, {g(94), M::feed_per_minute, Gr::feed_mode},
      {g(95), M::feed_per_rev, Gr::feed_mode}, {g(96), M::css_on, Gr::css}, {g(97), M::css_off, Gr::css},
      {g(500), M::work_offset, Gr::work_offset},
      {g(60), M::exact_stop, Gr::path_control}, {g(601), M::state_only, Gr::non_modal},
      {g(602), M::state_only, Gr::non_modal}, {g(603), M::state_only, Gr::non_modal},
      {g(641), M::path_control, Gr::path_control}, {g(642), M::path_control, Gr::path_control},
      {g(643), M::path_control, Gr::path_control}, {g(644), M::path_control, Gr::path_control},
      {g(645), M::path_control, Gr::path_control},
      {g(33), M::threading, Gr::motion}, {g(331), M::threading, Gr::motion}, {g(332), M::threading, Gr::motion},
      {g(74), M::home_return, Gr::non_modal}, {g(75), M::home_return, Gr::non_modal},
      {g(25), M::state_only, Gr::non_modal}, {g(26), M::state_only, Gr::non_modal},
      {g(450), M::state_only, Gr::non_modal}, {g(451), M::state_only, Gr::non_modal},
      {g(153), M::machine_coords, Gr::non_modal}, {g(5), M::spline, Gr::motion},
      {g(28), M::unknown, Gr::none}, {g(30), M::unknown, Gr::none},
  });
  set(t, {{g(62), M::state_only, Gr::non_modal}, {g(621), M::state_only, Gr::non_modal},
          {g(43), M::state_only, Gr::non_modal}, {g(44), M::state_only, Gr::non_modal},
          {g(340), M::state_only, Gr::non_modal}, {g(341), M::state_only, Gr::non_modal},
          {g(110), M::polar_pole, Gr::non_modal}, {g(111), M::polar_pole, Gr::non_modal},
          {g(112), M::polar_pole, Gr::non_modal}, {g(90), M::absolute, Gr::distance}});
  for (int k = 501; k <= 599; ++k) set(t, {{static_cast<std::uint16_t>(k * 10), M::work_offset, Gr::work_offset}});
}

void heidenhain_iso(std::vector<GCodeDef>& t) {
  // Heidenhain TNC ISO / MillPlus DIN: G70/G71 inch/mm, G93 datum shift (not inverse time), G7
  // tilted plane, G74 machine-coordinate move, G94/G95 feed modes.
  set(t, {
      {g(70), M::inch, Gr::units}, {g(71), M::mm, Gr::units},
      {g(93), M::datum_shift_heidenhain, Gr::non_modal}, {g(94), M::feed_per_minute, Gr::feed_mode},
      {g(95), M::feed_per_rev, Gr::feed_mode},
      {g(7), M::tilted_plane_heidenhain, Gr::non_modal}, {g(74), M::machine_move_heidenhain, Gr::non_modal},
      {g(174), M::state_only, Gr::non_modal}, {g(43), M::tool_length_on, Gr::tool_length},
      {g(49), M::tool_length_off, Gr::tool_length},
      {g(81), M::drill_cycle, Gr::motion}, {g(83), M::drill_cycle, Gr::motion},
      {g(84), M::drill_cycle, Gr::motion}, {g(85), M::drill_cycle, Gr::motion},
      {g(86), M::drill_cycle, Gr::motion},
      {g(96), M::css_on, Gr::css}, {g(97), M::css_off, Gr::css},
      {g(98), M::state_only, Gr::non_modal}, {g(99), M::state_only, Gr::non_modal},
      {g(79), M::drill_cycle, Gr::non_modal},
      {g(28), M::unknown, Gr::none},
      // G30/G31 define the blank form (BLK FORM): their axis words are data, not a move.
      {g(30), M::polar_pole, Gr::non_modal}, {g(31), M::polar_pole, Gr::non_modal},
      {g(29), M::state_only, Gr::non_modal}, {g(99), M::state_only, Gr::non_modal},
  });
}

}  // namespace

Dialect make_dialect(DialectId id, const DialectOptions& opt) {
  Dialect d;
  d.id = id;
  d.lathe = opt.lathe;
  base_table(d.gcodes);
  switch (id) {
    case DialectId::fanuc:
      d.name = "fanuc";
      fanuc(d.gcodes, opt.lathe, opt.gcode_system);
      d.integer_input = opt.integer_input;
      d.gcode_system = opt.gcode_system;
      d.power_on_motion = opt.power_on_motion == 1 ? GMeaning::linear : GMeaning::rapid;
      d.g80_keeps_motion = true;
      d.arc_without_centre_linear = !opt.arc_without_centre_alarm;
      if (opt.lathe) d.diameter_axis = 'X';
      break;
    case DialectId::siemens:
      d.name = "siemens";
      d.paren_comments = false;
      d.semicolon_comments = true;
      d.multi_letter_identifiers = true;
      d.hash_parameters = false;
      d.r_parameters = true;
      d.decimal_point_required = false;
      d.basic_inch = opt.basic_inch;
      // 840D sl Fundamentals, list of G functions, group 1: G1 is the Siemens default (MD20150[0]).
      d.reset_motion = opt.reset_motion == '0' ? GMeaning::rapid : GMeaning::linear;
      siemens(d.gcodes);
      break;
    case DialectId::linuxcnc:
      d.name = "linuxcnc";
      d.semicolon_comments = true;
      d.o_word_control = true;
      d.spaces_inside_words = true;
      d.decimal_point_required = false;
      d.assignment_timing = AssignmentTiming::end_of_line;
      linuxcnc(d.gcodes);
      break;
    case DialectId::heidenhain_iso:
      d.name = "heidenhain-iso";
      d.semicolon_comments = true;
      d.star_block_end = true;
      d.hash_parameters = false;
      d.decimal_point_required = false;
      heidenhain_iso(d.gcodes);
      break;
    case DialectId::heidenhain:
      // Klartext: its own lexer and interpreter (src/gcode/klartext*.cpp); no G-code table.
      d.name = "heidenhain";
      d.paren_comments = false;
      d.semicolon_comments = true;
      d.hash_parameters = false;
      d.decimal_point_required = false;
      break;
  }
  if (opt.diameter_axis != 0) d.diameter_axis = opt.diameter_axis;
  d.tool_lengths = opt.tool_lengths;
  d.tool_radii = opt.tool_radii;
  d.tool_orientations = opt.tool_orientations;
  d.rollover = opt.rollover;
  return d;
}

void set_gcode_system(Dialect& d, char system) {
  d.gcode_system = system;
  if (d.id != DialectId::fanuc) return;
  d.gcodes.clear();
  base_table(d.gcodes);
  fanuc(d.gcodes, d.lathe, system);
}

std::optional<Dialect> make_dialect(std::string_view name, const DialectOptions& opt) {
  if (name == "fanuc") return make_dialect(DialectId::fanuc, opt);
  if (name == "siemens") return make_dialect(DialectId::siemens, opt);
  if (name == "linuxcnc") return make_dialect(DialectId::linuxcnc, opt);
  if (name == "heidenhain-iso") return make_dialect(DialectId::heidenhain_iso, opt);
  if (name == "heidenhain") return make_dialect(DialectId::heidenhain, opt);
  return std::nullopt;
}

std::string_view dialect_names() { return "fanuc|siemens|linuxcnc|heidenhain-iso|heidenhain"; }

}  // namespace postproc::gcode
