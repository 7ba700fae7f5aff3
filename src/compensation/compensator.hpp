#pragma once
// compensate's block visitor: the state carried from block to block (controller map, corrected
// positions the controller holds, modal tool vector, arc mode) and the steps per motion. Its
// member functions are defined in compensate.cpp and compensate_shapes.cpp (arcs, cycles).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include <fmt/format.h>

#include "postproc/compensation/compensate.hpp"
#include "postproc/machine/program_map.hpp"
#include "postproc/gcode/block_writer.hpp"
#include "postproc/gcode/lexer.hpp"
#include "postproc/gcode/number_style.hpp"
#include "postproc/gcode/program.hpp"
#include "src/compensation/compensate_support.hpp"
#include "src/gcode/convert_support.hpp"
#include "src/gcode/linearize.hpp"
#include "src/gcode/text.hpp"

namespace postproc::comp::detail {
using gcode::AxisMask;
using gcode::AxisVector;
using gcode::Block;
using gcode::Motion;
using gcode::MotionType;
using gcode::Word;

inline constexpr std::string_view kRefused = "PP-E601";         // a block cannot be compensated exactly
inline constexpr std::string_view kMachine = "PP-E602";         // the program needs data the machine file lacks
inline constexpr std::string_view kTravel = "PP-E603";          // the corrected block leaves the axis travel
inline constexpr std::string_view kKinematics = "PP-E604";      // the kinematics failed (singular, no convergence)
inline constexpr std::string_view kRapidAsWritten = "PP-W601";  // a rapid left uncorrected (positions unknown)
inline constexpr std::string_view kTurningLimit = "PP-W602";    // a turning radius below what the machine reaches
inline constexpr std::string_view kUnnumberedBlocks = "PP-W603";  // Klartext blocks inserted without a block number
inline constexpr std::string_view kSpindlePosition = "PP-E605"; // the turning spindle's axis programmed while it turns
inline constexpr int kMaxSegments = 4096;

class Compensator final : public gcode::BlockVisitor {
 public:
  /// `out`: where the written lines go (flushed every MiB); nullptr keeps them in memory for
  /// take_output() (a chunk of a parallel run, compensate_parallel.cpp).
  Compensator(std::string_view file, const gcode::Dialect& d, const machine::Machine& m, const CompensateOptions& opt,
              io::OutputFile* out, gcode::DiagnosticSink& sink, CompensateResult& r)
      : file_(file), d_(d), m_(m), opt_(opt), out_(out), sink_(sink), r_(r), track_(d), models_(m) {
    collect_.on_report = [this](const gcode::Diagnostic& diag) {
      if (diag.severity == gcode::Severity::error) block_error_ = true;
      sink_.report(diag);
    };
    joints_ = kin::JointVector::Zero(m.nominal->joint_count());
    for (int j = 0; j < m.nominal->joint_count(); ++j) {
      const kin::Joint& jt = m.nominal->joints()[static_cast<std::size_t>(j)];
      joints_[j] = std::clamp(0.0, jt.min, jt.max);
    }
    written_.setZero();
  }
  gcode::DiagnosticSink& collector() { return collect_; }

  /// The modal context a controller map is built for.
  struct MapKey {
    Form form = Form::axes;
    gcode::Frame frame = gcode::Frame::work;
    std::uint16_t code10 = 0, p = 0;
    bool length_active = false;
    std::uint16_t h = 0;
    AxisVector shift = AxisVector::Zero();
    gcode::AxisMask shift_unknown = 0;
    bool work_rewritten = false, length_rewritten = false;  ///< a G10 wrote the offset / the length
    gcode::AxisMask work_written = 0;                       ///< axes a G10 L2 wrote as numbers …
    AxisVector work_value = AxisVector::Zero();             ///< … and their values
    bool operator==(const MapKey& o) const {
      return form == o.form && frame == o.frame && code10 == o.code10 && p == o.p && length_active == o.length_active &&
             h == o.h && shift == o.shift && shift_unknown == o.shift_unknown && work_rewritten == o.work_rewritten &&
             length_rewritten == o.length_rewritten && work_written == o.work_written && work_value == o.work_value;
    }
  };

