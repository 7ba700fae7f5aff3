#pragma once
/// @file
/// Modal interpreter: turns lexed blocks into resolved motions (absolute mm / degrees in the active
/// work coordinate system) and reports every construct it cannot resolve with a stable code.

#include <memory>
#include <map>
#include <set>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/gcode/block.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/motion.hpp"

namespace postproc::gcode {
namespace turning {
struct Move;
}  // namespace turning
namespace threading {
struct Move;
}

/// Receives each resolved motion together with the block it came from.
class MotionSink {
 public:
  virtual ~MotionSink() = default;
  virtual void motion(const Motion& m, const Block& b) = 0;
};

/// Modal state carried from block to block (the part that is not already in Motion).
struct ModalState {
  GMeaning motion = GMeaning::cancel_motion;
  std::uint16_t motion_code10 = 0;
  GMeaning interp_motion = GMeaning::cancel_motion;  ///< last G00–G03 (Fanuc: what G80 returns to)
  std::uint16_t interp_code10 = 0;
  Plane plane = Plane::xy;
  bool absolute = true;
  bool arc_absolute = false;        ///< G90.1 (LinuxCNC); IJK incremental by default
  bool inch = false;
  bool feed_inch = false;           ///< F in inch/min (inch/rev); Sinumerik: only after G700 (G70 keeps the basic system)
  FeedMode feed_mode = FeedMode::per_minute;
  double feed = 0;                  ///< in program units (mm or inch per min/rev; 1/min inverse time)
  bool feed_known = false;
  bool feed_undefined = false;      ///< the feed mode changed to or from G93 and no F followed
  bool diameter_mode = false;
  bool return_to_r = false;         ///< G99 (mills)
  double cycle_r = 0;               ///< retract plane of the active drilling cycle, mm along the normal
  double cycle_initial = 0;         ///< initial level when the cycle started
  bool cycle_initial_known = false;
  bool cycle_r_known = false;
  double cycle_bottom = 0;
  bool cycle_bottom_known = false;
  /// LinuxCNC: R and the plane-normal word of the cycle as written (program units), kept for the
  /// next cycle blocks, which compute the levels from them again (rs274's cycle_r / cycle_cc).
  double cycle_r_word = 0, cycle_n_word = 0;
  bool cycle_r_word_known = false, cycle_n_word_known = false;
  WorkOffset work_offset;
  AxisVector local_offset = AxisVector::Zero();
  AxisVector position_offset = AxisVector::Zero();
  AxisVector saved_position_offset = AxisVector::Zero();
  /// Axes whose G92 shift is not known: G92 named them where their position was unknown (after
  /// G28/G30, probing, an unknown work offset). Their program coordinates are still known.
  AxisMask position_offset_unknown = 0;
  /// LinuxCNC keeps the G92 shift in parameters #5211–#5219, which G92.3 applies again: written by
  /// every G92 and G52, cleared by G92.1, kept by G92.2. Before the program writes them they hold
  /// what the var file holds (unknown here).
  AxisMask saved_position_offset_unknown = (1u << kAxisCount) - 1;
  /// LinuxCNC #5210: a G92/G52 shift is applied (G92, G52, G92.3 set it; G92.1, G92.2 clear it).
  /// M72 restores it: on, the stored shift is applied again (as G92.3); off, it is removed (G92.2).
  bool position_offset_applied = false;
  bool tool_length_active = false;
  bool spindle_turning = false;  ///< M3/M4 given, not stopped by M5 / M2 / M30 (every dialect)
  std::uint16_t tool_length_h = 0;
  double tool_length = 0;           ///< mm, the applied tool length offset (0 at power-on, G49)
  bool tool_length_known = true;
  std::uint64_t tool_length_line = 0;   ///< line of the last offset change that left Z unknown
  /// 1: Z unknown since that change and not programmed yet; 2: Z moved in the change's own block
  /// (Fanuc), so a feed move without Z right after it is not what the program reads as.
  std::uint8_t tool_z_pending = 0;
  int selected_tool = -1;           ///< T word (LinuxCNC: selected, loaded by M6), -1 = none
  int current_tool = -1;            ///< tool in the spindle (LinuxCNC M6 / M61 Q), -1 = unknown
  bool current_tool_by_m61 = false; ///< LinuxCNC: that tool came by M61 (rs274 keeps the old tool's data)
  int siemens_d = -1;               ///< Sinumerik active D (cutting edge), -1 = none programmed
  int cutter_comp = 0;              ///< 0 = G40, 1 = left (G41), 2 = right (G42)
  double cutter_radius = 0;         ///< mm, when cutter_radius_known
  bool cutter_radius_known = true;
  bool cutter_comp_reported = false;  ///< the refusal of this activation was reported
  std::uint64_t cutter_comp_line = 0;
  TcpMode tcp = TcpMode::off;
  bool tilted_plane = false;
  bool ori_mks = false;             ///< Siemens ORIMKS: orientation vectors in the machine frame
  bool polar_interp = false;
  bool polar_coords = false;        ///< Fanuc G16 polar coordinate command
  bool scaling = false;             ///< Fanuc G51 scaling (motions refused while active)
  AxisMask mirror = 0;              ///< Fanuc G51.1: mirrored axes
  AxisMask mirror_centre_known = 0;
  AxisMask mirror_synced = 0;       ///< mirrored axes reached by an absolute word since the mirror began
  AxisVector mirror_centre = AxisVector::Zero();  ///< G51.1 axis of symmetry per axis, mm / deg
  AxisVector home_mid = AxisVector::Zero();       ///< Fanuc G28/G30 intermediate point (work frame), for G29
  AxisMask home_mid_known = 0;
  Eigen::Vector3d circle_centre = Eigen::Vector3d::Zero();  ///< Heidenhain CC (I J K), mm, modal
  std::uint8_t circle_centre_known = 0;  ///< bits 0..2 = X Y Z components set
  Eigen::Vector2d pole = Eigen::Vector2d::Zero();  ///< Siemens polar pole in the plane's (first, second) axes, mm
  Plane pole_plane = Plane::xy;
  bool pole_defined = false;        ///< G110/G111/G112 seen (else the work origin is the pole)
  bool pole_known = true;
  double polar_angle = 0, polar_radius = 0;  ///< modal AP= (deg) and RP= (mm)
  bool polar_angle_set = false, polar_radius_set = false;
  Eigen::Vector3d tangent = Eigen::Vector3d::UnitX();  ///< direction at the end of the last motion (Siemens CT)
  bool tangent_known = false;
  AxisVector position = AxisVector::Zero();  ///< current point, active work coordinates, mm / deg
  AxisMask known = 0;
};

struct InterpreterOptions {
  /// Tolerance on the difference of start and end radius of an arc given by its centre, in mm,
  /// applied together with a relative tolerance of 0.1 % (both must be exceeded to refuse).
  double arc_radius_tolerance_mm = 0.002;
  /// The lines read are the program's own source (false: text a resolver wrote from it), so the
  /// limits of the controller's line reader apply to them (LinuxCNC: 252 characters, CR counted).
  bool source_text = true;
};

/// Interprets one program. Not thread-safe; one instance per program.
class Interpreter {
 public:
  Interpreter(const Dialect& dialect, std::string file, DiagnosticSink& sink, InterpreterOptions opt = {});
  /// Executes one lexed block. Motions are passed to `out` in order.
  void execute(const Block& block, MotionSink& out);
  /// True after execute() when the block's move ends in a chamfer or corner rounding (Fanuc ,C ,R;
  /// Sinumerik CHF= CHR= RND=) whose geometry needs the next block: run_program then calls
  /// resolve_corner with the next line before it hands this block on.
  [[nodiscard]] bool corner_pending() const { return corner_.has_value(); }
  /// Builds the pending corner of `current` with `next` (the following line, lexed): shortens the
  /// last motion in `motions` and appends the chamfer line or rounding arc; the next block's move
  /// then starts where the corner ends. Where it cannot (the next line is not a straight move in the
  /// plane, the corner is too large), both moves are refused, located.
  void resolve_corner(const Block& current, const Block& next, std::vector<Motion>& motions);
  /// Reports what the program left unfinished at its end (a Fanuc cycle whose profile never ended).
  void finish();
  /// LinuxCNC cutter radius compensation holds a compensated move until the next move says where it
  /// ends (src/gcode/interpreter_cutter.cpp): it is passed to a later block's sink, with its own line.
  [[nodiscard]] bool offset_holding() const;
  [[nodiscard]] const ModalState& state() const { return s_; }
  [[nodiscard]] const Dialect& dialect() const { return d_; }

