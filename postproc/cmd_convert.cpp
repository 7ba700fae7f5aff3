// postproc convert IN -o OUT [options]: with no options the output is byte-identical to the input.
#include <cmath>
#include <filesystem>
#include <memory>

#include <fmt/format.h>

#include "common.hpp"
#include "postproc/gcode/convert.hpp"
#include "postproc/io/input_file.hpp"

namespace postproc::cli {
namespace {

struct ConvertArgs {
  std::string input;
  std::string output;
  DialectArgs dialect;
  bool in_place = false;
  bool quiet = false;
  std::size_t max_per_code = 20;
  std::string renumber;  ///< "START[,STEP]"
  std::string decimals;  ///< "X=4,Y=4,…"
  std::string units;     ///< "mm" | "inch"
  ResolveArgs resolve;
  std::optional<double> linearize;
  gcode::ConvertOptions opt;
};

/// Letters --decimals accepts: axes, and the arc centre words that go with them.
constexpr std::string_view kDecimalLetters = "XYZABCUVWIJKR";

void parse_decimals(const std::string& s, gcode::ConvertOptions& opt) {
  auto bad = [&s](std::string_view why) {
    return Error(ExitCode::usage, fmt::format("--decimals '{}': {}; expected e.g. X=4,Y=4,Z=4,A=3", s, why));
  };
  std::size_t at = 0;
  while (at <= s.size()) {
    const auto comma = std::min(s.find(',', at), s.size());
    const std::string item = s.substr(at, comma - at);
    if (item.size() < 3 || item[1] != '=') throw bad(fmt::format("'{}' is not LETTER=DECIMALS", item));
    const char L = static_cast<char>(std::toupper(static_cast<unsigned char>(item[0])));
    if (kDecimalLetters.find(L) == std::string_view::npos)
      throw bad(fmt::format("'{}' is not one of {}", item[0], kDecimalLetters));
    int d = -1;
    try {
      std::size_t used = 0;
      d = std::stoi(item.substr(2), &used);
      if (used != item.size() - 2) d = -1;
    } catch (const std::exception&) {
      d = -1;
    }
    if (d < 0 || d > 9) throw bad(fmt::format("'{}': decimals must be 0 to 9", item));
    opt.min_decimals[static_cast<std::size_t>(L - 'A')] = static_cast<std::int8_t>(d);
    at = comma + 1;
  }
}

void print_summary(const gcode::ConvertOptions& opt, const gcode::ConvertResult& r) {
  if (opt.any_min_decimals())
    std::fputs(fmt::format("note: --decimals: {} words written with more decimals; {} already finer, {} given by "
                           "expressions (see PP-U213) and {} whole numbers whose meaning depends on --integer-input "
                           "(see PP-U218) left as written\n",
                           r.decimals_raised, r.decimals_finer, r.decimals_expression, r.decimals_integer)
                   .c_str(),
               stderr);
  if (opt.units)
    std::fputs(fmt::format("note: --units: {} unit words written, {} length and feed words converted\n", r.unit_words,
                           r.scaled_words)
                   .c_str(),
               stderr);
  if (opt.linearize_tolerance_mm)
    std::fputs(fmt::format("note: --linearize: {} arcs replaced by {} G1 segments\n", r.arcs_linearized, r.segments)
                   .c_str(),
               stderr);
}

}  // namespace

void setup_convert(CLI::App& app, int& rc) {
  auto o = std::make_shared<ConvertArgs>();
  auto* cmd = app.add_subcommand("convert", "rewrite a program; with no options the output equals the input");
  cmd->add_option("input", o->input, "NC program ('-' = stdin)")->required();
  cmd->add_option("-o,--output", o->output, "output file ('-' = stdout)")->required();
  add_dialect_options(*cmd, o->dialect, true);
  cmd->add_flag("--in-place", o->in_place, "allow -o to name the input (a .bak backup is kept)");
  cmd->add_flag("-q,--quiet", o->quiet, "diagnostics only, no summary notes");
  cmd->add_flag("--strip-comments", o->opt.strip_comments, "remove ( ) and ; comments; comment-only lines go");
  cmd->add_option("--renumber", o->renumber, "renumber existing N words: START[,STEP] (refused if the program "
                                             "jumps to sequence numbers)");
  cmd->add_option("--decimals", o->decimals,
                  "minimum decimals per letter, e.g. X=4,Y=4,Z=4,A=3 (letters X Y Z A B C U V W I J K R); literal "
                  "words with fewer are padded, the value is unchanged");
  cmd->add_option("--units", o->units, "convert lengths and feeds to mm or inch and write the unit words")
      ->check(CLI::IsMember({"mm", "inch"}));
  cmd->add_option("--linearize", o->linearize,
                  "replace arcs by G1 chords within this tolerance, mm (rounding of the printed points included)");
  cmd->add_flag("--flatten", o->opt.flatten,
                "programs with parameters, expressions, subprograms or loops: convert and write the resolved program "
                "as literal moves (without it: --linearize writes its chords into the program's own lines where that "
                "is exact, --units is refused)");
  add_resolve_options(*cmd, o->resolve);
  cmd->add_option("--max-per-code", o->max_per_code, "show at most this many diagnostics per code")
      ->capture_default_str();
  cmd->callback([o, &rc] {
    if (!o->renumber.empty()) parse_renumber(o->renumber, o->opt);
    if (!o->decimals.empty()) parse_decimals(o->decimals, o->opt);
    if (!o->units.empty()) o->opt.units = o->units == "inch" ? gcode::Units::inch : gcode::Units::mm;
    if (o->linearize) {
      if (!std::isfinite(*o->linearize) || *o->linearize <= 0)
        throw Error(ExitCode::usage, "--linearize: the tolerance must be a positive number of mm, e.g. 0.005");
      o->opt.linearize_tolerance_mm = *o->linearize;
    }
    const gcode::Dialect d = make_dialect(o->dialect);
    gcode::DiagnosticSink sink;
    DiagnosticPrinter printer(sink, o->max_per_code);
    o->opt.resolve = make_resolve_options(o->resolve);
    io::OutputFile out(o->output, o->input, o->in_place);
    // Programs without parameters or control flow stream from the file; others are held in memory.
    std::error_code ec;
    bool streaming = o->input != "-" && std::filesystem::is_regular_file(o->input, ec);
    if (streaming) {
      gcode::LineReader scan(o->input);
      streaming = !gcode::needs_resolution(scan, d);
    }
    gcode::ConvertResult r;
    if (streaming) {
      gcode::LineReader reader(o->input);
      r = gcode::convert(reader, o->input, d, o->opt, out, sink);
    } else {
      const std::string text = io::read_file(o->input, "NC program");
      r = gcode::convert_program(text, o->input, d, o->opt, out, sink);
    }
    printer.finish();
    if (sink.has_errors()) {
      std::fputs(fmt::format("postproc: {}: refused; nothing was written\n", o->input).c_str(), stderr);
      rc = static_cast<int>(ExitCode::refused);
      return;
    }
    if (!o->quiet) print_summary(o->opt, r);
    out.commit();
    note_backup_kept(out);
    rc = 0;  // written; warnings (unresolved constructs) were printed but change nothing here
  });
}

}  // namespace postproc::cli
