#include "common.hpp"
#include "progress_bar.hpp"

#include <sched.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <thread>

#include <fmt/format.h>

#include "postproc/gcode/convert.hpp"
#include "postproc/gcode/tool_table.hpp"
#include "postproc/io/input_file.hpp"
#include "postproc/io/output_file.hpp"

namespace postproc::cli {

unsigned usable_cores() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0) {
    const int n = CPU_COUNT(&set);
    if (n > 0) return static_cast<unsigned>(n);
  }
  return std::max(1u, std::thread::hardware_concurrency());
}

void parse_renumber(const std::string& s, gcode::ConvertOptions& opt) {
  const auto comma = s.find(',');
  try {
    opt.renumber_start = std::stoull(s.substr(0, comma));
    if (comma != std::string::npos) opt.renumber_step = std::stoull(s.substr(comma + 1));
  } catch (const std::exception&) {
    throw Error(ExitCode::usage, fmt::format("--renumber '{}': expected START[,STEP], e.g. 10,10", s));
  }
  if (opt.renumber_step == 0) throw Error(ExitCode::usage, "--renumber: STEP must be at least 1");
}

std::string head_of(const std::string& path, std::size_t bytes) {
  if (path == "-") return {};
  io::check_input_kind(path, "NC program");  // a folder is exit 66 before any dialect question
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(ExitCode::no_input, fmt::format("{}: cannot open for reading: {}", path, std::strerror(errno)));
  std::string s(bytes, '\0');
  f.read(s.data(), static_cast<std::streamsize>(bytes));
  s.resize(static_cast<std::size_t>(f.gcount()));
  return s;
}

void add_dialect_options(CLI::App& cmd, DialectArgs& a, bool required) {
  auto* opt = cmd.add_option("--dialect", a.dialect,
                             "controller dialect: fanuc|siemens|linuxcnc|heidenhain-iso|heidenhain (Klartext) (G70/G71, comments, G7 and "
                             "assignment timing differ)")
                  ->check(CLI::IsMember({"fanuc", "siemens", "linuxcnc", "heidenhain-iso", "heidenhain"}));
  if (required) opt->required();
  cmd.add_flag("--lathe", a.lathe,
               "lathe programs: Fanuc G-code system A (G98/G99 feed modes, U/W incremental, G70–G76 cycles), X "
               "programmed as diameter");
  cmd.add_option("--gcode-system", a.gcode_system,
                 "Fanuc lathe G-code system (parameters GSB/GSC): A (G98/G99 feed per min/rev, U/W incremental), B "
                 "(G90/G91, G94/G95), or auto: read off the program (G90 beside G00, G99 beside a feed, …; refused "
                 "when the program shows both)")
      ->check(CLI::IsMember({"A", "B", "auto"}))
      ->capture_default_str();
  cmd.add_option("--integer-input", a.integer_input,
                 "Fanuc: how axis words without a decimal point are read: increment (X100 = 0.1 mm, the factory "
                 "setting) or calculator (X100 = 100 mm, parameter DPI=1, Haas)")
      ->check(CLI::IsMember({"increment", "calculator"}));
  cmd.add_option("--power-on-motion", a.power_on_motion,
                 "Fanuc: motion mode at power-on, G0 (factory setting) or G1 (parameter 3402#0 G01=1); axis words "
                 "before any motion G move in it")
      ->check(CLI::IsMember({"G0", "G1", "G00", "G01"}));
  cmd.add_option("--arc-without-centre", a.arc_without_centre,
                 "Fanuc: a G02/G03 block with neither I J K nor R: linear (moves straight to its end, parameter "
                 "3403#5 CIR=0, the factory setting) or alarm (CIR=1: refused)")
      ->check(CLI::IsMember({"linear", "alarm"}));
  cmd.add_option("--diameter-axis", a.diameter_axis, "axis programmed as a diameter from the start (X), or 'none'")
      ->check(CLI::IsMember({"X", "x", "none"}));
  cmd.add_option("--tool-table", a.tool_table,
                 "LinuxCNC tool table file (T<n> Z<length> D<diameter>, mm): resolves G43 H / G43 / G41 / G42; "
                 "without it a tool-length change leaves Z unknown until the program states it")
      ->check(CLI::ExistingFile);
  cmd.add_option("--basic-system", a.basic_system,
                 "Siemens: the control's basic system (MD10240 SCALING_SYSTEM_IS_METRIC): metric (assumed) or inch; "
                 "F under G70/G71 is in this system")
      ->check(CLI::IsMember({"metric", "inch"}))
      ->capture_default_str();
  cmd.add_option("--reset-motion", a.reset_motion,
                 "Siemens: motion mode before the program's first G0/G1/G2/G3 (MD20150 GCODE_RESET_VALUES[0]; "
                 "factory setting G1)")
      ->check(CLI::IsMember({"G0", "G1"}))
      ->capture_default_str();
}