 private:
  struct BlockWords;
  void report(const Block& b, Span at, Severity sev, std::string_view code, std::string msg);
  bool collect(const Block& b, BlockWords& w);
  void apply_tokens(const Block& b, BlockWords& w);
  void apply_modes(const Block& b, BlockWords& w);
  void do_motion(const Block& b, BlockWords& w, MotionSink& out);
  bool target(const Block& b, const BlockWords& w, Motion& m);
  bool arc(const Block& b, const BlockWords& w, Motion& m, AxisMask start_known);
  bool check_arc_words(const Block& b, const BlockWords& w);
  bool turn_fraction(const Block& b, const BlockWords& w);
  bool siemens_motion_words(const Block& b, const BlockWords& w, GMeaning mode);
  void corner_words(const Block& b, const BlockWords& w);
  void siemens_pole(const Block& b, const BlockWords& w, std::uint16_t code10, Span at);
  bool siemens_polar_end(const Block& b, const BlockWords& w, GMeaning mode, Eigen::Vector2d& end);
  bool cip_arc(const Block& b, const BlockWords& w, Motion& m, AxisMask start_known);
  bool tangent_arc(const Block& b, const BlockWords& w, Motion& m, AxisMask start_known,
                   const Eigen::Vector3d& tangent, bool tangent_known);
  bool set_plane_arc(const Block& b, Span at, Motion& m, Plane plane, const Eigen::Vector2d& c, double sweep);
  void emit(Motion& m, const Block& b, MotionSink& out);
  bool radii_agree(const Block& b, Span at, const Eigen::Vector2d& s, const Eigen::Vector2d& e,
                   const Eigen::Vector2d& c,
                   std::string_view hint = {});
  void drill(const Block& b, const BlockWords& w, Motion& m, MotionSink& out, std::uint16_t prev_code10);
  bool linuxcnc_cycle_levels(const Block& b, const BlockWords& w, AxisMask normal_bit, std::uint16_t prev_code10);
  void drill_hole(const Block& b, const BlockWords& w, Motion& m, MotionSink& out, AxisMask normal_bit,
                  const PlaneAxes& p);
  /// The repeat count of a drilling cycle block (L / K), 1 without one; -1 when the block is
  /// refused or not followed (reported).
  long drill_repeats(const Block& b, const BlockWords& w, AxisMask normal_bit);
  void fill_state(Motion& m) const;
  void tool_vector(const BlockWords& w, Motion& m) const;
  void dwell(const Block& b, BlockWords& w);
  void tool_offsets(const Block& b, BlockWords& w);
  void tool_length_change(const Block& b, const BlockWords& w, Span at, double mm, bool known);
  [[nodiscard]] bool table_length(long number, double& mm) const;
  /// The radius of tool / cutting edge `number` (D0 / tool 0: 0); false when unknown.
  [[nodiscard]] bool table_radius(long number, double& mm) const;
  /// G10 L1/L10/L11 (LinuxCNC tool table; Fanuc L10–L13 tool offset memory): the entries written.
  void tool_table_write(const Block& b, const BlockWords& w, long l, long p);
  void cutter_comp_motion(const Block& b, Span at);
  // LinuxCNC cutter radius compensation (src/gcode/interpreter_cutter.cpp; geometry: cutter_offset.cpp).
  struct CutterComp;
  struct CompBefore {
    int comp = 0;
    Plane plane = Plane::xy;
    bool inch = false;
  };
  CutterComp& cutter_comp();
  [[nodiscard]] bool offset_active() const;
  void execute_linuxcnc(const Block& b, MotionSink& out);
  void comp_refuse(const Block& b, Span at, std::string_view why, std::string_view what);
  void linuxcnc_comp_on(const Block& b, const BlockWords& w, std::uint16_t code10, Span at);
  void linuxcnc_comp_off();
  void linuxcnc_comp_modes(const Block& b, BlockWords& w, const CompBefore& before, MotionSink& out);
  bool linuxcnc_comp_motion(const Block& b, BlockWords& w, GMeaning mode, Span at);
  void compensated_emit(Motion& m, const Block& b, MotionSink& out);
  void unknown_radius_emit(Motion& m);
  void linuxcnc_comp_stop(const Block& b, const BlockWords& w, MotionSink& out);
  void linuxcnc_comp_finish();
  void comp_break(const Block& b, MotionSink& out);
  void comp_restore_break();
  static void pass_on(const Block& b, std::vector<Motion>& moves, MotionSink& out);
  void linuxcnc_tool_setup(const Block& b, const BlockWords& w);
  void modal_save_restore(const Block& b, BlockWords& w);
  /// G92.1 (`clear`: the stored shift too) / G92.2: the G92 shift leaves the coordinates.
  void siemens_frame(const Block& b, const BlockWords& w);
  void set_offsets(const Block& b, BlockWords& w);
  void shift_origin(BlockWords& w, GMeaning meaning);
  void remove_position_offset(bool clear);
  /// G92.3: the stored shift (#5211…) replaces the one in force.
  void apply_stored_position_offset();
  bool polar_to_xy(const Block& b, BlockWords& w, bool cycle);
  void set_polar_xy(BlockWords& w, double x, double y) const;
  bool polar_cycle_step(const Block& b, BlockWords& w);
  void siemens_token(const Block& b, const Token& t, BlockWords& w);
  void non_modal(const Block& b, BlockWords& w, MotionSink& out);
  bool fanuc_frame(const Block& b, BlockWords& w, GMeaning& mode);
  void fanuc_g29(const Block& b, BlockWords& w, Span at, MotionSink& out);
  void fanuc_frame_command(const Block& b, BlockWords& w, const GCodeDef& def, Span at);
  void unresolved_motion(const Block& b, const BlockWords& w, std::string_view code, std::string what);
  [[nodiscard]] double to_mm(int axis, double v) const;
  // LinuxCNC lathe profile cycles G70–G72 (src/gcode/interpreter_lathe.cpp): the resolver hands
  // the Q subroutine over as "oN sub" … "oN endsub" lines just before the cycle's block.
  struct LatheProfile;
  bool lathe_profile_line(const Block& b);
  void lathe_cycle(const Block& b, const BlockWords& w, MotionSink& out);
  void spindle_synced_move(const Block& b, const BlockWords& w, Motion& m, MotionSink& out);
  // Fanuc lathe turning cycles G70–G75, G90/G94 (G77/G79) (src/gcode/interpreter_fanuc_cycles.cpp).
  struct FanucCycles;
  bool fanuc_profile_line(const Block& b, MotionSink& out);
  bool fanuc_cycle(const Block& b, BlockWords& w, MotionSink& out, GMeaning prev_motion, std::uint16_t prev_code10);
  void fanuc_cycle_words(const Block& b, const BlockWords& w, int code, MotionSink& out);
  bool fanuc_shape(const Block& cb);
  /// A state under which a Fanuc turning cycle is not followed (plane, nose radius compensation,
  /// mirror, scaling, polar coordinates), described; nullptr when none.
  [[nodiscard]] const char* cycle_blocking_mode() const;
  void fanuc_shape_cycle(const Block& cb, MotionSink& out);
  void fanuc_g70(const Block& b, const BlockWords& w, MotionSink& out);
  void fanuc_single(const Block& b, const BlockWords& w, int code, MotionSink& out);
  void fanuc_peck(const Block& b, const BlockWords& w, int code, MotionSink& out);
  void fanuc_emit(const Block& b, Span at, MotionSink& out);
  /// Emits an expanded lathe cycle's moves (program units × `scale` = mm, X as a radius) as the
  /// block's motions, from the current point; updates the position (interpreter_lathe.cpp).
  void emit_turning_moves(const Block& b, Span at, const std::vector<turning::Move>& moves, double scale,
                          MotionSink& out);
  // Lathe threading cycles (src/gcode/interpreter_threading.cpp): true when the block was handled.
  struct ThreadingState;
  bool threading_cycle(const Block& b, const BlockWords& w, MotionSink& out);
  ThreadingState& threading_state();
  void linuxcnc_g76(const Block& b, const BlockWords& w, MotionSink& out);
  void fanuc_g32(const Block& b, const BlockWords& w, MotionSink& out);
  void fanuc_g92(const Block& b, const BlockWords& w, MotionSink& out);
  void thread_moves(const Block& b, Span at, const std::vector<threading::Move>& moves, MotionSink& out);