  /// Everything the compensation of a block takes from the blocks before it. Two runs that reach
  /// a block with equal states write it, and everything after it, identically: the parallel run
  /// (compensate_parallel.cpp) starts chunks from a guessed state and accepts a chunk only when its
  /// guess equals the state the chunk before it ended with.
  struct Carry {
    // From the program text alone (the parallel run's reader tracks them exactly).
    gcode::ModalTrack track;
    ModalToolVector vector;
    std::string eol;
    bool recompensation_checked = false;
    bool header_done = false;
    std::string arc_word;
    // From the corrections written before.
    kin::JointVector joints;
    AxisVector written = AxisVector::Zero();
    AxisMask written_known = 0;
    AxisMask mask = 0;
    Eigen::Vector3d prev_vector = Eigen::Vector3d::UnitZ();
    Eigen::Vector3d prev_written_vector = Eigen::Vector3d::UnitZ();
    bool arc_mode_broken = false;
    bool turning_limit_warned = false;
    bool unnumbered_warned = false;
    bool map_held = false;  ///< a controller map of context map_key is held
    MapKey map_key;
    [[nodiscard]] bool operator==(const Carry& o) const;
  };
  [[nodiscard]] Carry carry() const {
    return Carry{track_,  vector_,      eol_,         recompensation_checked_, header_done_,
                 arc_word_, joints_,     written_,     written_known_,          mask_,
                 prev_vector_, prev_written_vector_, arc_mode_broken_, turning_limit_warned_, unnumbered_warned_,
                 map_held_,    map_key_};
  }
  void restore(const Carry& c) {
    track_ = c.track;
    vector_ = c.vector;
    eol_ = c.eol;
    recompensation_checked_ = c.recompensation_checked;
    header_done_ = c.header_done;
    joints_ = c.joints;
    written_ = c.written;
    written_known_ = c.written_known;
    mask_ = c.mask;
    prev_vector_ = c.prev_vector;
    prev_written_vector_ = c.prev_written_vector;
    arc_mode_broken_ = c.arc_mode_broken;
    arc_word_ = c.arc_word;
    turning_limit_warned_ = c.turning_limit_warned;
    unnumbered_warned_ = c.unnumbered_warned;
    map_held_ = c.map_held;
    map_key_ = c.map_key;
    map_.reset();  // rebuilt from map_key_ by the next motion
  }
  /// Reader-only mode: blocks update what comes from the text (carry()'s first part) and nothing
  /// is corrected (give it options without a line map and a sink and result that are discarded:
  /// the header and a PP-E620 refusal still go there).
  void set_text_only(bool on) { text_only_ = on; }
  /// The lines written so far (out == nullptr).
  [[nodiscard]] std::string take_output() { return std::move(buffer_); }
  /// For progress reports (bytes read).
  void set_reader(const gcode::LineReader* in) { reader_ = in; }

  void block(const Block& b, std::span<const Motion> motions, bool lexed_ok) override {
    ++r_.blocks;
    if (opt_.progress && reader_ != nullptr && (r_.blocks & 8191) == 0)
      opt_.progress("compensate", static_cast<double>(reader_->bytes_read()), static_cast<double>(opt_.input_bytes));
    if (!b.eol.empty()) eol_ = std::string(b.eol);
    if (!recompensation_checked_ && refuse_recompensation(b.raw, b.line, file_, opt_, sink_)) {
      recompensation_checked_ = true;  // reported once, at the first header
      block_error_ = true;
    }
    maybe_header(b);
    track_.update(b);
    note_arc_word(b);
    if (text_only_) {  // the modal tool vector follows the motions a correction would see
      if (lexed_ok && !block_error_ && !track_.has(gcode::GMeaning::home_return))
        for (const Motion& m : motions) (void)vector_.apply(m);
      block_error_ = false;
      return;
    }
    after_.clear();
    gcode::BlockEditor ed(b, d_.decimal_point_required);
    if (lexed_ok && !block_error_ && track_.has(gcode::GMeaning::home_return)) {
      // G28/G30 go to the machine's reference position (through an intermediate point): machine
      // positions, not part geometry, so they stay as written and the positions become unknown.
      written_known_ = 0;
      ++r_.reference_moves;
    } else if (lexed_ok && !block_error_) {
      if (const Motion* o = cutter_offset_motion(motions)) {
        // LinuxCNC cutter radius compensation: refused once, and nothing under it is corrected.
        if (!offset_refused_) refuse(b, o->column, kRefused, cutter_offset_refusal(*o));
        offset_refused_ = true;
        written_known_ = 0;
      } else if (motions.size() > 1) {
        for (const Motion& m : motions) check_unchanged(b, vector_.apply(m));
      } else if (motions.size() == 1) {
        motion(b, vector_.apply(motions.front()), ed);
      }
    }
    block_error_ = false;
    // A block that moves to the reference point or changes the work offset without moving: the
    // corrected position the controller holds is no longer known in the program's coordinates.
    if (motions.empty() && !keeps_coordinates()) written_known_ = 0;
    // Axis words that produced no motion (a move the reader refused or does not resolve: an arc from
    // an unknown start, a Fanuc ,R corner, a Sinumerik TURN=.5 helix): what the controller holds on
    // those axes is not the last written value.
    if (motions.empty() && track_.axis_consumer() == nullptr && !track_.axis_words_data)
      for (const gcode::Word& w : b.words)
        if (const int a = track_.axis_of(w); a >= 0) written_known_ &= static_cast<gcode::AxisMask>(~(1u << a));
    if (ed.empty()) {
      emit(b.raw, after_.empty() ? b.eol : std::string_view(eol_), b.line);
    } else {
      line_.clear();
      ed.render(line_);
      ++r_.changed_blocks;
      const std::string_view eol = after_.empty() ? b.eol : std::string_view(eol_);
      if (const auto too_long = gcode::line_too_long(d_, line_, eol))
        refuse(b, 1, kRefused, corrected_line_too_long(*too_long));
      emit(line_, eol, b.line);
    }
    for (std::size_t i = 0; i < after_.size(); ++i)
      emit(after_[i], i + 1 == after_.size() ? b.eol : std::string_view(eol_), b.line);
    r_.segments_added += after_.size();
  }

