#pragma once
/// @file
/// `postproc compensate --mode geometric`: rewrites a program so that the real (calibrated)
/// machine puts the tool where the nominal machine would have (see program_map.hpp for the
/// remap per program form). Blocks that need no change are copied byte for byte.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/contour/path.hpp"
#include "postproc/contour/precompensate.hpp"
#include "postproc/contour/reference.hpp"
#include "postproc/contour/simulate.hpp"
#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/gcode/resolve.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/machine/machine.hpp"
#include "postproc/progress.hpp"

namespace postproc::comp {

/// Which stages run (postproc compensate --mode).
enum class Mode : std::uint8_t {
  geometric,  ///< the geometric remap through the calibrated machine
  contour,    ///< the servo contour precompensation
  all,        ///< the geometric remap, then the contour stage on its result
};
[[nodiscard]] std::string_view to_string(Mode m);
/// "geometric", "contour" or "all"; nullopt otherwise.
[[nodiscard]] std::optional<Mode> parse_mode(std::string_view s);

struct CompensateOptions {
  /// Largest distance allowed between the real tool-tip path of the corrected program and the
  /// intended path, between corrected end points (mm); longer moves are subdivided.
  double max_deviation_mm = 0.001;
  /// Largest tool-axis angle allowed between the two paths (rad).
  double max_angle_rad = 2e-5;
  bool header = true;          ///< write the header comment naming tool, machine file, hash, mode
  std::string tool_version;    ///< for the header and the report
  Mode mode = Mode::geometric;
  /// If set, receives for every output line the input line it came from (0 for the header).
  std::vector<std::uint64_t>* line_map = nullptr;
  /// Told how far the run is (optional): "compensate" in bytes read of `input_bytes` (0 =
  /// unknown), the contour stages by name (the iterations through PrecompensateOptions::progress).
  Progress progress;
  std::uint64_t input_bytes = 0;
  /// Programs with parameters, expressions, calls or control flow (issue 3): resolved with these
  /// options (--set values; subprogram folders, default: the program's folder) …
  gcode::ResolveOptions resolve;
  /// … and written as the resolved literal program (loops unrolled, calls expanded, comments and
  /// non-motion blocks kept; the header says "flattened"). Without it the corrections are written
  /// back into the program's own lines (write_back.hpp), and where that cannot be exact (a word
  /// that needs a correction is an expression, a loop body needs different corrections per run)
  /// the program is refused (PP-E711).
  bool flatten = false;
  /// Set by compensate_program when it wrote a resolved program's corrections back into its own
  /// lines: the header says so.
  bool resolved_in_place = false;
  /// Compensate a program that already carries postproc's compensation header (header_comment);
  /// without it such a program is refused (PP-E620, docs/compensation-verification.md).
  bool allow_recompensation = false;
  /// The caller renumbers the written program's blocks afterwards (compensate --renumber): no
  /// PP-W603 for Klartext blocks inserted without numbers.
  bool renumbered_after = false;
  /// Threads for the geometric stage of one program (compensate_parallel.cpp). The program is
  /// read once, in order, and cut into chunks of `chunk_blocks` blocks that are corrected in
  /// parallel, each starting from the state it guesses by correcting the `warmup_blocks` blocks
  /// before it. A chunk is written only when its guessed start state equals the state the chunk
  /// before it ended with, else it is corrected again from that state: the output, the report and
  /// the diagnostics are those of the one-thread run, for any number of jobs. 1: one thread.
  unsigned jobs = 1;
  std::size_t chunk_blocks = 4096;
  std::size_t warmup_blocks = 32;
  /// The contour modes' second candidate (docs/contour.md, "Long moves and arcs"): the servo error
  /// a corner leaves lies inside the long move after it, and on an arc, where moving block end
  /// points cannot reach it. With `contour_split`, compensate_program also runs the contour stage
  /// on the program with those moves split near their ends and its feed arcs written as chords,
  /// and writes that candidate when the simulation of both written programs finds it better.
  bool contour_split = true;
  /// How the geometric stage's writer splits for that candidate (set by compensate_program; off
  /// when step_s is 0): pieces of a linear feed move last at most `step_s` within `span_s` of
  /// either end (a move shorter than 2·span_s: everywhere), from its programmed feed; with
  /// `linearize_arcs` every feed arc is written as chords within max_deviation_mm / 2.
  struct SplitForContour {
    double step_s = 0;
    double span_s = 0;
    bool linearize_arcs = false;
  } split;
  /// --mode contour / all: the precompensation iteration (contour/precompensate.hpp).
  contour::PrecompensateOptions contour;
};

/// One program to compensate, held in memory: its text, the name its diagnostics give it (and
/// where its subprogram files are looked for), the dialect it is read in and the machine.
struct ProgramInput {
  std::string_view text;
  std::string_view file;
  const gcode::Dialect& dialect;
  const machine::Machine& machine;
};

/// Where `line` carries postproc's compensation header (as header_comment writes it: "postproc
/// VERSION compensate mode=… machine=… sha256=…" in a comment): its 0-based byte offset, or npos.
[[nodiscard]] std::size_t compensation_header_offset(std::string_view line);

/// The first line of a program that carries postproc's compensation header.
struct CompensationHeader {
  std::uint64_t line = 0;      ///< 1-based line number
  std::uint32_t column = 1;    ///< of "postproc" in it
  std::string_view text;       ///< the line (into the program's text; no end of line)
  std::string_view mode;       ///< "geometric", "contour" or "all" (as the header writes it)
  std::string_view machine;    ///< the machine file it names ("?" when the header leaves it out)
};
[[nodiscard]] std::optional<CompensationHeader> find_compensation_header(std::string_view program);

/// Warns (PP-W622, located at the header) when `program` was written by `compensate --mode contour`
/// or `--mode all`: its points lead the servo lag on purpose, so contour errors measured against
/// its own points (`predict`; `simulate` without --reference) are not those of the intended
/// contour. `command` names the command that measures so. True when warned.
bool warn_servo_precompensated(std::string_view program, std::string_view file, std::string_view command,
                               gcode::DiagnosticSink& sink);

/// Refuses (PP-E620, located at the header of line `line_no` = `line`) a program that already
/// carries postproc's compensation header, unless opt.allow_recompensation. True when refused.
bool refuse_recompensation(std::string_view line, std::uint64_t line_no, std::string_view file,
                           const CompensateOptions& opt, gcode::DiagnosticSink& sink);

/// One end point whose tool axis the geometric remap could correct only in part.
struct AxisLimitedBlock {
  std::uint64_t line = 0;   ///< of the source program
  double before_rad = 0;    ///< tool-axis error of the original block on the real machine
  double after_rad = 0;     ///< … of the written block
};
inline constexpr std::size_t kMaxAxisLimitedListed = 10000;

/// --mode contour / all: what one run of the contour stage got. Figures in mm and rad; the
/// "simulated" ones from the time-domain simulation of the written candidates (contour/simulate.hpp).
struct ContourRunReport {
  std::uint64_t line = 0;       ///< line of the run's first move
  std::uint64_t moves = 0;
  int iterations = 0;           ///< accepted iterations of the run
  std::string stop;             ///< why its iteration stopped (contour::to_string(RunStop))
  /// "iterated", "lag" (first-order lag precompensation), "refined" (one of them or the input,
  /// refined on the simulation: contour/learning_control.hpp) or "uncorrected"
  std::string written;
  double predicted_before_mm = 0, predicted_after_mm = 0;  ///< the iteration's prediction (largest tip error)
  double before_mm = 0, before_rad = 0, before_rms_mm = 0;  ///< simulated, as received
  double iterated_mm = 0, iterated_rad = 0, iterated_rms_mm = 0;  ///< simulated, iterated correction
  double lag_mm = 0, lag_rad = 0, lag_rms_mm = 0;            ///< simulated, lag precompensation
  int refined_steps = 0;                                     ///< accepted steps of the refinement
  double refined_mm = 0, refined_rad = 0, refined_rms_mm = 0;  ///< simulated, refined (refined_steps > 0)
};


/// Figures of one run (the --report JSON carries them).
struct CompensateResult {
  std::uint64_t blocks = 0;
  std::uint64_t motions = 0;
  std::uint64_t changed_blocks = 0;
  std::uint64_t words_changed = 0;
  std::uint64_t words_inserted = 0;
  std::uint64_t subdivided_blocks = 0;   ///< moves split because joint interpolation left the path
  std::uint64_t segments_added = 0;      ///< lines added by subdivision
  std::uint64_t arcs_kept = 0;           ///< arcs whose correction is rigid: end point rewritten
  std::uint64_t arcs_linearized = 0;     ///< arcs replaced by corrected G1 chords
  std::uint64_t moves_split = 0;         ///< moves the contour modes' split candidate splits (written or not)
  std::uint64_t reference_moves = 0;     ///< G28/G30 blocks (machine reference: left as written)
  std::uint64_t rapids_as_written = 0;   ///< rapids before every axis was known (left as written, PP-W601)
  /// End points corrected by the bounded solve (kinematics/bounded_inverse.hpp): near a singular
  /// pose, or on a machine with fewer joints than tool tip + tool axis. The tool tip is corrected;
  /// the tool axis only as far as [machine] max_rotary_correction allows.
  std::uint64_t axis_limited_blocks = 0;
  /// The tool-axis angle those blocks keep on the real machine (written values), rad: the largest.
  double axis_limited_max_rad = 0;
  /// The first kMaxAxisLimitedListed of them, in program order (the report lists them).
  std::vector<AxisLimitedBlock> axis_limited;
  std::uint64_t bytes_in = 0;
  double max_correction_mm = 0;          ///< largest change of a linear axis / tool-tip word, mm
  double max_correction_deg = 0;         ///< … of a rotary axis word, degrees
  /// Largest change of the tool axis the written blocks command on the nominal machine, rad: the
  /// tool-axis correction whatever carries it (rotary words, a tool vector, hexapod struts).
  double max_axis_correction_rad = 0;
  double max_error_before_mm = 0;        ///< tool-tip error of the original program on the real machine, mm
  double max_error_before_rad = 0;       ///< … tool-axis angle, rad
  double max_residual_mm = 0;            ///< tool-tip error of the corrected (written) end points, mm
  double max_residual_rad = 0;           ///< … tool-axis angle, rad
  std::uint64_t worst_line = 0;          ///< line of max_error_before_mm
  // --mode contour / all: the servo contour errors of the time-domain simulation (contour/simulate.hpp)
  // of the contour stage's input and of the program as written (docs/compensation-verification.md)
  double contour_before_mm = 0;          ///< largest tool-tip contour error of the program, mm
  double contour_before_rad = 0;         ///< largest tool-axis contour error, rad
  double contour_after_mm = 0;           ///< … of the program as written (read back, simulated), mm
  double contour_after_rad = 0;          ///< rad
  double contour_predicted_after_mm = 0;   ///< the iteration's quasi-static prediction (not verified), mm
  double contour_predicted_after_rad = 0;  ///< rad
  bool contour_verified = false;         ///< before / after come from the simulation (false: not simulated)
  std::uint64_t contour_runs = 0;        ///< runs (stretches of feed moves) of the path
  std::uint64_t contour_runs_withheld = 0;  ///< runs written without the contour correction (PP-W620/W621)
  std::uint64_t contour_worst_line = 0;  ///< line of contour_before_mm
  int contour_iterations = 0;             ///< the most accepted iterations of a run
  bool contour_converged = false;         ///< no run stopped at the iteration limit
  std::uint64_t contour_runs_iterated = 0;  ///< runs written with the iterated correction
  std::uint64_t contour_runs_refined = 0;   ///< runs written with the refinement on the simulation
  std::uint64_t contour_runs_lag = 0;       ///< runs written with the first-order lag precompensation
  std::uint64_t contour_runs_stopped[4] = {0, 0, 0, 0};  ///< runs per contour::RunStop
  std::vector<ContourRunReport> contour_run_reports;   ///< per run of the contour stage
  double fit_residual_mm = 0;            ///< largest NURBS fit residual of the intended contour, mm
  /// The split candidate (CompensateOptions::contour_split): tried (the program has long feed
  /// moves or feed arcs), written, and both written programs simulated against its reference.
  bool contour_split_tried = false;
  bool contour_split_written = false;
  std::uint64_t contour_split_arcs = 0;  ///< arcs the split candidate writes as chords
  /// Runs written from the split candidate (all of them when it is written whole; some, when the
  /// program is written run by run from both candidates).
  std::uint64_t contour_split_runs = 0;
  double contour_unsplit_after_mm = 0, contour_unsplit_after_rad = 0;
  double contour_split_after_mm = 0, contour_split_after_rad = 0;
  std::uint64_t resolved_lines = 0;      ///< lines of the resolved program (0: not resolved)
  std::uint64_t source_lines_rewritten = 0;  ///< resolved without --flatten: program lines rewritten
  bool flattened = false;                 ///< written as the resolved literal program (--flatten)
  std::vector<std::string> subprogram_files;  ///< files the resolution read besides the program
  std::map<std::string, double> used_settings;  ///< --set values the program read
  // The parallel geometric stage (CompensateOptions::jobs > 1): how its guesses fared.
  std::uint64_t parallel_chunks = 0;      ///< chunks the program was cut into (0: one thread)
  std::uint64_t parallel_recomputed = 0;  ///< chunks whose guessed start state was wrong: corrected again
};

/// Compensates the program read by `in` into `out`. Refusals go to `sink` as errors (the caller
/// must not commit `out` when sink.has_errors()).
CompensateResult compensate(gcode::LineReader& in, std::string_view file, const gcode::Dialect& dialect,
                            const machine::Machine& m, const CompensateOptions& opt, io::OutputFile& out,
                            gcode::DiagnosticSink& sink);

/// What --mode contour / all did, beyond CompensateResult: the path, the reference contour and
/// the prediction before and after (contour/predict.hpp).
struct ContourDetails {
  contour::Path path;
  std::optional<contour::Reference> reference;
  /// The verification's reference (simulated_before / simulated_after, the gate, the refinement):
  /// the input's contour with long moves densified (contour::PathOptions::densify_mm), so that
  /// the curve between far block end points is the one the controller interpolates.
  std::optional<contour::Reference> check_reference;
  contour::Precompensation result;
  std::vector<char> run_withheld;  ///< per run of `path`: written without the contour correction
  /// The verification (docs/compensation-verification.md): time-domain simulation of the contour
  /// stage's input and of the program as written (read back); empty when it could not be run.
  std::optional<contour::Simulation> simulated_before, simulated_after;
  /// result.after is the prediction of the commands as written (withheld runs: the input's
  /// commands), not the iteration's last iterate, when a run was withheld.