  Dialect d_;
  std::string file_;
  DiagnosticSink* sink_;  ///< a pointer: resolve_corner runs a quiet copy of the interpreter
  InterpreterOptions opt_;
  ModalState s_;
  ModalState saved_;           ///< LinuxCNC M70 saved state, valid when saved_valid_
  bool saved_valid_ = false;
  /// LinuxCNC: the states saved (M70/M73) at subroutine call levels 1, 2, … of a resolved program,
  /// whose M70–M73 lines the resolver marks "(postproc: call level N)"; level 0 is saved_.
  std::vector<std::pair<ModalState, bool>> level_saved_;
  bool warned_integer_input_ = false;
  /// A chamfer or rounding at the end of this block's straight move, waiting for the next block.
  struct Corner {
    enum class Kind : std::uint8_t { leg, length, radius } kind = Kind::leg;  ///< ,C/CHR · CHF · ,R/RND
    double size_mm = 0;
    Span at;                ///< the corner word
    Plane plane = Plane::xy;
    /// Fanuc lathe G01 with I/K/R (B-63944EN "Chamfering and corner R"): the next move must run along
    /// this axis (0 X, 2 Z) in this direction (+1/−1); -1 = any straight move (,C ,R, CHF=, …).
    int next_axis = -1;
    int next_sign = 0;
  };
  std::optional<Corner> corner_;
  /// Where the next block's move starts (the end of the corner), set by resolve_corner.
  std::optional<AxisVector> corner_start_;
  bool corner_word(const Block& b, const BlockWords& w, GMeaning mode);
  bool lathe_corner(const Block& b, const BlockWords& w, GMeaning mode);
  void withhold_corner(const Block& current, const Corner& c, Severity sev, std::string message,
                       std::vector<Motion>& motions);
  void round_with_arcs(const Block& current, const Corner& c, Motion& m, const Motion& n, std::vector<Motion>& motions);
  void execute_block(const Block& block, MotionSink& out);
  std::uint64_t corner_pending_line_ = 0;
  /// Tool table entries the program wrote (G10 L1/L10/L11…): the value, or nullopt where it is not
  /// known here (set from the machine position, or by an expression this version did not resolve).
  /// They take precedence over the tool table file / machine file. `tool_table_unknown_`: a G10 wrote
  /// an entry whose number is not known, so no entry is.
  std::map<std::uint32_t, std::optional<double>> lengths_written_, radii_written_;
  bool tool_table_unknown_ = false;
  /// Work systems whose table entry the program wrote (G10 L2/L20): code10 * 1000 + P (G54.1 Pn);
  /// `work_table_unknown_`: an entry whose system is not known (or Fanuc's external offset) was written.
  std::set<std::uint32_t> work_written_;
  /// Work systems whose table entry the program wrote as plain numbers (G10 L2, see
  /// Motion::work_offset_written), same keys: the axes written and their values (mm / degrees).
  std::map<std::uint32_t, std::pair<AxisMask, AxisVector>> work_values_;
  /// G10 L2 writes table entry `key` (code10 * 1000 + P): its plain values are recorded
  /// (work_values_) when `exact`, else the entry becomes unknown (work_written_).
  void work_table_values(const BlockWords& w, std::uint32_t key, bool exact);
  bool work_table_unknown_ = false;
  void work_table_write(long p_index);
  bool corner_angle_ = false;  ///< this block's refused corner word is a direct-drawing angle  ///< Fanuc: line of a ,C/,R whose next motion is moved by it
  bool corner_refused(const Block& b, const BlockWords& w, GMeaning mode);
  bool mcall_active_ = false;  ///< Siemens modal cycle call
  bool mcall_pending_ = false; ///< MCALL seen in this block
  Span frame_span_;            ///< where that frame keyword is
  int frame_keyword_ = 0;      ///< Siemens frame keyword in this block: 1 TRANS, 2 ATRANS, 3 ROT/SCALE/…
  std::shared_ptr<LatheProfile> lathe_profile_;  ///< the last profile subroutine read (LinuxCNC)
  bool spindle_turning_ = false;  ///< LinuxCNC: M3/M4 given and not stopped by M5 (G33 needs it)
  std::shared_ptr<FanucCycles> fanuc_cycles_;  ///< Fanuc lathe: cycle values, profiles, collection
  bool fanuc_replay_ = false;  ///< executing the profile blocks of a G70
  std::shared_ptr<ThreadingState> threading_;  ///< threading cycles' data, made on first use
  std::shared_ptr<CutterComp> comp_;  ///< LinuxCNC cutter radius compensation, made on first use
};

}  // namespace postproc::gcode