  void flush() {
    if (out_ == nullptr) return;
    out_->write(buffer_);
    buffer_.clear();
  }
  void finish() {
    flush();
    map_.reset();
    map_held_ = false;
  }

 private:
  /// The arc mode's G word as the program writes it (G2, G02, G3 …), from the last block that set
  /// it: what a modal arc after a linearised one gets back (restore_arc_mode).
  void note_arc_word(const Block& b) {
    if (const auto* g = track_.block_motion())
      if (g->def->meaning == gcode::GMeaning::arc_cw || g->def->meaning == gcode::GMeaning::arc_ccw)
        arc_word_ = std::string(b.text(b.words[g->word].span));
  }

  /// False for blocks that change what the program's coordinates mean (G28/G30, a work offset,
  /// G10 offset writes).
  bool keeps_coordinates() const {
    return !(track_.has(gcode::GMeaning::home_return) || track_.has(gcode::GMeaning::work_offset) ||
             track_.has(gcode::GMeaning::set_offsets_g10));
  }

  void emit(std::string_view raw, std::string_view eol, std::uint64_t from) {
    if (opt_.line_map != nullptr) opt_.line_map->push_back(from);
    buffer_.append(raw);
    buffer_.append(eol);
    if (out_ != nullptr && buffer_.size() > (1u << 20)) flush();
  }

  void maybe_header(const Block& b) {
    if (header_done_ || !opt_.header) return;
    if (header_waits(b)) return;
    header_done_ = true;
    emit(header_comment(d_, m_, opt_), eol_, 0);
  }

  void refuse(const Block& b, std::uint32_t column, std::string_view code, std::string why) {
    const gcode::Span s{column > 0 ? column - 1 : 0, column > 0 ? column : 1};
    gcode::report_at(gcode::LexContext{file_, &sink_}, b, s, gcode::Severity::error, code, std::move(why));
    block_error_ = true;
    written_known_ = 0;
  }
  void note(const Block& b, std::uint32_t column, std::string_view code, std::string why) {
    const gcode::Span s{column > 0 ? column - 1 : 0, column > 0 ? column : 1};
    gcode::report_at(gcode::LexContext{file_, &sink_}, b, s, gcode::Severity::warning, code, std::move(why));
  }

  Form form_of(const Motion& m) const { return machine::form_of(m_, m); }

  /// The controller map of this motion, or nullopt after a refusal.
  std::optional<ProgramMap> map_of(const Block& b, const Motion& m, Form form) {
    const auto offset = program_offset(m_, m);
    if (!offset) {
      refuse(b, m.column, kMachine, machine::program_offset_refusal(m_, m));
      return std::nullopt;
    }
    double length = m_.tool_length;
    if (m.tool_length_rewritten) {
      refuse(b, m.column, kMachine, machine::rewritten_length_refusal(m));
      return std::nullopt;
    }
    if (m.tool_length_active && m.tool_length_h != 0 && m.tool_length_known && m.tool_length != 0) {
      length = m.tool_length;  // the reader's (the machine file's, or what the program wrote with G10 L1)
    } else if (m.tool_length_active && m.tool_length_h != 0) {
      const auto it = m_.tool_lengths.find(m.tool_length_h);
      if (it == m_.tool_lengths.end()) {
        refuse(b, m.column, kMachine,
               fmt::format("tool length H{} is not in machine file {}; add [tool.lengths] {} = \"<length> mm\"",
                           m.tool_length_h, m_.file, m.tool_length_h));
        return std::nullopt;
      }
      length = it->second;
    }
    if (m_.nominal->parameter_index("tool.length") < 0 && std::abs(length - m_.tool_length) > 1e-9) {
      refuse(b, m.column, kMachine,
             fmt::format("a {} machine takes its tool length from [tool] length ({} mm) only, but H{} is {} mm; make "
                         "them equal or use a machine file per tool",
                         m_.model_kind, m_.tool_length, m.tool_length_h, length));
      return std::nullopt;
    }
    if (!models_.length_error_known(length)) {
      refuse(b, m.column, kToolLengthError, models_.unknown_length_error(length, m.tool_length_active ? m.tool_length_h : 0));
      return std::nullopt;
    }
    const auto& [nom, act] = models_.with_tool_length(length);
    return ProgramMap(m_, nom, act, form, *offset, form == Form::axes && m.tool_length_active, length);
  }

  AxisMask written_axes(Form form) const { return machine::written_axes(m_, form); }

