// convert_program: convert on programs with parameters, subprograms and control flow (convert.hpp).
#include <fmt/format.h>

#include "postproc/gcode/convert.hpp"
#include "postproc/gcode/write_back.hpp"
#include "src/gcode/codes.hpp"

namespace postproc::gcode {
namespace {

/// The source text of line `line` (1-based) of `text`.
std::string_view line_of(std::string_view text, std::uint64_t line) {
  std::size_t pos = 0;
  for (std::uint64_t k = 1; k < line && pos < text.size(); ++k) {
    pos = text.find_first_of("\r\n", pos);
    if (pos == std::string_view::npos) return {};
    pos += text.compare(pos, 2, "\r\n") == 0 ? 2 : 1;
  }
  const std::size_t end = text.find_first_of("\r\n", pos);
  return text.substr(pos, end == std::string_view::npos ? std::string_view::npos : end - pos);
}

/// The interpreter's warnings about statements it reads without evaluating: the program was
/// resolved, so they say nothing about the conversion.
bool resolver_covers(const Diagnostic& d) {
  return d.severity != Severity::error &&
         (d.code == codes::kSubprogramCall || d.code == codes::kControlFlow || d.code == codes::kExpressionValue ||
          d.code == codes::kAssignment || d.code == codes::kMacroCall);
}

}  // namespace

ConvertResult convert_program(std::string_view text, std::string_view file, const Dialect& dialect,
                              const ConvertOptions& opt, io::OutputFile& out, DiagnosticSink& sink) {
  const std::uint64_t first = first_resolution_line(text, dialect);
  if (first == 0) {
    LineReader in{text};
    return convert(in, file, dialect, opt, out, sink);
  }
  ConvertResult result;
  if (opt.units && !opt.flatten) {
    Diagnostic d;
    d.severity = Severity::error;
    d.code = std::string(codes::kUnitsRefused);
    d.file = std::string(file);
    d.where = {first, 1};
    set_source_line(d, line_of(text, first));
    d.length = static_cast<std::uint32_t>(std::max<std::size_t>(1, line_of(text, first).size()));
    d.message =
        "--units refused: the program uses parameters, expressions, subprograms or control flow (first here); lengths "
        "held in parameters and on lines this run does not reach cannot be converted exactly: give --flatten to "
        "convert the resolved program";
    sink.report(std::move(d));
    return result;
  }
  const std::size_t errors = sink.count(Severity::error);
  const ResolvedProgram r = resolve(text, file, dialect, with_program_folder(opt.resolve, file), sink);
  if (sink.count(Severity::error) > errors) return result;
  DiagnosticSink mapped = source_mapped(r, sink);
  if (opt.flatten && !r.not_flat.empty()) {  // the resolved text is not a program of its own here
    sink.report(r.not_flat.front());
    return result;
  }
  if (opt.flatten) {
    LineReader in{std::string_view(r.text)};
    ConvertOptions o = opt;
    o.line_map = nullptr;
    return convert(in, file, dialect, o, out, mapped);
  }
  // The syntactic options read the text as written; the interpreter's notes on the statements it
  // does not evaluate are dropped (the resolver followed them).
  DiagnosticSink quiet(0);
  quiet.on_report = [&](const Diagnostic& diag) {
    if (!resolver_covers(diag)) sink.report(diag);
  };
  ConvertOptions syntactic = opt;
  syntactic.linearize_tolerance_mm.reset();
  syntactic.line_map = nullptr;
  if (!opt.linearize_tolerance_mm) {
    LineReader in{text};
    return convert(in, file, dialect, syntactic, out, quiet);
  }
  // Linearise the literal program, then carry the chords back onto the source lines.
  ConvertOptions lin;
  lin.linearize_tolerance_mm = opt.linearize_tolerance_mm;
  std::vector<std::uint64_t> map;
  lin.line_map = &map;
  auto literal = io::OutputFile::memory();
  {
    LineReader in{std::string_view(r.text)};
    result = convert(in, file, dialect, lin, literal, mapped);
  }
  if (sink.count(Severity::error) > errors) return result;
  const std::string converted = literal.take();
  std::string written;
  if (!write_back(text, file, dialect, r, converted, map, {}, written, sink).ok) return result;
  if (syntactic.identity()) {
    out.write(written);
    return result;
  }
  LineReader in{std::string_view(written)};
  const ConvertResult rest = convert(in, file, dialect, syntactic, out, quiet);
  result.changed_blocks += rest.changed_blocks;
  result.removed_blocks = rest.removed_blocks;
  result.inserted_lines += rest.inserted_lines;
  result.decimals_raised = rest.decimals_raised;
  result.decimals_finer = rest.decimals_finer;
  result.decimals_expression = rest.decimals_expression;
  result.decimals_integer = rest.decimals_integer;
  return result;
}

}  // namespace postproc::gcode