gcode::Dialect make_dialect(const DialectArgs& a) {
  gcode::DialectOptions o;
  o.lathe = a.lathe;
  if (a.integer_input == "increment") o.integer_input = gcode::Dialect::IntegerInput::increment;
  if (a.integer_input == "calculator") o.integer_input = gcode::Dialect::IntegerInput::calculator;
  o.power_on_motion = a.power_on_motion == "G1" || a.power_on_motion == "G01" ? 1 : 0;
  o.arc_without_centre_alarm = a.arc_without_centre == "alarm";
  o.gcode_system = a.gcode_system.empty() || a.gcode_system == "auto" ? '?' : a.gcode_system[0];
  if (a.diameter_axis == "X" || a.diameter_axis == "x") o.diameter_axis = 'X';
  if (!a.tool_table.empty()) {
    gcode::DiagnosticSink sink;
    DiagnosticPrinter printer(sink, 20);
    const bool ok = gcode::read_linuxcnc_tool_table(a.tool_table, o, sink);
    printer.finish();
    if (!ok) throw Error(ExitCode::refused, fmt::format("{}: tool table refused", a.tool_table));
  }
  o.basic_inch = a.basic_system == "inch";
  o.reset_motion = a.reset_motion == "G0" ? '0' : '1';
  auto d = gcode::make_dialect(a.dialect, o);
  if (!d) throw Error(ExitCode::usage, fmt::format("unknown dialect '{}'; use {}", a.dialect, gcode::dialect_names()));
  if (a.diameter_axis == "none") d->diameter_axis = 0;
  return *d;
}

bool colour_on_stderr() {
  if (const char* c = std::getenv("POSTPROC_COLOR")) {
    if (std::string_view(c) == "always") return true;
    if (std::string_view(c) == "never") return false;
  }
  if (const char* n = std::getenv("NO_COLOR"); n != nullptr && *n != '\0') return false;
  if (const char* t = std::getenv("TERM"); t != nullptr && std::string_view(t) == "dumb") return false;
  return ::isatty(STDERR_FILENO) == 1;
}

std::string colourise_diagnostic(std::string_view text) {
  constexpr std::string_view bold = "\033[1m", reset = "\033[0m", green = "\033[1;32m";
  std::string out;
  out.reserve(text.size() + 64);
  std::size_t start = 0;
  bool first = true;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(start, end - start);
    if (first) {
      first = false;
      struct Sev {
        std::string_view word, colour;
      };
      bool done = false;
      for (const Sev& sv : {Sev{": error: ", "\033[1;31m"}, Sev{": warning: ", "\033[1;35m"}, Sev{": note: ", "\033[1;36m"}}) {
        const std::size_t at = line.find(sv.word);
        if (at == std::string_view::npos) continue;
        out += bold;
        out += line.substr(0, at + 1);
        out += reset;
        out += ' ';
        out += sv.colour;
        out += sv.word.substr(2, sv.word.size() - 3);  // "error:"
        out += reset;
        out += line.substr(at + sv.word.size() - 1);
        done = true;
        break;
      }
      if (!done) out += line;
    } else if (!line.empty() && line.find_first_not_of(" ^~") == std::string_view::npos &&
               line.find('^') != std::string_view::npos) {
      const std::size_t lead = line.find_first_not_of(' ');
      out += line.substr(0, lead);
      out += green;
      out += line.substr(lead);
      out += reset;
    } else {
      out += line;
    }
    if (end < text.size()) out += '\n';
    start = end + 1;
  }
  return out;
}