  void check_unchanged(const Block& b, const Motion& m) {
    // Several motions in one block (G28 intermediate points, cycles): accepted only when the
    // correction rounds away at every end point.
    Command out;
    if (!endpoint(b, m, out, nullptr)) {
      written_known_ = 0;
      return;
    }
    for (int a = 0; a < gcode::kAxisCount; ++a)
      if ((mask_ >> a) & 1u)
        if (rounded_change(a, m.end[a], out.c[a], m)) {
          refuse(b, m.column, kRefused,
                 "this block makes several moves (a cycle or an intermediate point) and the machine needs a "
                 "correction on them; write the moves out as G0/G1 blocks to compensate them");
          return;
        }
    // The controller now holds this move's end (its correction rounds away): a following block
    // that does not name an axis leaves it there (a lathe threading cycle ends away from where
    // the block before it left the tool).
    written_ = out.c;
    written_known_ = static_cast<gcode::AxisMask>(m.known | mask_);
  }

  /// True when the corrected value prints differently from the source value at the axis's decimals.
  bool rounded_change(int a, double from, double to, const Motion& m) const {
    // Differences below 1e-9 are arithmetic noise, not corrections (a value exactly half a unit
    // off the output grid would otherwise round either way).
    const double f = program_units(a, from, m), t = program_units(a, to, m);
    if (std::abs(t - f) < 1e-9) return false;
    const double s = gcode::decimal_scale(program_decimals(m_, a, m));
    return std::llround(f * s) != std::llround(t * s);
  }

  /// Corrects the end point of `m` into `out`; fills q_actual. False after a refusal. With
  /// `figures`, the error before and the residual after go into the report's figures.
  bool endpoint(const Block& b, const Motion& m, Command& out, kin::JointVector* q_actual, bool figures = false) {
    const Form form = form_of(m);
    // The controller map depends on the modal context only: reuse it while that stays the same.
    const MapKey key{form, m.frame, m.work_offset.code10, m.work_offset.p, m.tool_length_active, m.tool_length_h,
                     m.local_offset + m.position_offset, m.position_offset_unknown, m.work_offset_rewritten,
                     m.tool_length_rewritten, m.work_offset_written, m.work_offset_value};
    if (!map_ || !(key == map_key_)) {  // map_ is empty whenever !map_held_
      // The held corrected position is in the old context's coordinates unless only the tool
      // length changed (the program still names the same points).
      if (map_held_ && !(key.form == map_key_.form && key.frame == map_key_.frame && key.code10 == map_key_.code10 &&
                    key.p == map_key_.p && key.shift == map_key_.shift && key.work_written == map_key_.work_written &&
                    key.work_value == map_key_.work_value))
        written_known_ = 0;
      map_.reset();
      map_held_ = false;
      auto fresh = map_of(b, m, form);
      if (!fresh) return false;
      map_.emplace(std::move(*fresh));
      map_key_ = key;
      map_held_ = true;
    }
    ProgramMap* map = &*map_;
    map->new_block();
    mask_ = written_axes(form);
    if (form == Form::turning && ((m.programmed >> m_.turning_spindle_axis) & 1u)) {
      const char letter = gcode::kAxisLetters[static_cast<std::size_t>(m_.turning_spindle_axis)];
      refuse(b, m.column, kSpindlePosition,
             fmt::format("{0} is the turning spindle of machine '{1}' ([machine] turning_spindle) and turns here "
                         "(M3/M4): a {0} position cannot be compensated while it spins; stop the spindle (M5) before "
                         "positioning {0}",
                         letter, m_.name));
      return false;
    }
    // Rotary axes are not written by turning moves (a B head keeps its value), nor by TCP forms'
    // tool vectors; programming them is not foreign.
    const AxisMask kept = form == Form::axes ? 0 : static_cast<AxisMask>(0b111000);
    const AxisMask foreign = static_cast<AxisMask>(m.programmed & ~mask_ & ~kept);
    if (foreign != 0) {
      for (int a = 0; a < gcode::kAxisCount; ++a)
        if ((foreign >> a) & 1u) {
          refuse(b, m.column, kMachine,
                 fmt::format("axis {} is not an axis of machine '{}' ({}); check the machine file or the program",
                             gcode::kAxisLetters[static_cast<std::size_t>(a)], m_.name, m_.file));
          return false;
        }
    }
    if (form == Form::tcp_vector && m.orientation_machine_frame) {
      refuse(b, m.column, kRefused,
             "tool vectors in the machine frame (ORIMKS) are not compensated; program them in the workpiece frame "
             "(ORIWKS)");
      return false;
    }
    Command cmd{m.end, m.tool_vector};
    if ((form == Form::tcp_vector) && !m.tool_vector_known && m_.coordinates == machine::ProgramCoordinates::tool_tip) {
      refuse(b, m.column, kRefused, "the tool orientation of this move is not known (no tool vector programmed yet)");
      return false;
    }
    // Axes whose position the correction depends on: those it writes, and for turning moves the
    // rotary axes too (a B head tilts the tool) except the spinning spindle itself.
    AxisMask needed = mask_;
    if (form == Form::turning)
      for (int a = 3; a < 6; ++a)
        if (m_.joint_of_axis[static_cast<std::size_t>(a)] >= 0 && a != m_.turning_spindle_axis)
          needed = static_cast<AxisMask>(needed | (1u << a));
    const AxisMask unknown = static_cast<AxisMask>(needed & ~m.known);
    kin::JointVector q;
    if (unknown == 0) {
      const kin::Solve s = map->correct(cmd, joints_, out, q);
      if (!s.ok()) return kin_failure(b, m, s, map);
      // First: later checks run the remap on other points.
      measured_block_ = &b;
      if (figures) measure(m, cmd, *map, out, q);
    } else if (!invariant(b, m, *map, cmd, unknown, out, q, figures)) {
      return false;
    }
    // The travel of what is known: an unknown axis stays where the controller holds it.
    if (const int j = outside_known_travel(*map, q, unknown); j >= 0) {
      const kin::Joint& jt = map->actual().joints()[static_cast<std::size_t>(j)];
      refuse(b, m.column, kTravel,
             fmt::format("after correction joint {} would be at {:.6f} {}, outside its travel {} … {} {}; the block "
                         "cannot be compensated on this machine (move the part or the work offset)",
                         jt.name, q[j], jt.type == kin::JointType::rotary ? "deg" : "mm", jt.min, jt.max,
                         jt.type == kin::JointType::rotary ? "deg" : "mm"));
      return false;
    }
    if (q_actual != nullptr) *q_actual = q;
    return true;
  }

