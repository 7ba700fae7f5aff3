#pragma once
/// @file
/// Dialect semantics of parameters, expressions, subprograms and control flow (issue 3): a program
/// that uses them is *resolved* into the literal program the controller would execute — every
/// executed block once, in execution order, loops unrolled and calls expanded, every value a
/// literal number — before the motion interpreter reads it. Each resolved line points at its
/// source line and at the call stack that reached it.
///
/// Determinism boundary: control flow and values known before the program runs are followed.
/// Anything that depends on run-time state (probe results, machine positions, system variables the
/// controller fills while running, inputs, tool-life counters) is refused with a located
/// diagnostic naming the variable (PP-E701), unless the user supplies its value (`--set`), which
/// the result records in `used_settings`.
///
/// Per dialect (src/gcode/resolve/):
/// - LinuxCNC: numbered parameters #1–#5602 and named #<local> / #<_global>, `[ ]` expressions
///   with every operator and function, assignments taking effect after the line, O-word
///   sub/endsub/call with arguments and return values, if/elseif/else, while, do/while, repeat,
///   break/continue, subroutine files `name.ngc` next to the program.
/// - Fanuc macro B: #1–#33 locals, #100–#199 and #500–#999 common variables, arithmetic and
///   functions, G65 calls and G66/G67 modal calls, M98/M99 subprograms (same file, or O#### files in the folder),
///   IF [..] GOTO n, IF [..] THEN, WHILE [..] DO m … END m.
/// - Siemens: R parameters, DEF variables and arrays, NAME=expr, IF/ELSE/ENDIF, WHILE, FOR,
///   REPEAT/UNTIL, LOOP, CASE … OF, GOTOF/GOTOB/GOTO/GOTOC, IC()/AC() arguments evaluated.

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/gcode/program.hpp"