DiagnosticPrinter::DiagnosticPrinter(gcode::DiagnosticSink& s, std::size_t per_code_limit)
    : limit(per_code_limit), sink(s) {
  sink.on_report = [this](const gcode::Diagnostic& d) {
    std::size_t seen = 0;
    for (auto& [code, n] : shown)
      if (code == d.code) seen = ++n;
    if (seen == 0) {
      shown.emplace_back(d.code, 1);
      seen = 1;
    }
    if (seen <= limit) print_stderr(colour ? colourise_diagnostic(gcode::format(d)) : gcode::format(d));
  };
}

void DiagnosticPrinter::finish() const {
  for (const auto& [code, n] : shown)
    if (n > limit)
      std::fputs(fmt::format("note: {} more {} diagnostics not shown (raise --max-per-code)\n", n - limit, code).c_str(),
                 stderr);
}

void add_resolve_options(CLI::App& cmd, ResolveArgs& a) {
  cmd.add_option("--set", a.set,
                 "value of a variable the control fills at run time, for programs with parameters (repeatable): "
                 "'#5061=1.25', '#<_probe_z>=-3', 'R10=2', '$AA_IM[X]=10'; the report records it")
      ->expected(1)
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd.add_option("--subprogram-dir", a.subprogram_dirs,
                 "folder searched for subprogram files (LinuxCNC name.ngc, Fanuc O####, Siemens NAME.SPF) after the "
                 "program's own folder (repeatable, in order)")
      ->expected(1)  // one folder per occurrence: the program argument after it is not swallowed
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->check(CLI::ExistingDirectory);
  cmd.add_option("--max-silent-lines", a.max_silent_lines,
                 "programs with parameters: lines executed in a row without writing a block at most, before the run is "
                 "refused as an endless loop (PP-E705)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd.add_option("--max-array-elements", a.max_array_elements,
                 "Sinumerik programs: elements of all DEF arrays alive at once at most (PP-E714)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
}

gcode::ResolveOptions make_resolve_options(const ResolveArgs& a) {
  gcode::ResolveOptions o;
  for (const std::string& s : a.set) o.set.insert(gcode::parse_setting(s));
  o.search_dirs = a.subprogram_dirs;
  o.max_silent_lines = a.max_silent_lines;
  o.max_array_elements = a.max_array_elements;
  return o;
}

ExitCode exit_code_for(const gcode::DiagnosticSink& sink) {
  if (sink.has_errors()) return ExitCode::refused;
  if (sink.count(gcode::Severity::warning) > 0) return ExitCode::unresolved;
  return ExitCode::ok;
}

machine::Machine load_or_refuse(const std::string& path, std::size_t per_code_limit) {
  gcode::DiagnosticSink sink;
  DiagnosticPrinter printer(sink, per_code_limit);
  auto m = machine::load_machine(path, sink);
  printer.finish();
  if (!m) throw Error(ExitCode::refused, fmt::format("{}: machine file refused", path));
  return std::move(*m);
}

void note_backup_kept(const io::OutputFile& out) {
  if (out.backup_kept())
    std::fputs(fmt::format("postproc: PP-W901 {}.bak already exists and was kept (it holds the original from an "
                           "earlier --in-place run); remove it to keep this run's input as the backup instead\n",
                           out.path())
                   .c_str(),
               stderr);
}

io::OutputFile& OutputSet::open(const std::string& path, const std::string& input, bool allow_overwrite) {
  files_.push_back(std::make_unique<io::OutputFile>(path, input, allow_overwrite));
  return *files_.back();
}

void OutputSet::add(const std::string& path, const std::string& text) {
  open(path, "").write(text);
}

void OutputSet::commit(io::OutputFile* program) {
  std::vector<io::OutputFile*> all;
  if (program != nullptr) all.push_back(program);
  for (const auto& f : files_) all.push_back(f.get());
  io::OutputFile::commit_all(all);
}

}  // namespace postproc::cli