  /// The first joint of q outside its travel whose program axis is not in `unknown`; -1 if none.
  static int outside_known_travel(const ProgramMap& map, const kin::JointVector& q, AxisMask unknown) {
    kin::JointVector known = q;
    for (int j = 0; j < map.actual().joint_count(); ++j)
      if (const int a = map.axis_of_joint(j); a >= 0 && ((unknown >> a) & 1u)) {
        const kin::Joint& jt = map.actual().joints()[static_cast<std::size_t>(j)];
        known[j] = std::clamp(q[j], jt.min, jt.max);
      }
    return kin::joint_outside_limits(map.actual(), known);
  }

  bool kin_failure(const Block& b, const Motion& m, const kin::Solve& s, const ProgramMap* map = nullptr) {
    if (map != nullptr && s.status == kin::Status::out_of_limits && s.joint >= 0) {
      refuse(b, m.column, kTravel, map->explain(s));
      return false;
    }
    refuse(b, m.column, kKinematics,
           fmt::format("the kinematics failed for this position ({}, {} iterations, residual {:.3g} mm / {:.3g} rad); "
                       "the pose may be singular or unreachable on this machine",
                       kin::to_string(s.status), s.iterations, s.residual_mm, s.residual_rad));
    return false;
  }

  /// Axes whose position is unknown (nothing programmed them yet): the controller holds them
  /// where they are and moves only the named axes, so the correction is accepted only if it does
  /// not depend on where they stand, checked at sample positions the controller can hold (the ends
  /// of their travel, compensate_unknown_axes.cpp). With `figures`, the report's figures are the
  /// worst over those samples (none from an assumed 0).
  bool invariant(const Block& b, const Motion& m, const ProgramMap& map, const Command& cmd, AxisMask unknown,
                 Command& out, kin::JointVector& q, bool figures);
  /// Values of unknown axis `a` (mm / deg, program coordinates) the controller can hold: its joint
  /// at the ends of its travel; for axes that are not a joint (parallel machines' tool tip) the
  /// home pose's value ± 100 mm / ± 30 deg. Samples the machine cannot reach are dropped by the caller.
  std::vector<double> unknown_samples(const ProgramMap& map, const Command& cmd, int a) const;
  /// True when the controller can hold command `c` (its nominal joints give back `c` on the axes of `mask_`).
  bool reachable(const ProgramMap& map, const Command& c) const;

  void motion(const Block& b, const Motion& m, gcode::BlockEditor& ed) {
    ++r_.motions;
    if (siemens_unwritable(b, m)) return;
    Command out;
    kin::JointVector q;
    rapid_as_written_ = false;
    if (!endpoint(b, m, out, &q, true)) {
      if (rapid_as_written_) note_written(m, m.end);
      else written_known_ = 0;
      return;
    }
    const ProgramMap& map = *map_;
    if (m.tilted_plane) {
      check_unchanged(b, m);
      note_written(m, m.end);
      return;
    }
    if (m.type == MotionType::drill_cycle) {
      drill(b, m, map, ed);
      return;
    }
    const bool arc = m.type == MotionType::arc_cw || m.type == MotionType::arc_ccw;
    if (arc) {
      ArcCheck k = arc_check(b, m, out);
      if (k == ArcCheck::refused) return;
      if (k == ArcCheck::rigid && opt_.split.linearize_arcs) k = ArcCheck::linearize;
      if (k == ArcCheck::linearize) {
        if (linearize_arc(b, m, map, out, ed)) joints_ = q;
        return;
      }
      ++r_.arcs_kept;
      restore_arc_mode(b, ed);
    }
    // Subdivide feed moves whose joint-space interpolation would leave the intended path.
    std::vector<Command> points;
    std::vector<double> fractions;  // where the points are along the move; empty: equal pieces
    bool subdivided = false;
    if (m.type == MotionType::linear && (written_known_ & mask_) == mask_ && (m.known & mask_) == mask_) {
      if (!subdivide(b, m, map, out, points)) return;
      subdivided = !points.empty();
      if (opt_.split.step_s > 0 && splittable(b, m, map)) split_for_contour(m, map, out, points, fractions);
    }
    if (m.type != MotionType::rapid && !arc) restore_arc_mode(b, ed);
    if (!points.empty()) {
      if (subdivided) ++r_.subdivided_blocks;
      write_segments(b, m, ed, points, fractions, out);
    } else {
      write_end(b, m, ed, out);
    }
    joints_ = q;
  }