  /// Request (set before the call): in `--mode all`, keep the geometric stage's input, output and
  /// line map (output line → input line) below, for its report (comp::verify).
  bool keep_geometric_stage = false;
  std::string geometric_input, geometric_output;
  std::vector<std::uint64_t> geometric_line_map;
};

/// `compensate --mode contour`: predicts the servo contour errors of the program held in `text`
/// (machine data: the drives of every joint) and writes it with every linear feed move's end
/// point corrected so that the predicted contour errors cancel (predict.hpp). Arcs, rapids and
/// cycles are predicted but written as they are (linearise arcs first to correct them). The
/// header names mode `opt.mode`. Blocks whose words do not change are copied byte for byte.
CompensateResult compensate_contour(const ProgramInput& in, const CompensateOptions& opt, io::OutputFile& out,
                                    gcode::DiagnosticSink& sink, ContourDetails* details = nullptr);

/// `postproc compensate --mode geometric|contour|all` on a program held in memory, as the CLI and
/// `postproc batch` run it. A program with parameters or control flow is resolved
/// (gcode/resolve.hpp) and compensated as its literal program, with diagnostics and worst lines
/// mapped to the source lines; it is written as that literal program when opt.flatten, else its
/// corrections are carried back into its own lines (write_back.hpp, refusals PP-E711). Then: geometric streams the text through compensate(); contour runs
/// compensate_contour(); all runs the geometric stage into memory (no header), then the contour
/// stage on its output, and reports the geometric figures next to the contour ones (the contour
/// worst line mapped back to the input). `opt.mode` selects; anything else throws
/// postproc::Error (usage). Errors go to `sink`; `out` is not committed.
CompensateResult compensate_program(const ProgramInput& in, const CompensateOptions& opt, io::OutputFile& out,
                                    gcode::DiagnosticSink& sink, ContourDetails* details = nullptr);

/// The header comment line in the dialect's comment syntax (no end of line).
[[nodiscard]] std::string header_comment(const gcode::Dialect& d, const machine::Machine& m,
                                         const CompensateOptions& opt);

}  // namespace postproc::comp