namespace postproc::gcode {

struct ResolveOptions {
  /// Values supplied for run-time variables, as written by the user: "#5061", "#<_probe>",
  /// "$AA_IM[X]", "R10" → value.
  std::map<std::string, double> set;
  /// Folders searched for subprogram files (LinuxCNC name.ngc, Fanuc O####, Siemens NAME.SPF),
  /// in order; the program's own folder first.
  std::vector<std::string> search_dirs;
  /// Resolved blocks at most (a loop that never ends is refused, PP-E705).
  std::uint64_t max_blocks = 200'000'000;
  /// Bytes of resolved program text at most (held in memory; an endless loop of long blocks would
  /// otherwise use gigabytes before the block limit): also PP-E705.
  std::uint64_t max_resolved_bytes = std::uint64_t{1} << 30;
  /// Lines executed in a row without writing a block at most (statements and control flow only: a
  /// loop that computes forever is refused in well under a second, PP-E705). A loop that comes
  /// back to its head with nothing changed is refused at once whatever this limit.
  std::uint64_t max_silent_lines = 2'000'000;
  /// Call depth at most (PP-E706).
  int max_call_depth = 64;
  /// Siemens: elements of all DEF arrays alive at once at most (checked before allocating, PP-E714).
  std::uint64_t max_array_elements = 10'000'000;
};

/// Where a resolved line came from: the chain of calls that reached it (outermost first).
struct CallFrame {
  std::string file;        ///< the file of the call site
  std::uint64_t line = 0;  ///< the call's line
  std::string callee;      ///< "o100", "o<probe>", "O2000", "G65 P9010", "L100", "SUB1"
};

struct ResolvedProgram {
  /// True when the program uses parameters, expressions, calls or control flow and was resolved;
  /// false: `text` is empty and the source itself is the literal program.
  bool resolved = false;
  /// The literal program: one line per executed block, "\n" line ends; blocks with nothing left
  /// to execute after the statements were evaluated (pure assignments, control-flow lines,
  /// sub/endsub) are dropped, comments are kept with the block they are on.
  std::string text;
  /// Per resolved line (index = resolved line − 1): the source line, its file (index into
  /// `files`, 0 = the program) and its call stack (index into `stacks`, 0 = the main program).
  std::vector<std::uint64_t> source_line;
  std::vector<std::uint32_t> source_file;
  std::vector<std::uint32_t> stack;
  std::vector<std::string> files;                  ///< [0] = the program as named
  std::vector<std::vector<CallFrame>> stacks;      ///< [0] = empty (main program)
  /// Per resolved line: true when its text differs from its source line (values substituted).
  std::vector<bool> substituted;
  /// Blocks executed (resolved lines, dropped statement lines included).
  std::uint64_t executed_blocks = 0;
  /// The --set values the program read (name → value), for the report.
  std::map<std::string, double> used_settings;
  /// Empty, or the first place where `text` is right for postproc's interpreter but not as a program
  /// of its own: LinuxCNC keeps a saved modal state (M70/M73) per call level and the resolved text
  /// marks M70–M73 below the main program with "(postproc: call level N)"; a LinuxCNC main program
  /// has one saved state, so where a restore would find another save there, `--flatten` refuses
  /// (this diagnostic, PP-E709, at the source line).
  std::vector<Diagnostic> not_flat;
};

/// True when `text` contains anything `resolve` evaluates (cheap scan through the lexer).
[[nodiscard]] bool needs_resolution(std::string_view text, const Dialect& d);
/// The first line that needs resolution (1-based), 0 when none.
[[nodiscard]] std::uint64_t first_resolution_line(std::string_view text, const Dialect& d);
/// The same over a reader (streaming; the reader is consumed).
[[nodiscard]] bool needs_resolution(LineReader& in, const Dialect& d);

/// Resolves `text` (file name `file` for diagnostics). Errors go to `sink` with file:line:col
/// of the source (and the call stack in the message); the result is then incomplete.
[[nodiscard]] ResolvedProgram resolve(std::string_view text, std::string_view file, const Dialect& d,
                                      const ResolveOptions& opt, DiagnosticSink& sink);

/// Maps a diagnostic reported on a resolved line back to its source: line (and column when the
/// line was not substituted), file, and "(reached through …)" appended to the message.
void map_to_source(const ResolvedProgram& r, Diagnostic& d);

/// A sink that forwards every diagnostic reported on `r`'s resolved text to `to`, mapped to the
/// source (map_to_source). Both must outlive it.
[[nodiscard]] DiagnosticSink source_mapped(const ResolvedProgram& r, DiagnosticSink& to);

/// run_program (program.hpp) on the file `path` ("-" = stdin): a program without parameters or
/// control flow streams from the file as before; one with them is read, resolved (subprogram
/// files are looked for in `opt.search_dirs`, else next to the program) and the interpreter reads
/// the resolved text. The visitor sees blocks and motions with their *source* line numbers;
/// diagnostics are mapped to the source (map_to_source). `resolved` (optional) receives the
/// resolution. Nothing is interpreted when resolving reports an error.
ProgramStats run_program_file(const std::string& path, const Dialect& d, std::string_view file, DiagnosticSink& sink,
                              BlockVisitor& visitor, const ResolveOptions& opt, ResolvedProgram* resolved = nullptr);

/// run_program_file on a program held in memory (`text`, named `file`; subprogram files are looked
/// for in `opt.search_dirs`, else next to `file`).
ProgramStats run_program_text(std::string_view text, const Dialect& d, std::string_view file, DiagnosticSink& sink,
                              BlockVisitor& visitor, const ResolveOptions& opt, ResolvedProgram* resolved = nullptr);

/// `opt` with the folder of `file` ("-": the current folder) first among the subprogram folders.
[[nodiscard]] ResolveOptions with_program_folder(ResolveOptions opt, std::string_view file);

/// run_program on a resolved program's text, with blocks, motions and diagnostics mapped to the
/// source lines.
ProgramStats run_resolved(const ResolvedProgram& r, const Dialect& d, std::string_view file, DiagnosticSink& sink,
                          BlockVisitor& visitor);

/// Parses a --set argument "NAME=VALUE" (NAME as the dialect writes it: #5061, #<_x>, R10,
/// $AA_IM[X]); throws postproc::Error (usage) when malformed.
[[nodiscard]] std::pair<std::string, double> parse_setting(std::string_view text);

}  // namespace postproc::gcode