  /// Error of the original program on the real machine and the residual of the corrected one.
  /// `cmd`: the block's command (program values, the unknown axes at a sample position); `held`:
  /// axes the block does not write (unknown), which the controller keeps exactly.
  void measure(const Motion& m, const Command& cmd, const ProgramMap& map, const Command& out,
               const kin::JointVector& q_written, AxisMask held = 0) {
    // The intended pose and the nominal joints of the end point come from the remap itself.
    // Poses are compared as the part sees them (a turning move: radius and Z; ProgramMap::as_cut).
    const kin::Pose& want = map.last_intended_cut();
    kin::Pose before, after, written_nominal;
    kin::JointVector qa;
    if (!map.actual_forward(map.last_nominal_joints(), map.last_intended(), before).ok()) return;
    before = map.as_cut(map.actual(), map.last_nominal_joints(), before);
    // The tool-axis correction on every machine kind: the tool axis the nominal machine would
    // have for the written block against the intended one (rotary words, tool vectors or struts).
    // A tool vector is that axis as written; otherwise forward kinematics of the written joints.
    std::optional<Eigen::Vector3d> written_axis;
    if (map.form() == Form::tcp_vector) written_axis = out.vector.normalized();
    else if (q_written.size() == map.last_nominal_joints().size() && map.nominal().forward(q_written, written_nominal).ok())
      written_axis = map.as_cut(map.nominal(), q_written, written_nominal).axis();
    if (written_axis)
      r_.max_axis_correction_rad = std::max(r_.max_axis_correction_rad,
                                            std::acos(std::clamp(written_axis->dot(want.axis()), -1.0, 1.0)));
    const double e = (before.p - want.p).norm();
    const double ea = kin::angle_between(before.axis(), want.axis());
    if (e > r_.max_error_before_mm) {
      r_.max_error_before_mm = e;
      r_.worst_line = m.line;
    }
    r_.max_error_before_rad = std::max(r_.max_error_before_rad, ea);
    Command printed = out;
    for (int a = 0; a < gcode::kAxisCount; ++a) {
      if (!((mask_ >> a) & 1u) || ((held >> a) & 1u)) continue;
      const double s = gcode::decimal_scale(program_decimals(m_, a, m));
      // The value the controller will read: rounded in program units, back to mm / degrees.
      const double pu = program_units(a, out.c[a], m);
      printed.c[a] = out.c[a] + (static_cast<double>(std::llround(pu * s)) / s - pu) * unit_scale(a, m);
      const double dc = std::abs(out.c[a] - cmd.c[a]);
      if (gcode::is_rotary(a)) r_.max_correction_deg = std::max(r_.max_correction_deg, dc);
      else r_.max_correction_mm = std::max(r_.max_correction_mm, dc);
    }
    if (map.real(printed, joints_, after, qa).ok()) {
      after = map.as_cut(map.actual(), qa, after);
      r_.max_residual_mm = std::max(r_.max_residual_mm, (after.p - want.p).norm());
      if (map.form() == Form::turning && (after.p - want.p).norm() > opt_.max_deviation_mm && !turning_limit_warned_) {
        // Facing to the centre with a centre-height error: the tool passes the spindle axis at a
        // distance; the block is written at the closest approach and says so (once per program).
        turning_limit_warned_ = true;
        if (measured_block_ != nullptr) note(*measured_block_, m.column, kTurningLimit,
                  fmt::format("turning: this radius is not reachable on the real machine (the tool tip passes the "
                              "spindle axis at a distance, e.g. a centre-height error); written at the closest "
                              "approach, {:.4f} mm from the intended point — the part keeps a pip there",
                              (after.p - want.p).norm()));
      }
      const double left = std::acos(std::clamp(after.axis().dot(want.axis()), -1.0, 1.0));
      r_.max_residual_rad = std::max(r_.max_residual_rad, left);
      // A block whose tool axis the bounded solve left with more than 5 % of its error.
      if (map.last_bounded_residual_rad() > 0.05 * ea && map.last_bounded_residual_rad() > 1e-9) {
        ++r_.axis_limited_blocks;
        r_.axis_limited_max_rad = std::max(r_.axis_limited_max_rad, left);
        if (r_.axis_limited.size() < kMaxAxisLimitedListed) r_.axis_limited.push_back({m.line, ea, left});
      }
    }
  }

