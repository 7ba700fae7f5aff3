#pragma once
// Shared CLI plumbing: dialect options, diagnostic printing, exit codes.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "postproc/error.hpp"
#include "postproc/gcode/convert.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/resolve.hpp"
#include "postproc/io/output_file.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::cli {

/// Arcseconds per radian (the unit tool-axis angles are shown in).
inline constexpr double kArcsec = 180.0 / 3.14159265358979323846 * 3600.0;

struct DialectArgs {
  std::string dialect;       ///< empty = not given
  bool lathe = false;
  std::string gcode_system = "auto";  ///< "A", "B" or "auto" (Fanuc lathe)
  std::string diameter_axis; ///< "X" or empty
  std::string integer_input; ///< "", "increment" or "calculator" (Fanuc)
  std::string tool_table;    ///< LinuxCNC tool table file (lengths and diameters by tool number), "" = none
  std::string power_on_motion; ///< "", "G0" or "G1" (Fanuc parameter 3402#0)
  std::string arc_without_centre; ///< "", "linear" or "alarm" (Fanuc parameter 3403#5)
  std::string basic_system = "metric";  ///< Siemens MD10240: "metric" or "inch"
  std::string reset_motion = "G1";      ///< Siemens MD20150[0]: "G0" or "G1"
};

/// "START[,STEP]" of --renumber (convert, compensate) into `opt`; throws Error(usage) otherwise.
void parse_renumber(const std::string& s, gcode::ConvertOptions& opt);

/// The first `bytes` of a program file, for dialect suggestions; "" for standard input ("-"),
/// which cannot be read twice (nor can a pipe: callers that read the program afterwards ask only
/// for regular files). A folder or special file is exit 66.
[[nodiscard]] std::string head_of(const std::string& path, std::size_t bytes = std::size_t{1} << 18);

/// Adds --dialect, --lathe, --diameter-axis to `cmd`.
void add_dialect_options(CLI::App& cmd, DialectArgs& a, bool required);
/// Builds the dialect; throws Error(usage) on a bad combination.
gcode::Dialect make_dialect(const DialectArgs& a);

/// --set NAME=VALUE… : values of run-time variables for programs with parameters (issue 3).
struct ResolveArgs {
  std::vector<std::string> set;
  std::vector<std::string> subprogram_dirs;
  std::uint64_t max_silent_lines = gcode::ResolveOptions{}.max_silent_lines;
  std::uint64_t max_array_elements = gcode::ResolveOptions{}.max_array_elements;
};
void add_resolve_options(CLI::App& cmd, ResolveArgs& a);
/// Parses the --set values; throws Error(usage) on a malformed one.
gcode::ResolveOptions make_resolve_options(const ResolveArgs& a);

/// Prints diagnostics to stderr as they arrive, at most `per_code_limit` per code.
/// Colour on stderr: POSTPROC_COLOR=always / never decides; otherwise off when NO_COLOR is set
/// (no-color.org) or TERM is "dumb", on when stderr is a terminal.
[[nodiscard]] bool colour_on_stderr();
/// A formatted diagnostic (gcode::format) with GCC's colours: the location bold, the severity
/// red / magenta / cyan, the caret line green.
[[nodiscard]] std::string colourise_diagnostic(std::string_view text);

struct DiagnosticPrinter {
  explicit DiagnosticPrinter(gcode::DiagnosticSink& sink, std::size_t per_code_limit);
  /// Prints how many were not shown, per code.
  void finish() const;
  std::size_t limit;
  std::vector<std::pair<std::string, std::size_t>> shown;
  gcode::DiagnosticSink& sink;
  bool colour = colour_on_stderr();
};

/// Loads a machine file, printing its diagnostics; throws Error(refused) "PATH: machine file
/// refused" when it has errors.
machine::Machine load_or_refuse(const std::string& path, std::size_t per_code_limit = 20);

/// The files one command writes (program, --report, --json, --html, --csv …): each is written to
/// its temporary as soon as it is produced, and all are published together by commit(), so a full
/// disk or a refused rename leaves every target as it was (io::OutputFile::commit_all).
class OutputSet {
 public:
  /// Opens `path` (never over an input of the run) and writes `text`.
  void add(const std::string& path, const std::string& text);
  /// Opens an output the command writes itself.
  io::OutputFile& open(const std::string& path, const std::string& input, bool allow_overwrite = false);
  /// Publishes every output added, together with `program` when given.
  void commit(io::OutputFile* program = nullptr);

 private:
  std::vector<std::unique_ptr<io::OutputFile>> files_;
};

/// After an --in-place run: says so when an existing NAME.bak (an earlier original) was kept.
void note_backup_kept(const io::OutputFile& out);

/// The cores this process may run on (its CPU affinity mask, not the machine's count): the
/// default of -j. At least 1.
[[nodiscard]] unsigned usable_cores();

/// Exit code for a program given its diagnostics.
ExitCode exit_code_for(const gcode::DiagnosticSink& sink);

void setup_check(CLI::App& app, int& rc);
void setup_dump(CLI::App& app, int& rc);
void setup_convert(CLI::App& app, int& rc);
void setup_compensate(CLI::App& app, int& rc);
void setup_calibrate(CLI::App& app, int& rc);
void setup_predict(CLI::App& app, int& rc);
void setup_simulate(CLI::App& app, int& rc);
void setup_diff(CLI::App& app, int& rc);
void setup_batch(CLI::App& app, int& rc);

}  // namespace postproc::cli