  /// Deviation between the real path of the corrected move and the intended path at fraction t.
  bool deviation(const ProgramMap& map, const Command& c0, const Command& c1, const Command& k0, const Command& k1,
                 double t, double& mm, double& rad) {
    Command c = lerp(c0, c1, t);
    Command k = lerp(k0, k1, t);
    kin::Pose want, got;
    kin::JointVector q1, q2;
    if (!map.intended(c, joints_, want, q1).ok() || !map.real(k, joints_, got, q2).ok()) return false;
    want = map.as_cut(map.nominal(), q1, want);
    got = map.as_cut(map.actual(), q2, got);
    mm = (got.p - want.p).norm();
    rad = std::acos(std::clamp(got.axis().dot(want.axis()), -1.0, 1.0));
    return true;
  }

  /// True when the real path of the corrected segment k0 → k1 stays within `tol_mm` of the
  /// intended segment c0 → c1 inside it, and its tool axis no further from the intended one than
  /// at the worse end plus --max-angle-deviation (machines with fewer joints than the pose has
  /// conditions, e.g. the 4-axis lathe, cannot match the axis even at the end points).
  bool within(const ProgramMap& map, const Command& c0, const Command& c1, const Command& k0, const Command& k1,
              double tol_mm) {
    // The common case first: the middle of the move is on the path (tool axis included).
    double mid_mm = 0, mid_rad = 0;
    if (!deviation(map, c0, c1, k0, k1, 0.5, mid_mm, mid_rad)) return false;
    if (mid_mm <= tol_mm && mid_rad <= opt_.max_angle_rad) return true;
    double mm0 = 0, rad0 = 0, mm1 = 0, rad1 = 0;
    if (!deviation(map, c0, c1, k0, k1, 0.0, mm0, rad0) || !deviation(map, c0, c1, k0, k1, 1.0, mm1, rad1)) return false;
    const double rad_ends = std::max(rad0, rad1);
    for (double f : {0.25, 0.5, 0.75}) {
      double mm = 0, rad = 0;
      if (!deviation(map, c0, c1, k0, k1, f, mm, rad)) return false;
      if (mm > tol_mm + std::max(mm0, mm1) || rad > rad_ends + opt_.max_angle_rad) return false;
    }
    return true;
  }

  bool subdivide(const Block& b, const Motion& m, const ProgramMap& map, const Command& out, std::vector<Command>& pts) {
    const Command c0{m.start, prev_vector_};
    const Command c1{m.end, m.tool_vector};
    Command k0{written_, prev_written_vector_};
    std::uint32_t n = 1;
    for (int round = 0; round < 13; ++round) {
      bool ok = true;
      Command prev_k = k0;
      std::vector<Command> cand;
      for (std::uint32_t i = 1; i <= n && ok; ++i) {
        const double t0 = static_cast<double>(i - 1) / n, t1 = static_cast<double>(i) / n;
        Command ki = out;
        if (i < n) {
          kin::JointVector qq;
          if (!map.correct(lerp(c0, c1, t1), joints_, ki, qq).ok()) return kin_failure(b, m, {kin::Status::no_convergence});
          cand.push_back(ki);
        }
        if (!within(map, lerp(c0, c1, t0), lerp(c0, c1, t1), prev_k, ki, opt_.max_deviation_mm)) ok = false;
        prev_k = ki;
      }
      if (ok) {
        pts = std::move(cand);
        return true;
      }
      n *= 2;
      if (n > kMaxSegments) break;
    }
    refuse(b, m.column, kRefused,
           fmt::format("even {} segments leave the intended path by more than --max-deviation {} mm; raise the limit",
                       kMaxSegments, opt_.max_deviation_mm));
    return false;
  }

  /// The contour candidate splits only plain moves: the block holds nothing but its motion word,
  /// axis words, F, a feed-mode G code (G93 / G94 / G95: modal, in force from the first piece on),
  /// a tool vector (I J K under G43.5-like forms) and comments (Klartext: the L verb and its
  /// words), all literal numbers, and is not block-deleted. Anything else (G9's exact
  /// stop, M functions, S T D H, other G codes, radius compensation) would act at the first
  /// piece instead of the move's end, or is left to the geometric stage's own rules.
  [[nodiscard]] bool splittable(const Block& b, const Motion& m, const ProgramMap& map) const;
  /// Where the contour candidate splits a linear feed move (CompensateOptions::split): fractions
  /// in (0, 1), ascending. The move's time comes from its programmed feed over the root sum of
  /// squares of its program axes (degrees as mm; G93: 1/F min); a heuristic for where the points
  /// go, not the controller's timing, which the contour stage models.
  [[nodiscard]] std::vector<double> split_fractions(const Motion& m) const;
  /// Adds the contour candidate's split points to `pts` (the subdivision's, equal pieces): each
  /// corrected through the remap, every new piece checked against the intended path as the
  /// subdivision's are; `fractions` receives where each point is along the move (G93 pieces take
  /// those shares of the block's time). Leaves both as they were when a point cannot be corrected
  /// or a piece leaves the path.
  void split_for_contour(const Motion& m, const ProgramMap& map, const Command& out, std::vector<Command>& pts,
                         std::vector<double>& fractions);

  static Command lerp(const Command& a, const Command& b, double t) {
    Command c;
    c.c = a.c + (b.c - a.c) * t;
    c.vector = (a.vector + (b.vector - a.vector) * t).normalized();
    return c;
  }

  enum class ArcCheck : std::uint8_t { rigid, linearize, refused };
  /// An arc stays an arc when its correction is a rigid shift (within --max-deviation) over it;
  /// otherwise it is replaced by corrected chords (compensate_shapes.cpp).
  ArcCheck arc_check(const Block& b, const Motion& m, const Command& out);
  /// Refuses (true) a Sinumerik move written in polar coordinates (AP= RP=) or an arc written with
  /// CIP / CT or AR= / I1=: their words are not rewritten by this version (an absolute
  /// intermediate point, a computed end point or a polar end point would go stale).
  bool siemens_unwritable(const Block& b, const Motion& m);
  /// After an arc was replaced by G1 chords, the next arc block that relied on the modal G2/G3
  /// gets its motion word back.
  void restore_arc_mode(const Block& b, gcode::BlockEditor& ed);
  bool linearize_arc(const Block& b, const Motion& m, const ProgramMap& map, const Command& out, gcode::BlockEditor& ed);
  /// A drilling cycle: the hole is corrected at its bottom; the hole axis must stay square to
  /// the work plane on the real machine (the X Y correction at the R plane and at the bottom
  /// agree within --max-deviation), the bottom and R levels are corrected along the normal.
  void drill(const Block& b, const Motion& m, const ProgramMap& map, gcode::BlockEditor& ed);
  void note_written(const Motion& m, const AxisVector& v) {
    written_ = v;
    written_known_ = m.known;
    prev_vector_ = m.tool_vector;
    prev_written_vector_ = m.tool_vector;
  }

  void write_end(const Block& b, const Motion& m, gcode::BlockEditor& ed, const Command& out);
  /// The block ends at pts.front(), new lines continue to the other points and `out`.
  /// `fractions`: where each point is along the move (empty: equal pieces); an inverse-time F is
  /// scaled per piece so that every piece takes its share of the block's time.
  void write_segments(const Block& b, const Motion& m, gcode::BlockEditor& ed, const std::vector<Command>& pts,
                      const std::vector<double>& fractions, const Command& out);

  std::string_view file_;
  const gcode::Dialect& d_;
  const machine::Machine& m_;
  const CompensateOptions& opt_;
  io::OutputFile* out_;
  gcode::DiagnosticSink& sink_;
  CompensateResult& r_;
  const gcode::LineReader* reader_ = nullptr;
  gcode::ModalTrack track_;
  ToolLengthModels models_;
  gcode::DiagnosticSink collect_{0};
  std::optional<ProgramMap> map_;  ///< the map of map_key_ (a cache: rebuilt when empty)
  MapKey map_key_;
  bool map_held_ = false;  ///< the last motion's context is map_key_ (its map built without refusal)
  bool text_only_ = false;
  bool block_error_ = false;
  bool offset_refused_ = false;  ///< a block under LinuxCNC cutter radius compensation was refused
  bool recompensation_checked_ = false;  ///< PP-E620 reported
  bool header_done_ = false;
  bool rapid_as_written_ = false;
  bool turning_limit_warned_ = false;      ///< PP-W602 is said once per program
  bool unnumbered_warned_ = false;        ///< PP-W603 is said once per program
  const Block* measured_block_ = nullptr;  ///< the block measure() reports on
  bool arc_mode_broken_ = false;  ///< an arc was linearised; a following modal arc needs its G word
  std::string arc_word_ = "G2";
  AxisMask mask_ = 0;
  kin::JointVector joints_;
  AxisVector written_;            ///< corrected end of the previous motion, work coordinates
  AxisMask written_known_ = 0;
  Eigen::Vector3d prev_vector_ = Eigen::Vector3d::UnitZ();
  ModalToolVector vector_{m_};
  Eigen::Vector3d prev_written_vector_ = Eigen::Vector3d::UnitZ();
  std::vector<std::string> after_;
  std::string line_, buffer_;
  std::string eol_ = "\n";
  WordWriter writer_{d_, m_, track_};
};

/// compensate() with opt.jobs > 1 threads (compensate_parallel.cpp): the same output, report and
/// diagnostics as one thread.
CompensateResult compensate_parallel(gcode::LineReader& in, std::string_view file, const gcode::Dialect& dialect,
                                     const machine::Machine& m, const CompensateOptions& opt, io::OutputFile& out,
                                     gcode::DiagnosticSink& sink);

}  // namespace postproc::comp::detail
